//! hamel's errors as Python exceptions: `hamel.HamelError`, and `hamel.ModelError` for a
//! located problem in a model or scene, with the diagnostic's parts as attributes.

use pyo3::exceptions::PyException;
use pyo3::prelude::*;

pyo3::create_exception!(
    hamel,
    HamelError,
    PyException,
    "Base class of hamel's errors."
);
pyo3::create_exception!(
    hamel,
    ModelError,
    HamelError,
    "A problem in a model or scene: `file`, `line`, `column` (1-based, or None), `key` (the \
     field, such as `constraints.knife`) and `reason`, and the whole diagnostic as the message."
);

/// A hamel error as a Python exception: its message the diagnostic, its parts attributes.
pub(crate) fn to_py(py: Python<'_>, e: &hamel_model::ModelError) -> PyErr {
    let err = match e.kind() {
        hamel_model::ErrorKind::Input => ModelError::new_err(e.to_string()),
        _ => HamelError::new_err(e.to_string()),
    };
    let value = err.value(py);
    let (line, column) = e.line_col().unzip();
    // Setting an attribute of a new exception cannot fail but for memory.
    let _ = value.setattr("file", e.file());
    let _ = value.setattr("line", line);
    let _ = value.setattr("column", column);
    let _ = value.setattr("key", e.key());
    let _ = value.setattr("reason", e.message());
    err
}
