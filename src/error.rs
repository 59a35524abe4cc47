//! Library errors. Every error that concerns a file names it, and the line and field when the
//! problem is inside it, so a batch log points straight at the culprit.

use std::path::{Path, PathBuf};

#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// A malformed value inside a text file.
    #[error("{}:{line}: {field}: {message}", path.display())]
    Parse {
        path: PathBuf,
        line: usize,
        field: String,
        message: String,
    },
    /// A file that is unusable as a whole (missing, empty, undecodable, inconsistent).
    #[error("{}: {message}", path.display())]
    File { path: PathBuf, message: String },
    /// The OS error is part of the message, not a separate cause, so that it is printed once.
    #[error("{}: {cause}", path.display())]
    Io {
        path: PathBuf,
        cause: std::io::Error,
    },
    /// A problem with the run's set-up (paths, options); nothing has been written.
    #[error("{0}")]
    Setup(String),
    /// A failure of the style model (a `style::StyleError`), boxed so that this lowest layer
    /// does not depend on the ONNX code above it.
    #[error(transparent)]
    Style(Box<dyn std::error::Error + Send + Sync>),
    /// The output device refused writes (full, over quota, read-only) and the run stopped;
    /// the message says how far it got and what to do.
    #[error("{0}")]
    DeviceFull(String),
}

impl Error {
    pub fn parse(
        path: &Path,
        line: usize,
        field: impl Into<String>,
        message: impl Into<String>,
    ) -> Self {
        Error::Parse {
            path: path.to_path_buf(),
            line,
            field: field.into(),
            message: message.into(),
        }
    }

    pub fn file(path: &Path, message: impl Into<String>) -> Self {
        Error::File {
            path: path.to_path_buf(),
            message: message.into(),
        }
    }

    pub fn io(path: &Path, cause: std::io::Error) -> Self {
        Error::Io {
            path: path.to_path_buf(),
            cause,
        }
    }
}

impl Error {
    /// Whether the output device refused a write for a reason every later write shares (no
    /// space, no quota, a read-only file system): a run stops taking frames then.
    pub fn is_device_full(&self) -> bool {
        use std::io::ErrorKind;
        matches!(self, Error::Io { cause, .. } if matches!(
            cause.kind(),
            ErrorKind::StorageFull | ErrorKind::QuotaExceeded | ErrorKind::ReadOnlyFilesystem
        ))
    }
}

pub type Result<T, E = Error> = std::result::Result<T, E>;
