//! Exceptions of the module and the conversion of core errors into them.

use pyo3::create_exception;
use pyo3::exceptions::{PyFileNotFoundError, PyOSError, PyPermissionError, PyValueError};
use pyo3::PyErr;
use starid_core::ErrorKind;

create_exception!(
    starid,
    StaridError,
    PyValueError,
    "Base class of starid's own exceptions (a ValueError: each says what input is wrong)."
);
create_exception!(
    starid,
    InvalidInputError,
    StaridError,
    "An argument is out of its domain: NaN or far off-sensor centroids, absurd settings."
);
create_exception!(
    starid,
    CatalogError,
    StaridError,
    "A catalogue file or table is malformed."
);

/// A core error on its way to Python; lets binding code use `?` on core results.
pub struct PyStaridError(pub starid_core::Error);

impl From<starid_core::Error> for PyStaridError {
    fn from(e: starid_core::Error) -> Self {
        Self(e)
    }
}

impl From<PyStaridError> for PyErr {
    fn from(e: PyStaridError) -> Self {
        let msg = e.0.to_string();
        match e.0.kind() {
            ErrorKind::InvalidInput => InvalidInputError::new_err(msg),
            ErrorKind::Catalog { .. } => CatalogError::new_err(msg),
            ErrorKind::Io(std::io::ErrorKind::NotFound) => PyFileNotFoundError::new_err(msg),
            ErrorKind::Io(std::io::ErrorKind::PermissionDenied) => PyPermissionError::new_err(msg),
            ErrorKind::Io(_) => PyOSError::new_err(msg),
            _ => StaridError::new_err(msg),
        }
    }
}
