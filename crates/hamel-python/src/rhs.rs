//! `Model.rhs(...)`: the generated core's right-hand side of the full system, y = (q, η), as
//! a Python callable `f(t, y)` for scipy's `solve_ivp` and as the C callback (an address and a
//! data block) that numbalsoda and `numba.cfunc` take.

use std::sync::Arc;

use numpy::{
    PyArray1, PyArray2, PyArrayMethods, PyReadonlyArray2, PyReadonlyArrayDyn, PyUntypedArrayMethods,
};
use pyo3::prelude::*;

use indexmap::IndexMap;

use crate::core::Core;
use crate::errors::{HamelError, ModelError};

/// The compiled right-hand side of a model's full system: y = (q₁…q_ℓ, η₁…η_σ),
/// dy/dt = (q̇, η̇) from the Boltzmann–Hamel equations (11) and q̇ = Γη (6).
///
/// `rhs(t, y)` returns dy/dt as a new array (for `scipy.integrate.solve_ivp`); `rhs.address`
/// and `rhs.data` are the C callback `void f(double t, double *y, double *dy, double *data)`
/// and its data block, for numbalsoda (`lsoda(rhs.address, y0, t_eval, data=rhs.data)`) and
/// for calls from `numba` (`rhs.ctypes()`).
#[pyclass(module = "hamel._hamel", frozen)]
pub struct Rhs {
    core: Arc<Core>,
    model: Arc<hamel_model::Model>,
    /// The parameters set on top of the model's.
    overrides: IndexMap<String, f64>,
    /// The data block for `values`.
    data: Vec<f64>,
    /// The quasi-velocities' names.
    eta: Vec<String>,
    /// The derivation the core was generated from.
    derivation: Arc<hamel_derive::Derivation>,
    /// Whether the core has the parameter values folded in.
    specialised: bool,
}

impl Rhs {
    /// The hot path of `rhs(t, y)` for `solve_ivp`: y a contiguous float64 vector of ℓ + σ
    /// values, dy written straight into a new array; None for anything else.
    fn one_contiguous<'py>(
        &self,
        py: Python<'py>,
        y: &Bound<'py, PyAny>,
    ) -> PyResult<Option<Bound<'py, PyArray1<f64>>>> {
        let Ok(y) = y.cast::<PyArray1<f64>>() else {
            return Ok(None);
        };
        let n = self.n();
        if !y.is_contiguous() || y.len() != n {
            return Ok(None);
        }
        // SAFETY: a new array, not yet shared.
        let dy = unsafe { PyArray1::<f64>::new(py, n, false) };
        // SAFETY: `y` is read and `dy` written while this thread holds the GIL and runs no
        // Python code, so nothing else can write `y` or see `dy` meanwhile.
        let (ys, dys) = unsafe { (y.as_slice()?, dy.as_slice_mut()?) };
        self.core
            .rhs(ys, dys, &self.data)
            .map_err(HamelError::new_err)?;
        Ok(Some(dy))
    }

    /// The right-hand side of `core` (a core of `model`) with `overrides` set on top of the
    /// model's parameter values (derived ones evaluated again).
    pub fn new(
        core: Arc<Core>,
        model: Arc<hamel_model::Model>,
        overrides: IndexMap<String, f64>,
        derivation: Arc<hamel_derive::Derivation>,
        specialised: bool,
    ) -> PyResult<Rhs> {
        let eta = (1..=derivation.sigma).map(|i| format!("eta{i}")).collect();
        let values = core_values(&model, &core, &overrides)?;
        let data = core.prepare(&values).map_err(HamelError::new_err)?;
        Ok(Rhs {
            core,
            model,
            overrides,
            data,
            eta,
            derivation,
            specialised,
        })
    }

    fn n(&self) -> usize {
        self.core.dims.ell + self.core.dims.sigma
    }
}

#[pymethods]
impl Rhs {
    /// dy/dt at `y`: ℓ + σ values, or an array of shape (ℓ + σ, k) whose columns are states
    /// (`solve_ivp(..., vectorized=True)`). `t` is not used: the equations are autonomous. A
    /// state where the equations are not defined raises `hamel.HamelError` saying why.
    fn __call__<'py>(
        &self,
        py: Python<'py>,
        t: f64,
        y: &Bound<'py, PyAny>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let _ = t;
        if let Some(dy) = self.one_contiguous(py, y)? {
            return Ok(dy.into_any());
        }
        let y: PyReadonlyArrayDyn<'py, f64> = y.extract()?;
        let n = self.n();
        let shape = y.shape().to_vec();
        if shape.first() != Some(&n) || shape.len() > 2 {
            let msg = format!("y must have ℓ + σ = {n} values (or rows), got shape {shape:?}");
            return Err(pyo3::exceptions::PyValueError::new_err(msg));
        }
        if shape.len() == 1 {
            let y: Vec<f64> = y.as_array().iter().copied().collect();
            let mut dy = vec![0.0; n];
            self.core
                .rhs(&y, &mut dy, &self.data)
                .map_err(HamelError::new_err)?;
            return Ok(PyArray1::from_vec(py, dy).into_any());
        }
        // Columns are states: transposed to rows for the core, and back.
        let rows: Vec<f64> = y.as_array().t().iter().copied().collect();
        let mut dy = vec![0.0; rows.len()];
        let bad = py.detach(|| self.core.rhs_states(&rows, &mut dy, &self.data));
        if bad > 0 {
            let first = dy
                .chunks(n)
                .position(|r| r.iter().any(|x| x.is_nan()))
                .unwrap_or(0);
            let mut one = vec![0.0; n];
            let why = self
                .core
                .rhs(&rows[first * n..(first + 1) * n], &mut one, &self.data);
            let msg = format!("column {first}: {}", why.err().unwrap_or_default());
            return Err(HamelError::new_err(msg));
        }
        let k = shape[1];
        Ok(PyArray1::from_vec(py, dy)
            .reshape([k, n])?
            .transpose()?
            .into_any())
    }

    /// dy/dt at the rows of `y`, shape (N, ℓ + σ), in one call (the GIL released): NaN in the
    /// rows where the equations are not defined.
    fn states<'py>(
        &self,
        py: Python<'py>,
        y: PyReadonlyArray2<'py, f64>,
    ) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let n = self.n();
        if y.shape()[1] != n {
            let msg = format!("y must have shape (N, {n}), got {:?}", y.shape());
            return Err(pyo3::exceptions::PyValueError::new_err(msg));
        }
        let rows: Vec<f64> = y.as_array().iter().copied().collect();
        let mut dy = vec![0.0; rows.len()];
        py.detach(|| self.core.rhs_states(&rows, &mut dy, &self.data));
        PyArray1::from_vec(py, dy).reshape([rows.len() / n, n])
    }

    /// The address of `hamel_rhs`, `void f(double t, const double *y, double *dy, const double
    /// *data)` (numbalsoda's `lsoda_sig`): NaN in every dy where the equations are not defined.
    #[getter]
    fn address(&self) -> usize {
        self.core.rhs as usize
    }

    /// A copy of the data block to pass with [`address`] (parameters and their prepared
    /// constants; opaque: change parameters with `data_for`).
    #[getter]
    fn data<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        PyArray1::from_slice(py, &self.data)
    }

    /// The data block for other parameter values (`{name: value}` on top of this one's): for
    /// an ensemble over parameters in numba, one block per member.
    fn data_for<'py>(
        &self,
        py: Python<'py>,
        params: IndexMap<String, f64>,
    ) -> PyResult<Bound<'py, PyArray1<f64>>> {
        Ok(PyArray1::from_vec(py, self.with_params(params)?.data))
    }

    /// The same right-hand side with `params` set on top of this one's.
    fn with_params(&self, params: IndexMap<String, f64>) -> PyResult<Rhs> {
        if self.specialised {
            let msg = "this right-hand side has its parameter values folded in \
                       (specialise=True): ask the model for another, Model.rhs(eta, params=..., specialise=True)";
            return Err(HamelError::new_err(msg));
        }
        let mut overrides = self.overrides.clone();
        overrides.extend(params);
        Rhs::new(
            self.core.clone(),
            self.model.clone(),
            overrides,
            self.derivation.clone(),
            false,
        )
    }

    /// The C callback as a `ctypes` function (which `numba.njit` code can call).
    fn ctypes<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let ctypes = py.import("ctypes")?;
        let double = ctypes.getattr("c_double")?;
        let ptr = ctypes.call_method1("POINTER", (&double,))?;
        let proto = ctypes.call_method1("CFUNCTYPE", (py.None(), &double, &ptr, &ptr, &ptr))?;
        proto.call1((self.address(),))
    }

    /// The same equations as Python source, `def rhs_into(t, y, dy)` (straight-line code over
    /// `math`, this one's parameter values as numbers): what `numba.njit` compiles into a copy
    /// of hamel's equations. Needs a closed form (a structured derivation has none).
    fn python_source(&self) -> PyResult<String> {
        let values = self
            .model
            .parameter_values(&self.overrides)
            .map_err(|e| ModelError::new_err(format!("params: {e}")))?;
        let specialised;
        let d = match self.specialised {
            true => {
                specialised = self
                    .derivation
                    .specialise(&values)
                    .map_err(|e| HamelError::new_err(e.to_string()))?;
                &specialised
            }
            false => &*self.derivation,
        };
        match hamel_run::tradeoff::python_rhs_into(d, &values) {
            Ok(Some(text)) => Ok(text),
            Ok(None) => Err(HamelError::new_err(format!(
                "the equations of {} ({}) are in structured form: no closed form to write",
                self.derivation.model, self.derivation.eta_name
            ))),
            Err(e) => Err(HamelError::new_err(e.to_string())),
        }
    }

    /// The state's names: the coordinates, then the quasi-velocities.
    #[getter]
    fn names(&self) -> Vec<String> {
        self.core
            .coordinates
            .iter()
            .chain(&self.eta)
            .cloned()
            .collect()
    }

    /// The coordinates q₁…q_ℓ.
    #[getter]
    fn coordinates(&self) -> Vec<String> {
        self.core.coordinates.clone()
    }

    /// The quasi-velocities' names, η₁…η_σ as `eta1`…: their definitions are the
    /// derivation's (`Model.derive(eta).to_dict()["eta"]`).
    #[getter]
    fn quasi_velocities(&self) -> Vec<String> {
        self.eta.clone()
    }

    /// The parameter values it evaluates with, by name (derived ones included).
    #[getter]
    fn parameters(&self) -> PyResult<IndexMap<String, f64>> {
        self.model
            .parameter_values(&self.overrides)
            .map_err(|e| ModelError::new_err(format!("params: {e}")))
    }

    /// Whether the parameter values are folded into the code (`specialise=True`).
    #[getter]
    fn specialised(&self) -> bool {
        self.specialised
    }

    /// The quasi-velocity choice.
    #[getter]
    fn choice(&self) -> &str {
        &self.derivation.eta_name
    }

    /// The shared library (in hamel's code cache).
    #[getter]
    fn library(&self) -> String {
        self.core.path.display().to_string()
    }

    fn __len__(&self) -> usize {
        self.n()
    }

    fn __repr__(&self) -> String {
        format!(
            "<hamel.Rhs y = ({}) in {}>",
            self.names().join(", "),
            self.core.path.display()
        )
    }
}

/// The values of `core`'s parameters (in its order) for `model` with `overrides` set.
pub(crate) fn core_values(
    model: &hamel_model::Model,
    core: &Core,
    overrides: &IndexMap<String, f64>,
) -> PyResult<Vec<f64>> {
    let values = model
        .parameter_values(overrides)
        .map_err(|e| ModelError::new_err(format!("params: {e}")))?;
    core.parameters
        .iter()
        .map(|name| {
            values.get(name).copied().ok_or_else(|| {
                HamelError::new_err(format!(
                    "the core {} has a parameter `{name}` the model lacks",
                    core.path.display()
                ))
            })
        })
        .collect()
}
