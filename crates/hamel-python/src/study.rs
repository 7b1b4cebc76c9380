//! `Model.linearize`: a steady motion's linearisation at a point, a sweep over one parameter
//! with its crossings, or a map over two (`hamel_study::Study`, as `hamel linearize` runs it),
//! as Python objects with numpy arrays (`hamel._linear.convert`).

use pyo3::prelude::*;

use hamel_study::{Point, Progress, Range, Study};

use crate::errors::to_py;

/// No progress bar in a notebook.
struct Quiet;

impl Progress for Quiet {
    fn start(&self, _: u64) {}
    fn tick(&self) {}
    fn finish(&self) {}
}

/// The linearisation of `model` at `steady` (choice `eta`), at the point `at` (steady and
/// model parameters by name), swept over `sweep` (`P=START:STOP:COUNT`, at most two).
pub fn linearize<'py>(
    py: Python<'py>,
    model: &hamel_model::Model,
    steady: &str,
    eta: Option<&str>,
    at: indexmap::IndexMap<String, f64>,
    sweep: Vec<String>,
) -> PyResult<Bound<'py, PyAny>> {
    let located = |e: hamel_study::StudyError| to_py(py, &e.locate(model));
    let ranges = sweep
        .iter()
        .map(|s| Range::parse(s))
        .collect::<Result<Vec<_>, _>>()
        .map_err(|e| crate::errors::ModelError::new_err(format!("sweep: {e}")))?;
    if ranges.len() > 2 {
        let msg = "at most two sweeps: one gives a sweep, two a stability map";
        return Err(crate::errors::ModelError::new_err(msg));
    }
    let study = crate::detached(py, || Study::prepare_with(model, eta, steady, false));
    let study = study.map_err(located)?;
    let outcome = crate::detached(py, || study.run(&Point(at), &ranges, &Quiet));
    let outcome = outcome.map_err(|e| to_py(py, &e))?;
    py.import("hamel._linear")?
        .call_method1("convert", (outcome.json(),))
}
