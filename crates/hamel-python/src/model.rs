//! A model as Python sees it: loaded from a file or TOML text, its names, its derivations
//! (from the derivation store, or made in a worker process) and its evaluation on arrays of
//! states.

use std::borrow::Cow;
use std::collections::HashMap;
use std::path::PathBuf;
use std::sync::{Arc, Mutex};

use indexmap::IndexMap;
use numpy::ndarray::ArrayView2;
use numpy::{PyArray1, PyArrayMethods, PyReadonlyArray2};
use pyo3::prelude::*;
use pyo3::types::PyDict;

use hamel_reduce::pass::{Analysis, Job};

use crate::core::{Core, Evaluated, Wanted};
use crate::derivation::Derivation;
use crate::errors::{HamelError, ModelError, to_py};
use crate::rhs::{Rhs, core_values};

/// A mechanical system: L = T + U and linear velocity constraints α(q)q̇ = 0, typed by hand
/// or made from bodies, frames and wheels.
#[pyclass(module = "hamel._hamel", frozen)]
pub struct Model {
    inner: Arc<hamel_model::Model>,
    /// The derivations obtained so far, by the choice asked for (None: the first).
    derivations: Mutex<HashMap<Option<String>, Arc<hamel_derive::Derivation>>>,
    /// The generated cores opened so far, by their code cache key.
    cores: Mutex<HashMap<String, Arc<Core>>>,
}

impl Model {
    fn new(m: hamel_model::Model) -> Model {
        Model {
            inner: Arc::new(m),
            derivations: Mutex::default(),
            cores: Mutex::default(),
        }
    }
}

#[pymethods]
impl Model {
    /// Read and check a model file (errors: `hamel.ModelError`, located).
    #[staticmethod]
    fn load(py: Python<'_>, path: PathBuf) -> PyResult<Model> {
        let m = hamel_model::Model::load(&path).map_err(|e| to_py(py, &e))?;
        Ok(Model::new(m))
    }

    /// Check a model given as TOML text; `name` names it in messages.
    #[staticmethod]
    #[pyo3(signature = (text, name = "<text>"))]
    fn from_toml(py: Python<'_>, text: &str, name: &str) -> PyResult<Model> {
        let m = hamel_model::Model::from_source(name, text).map_err(|e| to_py(py, &e))?;
        Ok(Model::new(m))
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
        Ok(Derivation { inner: d })
    }

    /// η̇, q̇ and the energy at N states, in one call: `q` of shape (N, ℓ), `eta` (N, σ),
    /// with the choice `choice` and parameter values `params` on top of the model's. Returns
    /// a dict of arrays: `eta_dot` (N, σ), `q_dot` (N, ℓ), `energy` (N,); with `paper=True`
    /// also `eta_dot_paper` (N, σ), η̇ of the paper's (14) without the term it drops; with
    /// `forces=True` also `constraint_forces`, {name: (N,)}. `engine="compiled"` (the default)
    /// runs the generated core (built by cargo on first use, then kept in the code cache);
    /// `"interpreted"` evaluates the derivation's expressions without building anything.
    #[pyo3(signature = (q, eta, *, choice = None, params = None, paper = false, forces = false, engine = "compiled"))]
    #[allow(clippy::too_many_arguments)]
    fn eval<'py>(
        &self,
        py: Python<'py>,
        q: PyReadonlyArray2<'py, f64>,
        eta: PyReadonlyArray2<'py, f64>,
        choice: Option<&str>,
        params: Option<IndexMap<String, f64>>,
        paper: bool,
        forces: bool,
        engine: &str,
    ) -> PyResult<Bound<'py, PyDict>> {
        let d = self.derivation(py, choice)?;
        let dims = (d.ell, d.sigma);
        let (q, eta) = (q.as_array(), eta.as_array());
        let (q, eta) = states(&q, &eta, dims)?;
        let overrides = params.unwrap_or_default();
        let wanted = Wanted { paper, forces };
        let (out, force_names) = match engine {
            "compiled" => {
                let core = self.core(py, &d, &IndexMap::new())?;
                let values = core_values(&self.inner, &core, &overrides)?;
                let data = core.prepare(&values).map_err(HamelError::new_err)?;
                let out = crate::detached(py, || core.eval(&q, &eta, &data, wanted));
                (out, core.forces.clone())
            }
            "interpreted" => {
                if forces {
                    let msg = "constraint forces need the compiled engine (engine=\"compiled\")";
                    return Err(pyo3::exceptions::PyValueError::new_err(msg));
                }
                let values = self
                    .inner
                    .parameter_values(&overrides)
                    .map_err(|e| ModelError::new_err(format!("params: {e}")))?;
                let compiled = d.compile().map_err(|e| {
                    HamelError::new_err(format!("the equations do not compile: {e}"))
                })?;
                let out = crate::detached(py, || {
                    interpreted(&compiled, &q, &eta, &values, dims, paper)
                });
                (out, Vec::new())
            }
            other => {
                let msg = format!("engine must be \"compiled\" or \"interpreted\", not {other:?}");
                return Err(pyo3::exceptions::PyValueError::new_err(msg));
            }
        };
        let out = out.map_err(HamelError::new_err)?;
        evaluated_dict(py, out, &force_names, dims)
    }

    /// The compiled right-hand side of the full system with the choice `eta` and parameter
    /// values `params` on top of the model's: `f(t, y)` for scipy's `solve_ivp`, with
    /// y = (q₁…q_ℓ, η₁…η_σ), and the C callback (`.address`, `.data`) for numbalsoda and
    /// numba. The generated core is built by cargo on first use and kept in the code cache.
    /// With `specialise=True` the parameter values are folded into the code as a scene's are
    /// (often a much shorter solved form; one core per set of values, and `with_params`
    /// refused); else they are inputs, changed without a new build.
    #[pyo3(signature = (eta = None, *, params = None, specialise = false))]
    fn rhs(
        &self,
        py: Python<'_>,
        eta: Option<&str>,
        params: Option<IndexMap<String, f64>>,
        specialise: bool,
    ) -> PyResult<Rhs> {
        let d = self.derivation(py, eta)?;
        let overrides = params.unwrap_or_default();
        let fixed = match specialise {
            true => self
                .inner
                .parameter_values(&overrides)
                .map_err(|e| ModelError::new_err(format!("params: {e}")))?,
            false => IndexMap::new(),
        };
        let core = self.core(py, &d, &fixed)?;
        Rhs::new(core, self.inner.clone(), overrides, d, specialise)
    }

    /// The steady motion `steady`'s linearisation (as `hamel linearize` computes it): at the
    /// point `at` (steady and model parameters by name; the defaults elsewhere), or swept over
    /// `sweep` (`"P=START:STOP:COUNT"`, or a list of at most two: a stability map). Returns
    /// hamel's JSON as Python objects, matrices and eigenvalues as numpy arrays: a point has
    /// `a`, `b`, `jacobian`, `eigenvalues`, `second_order` (`m`, `c`, `k`, …), `stability`;
    /// a sweep `points` and `crossings` (the weave and capsize speeds of a bicycle).
    #[pyo3(signature = (steady, *, eta = None, at = None, sweep = None))]
    fn linearize<'py>(
        &self,
        py: Python<'py>,
        steady: &str,
        eta: Option<&str>,
        at: Option<IndexMap<String, f64>>,
        sweep: Option<Bound<'py, PyAny>>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let sweep: Vec<String> = match sweep {
            None => Vec::new(),
            Some(s) => match s.extract::<String>() {
                Ok(one) => vec![one],
                Err(_) => s.extract()?,
            },
        };
        crate::study::linearize(py, &self.inner, steady, eta, at.unwrap_or_default(), sweep)
    }

    /// Which coordinates drop out with the choice `eta` when `eliminate` are eliminated,
    /// decided exactly (`hamel reduce`; in a worker process when the store lacks it): the
    /// reduction's JSON as Python objects (`free_of`, witnesses, the ground truth, …) and its
    /// printed report as `text`.
    #[pyo3(signature = (eliminate, *, eta = None))]
    fn reduce<'py>(
        &self,
        py: Python<'py>,
        eliminate: Vec<String>,
        eta: Option<&str>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let model = &self.inner;
        let r = crate::detached(py, || reduction(model, eta, &eliminate))
            .map_err(|e| to_py(py, &e.locate(model)))?;
        let text = hamel_print::reduction::text(&r, model)
            .map_err(|e| HamelError::new_err(format!("printing the reduction: {e}")))?;
        let json = serde_json::to_string(&r).expect("serialisable");
        let dict = py.import("json")?.call_method1("loads", (json,))?;
        dict.set_item("text", text)?;
        Ok(dict)
    }

    /// Search parametrised quasi-velocities for choices that eliminate `eliminate`
    /// (`hamel search`), within `budget` seconds, collecting at most `max` candidates; in a
    /// worker process (`python -m hamel._worker search-worker`), ended at the deadline. The
    /// report's JSON as Python objects: `candidates` a list of rows (a table:
    /// `pandas.DataFrame(r["candidates"])`), `families`, `stop`, and `text`.
    #[pyo3(signature = (eliminate, *, budget = 60.0, max = 12))]
    fn search<'py>(
        &self,
        py: Python<'py>,
        eliminate: Vec<String>,
        budget: f64,
        max: usize,
    ) -> PyResult<Bound<'py, PyAny>> {
        if !(budget.is_finite() && budget > 0.0) {
            let msg = format!("budget must be a positive number of seconds, got {budget}");
            return Err(pyo3::exceptions::PyValueError::new_err(msg));
        }
        let model = &self.inner;
        let file = crate::search::model_file(model).map_err(HamelError::new_err)?;
        let options = hamel_reduce::SearchOptions {
            budget: std::time::Duration::from_secs_f64(budget),
            max_candidates: max,
        };
        let report = crate::detached(py, || {
            hamel_reduce::supervised::run_search(file.path(), model, &eliminate, options)
        })
        .map_err(|e| to_py(py, &e.locate(model)))?;
        let json = serde_json::to_string(&report).expect("serialisable");
        let dict = py.import("json")?.call_method1("loads", (json,))?;
        dict.set_item("text", report.to_text())?;
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
    /// The generated core of the full system of the derivation `d`: opened before in this
    /// model, else from the code cache (generated and built by cargo when missing, the GIL
    /// released).
    fn core(
        &self,
        py: Python<'_>,
        d: &hamel_derive::Derivation,
        fixed: &IndexMap<String, f64>,
    ) -> PyResult<Arc<Core>> {
        let key = hamel_run::cache::Key::library(&self.inner, &d.eta_name, fixed);
        let mut cores = self.cores.lock().unwrap_or_else(|e| e.into_inner());
        if let Some(core) = cores.get(key.text()) {
            return Ok(core.clone());
        }
        let model = &self.inner;
        let opened = crate::detached(py, || {
            let entry =
                hamel_run::cache::prepare_library(model, d, fixed).map_err(|e| e.to_string())?;
            let built = hamel_run::cache::library(&entry).map_err(|e| e.to_string())?;
            Core::open(&built.path)
        })
        .map_err(HamelError::new_err)?;
        let core = Arc::new(opened);
        cores.insert(key.text().to_string(), core.clone());
        Ok(core)
    }

    /// The derivation with the choice `eta`: the store's, or made in a worker process (the
    /// GIL released while it waits).
    fn derivation(
        &self,
        py: Python<'_>,
        eta: Option<&str>,
    ) -> PyResult<Arc<hamel_derive::Derivation>> {
        let key = eta.map(str::to_string);
        if let Some(d) = self
            .derivations
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .get(&key)
        {
            return Ok(d.clone());
        }
        let model = &self.inner;
        let job =
            Job::new(model, eta, Analysis::Equations).map_err(|e| to_py(py, &e.locate(model)))?;
        let made = crate::detached(py, || {
            hamel_reduce::pass::obtain(&job, false).and_then(|a| a.into_derivation())
        });
        let d = Arc::new(made.map_err(|e| to_py(py, &e.locate(model)))?);
        let mut derivations = self.derivations.lock().unwrap_or_else(|e| e.into_inner());
        derivations.insert(key, d.clone());
        Ok(d)
    }
}

/// A table of states, row-major: borrowed from a contiguous array, else copied.
type Rows<'a> = Cow<'a, [f64]>;

/// `q` (N, ℓ) and `eta` (N, σ) as row-major slices (borrowed when contiguous), their shapes
/// checked.
fn states<'a>(
    q: &'a ArrayView2<'_, f64>,
    eta: &'a ArrayView2<'_, f64>,
    (ell, sigma): (usize, usize),
) -> PyResult<(Rows<'a>, Rows<'a>)> {
    if q.ncols() != ell || eta.ncols() != sigma || q.nrows() != eta.nrows() {
        let msg = format!(
            "q must have shape (N, {ell}) and eta (N, {sigma}) with the same N; got {:?} and {:?}",
            q.shape(),
            eta.shape()
        );
        return Err(pyo3::exceptions::PyValueError::new_err(msg));
    }
    let rows = |a: &'a ArrayView2<'_, f64>| match a.as_slice() {
        Some(s) => Cow::Borrowed(s),
        None => Cow::Owned(a.iter().copied().collect()),
    };
    Ok((rows(q), rows(eta)))
}

/// [`Model::eval`] by the interpreted evaluator.
fn interpreted(
    compiled: &hamel_derive::Compiled,
    q: &[f64],
    eta: &[f64],
    values: &IndexMap<String, f64>,
    (ell, sigma): (usize, usize),
    paper: bool,
) -> Result<Evaluated, String> {
    let mut out = Evaluated {
        eta_dot_paper: paper.then(Vec::new),
        ..Evaluated::default()
    };
    let rows = q.chunks(ell.max(1)).zip(eta.chunks(sigma.max(1)));
    for (i, (qi, ei)) in rows.enumerate().take(eta.len() / sigma.max(1)) {
        let e = compiled
            .evaluate(qi, ei, values)
            .map_err(|e| format!("state {i}: {e}"))?;
        out.eta_dot.extend(e.eta_dot);
        out.q_dot.extend(e.q_dot);
        out.energy.push(e.energy);
        if let Some(p) = out.eta_dot_paper.as_mut() {
            p.extend(e.eta_dot_paper);
        }
    }
    Ok(out)
}

/// An evaluation as the dict [`Model::eval`] returns.
fn evaluated_dict<'py>(
    py: Python<'py>,
    out: Evaluated,
    force_names: &[String],
    (ell, sigma): (usize, usize),
) -> PyResult<Bound<'py, PyDict>> {
    let n = out.energy.len();
    let dict = PyDict::new(py);
    let table = |flat: Vec<f64>, width: usize| PyArray1::from_vec(py, flat).reshape([n, width]);
    dict.set_item("eta_dot", table(out.eta_dot, sigma)?)?;
    dict.set_item("q_dot", table(out.q_dot, ell)?)?;
    dict.set_item("energy", PyArray1::from_vec(py, out.energy))?;
    if let Some(paper) = out.eta_dot_paper {
        dict.set_item("eta_dot_paper", table(paper, sigma)?)?;
    }
    if let Some(forces) = out.forces {
        let by_name = PyDict::new(py);
        let width = force_names.len();
        for (j, name) in force_names.iter().enumerate() {
            let column: Vec<f64> = (0..n).map(|i| forces[i * width + j]).collect();
            by_name.set_item(name, PyArray1::from_vec(py, column))?;
        }
        dict.set_item("constraint_forces", by_name)?;
    }
    Ok(dict)
}

/// The reduction of `model` with `eliminate` (`hamel reduce`'s analysis), from the store or
/// made in a worker process ([`hamel_reduce::pass::obtain`]): never the computer algebra here.
fn reduction(
    model: &hamel_model::Model,
    eta: Option<&str>,
    eliminate: &[String],
) -> Result<hamel_reduce::Reduction, hamel_reduce::ReduceError> {
    let p = hamel_reduce::coordinate_indices(model, eliminate)?;
    let job = Job::new(model, eta, Analysis::Eliminate(p))?;
    let artefact = hamel_reduce::pass::obtain(&job, false)?;
    artefact.reduction.ok_or_else(|| {
        hamel_reduce::ReduceError::StoredUnreadable("the stored analysis has no reduction".into())
    })
}
