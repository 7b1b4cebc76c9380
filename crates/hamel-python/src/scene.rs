//! A scene as Python sees it: a model, quasi-velocities, parameters, an initial state and an
//! integrator (`scenes/*.toml`), simulated into arrays with names.

use std::path::PathBuf;

use indexmap::IndexMap;
use numpy::{PyArray1, PyArrayMethods};
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::errors::to_py;

/// A scene file: what `hamel simulate` runs (docs/tradeoff.md, scenes/).
#[pyclass(module = "hamel._hamel", frozen)]
pub struct Scene {
    path: PathBuf,
    set: IndexMap<String, f64>,
}

#[pymethods]
impl Scene {
    /// Read and check a scene (its model, choice, initial state, integrator), with parameter
    /// values `set` on top of its `[parameters]`; the equations from the derivation store, or
    /// derived in a worker process.
    #[staticmethod]
    #[pyo3(signature = (path, *, set = None))]
    fn load(py: Python<'_>, path: PathBuf, set: Option<IndexMap<String, f64>>) -> PyResult<Scene> {
        let scene = Scene {
            path,
            set: set.unwrap_or_default(),
        };
        scene.loaded(py)?;
        Ok(scene)
    }

    /// Integrate the scene (`engine`: `compiled`, its generated core built with cargo on
    /// first use and cached, or `interpreted`). Returns a dict: `t` (N,), `q` {coordinate:
    /// (N,)} for the requested coordinates, `eta` (N, σ) when requested, `energy` (N,) when
    /// requested, `expressions` and `forces` {name: (N,)} (NaN where a value cannot be
    /// computed), `complete`, and `stats`. A run that stops early raises `hamel.HamelError`
    /// naming why.
    #[pyo3(signature = (*, engine = "compiled"))]
    fn simulate<'py>(&self, py: Python<'py>, engine: &str) -> PyResult<Bound<'py, PyDict>> {
        let engine = engine_named(engine)?;
        let (path, set) = (&self.path, &self.set);
        let run = crate::detached(py, || {
            let loaded = hamel_run::load_with_options(path, set, Default::default())?;
            hamel_run::simulate::run_loaded(&loaded, engine, false)
        })
        .map_err(|e| to_py(py, &e))?;
        if let Some(e) = &run.failure {
            return Err(to_py(py, e));
        }
        trajectory(py, &run.trajectory)
    }

    /// Run an ensemble on the scene's compiled core, its members in parallel on the core's
    /// rayon pool (`threads`, 0: one per core), the GIL released. `members`: `{name: values}`
    /// (coordinates, `eta1`…, parameters; equal lengths; NaN: the scene's value), else the
    /// scene's own `[ensemble]`. `save`: `"final"` (the last output time) or `"outputs"` (every
    /// one); default the scene's. Returns `member`, `complete`, `steps`, `rhs_evals`
    /// (arrays), `given` and `values` ({name: array}: (N,) when final, (N, T) otherwise),
    /// `t`, `errors` (a message or None per member) and `header`.
    #[pyo3(signature = (members = None, *, save = None, threads = 0))]
    fn ensemble<'py>(
        &self,
        py: Python<'py>,
        members: Option<IndexMap<String, Vec<f64>>>,
        save: Option<&str>,
        threads: usize,
    ) -> PyResult<Bound<'py, PyDict>> {
        let save = match save {
            None => None,
            Some("final") => Some(hamel_run::file::Save::Final),
            Some("outputs") => Some(hamel_run::file::Save::Outputs),
            Some(other) => {
                let msg = format!("save must be \"final\" or \"outputs\", not {other:?}");
                return Err(pyo3::exceptions::PyValueError::new_err(msg));
            }
        };
        let (path, set) = (&self.path, &self.set);
        let settings = hamel_run::ensemble::Settings {
            threads,
            ..Default::default()
        };
        let (run, save) = crate::detached(py, || {
            let loaded = hamel_run::load_with_options(path, set, Default::default())?;
            let save = save.unwrap_or_else(|| loaded.ensemble_save());
            let members = match &members {
                Some(columns) => crate::ensemble::members(&loaded, columns, save),
                None => crate::ensemble::scene_members(&loaded, save),
            }?;
            Ok((loaded.run_ensemble(&members, settings, &|_, _| {})?, save))
        })
        .map_err(|e: hamel_model::ModelError| to_py(py, &e))?;
        crate::ensemble::to_dict(py, &run, save)
    }

    /// The trade of speed against accuracy (`hamel tradeoff`): every integrator at its
    /// settings (`range="all"`), the adaptive ones (`"adaptive"`), or the fine work–precision
    /// curve (`"work-precision"`), each timed and its error measured against a tight
    /// reference. Returns the table's JSON as Python objects (`rows`: a list of dicts, a
    /// table for `pandas.DataFrame`; `recommended`: the index of the fastest row that meets
    /// the scene's target) and the printed table as `text`. Each setting is timed for
    /// `min_time` seconds (a shorter run repeated, the median taken; 0: one run each).
    #[pyo3(signature = (*, range = "all", engine = "compiled", min_time = 0.05))]
    fn tradeoff<'py>(
        &self,
        py: Python<'py>,
        range: &str,
        engine: &str,
        min_time: f64,
    ) -> PyResult<Bound<'py, PyAny>> {
        use hamel_run::tradeoff::{Range, Timing};
        let engine = engine_named(engine)?;
        let Some(timing) = Timing::from_secs(min_time) else {
            let max = Timing::MAX_SECONDS;
            let msg = format!("min_time must be seconds from 0 to {max}, not {min_time}");
            return Err(pyo3::exceptions::PyValueError::new_err(msg));
        };
        let range = match range {
            "all" => Range::All,
            "adaptive" => Range::Adaptive,
            "work-precision" => Range::WorkPrecision,
            other => {
                let msg = format!(
                    "range must be \"all\", \"adaptive\" or \"work-precision\", not {other:?}"
                );
                return Err(pyo3::exceptions::PyValueError::new_err(msg));
            }
        };
        let (path, set) = (&self.path, &self.set);
        let table = crate::detached(py, || {
            let loaded = hamel_run::load_with_options(path, set, Default::default())?;
            hamel_run::tradeoff::table_timed(&loaded, range, engine, timing)
        })
        .map_err(|e| to_py(py, &e))?;
        let json = serde_json::to_string(&table).expect("serialisable");
        let dict = py.import("json")?.call_method1("loads", (json,))?;
        dict.set_item("text", table.to_text())?;
        Ok(dict)
    }

    fn __repr__(&self) -> String {
        format!("<hamel.Scene {}>", self.path.display())
    }
}

impl Scene {
    /// Check the scene: read, checked and derived (from the store, or in a worker process).
    fn loaded(&self, py: Python<'_>) -> PyResult<()> {
        let (path, set) = (&self.path, &self.set);
        crate::detached(py, || {
            hamel_run::load_with_options(path, set, Default::default()).map(drop)
        })
        .map_err(|e| to_py(py, &e))
    }
}

/// A trajectory as a dict of arrays.
fn trajectory<'py>(py: Python<'py>, t: &hamel_run::Trajectory) -> PyResult<Bound<'py, PyDict>> {
    let out = PyDict::new(py);
    let column = |v: &[Option<f64>]| {
        PyArray1::from_vec(py, v.iter().map(|x| x.unwrap_or(f64::NAN)).collect())
    };
    out.set_item("t", PyArray1::from_slice(py, &t.t))?;
    let q = PyDict::new(py);
    for (name, v) in &t.q {
        q.set_item(name, PyArray1::from_slice(py, v))?;
    }
    out.set_item("q", q)?;
    if let Some(first) = t.eta.first() {
        let flat: Vec<f64> = t.eta.concat();
        let eta = PyArray1::from_vec(py, flat).reshape([t.eta.len(), first.len()])?;
        out.set_item("eta", eta)?;
    }
    if let Some(e) = &t.energy {
        out.set_item("energy", column(e))?;
    }
    for (key, map) in [("expressions", &t.expressions), ("forces", &t.forces)] {
        let d = PyDict::new(py);
        for (name, v) in map {
            d.set_item(name, column(v))?;
        }
        out.set_item(key, d)?;
    }
    out.set_item("complete", t.complete)?;
    let stats = PyDict::new(py);
    stats.set_item("steps", t.stats.steps)?;
    stats.set_item("rejected", t.stats.rejected)?;
    stats.set_item("rhs_evals", t.stats.rhs_evals)?;
    stats.set_item("energy_drift", t.stats.energy_drift)?;
    out.set_item("stats", stats)?;
    out.set_item("method", t.method.as_str())?;
    Ok(out)
}

/// The engine named `name`.
fn engine_named(name: &str) -> PyResult<hamel_run::Engine> {
    match name {
        "compiled" => Ok(hamel_run::Engine::Compiled),
        "interpreted" => Ok(hamel_run::Engine::Interpreted),
        other => {
            let msg = format!("engine `{other}`: write `compiled` or `interpreted`");
            Err(pyo3::exceptions::PyValueError::new_err(msg))
        }
    }
}
