//! The exceptions the module raises: a file the operating system refused is an `OSError`
//! (`FileNotFoundError`, `PermissionError` where the kind says so); a file whose contents are
//! refused, a refused option and a refused computation are `ValueError` subclasses. Each
//! carries the one-line message the command line prints.

use pyo3::create_exception;
use pyo3::exceptions::{PyFileNotFoundError, PyOSError, PyPermissionError, PyValueError};
use pyo3::prelude::*;
use raw_formats::FormatError;

create_exception!(
    _camsim,
    FileFormatError,
    PyValueError,
    "A file's contents were refused: not the format, truncated, or holding values outside what \
     the format allows."
);
create_exception!(
    _camsim,
    OptionError,
    PyValueError,
    "A processing option's value (or combination of options) was refused."
);
create_exception!(
    _camsim,
    ProcessingError,
    PyValueError,
    "The ISP, the renderer or the sensor model refused its input."
);

pub(crate) fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    let py = m.py();
    m.add("FileFormatError", py.get_type::<FileFormatError>())?;
    m.add("OptionError", py.get_type::<OptionError>())?;
    m.add("ProcessingError", py.get_type::<ProcessingError>())?;
    Ok(())
}

/// The operating system's error inside `e`, if it is one.
fn io_kind(e: &FormatError) -> Option<std::io::ErrorKind> {
    match e {
        FormatError::Io { source, .. } => Some(source.kind()),
        FormatError::InFile { error, .. } => io_kind(error),
        _ => None,
    }
}

fn os_error(kind: std::io::ErrorKind, message: String) -> PyErr {
    match kind {
        std::io::ErrorKind::NotFound => PyFileNotFoundError::new_err(message),
        std::io::ErrorKind::PermissionDenied => PyPermissionError::new_err(message),
        _ => PyOSError::new_err(message),
    }
}

/// A file error as `OSError` or [`FileFormatError`].
pub(crate) fn format(e: FormatError) -> PyErr {
    let message = e.to_string();
    match io_kind(&e) {
        Some(kind) => os_error(kind, message),
        None => FileFormatError::new_err(message),
    }
}

/// One of camsim's errors as the exception that fits it, with its one-line message.
pub(crate) fn camsim(e: camsim::Error) -> PyErr {
    use camsim::Error as E;
    let message = e.to_string();
    let mut inner = &e;
    while let E::InFile { error, .. } = inner {
        inner = error;
    }
    match inner {
        E::Format(f) => match io_kind(f) {
            Some(kind) => os_error(kind, message),
            None => FileFormatError::new_err(message),
        },
        E::Option { .. } | E::Needs { .. } | E::Options(_) | E::Message(_) => {
            OptionError::new_err(message)
        }
        _ => ProcessingError::new_err(message),
    }
}

/// A lens file's error: one the operating system gave as `OSError` (`FileNotFoundError` for a
/// missing file), the rest as [`camsim`] maps them.
pub(crate) fn lens_file(e: host_tracer::Error) -> PyErr {
    match &e {
        host_tracer::Error::Io { source, .. } => os_error(source.kind(), e.to_string()),
        _ => camsim(e.into()),
    }
}

/// An isp-core refusal.
pub(crate) fn isp(e: isp_core::IspError) -> PyErr {
    ProcessingError::new_err(e.to_string())
}

/// An option refused with a message in words.
pub(crate) fn option(message: impl Into<String>) -> PyErr {
    OptionError::new_err(message.into())
}
