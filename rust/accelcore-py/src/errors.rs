//! The one place that knows both sides: core errors become Python exceptions.
//!
//! The exception classes are declared once, in `accelcore/errors.py`, because
//! several of them derive from two builtins (`ValueError` or `OSError` beside
//! `AccelcoreError`), which `create_exception!` cannot express. This module
//! looks them up by name and attaches the values each core variant carries as
//! attributes, so Python code never has to parse a message.

use accelcore_core::Error;
use pyo3::exceptions::PyRuntimeError;
use pyo3::prelude::*;
use pyo3::types::PyDict;

/// Newtype that lets us implement `From<CoreError> for PyErr` (orphan rule).
pub(crate) struct CoreError(pub(crate) Error);

impl From<Error> for CoreError {
    fn from(err: Error) -> Self {
        Self(err)
    }
}

impl From<CoreError> for PyErr {
    fn from(err: CoreError) -> Self {
        Python::attach(|py| to_pyerr(py, &err.0))
    }
}

/// Map one core error to an instance of its Python class.
fn to_pyerr(py: Python<'_>, err: &Error) -> PyErr {
    let attrs = PyDict::new(py);
    let class = match err {
        Error::InvalidParameter { name, .. } => {
            let _ = attrs.set_item("parameter", *name);
            "ParameterError"
        }
        Error::Shape { .. } => "ShapeError",
        Error::TimeNotIncreasing {
            index,
            previous_s,
            time_s,
        } => {
            let _ = attrs.set_item("index", *index);
            let _ = attrs.set_item("previous_s", *previous_s);
            let _ = attrs.set_item("time_s", *time_s);
            "TimeOrderError"
        }
        Error::NonFinite { row, column, .. } => {
            let _ = attrs.set_item("row", *row);
            let _ = attrs.set_item("column", *column);
            "NonFiniteError"
        }
        Error::Empty { .. } | Error::InsufficientData { .. } => "InsufficientDataError",
        Error::Incompatible { .. } => "IncompatibleError",
        Error::RankDeficient { columns } => {
            let _ = attrs.set_item("columns", columns.clone());
            "SingularSystemError"
        }
        Error::Parse {
            path, line, column, ..
        } => {
            let _ = attrs.set_item("path", path.as_str());
            let _ = attrs.set_item("line", *line);
            let _ = attrs.set_item("column", *column);
            "ParseError"
        }
        Error::Io { path, .. } => {
            let _ = attrs.set_item("path", path.as_str());
            "AccelcoreIOError"
        }
        // The core enum is non-exhaustive: a variant added there without a
        // mapping here still reaches Python as the base class.
        _ => "AccelcoreError",
    };
    let message = err.to_string();
    let build = || -> PyResult<PyErr> {
        let module = py.import("accelcore.errors")?;
        let exc = module.getattr(class)?.call1((message.as_str(),))?;
        for (key, value) in attrs.iter() {
            exc.setattr(key.cast::<pyo3::types::PyString>()?, value)?;
        }
        Ok(PyErr::from_value(exc))
    };
    build().unwrap_or_else(|e| {
        PyRuntimeError::new_err(format!(
            "{message} (and accelcore.errors could not be loaded: {e})"
        ))
    })
}

/// An internal error (a caught panic) as `accelcore.AccelcoreError`.
pub(crate) fn internal_error(py: Python<'_>, what: &str) -> PyErr {
    let message =
        format!("internal error in the accelcore core (please report it with the input): {what}");
    py.import("accelcore.errors")
        .and_then(|m| m.getattr("AccelcoreError"))
        .and_then(|cls| cls.call1((message.as_str(),)))
        .map_or_else(|e| e, PyErr::from_value)
}
