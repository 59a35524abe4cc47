//! Library errors. Every error that concerns a file names it, and the line and field when the
//! problem is inside it, so a batch log points straight at the culprit. A set-up error that a
//! caller acts on (a folder to overwrite, a lock to wait for, a resume to start afresh, a full
//! device) is a variant of its own; the others are [`Error::Setup`] messages.

use std::path::{Path, PathBuf};

/// Any failure of the library: displayed as `path:line: field: message`, `path: message` or
/// the message alone.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// A malformed value inside a text file.
    #[error("{}:{line}: {field}: {message}", path.display())]
    Parse {
        /// The file the value is in.
        path: PathBuf,
        /// 1-based line of the value.
        line: usize,
        /// The field (key, column or record name) the value belongs to.
        field: String,
        /// What is wrong with the value.
        message: String,
    },
    /// A file that is unusable as a whole (missing, empty, undecodable, inconsistent).
    #[error("{}: {message}", path.display())]
    File {
        /// The file.
        path: PathBuf,
        /// What is wrong with it.
        message: String,
    },
    /// The OS error is part of the message, not a separate cause, so that it is printed once.
    #[error("{}: {cause}", path.display())]
    Io {
        /// The file or directory the operation was on.
        path: PathBuf,
        /// The operating system's error.
        cause: std::io::Error,
    },
    /// A problem with the run's set-up (paths, options) that no caller tells from another;
    /// nothing has been written.
    #[error("{0}")]
    Setup(String),
    /// The output folder holds files and `--overwrite` was not given; nothing has been written.
    #[error("output {} is not empty ({advice})", output.display())]
    OutputNotEmpty {
        /// The output folder as given.
        output: PathBuf,
        /// What to do about it (the option that writes into it anyway).
        advice: &'static str,
    },
    /// Another live process holds the output folder's lock; nothing has been written.
    #[error("{} is being written by {holder} (it holds {}); wait for it to end, or write to another --output (distinct --shard K/N may share a folder)", output.display(), lock.display())]
    OutputLocked {
        /// The output folder.
        output: PathBuf,
        /// The lock file.
        lock: PathBuf,
        /// Who holds it (`pid P on host H`, or `another process`).
        holder: String,
    },
    /// `--resume` on a folder written with other parameters; nothing has been written.
    #[error("cannot resume: {} was written with other parameters ({}); use the same options, or a new output folder", manifest.display(), differ.join(", "))]
    ResumeMismatch {
        /// The previous run's manifest.
        manifest: PathBuf,
        /// The parameters that differ.
        differ: Vec<String>,
    },
    /// A failure of the style model (a `style::StyleError`), boxed so that this lowest layer
    /// does not depend on the ONNX code above it.
    #[error(transparent)]
    Style(Box<dyn std::error::Error + Send + Sync>),
    /// The output device refused writes (full, over quota, read-only) and the run stopped;
    /// the message says how far it got and what to do.
    #[error("{0}")]
    DeviceFull(String),
    /// The process serving the frames (`rig-stream`'s peer) no longer answers: no later frame
    /// can be read, so the run stops taking frames (the frame asked is not recorded as failed).
    #[error("{0}")]
    SourceLost(String),
}

impl Error {
    /// An [`Error::Parse`]: `message` about `field` at 1-based `line` of `path`.
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

    /// An [`Error::File`]: `message` about `path` as a whole.
    pub fn file(path: &Path, message: impl Into<String>) -> Self {
        Error::File {
            path: path.to_path_buf(),
            message: message.into(),
        }
    }

    /// An [`Error::Io`]: the OS error `cause` of an operation on `path`.
    pub fn io(path: &Path, cause: std::io::Error) -> Self {
        Error::Io {
            path: path.to_path_buf(),
            cause,
        }
    }
}

impl Error {
    /// Whether the frames' source is gone ([`Error::SourceLost`]): a run stops taking frames.
    pub fn is_source_lost(&self) -> bool {
        matches!(self, Error::SourceLost(_))
    }

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

/// A result whose error is, by default, the library's [`Error`].
pub type Result<T, E = Error> = std::result::Result<T, E>;
