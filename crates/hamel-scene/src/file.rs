//! The scene file (TOML) as written: what `load` reads before anything is checked against
//! the model.

use hamel_sim::MethodName;
use indexmap::IndexMap;
use serde::Deserialize;

/// An error at a key of the scene file: (the key, the reason).
#[cfg(feature = "derive")]
pub(crate) type KeyedError = (&'static str, String);

/// A scene file: the model, the quasi-velocities, the time span and outputs, the parameters,
/// the initial state, what is requested and how it is integrated.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Scene {
    pub model: String,
    pub eta: Option<String>,
    #[serde(default)]
    pub t0: f64,
    pub t_end: f64,
    pub outputs: Outputs,
    #[serde(default)]
    pub parameters: IndexMap<String, f64>,
    pub initial: Initial,
    /// The outputs wanted (default: everything).
    pub request: Option<Vec<String>>,
    /// Named outputs defined as expressions of the coordinates, the parameters and η (e.g.
    /// the position of a contact point): `name = "x + a*cos(theta)"`.
    #[serde(default)]
    pub expressions: IndexMap<String, String>,
    /// An accuracy target instead of an explicit integrator.
    pub accuracy: Option<Accuracy>,
    pub integrator: Option<Integrator>,
}

/// `[accuracy]`: relative and absolute error wanted on the outputs.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Accuracy {
    pub rtol: f64,
    pub atol: f64,
}

/// `outputs`: how many output times, spread evenly over [t0, t_end], or the times themselves.
#[derive(Deserialize)]
#[serde(untagged)]
pub enum Outputs {
    Count(usize),
    Times(Vec<f64>),
}

/// `[initial]`: the configuration q and the velocities, as η or as q̇.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Initial {
    pub q: IndexMap<String, f64>,
    /// The quasi-velocities η, or else:
    pub eta: Option<Vec<f64>>,
    /// The velocities q̇, projected onto the constraints (kinetic metric) with the correction
    /// reported.
    pub q_dot: Option<IndexMap<String, f64>>,
}

/// `[integrator]`: the method and its settings (`step` for the fixed-step ones, `stages` for
/// Gauss–Legendre).
#[derive(Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Integrator {
    pub method: MethodName,
    #[serde(default = "default_rtol")]
    pub rtol: f64,
    #[serde(default = "default_atol")]
    pub atol: f64,
    pub step: Option<f64>,
    pub stages: Option<usize>,
    pub max_steps: Option<usize>,
}

fn default_rtol() -> f64 {
    1e-10
}
fn default_atol() -> f64 {
    1e-12
}

impl Default for Integrator {
    fn default() -> Self {
        Integrator {
            method: MethodName::Dop853,
            rtol: default_rtol(),
            atol: default_atol(),
            step: None,
            stages: None,
            max_steps: None,
        }
    }
}
