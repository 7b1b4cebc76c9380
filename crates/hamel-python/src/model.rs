//! A model as Python sees it: loaded from a file or TOML text, its names, its derivations
//! (from the derivation store, or made in a worker process) and its evaluation on arrays of
//! states.

use std::collections::HashMap;
use std::path::PathBuf;
use std::sync::Arc;

use numpy::{PyArray1, PyArrayMethods, PyReadonlyArray2};
use pyo3::prelude::*;
use pyo3::types::PyDict;

use hamel_reduce::pass::{Analysis, Job};

use crate::derivation::Derivation;
use crate::errors::{HamelError, ModelError, to_py};

/// A mechanical system: L = T + U and linear velocity constraints α(q)q̇ = 0, typed by hand
/// or made from bodies, frames and wheels.
#[pyclass(module = "hamel._hamel", frozen)]
pub struct Model {
    inner: Arc<hamel_model::Model>,
}

/// The rows of an evaluation, as arrays.
struct Evaluated {
    eta_dot: Vec<Vec<f64>>,
    q_dot: Vec<Vec<f64>>,
    energy: Vec<f64>,
    eta_dot_paper: Vec<Vec<f64>>,
}

#[pymethods]
impl Model {
    /// Read and check a model file (errors: `hamel.ModelError`, located).
    #[staticmethod]
    fn load(py: Python<'_>, path: PathBuf) -> PyResult<Model> {
        let m = hamel_model::Model::load(&path).map_err(|e| to_py(py, &e))?;
        Ok(Model { inner: Arc::new(m) })
    }

    /// Check a model given as TOML text; `name` names it in messages.
    #[staticmethod]
    #[pyo3(signature = (text, name = "<text>"))]
    fn from_toml(py: Python<'_>, text: &str, name: &str) -> PyResult<Model> {
        let m = hamel_model::Model::from_source(name, text).map_err(|e| to_py(py, &e))?;
        Ok(Model { inner: Arc::new(m) })
    }

    /// Its name.
    #[getter]
    fn name(&self) -> &str {
        &self.inner.name
    }

    /// Its title.
    #[getter]
    fn title(&self) -> &str {
        &self.inner.title
    }

    /// The coordinates q₁…q_ℓ, in order.
    #[getter]
    fn coordinates(&self) -> Vec<String> {
        self.inner.coordinates.clone()
    }

    /// The parameters' values (derived ones included), by name.
    #[getter]
    fn parameters(&self) -> indexmap::IndexMap<String, f64> {
        self.inner.parameters.clone()
    }

    /// The names of its quasi-velocity choices (`[quasi_velocities.NAME]`; hamel's default
    /// when the file gives none).
    #[getter]
    fn choices(&self) -> Vec<String> {
        self.inner.choices.iter().map(|c| c.name.clone()).collect()
    }

    /// The Boltzmann–Hamel equations with the choice `eta` (the first when None): from the
    /// derivation store when it holds them, else derived exactly in a worker process.
    #[pyo3(signature = (eta = None))]
    fn derive(&self, py: Python<'_>, eta: Option<&str>) -> PyResult<Derivation> {
        let d = self.derivation(py, eta)?;
        Ok(Derivation { inner: Arc::new(d) })
    }

    /// η̇, q̇, the energy and the paper's η̇ at N states: `q` of shape (N, ℓ), `eta` (N, σ), with
    /// the choice `choice` and parameter values `params` on top of the model's. Returns a dict
    /// of arrays: `eta_dot` (N, σ), `q_dot` (N, ℓ), `energy` (N,), `eta_dot_paper` (N, σ).
    #[pyo3(signature = (q, eta, *, choice = None, params = None))]
    fn eval<'py>(
        &self,
        py: Python<'py>,
        q: PyReadonlyArray2<'py, f64>,
        eta: PyReadonlyArray2<'py, f64>,
        choice: Option<&str>,
        params: Option<HashMap<String, f64>>,
    ) -> PyResult<Bound<'py, PyDict>> {
        let d = self.derivation(py, choice)?;
        let (q, eta) = (q.as_array().to_owned(), eta.as_array().to_owned());
        let dims = (d.ell, d.sigma);
        if q.ncols() != dims.0 || eta.ncols() != dims.1 || q.nrows() != eta.nrows() {
            let msg = format!(
                "q must have shape (N, {}) and eta (N, {}) with the same N; got {:?} and {:?}",
                dims.0,
                dims.1,
                q.shape(),
                eta.shape()
            );
            return Err(pyo3::exceptions::PyValueError::new_err(msg));
        }
        let overrides: indexmap::IndexMap<String, f64> =
            params.unwrap_or_default().into_iter().collect();
        let values = self
            .inner
            .parameter_values(&overrides)
            .map_err(|e| ModelError::new_err(format!("params: {e}")))?;
        let compiled = d
            .compile()
            .map_err(|e| HamelError::new_err(format!("the equations do not compile: {e}")))?;
        let out = crate::detached(py, || -> Result<Evaluated, String> {
            let mut out = Evaluated {
                eta_dot: Vec::new(),
                q_dot: Vec::new(),
                energy: Vec::new(),
                eta_dot_paper: Vec::new(),
            };
            for (i, (qi, ei)) in q.rows().into_iter().zip(eta.rows()).enumerate() {
                let e = compiled
                    .evaluate(&qi.to_vec(), &ei.to_vec(), &values)
                    .map_err(|e| format!("state {i}: {e}"))?;
                out.eta_dot.push(e.eta_dot);
                out.q_dot.push(e.q_dot);
                out.energy.push(e.energy);
                out.eta_dot_paper.push(e.eta_dot_paper);
            }
            Ok(out)
        })
        .map_err(HamelError::new_err)?;
        let dict = PyDict::new(py);
        let table = |rows: &[Vec<f64>], width: usize| {
            let flat: Vec<f64> = rows.concat();
            PyArray1::from_vec(py, flat).reshape([rows.len(), width])
        };
        dict.set_item("eta_dot", table(&out.eta_dot, dims.1)?)?;
        dict.set_item("q_dot", table(&out.q_dot, dims.0)?)?;
        dict.set_item("energy", PyArray1::from_vec(py, out.energy))?;
        dict.set_item("eta_dot_paper", table(&out.eta_dot_paper, dims.1)?)?;
        Ok(dict)
    }

    fn __repr__(&self) -> String {
        format!(
            "<hamel.Model {} ({} coordinates, {} constraints)>",
            self.inner.name,
            self.inner.coordinates.len(),
            self.inner.constraints.len()
        )
    }
}

impl Model {
    /// The derivation with the choice `eta`: the store's, or made in a worker process (the
    /// GIL released while it waits).
    fn derivation(&self, py: Python<'_>, eta: Option<&str>) -> PyResult<hamel_derive::Derivation> {
        let model = &self.inner;
        let job =
            Job::new(model, eta, Analysis::Equations).map_err(|e| to_py(py, &e.locate(model)))?;
        let made = crate::detached(py, || {
            hamel_reduce::pass::obtain(&job, false).and_then(|a| a.into_derivation())
        });
        made.map_err(|e| to_py(py, &e.locate(model)))
    }
}
