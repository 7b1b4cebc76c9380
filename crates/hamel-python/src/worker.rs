//! The computer algebra in processes of its own: `python -m hamel._worker derive-worker
//! RESULT` makes what the derivation store lacks and exits, giving Symbolica's one licensed
//! thread back before the notebook computes numbers (as `hamel derive-worker` does for the
//! command line).

use std::path::PathBuf;

use pyo3::prelude::*;

/// From now on derivations the store lacks are made by `executable -m hamel._worker
/// derive-worker RESULT`.
pub(crate) fn use_workers(executable: PathBuf) {
    let args = ["-m", "hamel._worker", "derive-worker"].map(String::from);
    hamel_reduce::pass::derive_in_worker(executable, args.to_vec());
}

/// The worker's side: `kind` is `derive-worker`, `args` its result file. Reads the job from
/// stdin, derives, writes the result; an error is the worker's own failure (the caller reads
/// the outcome from the result file).
#[pyfunction]
pub fn work(py: Python<'_>, kind: &str, args: Vec<String>) -> PyResult<()> {
    match (kind, args.as_slice()) {
        ("derive-worker", [result]) => {
            let result = PathBuf::from(result);
            crate::detached(py, || hamel_reduce::pass::work(&result))
                .map_err(|e| crate::errors::HamelError::new_err(e.to_string()))
        }
        _ => Err(crate::errors::HamelError::new_err(format!(
            "unknown worker `{kind}` with {} arguments",
            args.len()
        ))),
    }
}
