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
    #[error(transparent)]
    Style(#[from] crate::style::StyleError),
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

/// Reads a whole file, tagging failures with its path.
pub fn read_file(path: &Path) -> Result<Vec<u8>> {
    std::fs::read(path).map_err(|e| Error::io(path, e))
}

/// Reads a whole file into `buf` (cleared first), reusing its allocation.
pub fn read_file_into(path: &Path, buf: &mut Vec<u8>) -> Result<()> {
    use std::io::Read;
    buf.clear();
    let mut file = std::fs::File::open(path).map_err(|e| Error::io(path, e))?;
    if let Ok(meta) = file.metadata() {
        buf.reserve(meta.len() as usize);
    }
    file.read_to_end(buf).map_err(|e| Error::io(path, e))?;
    Ok(())
}

/// Reads a text file as lines (LF or CRLF), tagging a non-UTF-8 line with its number.
pub fn read_lines(path: &Path) -> Result<Vec<String>> {
    split_lines(&read_file(path)?, path)
}

/// The lines of a text file already read (LF or CRLF); `path` tags a non-UTF-8 line.
pub fn split_lines(bytes: &[u8], path: &Path) -> Result<Vec<String>> {
    bytes
        .split(|&b| b == b'\n')
        .enumerate()
        .map(|(i, raw)| {
            let raw = raw.strip_suffix(b"\r").unwrap_or(raw);
            String::from_utf8(raw.to_vec())
                .map_err(|_| Error::parse(path, i + 1, "text", "line is not valid UTF-8"))
        })
        .collect::<Result<Vec<_>>>()
        .map(|mut lines| {
            // A final newline leaves one empty element behind, not a line.
            if lines.last().is_some_and(|l| l.is_empty()) {
                lines.pop();
            }
            lines
        })
}
