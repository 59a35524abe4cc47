//! The library's errors as Python exceptions. The message is the library error's own text, the
//! one the command line prints after `panoconv: error: ` (`label_2/000004.txt:3: location.y:
//! "abc" is not a number`), and its parts are attributes.

use pyo3::create_exception;
use pyo3::exceptions::PyException;
use pyo3::prelude::*;

create_exception!(
    panoconv,
    PanoconvError,
    PyException,
    "An error of panoconv: the message names the file, line and field as the command line does."
);
create_exception!(
    panoconv,
    ParseError,
    PanoconvError,
    "A malformed value inside a file: `path`, `line` and `field` say where."
);

/// The exception of a library error, with `path`, `line`, `field` and `message` set (None
/// where the error has no such part).
pub fn to_py(e: panoconv::error::Error) -> PyErr {
    use panoconv::error::Error;
    let text = e.to_string();
    let (path, line, field, message) = match &e {
        Error::Parse {
            path,
            line,
            field,
            message,
        } => (
            Some(path.display().to_string()),
            Some(*line),
            Some(field.clone()),
            message.clone(),
        ),
        Error::File { path, message } => (
            Some(path.display().to_string()),
            None,
            None,
            message.clone(),
        ),
        Error::Io { path, cause } => (
            Some(path.display().to_string()),
            None,
            None,
            cause.to_string(),
        ),
        Error::OutputNotEmpty { output, .. } | Error::OutputLocked { output, .. } => {
            (Some(output.display().to_string()), None, None, text.clone())
        }
        Error::ResumeMismatch { manifest, .. } => (
            Some(manifest.display().to_string()),
            None,
            None,
            text.clone(),
        ),
        // (no file of their own: the message says what went wrong)
        Error::Setup(_) | Error::Style(_) | Error::DeviceFull(_) | Error::SourceLost(_) => {
            (None, None, None, text.clone())
        }
    };
    let err = match e {
        Error::Parse { .. } => ParseError::new_err(text),
        _ => PanoconvError::new_err(text),
    };
    Python::attach(|py| {
        let value = err.value(py);
        // Setting attributes on a fresh exception instance cannot fail short of memory
        // exhaustion; the message alone is still right if it does.
        let _ = value.setattr("path", path);
        let _ = value.setattr("line", line);
        let _ = value.setattr("field", field);
        let _ = value.setattr("message", message);
    });
    err
}

/// A `PanoconvError` with a message of the bindings' own (a wrong argument).
pub fn usage(message: impl Into<String>) -> PyErr {
    let message = message.into();
    let err = PanoconvError::new_err(message.clone());
    Python::attach(|py| {
        let value = err.value(py);
        let _ = value.setattr("path", py.None());
        let _ = value.setattr("line", py.None());
        let _ = value.setattr("field", py.None());
        let _ = value.setattr("message", message);
    });
    err
}

/// `Result` of the library into `PyResult`.
pub trait IntoPy<T> {
    /// The value, or the library error as its exception.
    fn py(self) -> PyResult<T>;
}

impl<T> IntoPy<T> for Result<T, panoconv::error::Error> {
    fn py(self) -> PyResult<T> {
        self.map_err(to_py)
    }
}
