//! The scene file (TOML) as written: what `load` reads before anything is checked against
//! the model.

use hamel_sim::MethodName;
use indexmap::IndexMap;
use serde::Deserialize;

/// An error at a key of the scene file: (the key, the reason).
pub type KeyedError = (&'static str, String);

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
    /// The outputs wanted (default: everything but the constraint residual).
    pub request: Option<Vec<String>>,
    /// Named outputs defined as expressions of the coordinates, the parameters and η (e.g.
    /// the position of a contact point): `name = "x + a*cos(theta)"`.
    #[serde(default)]
    pub expressions: IndexMap<String, String>,
    /// An accuracy target instead of an explicit integrator.
    pub accuracy: Option<Accuracy>,
    pub integrator: Option<Integrator>,
    /// Many runs of the scene: members that change its initial state and parameters.
    pub ensemble: Option<Ensemble>,
    /// What drives the model's inputs: a constant, a control law, or a table of time.
    #[serde(default)]
    pub inputs: IndexMap<String, InputSpec>,
    /// Named numbers the control laws use (an ensemble may vary them).
    #[serde(default)]
    pub gains: IndexMap<String, f64>,
    /// The wheels' friction coefficient: the run watches the friction each needs and its
    /// normal force (`crate::forces`).
    pub friction: Option<crate::forces::Friction>,
}

/// How a scene drives one input.
#[derive(Clone, Debug, Deserialize)]
#[serde(untagged)]
pub enum InputSpec {
    /// A constant value (as `[parameters]` would set it).
    Constant(f64),
    /// A control law: an expression of t, the coordinates, der(q), eta1…, the parameters and
    /// the gains.
    Law(String),
    /// Samples in time.
    Table(TableSpec),
}

/// `inputs.NAME = { ... }`: samples of an input in time, from a CSV file or written out.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TableSpec {
    /// A CSV file (relative to the scene) with a header line naming its columns.
    pub file: Option<String>,
    /// The file's column of times (default `t`).
    pub time: Option<String>,
    /// The file's column of values (default: the input's name).
    pub column: Option<String>,
    /// Or the samples themselves: the times…
    pub times: Option<Vec<f64>>,
    /// …and the values.
    pub values: Option<Vec<f64>>,
    /// Between samples (default linear).
    #[serde(default)]
    pub interpolation: hamel_sim::Interpolation,
    /// Outside the samples (default: an error, found before the run when the scene's time
    /// span leaves the table).
    #[serde(default)]
    pub outside: hamel_sim::Outside,
}

/// `[ensemble]`: the members, from a file or drawn from distributions with a seed, and what
/// is kept of each.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Ensemble {
    /// A file of members, relative to the scene: CSV with a header line, or JSON lines (one
    /// object per member); the names are coordinates, `eta1`…, and parameters, and what a
    /// member does not give is the scene's.
    pub file: Option<String>,
    /// How many members to draw from `vary`.
    pub members: Option<usize>,
    /// The seed of the draws (ChaCha8; the same seed draws the same members everywhere).
    #[serde(default)]
    pub seed: u64,
    /// Distributions by name (coordinates, `eta1`…, parameters), drawn in this order for
    /// each member in turn.
    #[serde(default)]
    pub vary: IndexMap<String, Distribution>,
    /// What is kept of each member.
    #[serde(default)]
    pub save: Save,
}

/// A distribution to draw a member's value from.
#[derive(Clone, Copy, Debug, Deserialize, serde::Serialize)]
#[serde(rename_all = "lowercase", deny_unknown_fields)]
pub enum Distribution {
    /// Uniform on [low, high).
    Uniform([f64; 2]),
    /// Normal with [mean, standard deviation].
    Normal([f64; 2]),
}

/// What an ensemble keeps of each member (the core's job protocol's type).
pub use hamel_sim::job::Save;

/// `[accuracy]`: relative and absolute error wanted on the outputs.
#[derive(Clone, Copy, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Accuracy {
    /// Relative error.
    pub rtol: f64,
    /// Absolute error.
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
    /// The discrete Lagrange–d'Alembert method's discrete constraint (`dla` only).
    pub variant: Option<hamel_sim::dla::Variant>,
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
            variant: None,
        }
    }
}
