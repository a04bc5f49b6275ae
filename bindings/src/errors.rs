//! Engine errors as Python exceptions: OSError (FileNotFoundError) for files,
//! ValueError for everything else.

use engine::model::ParamError;
use engine::osi::OsiError;
use engine::ModelError;
use pyo3::exceptions::{PyFileNotFoundError, PyOSError, PyValueError};
use pyo3::PyErr;

pub(crate) fn model_error(e: ModelError) -> PyErr {
    match &e {
        ModelError::Io { source, .. } if source.kind() == std::io::ErrorKind::NotFound => {
            PyFileNotFoundError::new_err(e.to_string())
        }
        ModelError::Io { .. } => PyOSError::new_err(e.to_string()),
        _ => PyValueError::new_err(e.to_string()),
    }
}

pub(crate) fn param_error(e: ParamError) -> PyErr {
    PyValueError::new_err(e.to_string())
}

pub(crate) fn osi_error(context: &str, e: OsiError) -> PyErr {
    PyValueError::new_err(format!("{context}: {e}"))
}
