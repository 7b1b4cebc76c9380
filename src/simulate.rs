//! `hamel simulate SCENE.toml`: integrate a model's Boltzmann–Hamel equations.
//!
//! The scene names a model and a quasi-velocity choice; the equations are derived once (CAS)
//! and evaluated by the engine-free structured evaluator; the integrators are `hamel-sim`'s.
//! The scene's `request` decides what is integrated ([`crate::plan`]): state y = (integrated
//! coordinates, reconstructed coordinates, η); dropped coordinates are neither integrated nor
//! written (the equations are proven free of them; they are held at a reference value).
//! A singularity on the way (det[Z; α] → 0, A_Γ degenerate, a non-finite value) stops the run
//! with an error naming the time and state; what was computed is written and marked
//! incomplete.

use std::path::Path;
use std::sync::Arc;

use hamel_derive::Compiled;

use crate::plan::{Plan, Request};
use hamel_model::{Model, ModelError};
use hamel_sim::{Method, OdeSystem, Options, Solution, SystemError};
use indexmap::IndexMap;
use serde::{Deserialize, Serialize};

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct Scene {
    model: String,
    eta: Option<String>,
    #[serde(default)]
    t0: f64,
    t_end: f64,
    outputs: Outputs,
    #[serde(default)]
    parameters: IndexMap<String, f64>,
    initial: Initial,
    /// The outputs wanted (default: everything).
    request: Option<Vec<String>>,
    /// Named outputs defined as expressions of the coordinates, the parameters and η (e.g.
    /// the position of a contact point): `name = "x + a*cos(theta)"`.
    #[serde(default)]
    expressions: IndexMap<String, String>,
    /// An accuracy target instead of an explicit integrator.
    accuracy: Option<Accuracy>,
    integrator: Option<Integrator>,
}

/// `[accuracy]`: relative and absolute error wanted on the outputs.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct Accuracy {
    rtol: f64,
    atol: f64,
}

#[derive(Deserialize)]
#[serde(untagged)]
enum Outputs {
    Count(usize),
    Times(Vec<f64>),
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct Initial {
    q: IndexMap<String, f64>,
    /// The quasi-velocities η, or else:
    eta: Option<Vec<f64>>,
    /// The velocities q̇, projected onto the constraints (kinetic metric) with the correction
    /// reported.
    q_dot: Option<IndexMap<String, f64>>,
}

#[derive(Clone, Deserialize)]
#[serde(deny_unknown_fields)]
struct Integrator {
    method: String,
    #[serde(default = "default_rtol")]
    rtol: f64,
    #[serde(default = "default_atol")]
    atol: f64,
    step: Option<f64>,
    stages: Option<usize>,
    max_steps: Option<usize>,
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
            method: "dop853".into(),
            rtol: default_rtol(),
            atol: default_atol(),
            step: None,
            stages: None,
            max_steps: None,
        }
    }
}

/// What evaluates the right-hand side.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, clap::ValueEnum)]
#[serde(rename_all = "lowercase")]
pub enum Engine {
    /// The scene's generated core, compiled and cached ([`crate::scene_core`]).
    Compiled,
    /// The structured evaluator of the derivation (a tape interpreter).
    Interpreted,
}

/// The trajectory as written (`--format json`).
#[derive(Serialize)]
pub struct Trajectory {
    pub model: String,
    pub eta_name: String,
    method: String,
    /// What evaluated the right-hand side.
    pub engine: Engine,
    pub t: Vec<f64>,
    pub q: IndexMap<String, Vec<f64>>,
    /// η at the output times (empty when not requested).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub eta: Vec<Vec<f64>>,
    /// The energy (absent when not requested).
    #[serde(skip_serializing_if = "Option::is_none")]
    energy: Option<Vec<Option<f64>>>,
    /// The requested `[expressions]` at the output times (null where an expression cannot be
    /// evaluated, e.g. outside its domain; stderr says where).
    #[serde(skip_serializing_if = "IndexMap::is_empty")]
    pub expressions: IndexMap<String, Vec<Option<f64>>>,
    stats: StatsOut,
    pub complete: bool,
    /// When the initial velocities were given as q̇: their projection onto the constraints.
    #[serde(skip_serializing_if = "Option::is_none")]
    initial_projection: Option<Projection>,
    #[serde(skip_serializing_if = "Option::is_none")]
    error: Option<String>,
}

#[derive(Serialize)]
struct StatsOut {
    steps: usize,
    rejected: usize,
    rhs_evals: usize,
    energy_drift: Option<f64>,
    constraint_drift: Option<f64>,
    /// The largest condition number of [Z; α] over the output states, and where.
    max_condition: Option<f64>,
    max_condition_t: Option<f64>,
    /// Estimated global error on the requested outputs (max |y − y_c| / max(1, |y_c|) over the
    /// output times, y_c a check run at 1/1000 of the tolerances or half the step), computed
    /// for loose tolerances and on `--estimate-error`.
    #[serde(skip_serializing_if = "Option::is_none")]
    error_estimate: Option<f64>,
    /// How the check run was made.
    #[serde(skip_serializing_if = "Option::is_none")]
    error_estimate_by: Option<String>,
}

/// At or above this rtol or atol an adaptive run is *loose*: `hamel simulate` estimates its
/// global error with a check run and says so (issue 5 §4, docs/stability.md).
pub const LOOSE_TOLERANCE: f64 = 1e-3;

/// Above this condition number of [Z; α] along the path, `hamel simulate` warns: the singular
/// set of the quasi-velocities is near and accuracy degrades like cond·ε (docs/stability.md).
pub const CONDITION_WARNING: f64 = 1e6;

struct System<'a> {
    compiled: &'a Compiled,
    params: IndexMap<String, f64>,
    names: &'a [String],
    ell: usize,
    sigma: usize,
    /// The coordinates in the state (integrated, then reconstructed), model indices.
    state: Vec<usize>,
    /// The value at which the dropped coordinates are held (the equations are free of them).
    reference: f64,
    /// Whether the energy and the constraint residual are computed (requested).
    energy: bool,
    residual: bool,
    /// δ = det[Z; α] at the start: a path that changes its sign crosses the singular set.
    delta0: f64,
    numeric: hamel_model::NumericModel<'a>,
    /// The largest condition number of [Z; α] met, and when: computed whenever |δ| has fallen
    /// below 1e-3 of its start (δ comes with every evaluation; the condition number costs an SVD).
    watch: std::cell::Cell<Option<(f64, f64)>>,
}

impl System<'_> {
    /// The full coordinates at state y: the state's, the dropped ones at the reference value.
    fn full_q<T: Copy>(&self, y: &[T], reference: T) -> Vec<T> {
        let mut q = vec![reference; self.ell];
        for (i, &k) in self.state.iter().enumerate() {
            q[k] = y[i];
        }
        q
    }

    fn at(&self, y: &[f64]) -> Result<hamel_derive::Evaluation, SystemError> {
        let (qs, eta) = y.split_at(self.state.len());
        let q = self.full_q(qs, self.reference);
        let result = self
            .compiled
            .evaluate(&q, eta, &self.params)
            .and_then(|e| {
                if e.delta.signum() == self.delta0.signum() {
                    Ok(e)
                } else {
                    Err(hamel_derive::NumericError(format!(
                        "the path reaches the singular set of the quasi-velocities, det[Z; α] = 0 (δ = {:.3e} changed sign); choose other quasi-velocities there",
                        e.delta
                    )))
                }
            });
        result.map_err(|e| {
            let at: Vec<String> = self
                .state
                .iter()
                .zip(qs)
                .map(|(&k, v)| format!("{} = {v:.6}", self.names[k]))
                .chain(
                    eta.iter()
                        .enumerate()
                        .map(|(i, v)| format!("eta{} = {v:.6}", i + 1)),
                )
                .collect();
            SystemError::new(format!("{e} (state {})", at.join(", ")))
        })
    }
}

impl OdeSystem for System<'_> {
    fn dim(&self) -> usize {
        self.state.len() + self.sigma
    }
    fn rhs(&self, t: f64, y: &[f64], dy: &mut [f64]) -> Result<(), SystemError> {
        let e = self.at(y)?;
        if e.delta.abs() < 1e-3 * self.delta0.abs() {
            let q = self.full_q(&y[..self.state.len()], self.reference);
            if let Ok(cond) = self.compiled.condition(&q, &self.params)
                && self.watch.get().is_none_or(|(c, _)| cond > c)
            {
                self.watch.set(Some((cond, t)));
            }
        }
        let n = self.state.len();
        for (i, &k) in self.state.iter().enumerate() {
            dy[i] = e.q_dot[k];
        }
        dy[n..].copy_from_slice(&e.eta_dot);
        Ok(())
    }
    fn energy(&self, _t: f64, y: &[f64]) -> Option<f64> {
        if !self.energy {
            return None;
        }
        self.at(y).ok().map(|e| e.energy)
    }
    /// ‖α(q) q̇‖∞ with q̇ = Γη, from the model's own α (hamel-sim reports its maximum over the
    /// outputs as the constraint drift). Requested, it keeps every coordinate in the state.
    fn constraint_residual(&self, _t: f64, y: &[f64]) -> Option<f64> {
        if !self.residual {
            return None;
        }
        let e = self.at(y).ok()?;
        let q = self.full_q(&y[..self.state.len()], self.reference);
        hamel_oracle::constraint_residual(&self.numeric, &q, &e.q_dot).ok()
    }
    /// Exact Jacobian: the structured right-hand side over dual numbers, one column per
    /// state component (used by the implicit Gauss–Legendre method).
    fn jacobian(&self, t: f64, y: &[f64], jac: &mut [f64]) -> Option<Result<(), SystemError>> {
        use hamel_expr::Dual;
        let n = y.len();
        let ns = self.state.len();
        for j in 0..n {
            let yd: Vec<Dual> = y
                .iter()
                .enumerate()
                .map(|(i, &v)| Dual::new(v, if i == j { 1.0 } else { 0.0 }))
                .collect();
            let (qs, eta) = yd.split_at(ns);
            let q = self.full_q(qs, Dual::new(self.reference, 0.0));
            let r = match self.compiled.rhs::<Dual>(&q, eta, &self.params) {
                Ok(r) => r,
                Err(e) => return Some(Err(SystemError::new(format!("at t = {t}: {e}")))),
            };
            let rates = self.state.iter().map(|&k| &r.q_dot[k]);
            for (i, v) in rates.chain(&r.eta_dot).enumerate() {
                if !v.d.is_finite() {
                    return Some(Err(SystemError::new(format!(
                        "at t = {t}: the Jacobian is not finite"
                    ))));
                }
                jac[i * n + j] = v.d;
            }
        }
        Some(Ok(()))
    }
}

/// One integration of a scene.
pub struct Run {
    /// What was computed (up to the failure, if any).
    pub solution: Solution,
    /// Why it stopped early.
    pub failure: Option<ModelError>,
    /// The largest condition number of [Z; α] met near the singular set, and when (computed
    /// once |δ| has fallen below 1e-3 of its start).
    pub max_condition: Option<(f64, f64)>,
}

/// A scene read and checked, with its derivation, plan and initial state.
pub struct Loaded {
    scene: Scene,
    compiled: Compiled,
    model: Model,
    d: hamel_derive::Derivation,
    /// What the scene asks for.
    pub request: Request,
    /// What is integrated, reconstructed, dropped.
    pub plan: Plan,
    /// The integrator the scene names (or DOP853 at its `[accuracy]`): name, method, options.
    pub integrator: (String, Method, Options),
    /// The accuracy target, when the scene gives one instead of an integrator.
    pub accuracy: Option<(f64, f64)>,
    params: IndexMap<String, f64>,
    /// The scene's requested `[expressions]`, parameters substituted.
    expressions: Vec<OutputExpression>,
    /// The coordinates in the integrated state (integrated, then reconstructed).
    state: Vec<usize>,
    /// The initial configuration, every coordinate.
    q0: Vec<f64>,
    /// The initial state (those coordinates, then η) and the output times.
    pub y0: Vec<f64>,
    pub times: Vec<f64>,
    reference: f64,
    delta0: f64,
    projection: Option<Projection>,
    err: Box<dyn Fn(Option<&str>, String) -> ModelError>,
}

/// Read a scene, derive its equations, plan what to integrate and set up the initial state;
/// every error names the scene (or model) file, the key and the reason.
pub fn load(scene_path: &Path) -> Result<Loaded, ModelError> {
    let name = scene_path.display().to_string();
    let text = std::fs::read_to_string(scene_path).map_err(|e| {
        ModelError::new(
            &name,
            Arc::new(String::new()),
            None,
            None,
            format!("cannot read the scene: {e}"),
        )
    })?;
    let source = Arc::new(text.clone());
    let scene: Scene = toml::from_str(&text).map_err(|e| {
        ModelError::new(
            &name,
            source.clone(),
            e.span(),
            None,
            e.message().to_string(),
        )
    })?;
    let err = {
        let (name, source) = (name.clone(), source.clone());
        move |key: Option<&str>, m: String| ModelError::new(&name, source.clone(), None, key, m)
    };
    let model_path = scene_path
        .parent()
        .unwrap_or(Path::new("."))
        .join(&scene.model);
    let model = Model::load(&model_path)?;
    let parsed =
        parse_expressions(&scene.expressions, &model).map_err(|(k, m)| err(Some(&k), m))?;
    // The names `request` may use: the expressions' besides the model's outputs.
    let expression_names: Vec<String> = parsed.iter().map(|e| e.name.clone()).collect();
    // For `eta = "auto"`: the requested coordinates, and those the requested expressions need.
    let auto_request: Option<Vec<String>> = scene.request.as_ref().map(|names| {
        let mut v = names.clone();
        for e in parsed.iter().filter(|e| names.contains(&e.name)) {
            v.extend(e.coordinates.iter().map(|&k| model.coordinates[k].clone()));
        }
        v
    });
    let (model, choice) = if scene.eta.as_deref() == Some("auto") {
        if scene.initial.eta.is_some() {
            return Err(err(
                Some("initial.eta"),
                "with eta = \"auto\" the quasi-velocities are chosen by the search, so their initial values cannot be given: give the initial velocities as `q_dot = { ... }`".into(),
            ));
        }
        auto_choice(model, auto_request.as_deref())?
    } else {
        let chosen = model.choice(scene.eta.as_deref())?;
        crate::choice::note_default(&model, chosen);
        let choice = chosen.name.clone();
        (model, choice)
    };
    let d = hamel_derive::derive(&model, Some(&choice))?;
    let mut request = match &scene.request {
        Some(names) => {
            Request::parse(names, &d, &expression_names).map_err(|m| err(Some("request"), m))?
        }
        None => Request::everything(d.ell, parsed.len()),
    };
    for &i in &request.expressions {
        for &k in &parsed[i].coordinates {
            if !request.needed.contains(&k) {
                request.needed.push(k);
            }
        }
    }
    // `[accuracy]` alone: DOP853 at those tolerances unless `hamel simulate` finds a faster
    // setting that meets it (`crate::tradeoff`).
    let i = match (&scene.integrator, &scene.accuracy) {
        (Some(_), Some(_)) => {
            return Err(err(
                Some("accuracy"),
                "give either [accuracy] (a target) or [integrator] (a method), not both".into(),
            ));
        }
        (Some(i), None) => i.clone(),
        (None, Some(a)) => {
            if !(a.rtol > 0.0 && a.atol > 0.0 && a.rtol < 1.0) {
                return Err(err(
                    Some("accuracy"),
                    format!(
                        "rtol must be in (0, 1) and atol > 0 (got {}, {})",
                        a.rtol, a.atol
                    ),
                ));
            }
            Integrator {
                rtol: a.rtol,
                atol: a.atol,
                ..Integrator::default()
            }
        }
        (None, None) => Integrator::default(),
    };
    let method = match i.method.as_str() {
        "rk4" => Method::Rk4 {
            step: i
                .step
                .ok_or_else(|| err(Some("integrator.step"), "rk4 needs a step".into()))?,
        },
        "dopri5" => Method::Dopri5,
        "dop853" => Method::Dop853,
        "gauss-legendre" => Method::GaussLegendre {
            stages: i.stages.unwrap_or(3),
            step: i.step,
        },
        other => {
            return Err(err(
                Some("integrator.method"),
                format!("unknown method `{other}` (rk4, dopri5, dop853, gauss-legendre)"),
            ));
        }
    };
    // Tolerances the adaptive methods cannot meet are refused before anything runs.
    let key = if scene.accuracy.is_some() {
        "accuracy.rtol"
    } else {
        "integrator.rtol"
    };
    if !matches!(method, Method::Rk4 { .. }) && i.rtol <= 10.0 * f64::EPSILON {
        return Err(err(
            Some(key),
            format!(
                "rtol = {:e} is below what f64 arithmetic can deliver: it must exceed 10·ε ≈ 2.2e-15",
                i.rtol
            ),
        ));
    }
    let options = Options {
        rtol: i.rtol,
        atol: i.atol,
        max_steps: i.max_steps.unwrap_or(Options::default().max_steps),
        ..Options::default()
    };
    let compiled = d.compile().map_err(|e| err(Some("eta"), e.to_string()))?;
    let params = d
        .parameters_with(&scene.parameters)
        .map_err(|e| err(Some("parameters"), e.to_string()))?;
    let expressions = request
        .expressions
        .iter()
        .map(|&i| parsed[i].specialised(&params, &d))
        .collect::<Result<Vec<_>, _>>()
        .map_err(|(k, m)| err(Some(&k), m))?;
    let mut q0 = Vec::new();
    for c in &d.coordinates {
        q0.push(
            *scene
                .initial
                .q
                .get(c)
                .ok_or_else(|| err(Some("initial.q"), format!("missing coordinate `{c}`")))?,
        );
    }
    if let Some(extra) = scene.initial.q.keys().find(|k| !d.coordinates.contains(k)) {
        return Err(err(
            Some("initial.q"),
            format!("`{extra}` is not a coordinate of the model"),
        ));
    }
    let (eta0, projection) = {
        let numeric = hamel_model::NumericModel::new(&model, &params)
            .map_err(|e| err(Some("parameters"), e.to_string()))?;
        initial_eta(&scene.initial, &d, &numeric, &q0).map_err(|(key, m)| err(Some(key), m))?
    };
    if !(scene.t_end.is_finite() && scene.t0.is_finite()) || scene.t_end == scene.t0 {
        return Err(err(
            Some("t_end"),
            "t_end must be finite and differ from t0".into(),
        ));
    }
    let times: Vec<f64> = match &scene.outputs {
        Outputs::Count(n) if *n >= 2 => (0..*n)
            .map(|i| scene.t0 + (scene.t_end - scene.t0) * i as f64 / (*n - 1) as f64)
            .collect(),
        Outputs::Count(n) => {
            return Err(err(
                Some("outputs"),
                format!("needs at least 2 output times, got {n}"),
            ));
        }
        Outputs::Times(t) => t.clone(),
    };
    let mut plan = crate::plan::plan(&model, &d, &request, &params)?;
    plan.expressions = request
        .expressions
        .iter()
        .map(|&i| {
            (
                parsed[i].name.clone(),
                parsed[i]
                    .coordinates
                    .iter()
                    .map(|&k| d.coordinates[k].clone())
                    .collect(),
            )
        })
        .collect();
    let state: Vec<usize> = plan
        .integrated_ix
        .iter()
        .chain(&plan.reconstructed_ix)
        .copied()
        .collect();
    // The dropped coordinates are held at a reference value where the equations evaluate at
    // the initial state (they are free of them; [Z; α] may still be singular at some values).
    let references: &[f64] = if plan.dropped_ix.is_empty() {
        &[0.0]
    } else {
        &[0.5, 1.25, 2.0]
    };
    let (mut start, mut last) = (None, String::new());
    for &reference in references {
        let mut q = q0.clone();
        for &k in &plan.dropped_ix {
            q[k] = reference;
        }
        match compiled.evaluate(&q, &eta0, &params) {
            Ok(e) => {
                start = Some((reference, e.delta));
                break;
            }
            Err(e) => last = e.to_string(),
        }
    }
    let (reference, delta0) = start.ok_or_else(|| err(Some("initial"), last))?;
    let y0: Vec<f64> = state
        .iter()
        .map(|&k| q0[k])
        .chain(eta0.iter().copied())
        .collect();
    let q0 = q0.clone();
    Ok(Loaded {
        accuracy: match (&scene.integrator, &scene.accuracy) {
            (None, Some(a)) => Some((a.rtol, a.atol)),
            _ => None,
        },
        compiled,
        scene,
        model,
        d,
        request,
        plan,
        integrator: (i.method.clone(), method, options),
        params,
        expressions,
        state,
        q0,
        y0,
        times,
        reference,
        delta0,
        projection,
        err: Box::new(err),
    })
}

impl Loaded {
    /// An error about this scene, at `key`.
    pub fn error(&self, key: &str, message: String) -> ModelError {
        (self.err)(Some(key), message)
    }

    /// The requested `[expressions]` at the output states of `solution`, by name; a value
    /// that cannot be computed (outside the expression's domain, not finite) is None, and a
    /// warning on stderr names the expression and the first such time.
    pub fn expression_values(&self, solution: &Solution) -> IndexMap<String, Vec<Option<f64>>> {
        let values = self.evaluate_expressions(solution);
        for (name, v) in &values {
            if let Some(j) = v.iter().position(Option::is_none) {
                eprintln!(
                    "warning: expressions.{name} cannot be evaluated at t = {} (outside its domain or not finite): written as null",
                    solution.t[j]
                );
            }
        }
        values
    }

    /// [`Self::expression_values`] without the warnings.
    pub fn evaluate_expressions(&self, solution: &Solution) -> IndexMap<String, Vec<Option<f64>>> {
        let n = self.state.len();
        self.expressions
            .iter()
            .map(|e| {
                let values: Vec<Option<f64>> = solution
                    .y
                    .iter()
                    .map(|y| {
                        let mut inputs = vec![self.reference; self.d.ell];
                        for (i, &k) in self.state.iter().enumerate() {
                            inputs[k] = y[i];
                        }
                        inputs.extend_from_slice(&y[n..]);
                        e.tape
                            .eval::<f64>(&inputs)
                            .ok()
                            .map(|v| v[0])
                            .filter(|v| v.is_finite())
                    })
                    .collect();
                (e.name.clone(), values)
            })
            .collect()
    }

    /// The engine that can run this scene: `engine`, or the interpreted evaluator (with a
    /// warning on stderr) when the scene's compiled core cannot be built; and whether this call
    /// built the core.
    pub fn usable(&self, engine: Engine) -> (Engine, bool) {
        if engine == Engine::Interpreted {
            return (engine, false);
        }
        match crate::scene_core::binary(&self.plan.entry) {
            Ok((_, built)) => (Engine::Compiled, built),
            Err(e) => {
                eprintln!(
                    "warning: the scene's compiled core is not available, using the interpreted evaluator: {e}"
                );
                (Engine::Interpreted, false)
            }
        }
    }

    /// The coordinates in the integrated state, by index: integrated, then reconstructed.
    pub fn state(&self) -> &[usize] {
        &self.state
    }

    /// The model's name.
    pub fn model_name(&self) -> &str {
        &self.d.model
    }

    /// (ℓ, σ).
    pub fn dims(&self) -> (usize, usize) {
        (self.d.ell, self.d.sigma)
    }

    /// The scene's value of a parameter (the model's default unless overridden).
    pub fn parameter(&self, name: &str) -> f64 {
        self.params[name]
    }

    /// The model.
    pub fn model(&self) -> &Model {
        &self.model
    }

    /// The value at which the dropped coordinates are held.
    pub fn reference_value(&self) -> f64 {
        self.reference
    }

    /// The quasi-velocity choice's name.
    pub fn eta_name(&self) -> &str {
        &self.d.eta_name
    }

    /// Integrate the planned state with `method`; on failure, what was computed and the error.
    pub fn integrate(&self, method: Method, options: &Options) -> Result<Run, ModelError> {
        let numeric = hamel_model::NumericModel::new(&self.model, &self.params)
            .map_err(|e| (self.err)(Some("parameters"), e.to_string()))?;
        let system = System {
            compiled: &self.compiled,
            params: self.params.clone(),
            names: &self.d.coordinates,
            ell: self.d.ell,
            sigma: self.d.sigma,
            state: self.state.clone(),
            reference: self.reference,
            energy: self.request.energy,
            residual: self.request.constraint_residual,
            delta0: self.delta0,
            numeric,
            watch: Default::default(),
        };
        let (solution, failure) = match hamel_sim::integrate(
            &system,
            method,
            self.scene.t0,
            &self.y0,
            &self.times,
            options,
        ) {
            Ok(s) => (s, None),
            Err(e) => {
                let m = (self.err)(Some("integrator"), e.to_string());
                (*e.partial, Some(m))
            }
        };
        Ok(Run {
            solution,
            failure,
            max_condition: system.watch.get(),
        })
    }

    /// Integrate the planned state on the scene's compiled core ([`crate::scene_core`]: built
    /// on first use, cached): the run, the median time of one integration measured inside the
    /// core over `repeat` runs, and whether this call compiled the core. The singular set is
    /// watched at the output states (δ's sign, the condition number of [Z; α] once |δ| falls
    /// below 1e-3 of its start): a sign change ends the output before it, as an error.
    /// Errors: the core could not be built or run (the caller may fall back to [`Self::integrate`]).
    pub fn integrate_compiled(
        &self,
        method: Method,
        options: &Options,
        repeat: usize,
    ) -> Result<(Run, f64, bool), String> {
        let (exe, built) = crate::scene_core::binary(&self.plan.entry)?;
        let n = self.state.len();
        let mut kept = self.state.clone();
        kept.sort_unstable();
        let at = |k: usize| {
            self.state
                .iter()
                .position(|&s| s == k)
                .expect("kept = state")
        };
        let job = crate::scene_core::Job {
            t0: self.scene.t0,
            times: &self.times,
            y0: kept
                .iter()
                .map(|&k| self.y0[at(k)])
                .chain(self.y0[n..].iter().copied())
                .collect(),
            method,
            options: *options,
            reference: self.reference,
            energy: self.request.energy,
            residual: self.request.constraint_residual,
            repeat,
            params: IndexMap::new(),
        };
        let (mut solution, error, seconds) = crate::scene_core::run(&exe, &job)?;
        // Back to the state order (integrated, then reconstructed).
        let from: Vec<usize> = self
            .state
            .iter()
            .map(|k| kept.iter().position(|x| x == k).expect("state = kept"))
            .collect();
        for y in solution.y.iter_mut() {
            *y = from
                .iter()
                .map(|&i| y[i])
                .chain(y[n..].iter().copied())
                .collect();
        }
        let mut failure = error.map(|m| (self.err)(Some("integrator"), m));
        let mut max_condition: Option<(f64, f64)> = None;
        for j in 0..solution.t.len() {
            let y = &solution.y[j];
            let mut q = vec![self.reference; self.d.ell];
            for (i, &k) in self.state.iter().enumerate() {
                q[k] = y[i];
            }
            let delta = self
                .compiled
                .evaluate(&q, &y[n..], &self.params)
                .map(|e| e.delta);
            if let Ok(delta) = delta
                && delta.signum() != self.delta0.signum()
            {
                failure = Some((self.err)(
                    Some("integrator"),
                    format!(
                        "the path crosses the singular set of the quasi-velocities, det[Z; α] = 0, between t = {} and t = {} (δ = {delta:.3e} changed sign); choose other quasi-velocities there",
                        solution.t[j.saturating_sub(1)],
                        solution.t[j]
                    ),
                ));
                solution.t.truncate(j);
                solution.y.truncate(j);
                solution.energy.truncate(j);
                solution.constraint.truncate(j);
                solution.complete = false;
                break;
            }
            if delta.is_ok_and(|d| d.abs() < 1e-3 * self.delta0.abs())
                && let Ok(cond) = self.compiled.condition(&q, &self.params)
                && max_condition.is_none_or(|(c, _)| cond > c)
            {
                max_condition = Some((cond, solution.t[j]));
            }
        }
        Ok((
            Run {
                solution,
                failure,
                max_condition,
            },
            seconds,
            built,
        ))
    }

    /// The indices, in the integrated state, of the requested outputs (coordinates, then η).
    pub fn requested_components(&self) -> Vec<usize> {
        let n = self.state.len();
        self.request
            .coordinates
            .iter()
            .map(|&k| {
                self.state
                    .iter()
                    .position(|&s| s == k)
                    .expect("requested ⊆ state")
            })
            .chain(if self.request.eta {
                n..n + self.d.sigma
            } else {
                n..n
            })
            .collect()
    }

    /// The trajectory of the requested outputs.
    pub fn trajectory(&self, method_name: &str, run: &Run) -> Trajectory {
        let (solution, failure) = (&run.solution, run.failure.as_ref());
        let n = self.state.len();
        let d = &self.d;
        Trajectory {
            model: d.model.clone(),
            eta_name: d.eta_name.clone(),
            method: method_name.to_string(),
            engine: Engine::Interpreted,
            t: solution.t.clone(),
            q: self
                .request
                .coordinates
                .iter()
                .map(|&k| {
                    let i = self
                        .state
                        .iter()
                        .position(|&s| s == k)
                        .expect("requested ⊆ state");
                    (
                        d.coordinates[k].clone(),
                        solution.y.iter().map(|y| y[i]).collect(),
                    )
                })
                .collect(),
            eta: if self.request.eta {
                solution.y.iter().map(|y| y[n..].to_vec()).collect()
            } else {
                Vec::new()
            },
            energy: if self.request.energy {
                Some(solution.energy.clone())
            } else {
                None
            },
            expressions: self.expression_values(solution),
            stats: StatsOut {
                steps: solution.stats.steps,
                rejected: solution.stats.rejected,
                rhs_evals: solution.stats.rhs_evals,
                energy_drift: solution.stats.energy_drift,
                constraint_drift: solution.stats.constraint_drift,
                max_condition: run.max_condition.map(|c| c.0),
                max_condition_t: run.max_condition.map(|c| c.1),
                error_estimate: None,
                error_estimate_by: None,
            },
            complete: failure.is_none() && solution.complete,
            initial_projection: self.projection.clone(),
            error: failure.map(|e| e.message().to_string()),
        }
    }
}

/// `eta = "auto"`: the quasi-velocities that eliminate the coordinates the scene does not
/// request, as `hamel search` finds them (its first candidate without free functions, added to
/// the model as a choice); else, or when the scene requests every coordinate, the model's
/// first choice. stderr says which and why.
fn auto_choice(model: Model, request: Option<&[String]>) -> Result<(Model, String), ModelError> {
    let first = model.choice(None)?.name.clone();
    let eliminate: Vec<String> = match request {
        Some(r) => model
            .coordinates
            .iter()
            .filter(|c| !r.contains(c))
            .cloned()
            .collect(),
        None => Vec::new(),
    };
    if eliminate.is_empty() {
        eprintln!(
            "eta = auto: every coordinate is requested, nothing to eliminate: using the model's first choice `{first}`"
        );
        return Ok((model, first));
    }
    let report = hamel_reduce::search(
        &model,
        &eliminate,
        hamel_reduce::SearchOptions {
            budget: std::time::Duration::from_secs(20),
            max_candidates: 10,
        },
        Box::new(|_| {}),
    )?;
    // Candidates without free functions, in the search's order (simplest first); the first
    // whose map [Z; α] is regular everywhere wins, else the first.
    let usable: Vec<(Model, String, bool)> = report
        .candidates
        .iter()
        .filter(|c| c.free_functions.is_empty())
        .filter_map(|c| {
            let text = format!("{}\n{}\n", model.source, c.toml);
            let m = Model::from_source(&model.file, &text).ok()?;
            let regular = hamel_derive::derive(&m, Some(&c.name))
                .ok()?
                .singular_set
                .is_empty();
            Some((m, c.name.clone(), regular))
        })
        .collect();
    let pick = usable
        .iter()
        .position(|c| c.2)
        .or((!usable.is_empty()).then_some(0));
    match pick.map(|i| usable.into_iter().nth(i).expect("in range")) {
        Some((m, name, regular)) => {
            eprintln!(
                "eta = auto: using `{name}` (found by search; it eliminates {} from the equations{})",
                eliminate.join(", "),
                if regular {
                    "; [Z; α] is regular everywhere"
                } else {
                    "; no candidate is regular everywhere: see its singular set with hamel derive"
                }
            );
            Ok((m, name))
        }
        None => {
            eprintln!(
                "eta = auto: search found no quasi-velocities without free functions that eliminate {}: using the model's first choice `{first}`",
                eliminate.join(", ")
            );
            Ok((model, first))
        }
    }
}

/// The initial quasi-velocities: `eta` as given, or η = Z(q)w for the given q̇ projected onto
/// the constraints in the kinetic metric (w, [`hamel_oracle::project_kinetic`]), with the
/// projection's report. Errors: (the scene key, the reason).
fn initial_eta(
    initial: &Initial,
    d: &hamel_derive::Derivation,
    numeric: &hamel_model::NumericModel<'_>,
    q: &[f64],
) -> Result<(Vec<f64>, Option<Projection>), (&'static str, String)> {
    match (&initial.eta, &initial.q_dot) {
        (Some(eta), None) if eta.len() == d.sigma => Ok((eta.clone(), None)),
        (Some(eta), None) => Err((
            "initial.eta",
            format!("needs σ = {} values, found {}", d.sigma, eta.len()),
        )),
        (None, Some(v)) => {
            if let Some(extra) = v.keys().find(|k| !d.coordinates.contains(k)) {
                return Err((
                    "initial.q_dot",
                    format!("`{extra}` is not a coordinate of the model"),
                ));
            }
            let v: Vec<f64> = d
                .coordinates
                .iter()
                .map(|c| {
                    v.get(c).copied().ok_or((
                        "initial.q_dot",
                        format!("missing the velocity of `{c}` (give every coordinate's)"),
                    ))
                })
                .collect::<Result<_, _>>()?;
            let w =
                hamel_oracle::project_kinetic(numeric, q, &v).map_err(|e| ("initial.q_dot", e))?;
            let kinetic = |x: &[f64]| -> Result<f64, (&'static str, String)> {
                let a = numeric
                    .mass_matrix::<f64>(q)
                    .map_err(|e| ("initial.q", e.to_string()))?;
                Ok(0.5
                    * (0..x.len())
                        .map(|i| (0..x.len()).map(|j| x[i] * a[i][j] * x[j]).sum::<f64>())
                        .sum::<f64>())
            };
            let z = numeric
                .quasi_velocity_matrix::<f64>(&d.eta_name, q)
                .map_err(|e| ("initial.q", e.to_string()))?;
            let eta = z
                .iter()
                .map(|row| row.iter().zip(&w).map(|(a, b)| a * b).sum())
                .collect();
            let projection = Projection {
                q_dot: d
                    .coordinates
                    .iter()
                    .cloned()
                    .zip(w.iter().copied())
                    .collect(),
                correction: v
                    .iter()
                    .zip(&w)
                    .map(|(a, b)| (a - b).abs())
                    .fold(0.0, f64::max),
                kinetic_before: kinetic(&v)?,
                kinetic_after: kinetic(&w)?,
            };
            Ok((eta, Some(projection)))
        }
        (Some(_), Some(_)) => Err((
            "initial",
            "give the initial velocities as `eta` or as `q_dot`, not both".into(),
        )),
        (None, None) => Err((
            "initial",
            "give the initial velocities as `eta = [...]` (σ values) or `q_dot = { ... }`".into(),
        )),
    }
}

/// How given initial velocities were made admissible.
#[derive(Clone, Debug, Serialize)]
pub struct Projection {
    /// The admissible velocities used (α(q)q̇ = 0).
    pub q_dot: IndexMap<String, f64>,
    /// max |q̇ given − q̇ used|.
    pub correction: f64,
    /// Kinetic energy of the given velocities.
    pub kinetic_before: f64,
    /// Kinetic energy of the ones used (never more).
    pub kinetic_after: f64,
}

/// Run the scene; returns the trajectory (possibly incomplete) and, on failure, the error.
/// A scene with an `[accuracy]` target and no integrator runs the fastest adaptive setting that
/// meets it (`hamel tradeoff`'s recommendation among DOP853 and DOPRI5; stderr says which).
pub fn run(
    scene_path: &Path,
    engine: Engine,
    estimate_error: bool,
) -> Result<(Trajectory, Option<ModelError>), ModelError> {
    let loaded = load(scene_path)?;
    // The compiled core is built (or found) first: the accuracy measurement below runs on it too.
    let (engine, built) = loaded.usable(engine);
    let (mut name, mut method, mut options) = loaded.integrator.clone();
    if let Some((rtol, atol)) = loaded.accuracy {
        let table = crate::tradeoff::table(&loaded, crate::tradeoff::Range::Adaptive, engine)?;
        match table.recommended {
            Some(i) => {
                let row = &table.rows[i];
                eprintln!(
                    "accuracy rtol = {rtol:.0e}, atol = {atol:.0e}: using {} (error {:.1e} of the target against a DOP853 reference at 1e-14, the fastest of {} adaptive settings that meet it)",
                    row.setting(),
                    row.target_ratio,
                    table.rows.len()
                );
                name = row.method.clone();
                (method, options) = row.method();
            }
            None => eprintln!(
                "warning: no adaptive setting measured meets rtol = {rtol:.0e}, atol = {atol:.0e}; using DOP853 at those tolerances"
            ),
        }
    }
    let (run, engine) = match engine {
        Engine::Interpreted => (loaded.integrate(method, &options)?, Engine::Interpreted),
        Engine::Compiled => match loaded.integrate_compiled(method, &options, 1) {
            // The compiled core sees a singularity only as a failed step or a value that is
            // not finite; the interpreted evaluator checks δ and A_Γ at every evaluation and
            // names the cause, so a failed run is repeated with it for the diagnosis.
            Ok((run, _, _)) if run.failure.is_some() => {
                eprintln!(
                    "note: the compiled core stopped ({}); integrating again with the interpreted evaluator, which watches the singular set at every evaluation",
                    run.failure.as_ref().map_or("", |e| e.message())
                );
                (loaded.integrate(method, &options)?, Engine::Interpreted)
            }
            Ok((run, _, _)) => {
                eprintln!(
                    "compiled core ({} operations): {} {}",
                    loaded.plan.ops,
                    if built { "built into" } else { "cached in" },
                    loaded.plan.entry.dir.display()
                );
                (run, Engine::Compiled)
            }
            Err(e) => {
                eprintln!(
                    "warning: the scene's compiled core is not available, using the interpreted evaluator: {e}"
                );
                (loaded.integrate(method, &options)?, Engine::Interpreted)
            }
        },
    };
    if let Some((cond, t)) = run.max_condition
        && cond > CONDITION_WARNING
    {
        eprintln!(
            "warning: the path comes near the singular set of the quasi-velocities: the condition number of [Z; α] reaches {cond:.1e} at t = {t} (accuracy degrades like cond·ε; docs/stability.md)"
        );
    }
    let mut traj = loaded.trajectory(&name, &run);
    traj.engine = engine;
    let loose = options.rtol.max(options.atol) >= LOOSE_TOLERANCE && method.is_adaptive();
    if run.failure.is_none() && (estimate_error || loose) {
        match loaded.error_estimate(&run.solution, engine, method, &options) {
            Ok((error, by)) => {
                if loose {
                    eprintln!(
                        "warning: rtol = {:.0e}, atol = {:.0e} is loose: the error on the requested outputs is about {error:.1e} (difference from a run {by})",
                        options.rtol, options.atol
                    );
                } else {
                    eprintln!(
                        "error estimate: {error:.1e} on the requested outputs (difference from a run {by})"
                    );
                }
                traj.stats.error_estimate = Some(error);
                traj.stats.error_estimate_by = Some(by);
            }
            // The trajectory stands; only its estimate is missing, and stderr says why.
            Err(e) => eprintln!("warning: no error estimate: {}", e.message()),
        }
    }
    Ok((traj, run.failure))
}

impl Loaded {
    /// The global error of `solution` on the requested outputs, estimated by a check run on
    /// the same engine: at 1/1000 of the tolerances (not below 1e-13) for an adaptive method,
    /// at half the step for a fixed-step one; max |y − y_c| / max(1, |y_c|) over the output
    /// times, and how the check run was made.
    fn error_estimate(
        &self,
        solution: &Solution,
        engine: Engine,
        method: Method,
        options: &Options,
    ) -> Result<(f64, String), ModelError> {
        let (check, by) = match method {
            Method::Rk4 { step } => (
                Method::Rk4 { step: step / 2.0 },
                format!("at step {:.3e}", step / 2.0),
            ),
            Method::GaussLegendre {
                stages,
                step: Some(h),
            } => (
                Method::GaussLegendre {
                    stages,
                    step: Some(h / 2.0),
                },
                format!("at step {:.3e}", h / 2.0),
            ),
            m => (m, String::new()),
        };
        let mut tight = *options;
        let by = if by.is_empty() {
            tight.rtol = (options.rtol * 1e-3).max(1e-13);
            tight.atol = (options.atol * 1e-3).max(1e-13);
            format!("at rtol = {:.0e}, atol = {:.0e}", tight.rtol, tight.atol)
        } else {
            by
        };
        let run = match engine {
            Engine::Compiled => self
                .integrate_compiled(check, &tight, 1)
                .map(|r| r.0)
                .map_err(|e| self.error("integrator", format!("the check run failed: {e}")))?,
            Engine::Interpreted => self.integrate(check, &tight)?,
        };
        if let Some(e) = run.failure {
            return Err(self.error(
                "integrator",
                format!(
                    "the check run for the error estimate failed: {}",
                    e.message()
                ),
            ));
        }
        let got = crate::tradeoff::outputs(self, solution, true);
        let reference = crate::tradeoff::outputs(self, &run.solution, true);
        let (_, span, _) = crate::tradeoff::errors(&got, &reference, (1.0, 1.0));
        Ok((span, by))
    }
}

/// One of the scene's requested `[expressions]`, its parameters substituted: its name and a
/// tape over (the ℓ coordinates, η).
struct OutputExpression {
    name: String,
    tape: hamel_expr::Tape,
}

/// An expression parsed and checked against the model, before the parameters are substituted.
struct ParsedExpression {
    name: String,
    expr: hamel_expr::Expr,
    coordinates: Vec<usize>,
}

/// Names a scene's outputs already use; an expression may not take one.
const RESERVED: [&str; 4] = ["eta", "energy", "constraint_residual", "t"];

/// Parse `[expressions]`: each a name (an identifier not already an output, coordinate or
/// parameter) and an expression of the coordinates, the parameters and eta1…etaσ, with the
/// model's grammar. Errors: (key, reason).
fn parse_expressions(
    table: &IndexMap<String, String>,
    model: &Model,
) -> Result<Vec<ParsedExpression>, (String, String)> {
    let sigma = model.coordinates.len() - model.constraints.len();
    let etas: Vec<String> = (1..=sigma).map(|i| format!("eta{i}")).collect();
    table
        .iter()
        .map(|(name, text)| {
            let key = format!("expressions.{name}");
            let identifier = name.chars().next().is_some_and(|c| c.is_ascii_alphabetic())
                && name.chars().all(|c| c.is_ascii_alphanumeric() || c == '_');
            if !identifier {
                return Err((key, format!("`{name}` is not a name (letters, digits, _; a letter first)")));
            }
            if RESERVED.contains(&name.as_str())
                || etas.contains(name)
                || model.coordinates.contains(name)
                || model.parameters.contains_key(name)
            {
                return Err((
                    key,
                    format!("`{name}` is already a coordinate, parameter or output of this scene: choose another name"),
                ));
            }
            let parsed = hamel_expr::parse(text).map_err(|e| {
                (key.clone(), format!("cannot parse `{text}`: {e}"))
            })?;
            for o in &parsed.occurrences {
                let known = model.coordinates.contains(&o.name)
                    || model.parameters.contains_key(&o.name)
                    || etas.contains(&o.name);
                match &o.kind {
                    hamel_expr::OccurrenceKind::Symbol if known => {}
                    hamel_expr::OccurrenceKind::Symbol => {
                        return Err((
                            key,
                            format!(
                                "unknown name `{}` in `{text}`: an expression may use the coordinates ({}), the parameters ({}) and {}",
                                o.name,
                                model.coordinates.join(", "),
                                model.parameters.keys().cloned().collect::<Vec<_>>().join(", "),
                                if sigma == 1 { "eta1".to_string() } else { format!("eta1..eta{sigma}") }
                            ),
                        ));
                    }
                    hamel_expr::OccurrenceKind::Velocity => {
                        return Err((
                            key,
                            format!("`der({})` in `{text}`: an output expression takes coordinates, parameters and η (velocities are η's business: write them with eta1…)", o.name),
                        ));
                    }
                    hamel_expr::OccurrenceKind::FreeFunction(_) => {
                        return Err((
                            key,
                            format!("`{}` in `{text}` is not a built-in function", o.name),
                        ));
                    }
                }
            }
            let coordinates = (0..model.coordinates.len())
                .filter(|&k| {
                    parsed
                        .occurrences
                        .iter()
                        .any(|o| o.name == model.coordinates[k])
                })
                .collect();
            Ok(ParsedExpression {
                name: name.clone(),
                expr: parsed.expr,
                coordinates,
            })
        })
        .collect()
}

impl ParsedExpression {
    /// Substitute the scene's parameter values (exact: dyadic rationals, constants folded)
    /// and compile over (the coordinates, eta1…).
    fn specialised(
        &self,
        params: &IndexMap<String, f64>,
        d: &hamel_derive::Derivation,
    ) -> Result<OutputExpression, (String, String)> {
        let key = format!("expressions.{}", self.name);
        let mut values = std::collections::HashMap::new();
        for (name, &v) in params {
            let r = hamel_expr::rational_of_f64(v).ok_or_else(|| {
                (
                    key.clone(),
                    format!("parameter `{name}` = {v} is not finite"),
                )
            })?;
            values.insert(name.clone(), r);
        }
        let expr = self.expr.specialise(&values);
        let inputs: Vec<String> = d
            .coordinates
            .iter()
            .cloned()
            .chain((1..=d.sigma).map(|i| format!("eta{i}")))
            .collect();
        let tape = hamel_expr::Tape::compile(&[&expr], &inputs)
            .map_err(|e| (key, format!("cannot compile: {e}")))?;
        Ok(OutputExpression {
            name: self.name.clone(),
            tape,
        })
    }
}

impl Trajectory {
    /// One line for stderr.
    pub fn summary(&self) -> String {
        let s = &self.stats;
        format!(
            "{} ({}), {}: {} steps ({} rejected), {} RHS evaluations, energy drift {}, constraint drift {}{}",
            self.model,
            self.eta_name,
            self.method,
            s.steps,
            s.rejected,
            s.rhs_evals,
            s.energy_drift.map_or("n/a".into(), |x| format!("{x:.2e}")),
            s.constraint_drift
                .map_or("n/a".into(), |x| format!("{x:.2e}")),
            if self.complete { "" } else { "; INCOMPLETE" }
        ) + self
            .initial_projection
            .as_ref()
            .map_or(String::new(), |p| {
                format!(
                    "\ninitial velocities projected onto the constraints: max |Δq̇| = {:.3e}, kinetic energy {:.6e} → {:.6e}",
                    p.correction, p.kinetic_before, p.kinetic_after
                )
            })
            .as_str()
    }

    /// CSV: t, the coordinates, eta1…, energy, the expressions (a `# incomplete` comment first
    /// when cut short).
    pub fn to_csv(&self) -> String {
        let mut o = String::new();
        if let Some(e) = &self.error {
            o.push_str(&format!("# incomplete: {}\n", e.replace('\n', " ")));
        }
        let sigma = self.eta.first().map_or(0, Vec::len);
        let mut header = vec!["t".to_string()];
        header.extend(self.q.keys().cloned());
        header.extend((1..=sigma).map(|i| format!("eta{i}")));
        if self.energy.is_some() {
            header.push("energy".into());
        }
        header.extend(self.expressions.keys().cloned());
        o.push_str(&header.join(","));
        o.push('\n');
        for (j, t) in self.t.iter().enumerate() {
            let mut row = vec![format!("{t:e}")];
            row.extend(self.q.values().map(|v| format!("{:e}", v[j])));
            if let Some(eta) = self.eta.get(j) {
                row.extend(eta.iter().map(|v| format!("{v:e}")));
            }
            if let Some(energy) = &self.energy {
                row.push(energy[j].map_or(String::new(), |e| format!("{e:e}")));
            }
            row.extend(
                self.expressions
                    .values()
                    .map(|v| v[j].map_or(String::new(), |x| format!("{x:e}"))),
            );
            o.push_str(&row.join(","));
            o.push('\n');
        }
        o
    }
}

/// `hamel plan --measure`: the planned computation against the full unreduced system.
#[derive(Debug, Serialize)]
pub struct Measured {
    /// The integrator both ran.
    pub method: String,
    /// States integrated: planned, full.
    pub states: (usize, usize),
    /// Operations of the right-hand side: planned (specialised), full (parameters as inputs).
    pub ops: (usize, usize),
    /// Median time of one integration, seconds: planned, full (measured inside each core).
    pub seconds: (f64, f64),
    /// Right-hand side evaluations: planned, full.
    pub rhs_evals: (usize, usize),
    /// Full time over planned time.
    pub speedup: f64,
    /// The largest difference of the requested outputs between the two runs, relative to
    /// max(1, |value|).
    pub max_difference: f64,
}

impl Measured {
    /// The measurement as text.
    pub fn to_text(&self) -> String {
        format!(
            "measured ({}): planned {} states, {} operations, {:.3e} s, {} RHS evaluations; full {} states, {} operations, {:.3e} s, {} RHS evaluations; full / planned = {:.2}x; largest difference of the requested outputs {:.1e}\n",
            self.method,
            self.states.0,
            self.ops.0,
            self.seconds.0,
            self.rhs_evals.0,
            self.states.1,
            self.ops.1,
            self.seconds.1,
            self.rhs_evals.1,
            self.speedup,
            self.max_difference
        )
    }
}

/// Integrate a scene on its compiled core and the full unreduced system (every coordinate,
/// η; parameters not specialised, set at run time) on its own compiled core, both with the
/// scene's integrator (DOP853 at the `[accuracy]` tolerances when it gives only a target),
/// each repeated until it has run about 0.3 s; the median times and the outputs' agreement.
pub fn measure_plan(loaded: &Loaded) -> Result<Measured, ModelError> {
    let (name, method, options) = loaded.integrator.clone();
    let fail = |e: String| loaded.error("integrator", e);
    let repeats = |seconds: f64| ((0.3 / seconds.max(1e-9)) as usize).clamp(3, 10_000);
    let (probe, first, _) = loaded
        .integrate_compiled(method, &options, 1)
        .map_err(fail)?;
    if let Some(e) = probe.failure {
        return Err(e);
    }
    let (planned, planned_seconds, _) = loaded
        .integrate_compiled(method, &options, repeats(first))
        .map_err(fail)?;
    // The full system's core: nothing dropped, nothing specialised.
    let model = &loaded.model;
    let d = &loaded.d;
    let none = IndexMap::new();
    let key = crate::scene_core::Key::new(&model.source, &d.eta_name, &[], &none);
    let entry = match crate::scene_core::lookup(&key).map_err(fail)? {
        Some(e) => e,
        None => {
            let code = hamel_derive::derive_for_code(model, Some(&d.eta_name))?;
            crate::scene_core::store(
                &key,
                &code,
                &none,
                &[],
                |_| Ok(loaded.plan.ops_full),
                loaded.plan.ops_full,
                &format!(
                    "hamel plan --measure (full system of {}, {})",
                    model.file, d.eta_name
                ),
            )
            .map_err(fail)?
        }
    };
    let (exe, _) = crate::scene_core::binary(&entry).map_err(fail)?;
    let full_job = |repeat: usize| crate::scene_core::Job {
        t0: loaded.scene.t0,
        times: &loaded.times,
        y0: loaded
            .q0
            .iter()
            .chain(&loaded.y0[loaded.state.len()..])
            .copied()
            .collect(),
        method,
        options,
        reference: 0.0,
        energy: loaded.request.energy,
        residual: loaded.request.constraint_residual,
        repeat,
        params: loaded.params.clone(),
    };
    let (_, _, first_full) = crate::scene_core::run(&exe, &full_job(1)).map_err(fail)?;
    let (full, error, full_seconds) =
        crate::scene_core::run(&exe, &full_job(repeats(first_full))).map_err(fail)?;
    if let Some(e) = error {
        return Err(fail(format!("the full system's run failed: {e}")));
    }
    let p = &planned.solution;
    let n = loaded.state.len();
    let mut max_difference = 0.0_f64;
    for (yp, yf) in p.y.iter().zip(&full.y) {
        let pairs = loaded
            .request
            .coordinates
            .iter()
            .map(|&k| {
                (
                    loaded
                        .state
                        .iter()
                        .position(|&s| s == k)
                        .expect("requested ⊆ state"),
                    k,
                )
            })
            .chain((0..d.sigma).map(|i| (n + i, d.ell + i)));
        for (i, j) in pairs {
            max_difference = max_difference.max((yp[i] - yf[j]).abs() / yf[j].abs().max(1.0));
        }
    }
    if p.y.len() != full.y.len() {
        max_difference = f64::INFINITY;
    }
    Ok(Measured {
        method: name,
        states: (n + d.sigma, d.ell + d.sigma),
        ops: (loaded.plan.ops, loaded.plan.ops_full),
        seconds: (planned_seconds, full_seconds),
        rhs_evals: (p.stats.rhs_evals, full.stats.rhs_evals),
        speedup: full_seconds / planned_seconds,
        max_difference,
    })
}
