//! A derivation as Python sees it: the Boltzmann–Hamel equations of a model and a choice of
//! quasi-velocities, printed as text or LaTeX.

use std::sync::Arc;

use pyo3::prelude::*;

use crate::errors::HamelError;

/// The equations of a model with a choice of quasi-velocities η = Z(q)q̇ (Γ, A_Γ, Q, the
/// equations (11)/(14)), made exactly (`Model.derive`).
#[pyclass(module = "hamel._hamel", frozen)]
pub struct Derivation {
    pub(crate) inner: Arc<hamel_derive::Derivation>,
}

#[pymethods]
impl Derivation {
    /// The model's name.
    #[getter]
    fn model(&self) -> &str {
        &self.inner.model
    }

    /// The quasi-velocity choice's name.
    #[getter]
    fn eta_name(&self) -> &str {
        &self.inner.eta_name
    }

    /// The coordinates q₁…q_ℓ.
    #[getter]
    fn coordinates(&self) -> Vec<String> {
        self.inner.coordinates.clone()
    }

    /// ℓ, the number of coordinates, and σ, of quasi-velocities.
    #[getter]
    fn dims(&self) -> (usize, usize) {
        (self.inner.ell, self.inner.sigma)
    }

    /// The derivation printed as text (what `hamel derive` prints).
    fn text(&self) -> PyResult<String> {
        hamel_print::derivation::text(&self.inner).map_err(|e| HamelError::new_err(e.to_string()))
    }

    /// The derivation as a LaTeX document, or its equation blocks alone (`fragment`).
    #[pyo3(signature = (*, fragment = false))]
    fn latex(&self, fragment: bool) -> PyResult<String> {
        let options = hamel_print::derivation::Options {
            fragment,
            only: None,
        };
        hamel_print::derivation::latex(&self.inner, options)
            .map_err(|e| HamelError::new_err(e.to_string()))
    }

    /// Every object as hamel's canonical text (model-file syntax; `etaR` the quasi-velocities,
    /// `etaR_dot` their rates): `a`, `alpha`, `z`, `grad_u`, and in closed form `gamma`,
    /// `theta`, `delta`, `a_gamma`, `forcing`, `q` (the Q⁽ⁱ⁾), `kinematics`, `equations`, … —
    /// the derivation's JSON (what `hamel derive --format json` holds).
    fn to_dict<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let text = serde_json::to_string(&*self.inner)
            .map_err(|e| HamelError::new_err(format!("the derivation as JSON: {e}")))?;
        py.import("json")?.call_method1("loads", (text,))
    }

    /// The objects as SymPy matrices and expressions (`hamel._sympy.to_sympy`; needs SymPy):
    /// every name a real Symbol, `der(q)` the Symbol `q_dot`.
    fn to_sympy<'py>(slf: &Bound<'py, Self>) -> PyResult<Bound<'py, PyAny>> {
        slf.py()
            .import("hamel._sympy")?
            .call_method1("to_sympy", (slf,))
    }

    /// LaTeX for notebooks (Jupyter shows it).
    fn _repr_latex_(&self) -> PyResult<String> {
        self.latex(true)
    }

    fn __repr__(&self) -> String {
        format!(
            "<hamel.Derivation of {} with quasi-velocities `{}` (ℓ = {}, σ = {})>",
            self.inner.model, self.inner.eta_name, self.inner.ell, self.inner.sigma
        )
    }
}
