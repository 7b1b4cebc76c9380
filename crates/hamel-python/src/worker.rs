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
    hamel_reduce::pass::derive_in_worker(executable.clone(), args.to_vec());
    let args = ["-m", "hamel._worker", "search-worker"].map(String::from);
    hamel_reduce::supervised::search_in_worker(executable, args.to_vec());
}

/// The worker's side. `derive-worker RESULT`: reads the job from stdin, derives, writes the
/// result (an error is the worker's own failure: the caller reads the outcome from the result
/// file). `search-worker MODEL --eliminate A,B --budget S --max N`: the search, its events as
/// JSON lines on stdout for the supervising process (`hamel_reduce::supervised`).
#[pyfunction]
pub fn work(py: Python<'_>, kind: &str, args: Vec<String>) -> PyResult<()> {
    match (kind, args.as_slice()) {
        ("derive-worker", [result]) => {
            let result = PathBuf::from(result);
            crate::detached(py, || hamel_reduce::pass::work(&result))
                .map_err(|e| crate::errors::HamelError::new_err(e.to_string()))
        }
        ("search-worker", [model, e, eliminate, b, budget, m, max])
            if e == "--eliminate" && b == "--budget" && m == "--max" =>
        {
            let fail = |e: String| crate::errors::HamelError::new_err(e);
            let model = hamel_model::Model::load(model).map_err(|e| fail(e.to_string()))?;
            let eliminate: Vec<String> = eliminate.split(',').map(str::to_string).collect();
            let budget: f64 = budget
                .parse()
                .map_err(|_| fail(format!("--budget {budget}")))?;
            let max: usize = max.parse().map_err(|_| fail(format!("--max {max}")))?;
            let budget = std::time::Duration::from_secs_f64(budget.max(0.0));
            crate::detached(py, || {
                hamel_reduce::supervised::work(&model, &eliminate, budget, max)
            })
            .map_err(|e| fail(e.to_string()))
        }
        _ => Err(crate::errors::HamelError::new_err(format!(
            "unknown worker `{kind}` with {} arguments",
            args.len()
        ))),
    }
}
