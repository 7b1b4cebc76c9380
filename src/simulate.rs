//! `hamel simulate SCENE.toml`: integrate a model's Boltzmann–Hamel equations.
//!
//! The scene names a model and a quasi-velocity choice; the equations are derived once (CAS)
//! and evaluated by the engine-free structured evaluator; the integrators are `hamel-sim`'s.
//! State y = (q, η). A singularity on the way (det[Z; α] → 0, A_Γ degenerate, a non-finite
//! value) stops the run with an error naming the time and state; what was computed is written
//! and marked incomplete.

use std::path::Path;
use std::sync::Arc;

use hamel_derive::Compiled;
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
    #[serde(default)]
    integrator: Integrator,
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
    eta: Vec<f64>,
}

#[derive(Deserialize)]
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

/// The trajectory as written (`--format json`).
#[derive(Serialize)]
pub struct Trajectory {
    pub model: String,
    pub eta_name: String,
    method: String,
    pub t: Vec<f64>,
    pub q: IndexMap<String, Vec<f64>>,
    pub eta: Vec<Vec<f64>>,
    energy: Vec<Option<f64>>,
    stats: StatsOut,
    pub complete: bool,
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
}

struct System<'a> {
    compiled: &'a Compiled,
    params: IndexMap<String, f64>,
    names: &'a [String],
    ell: usize,
    sigma: usize,
    /// The sign of δ = det[Z; α] at the start: a path that changes it crosses the singular set.
    delta_sign: f64,
    numeric: hamel_model::NumericModel<'a>,
}

impl System<'_> {
    fn at(&self, y: &[f64]) -> Result<hamel_derive::Evaluation, SystemError> {
        let (q, eta) = y.split_at(self.ell);
        let result = self
            .compiled
            .evaluate(q, eta, &self.params)
            .and_then(|e| {
                if e.delta.signum() == self.delta_sign {
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
                .names
                .iter()
                .zip(q)
                .map(|(n, v)| format!("{n} = {v:.6}"))
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
        self.ell + self.sigma
    }
    fn rhs(&self, _t: f64, y: &[f64], dy: &mut [f64]) -> Result<(), SystemError> {
        let e = self.at(y)?;
        dy[..self.ell].copy_from_slice(&e.q_dot);
        dy[self.ell..].copy_from_slice(&e.eta_dot);
        Ok(())
    }
    fn energy(&self, _t: f64, y: &[f64]) -> Option<f64> {
        self.at(y).ok().map(|e| e.energy)
    }
    /// ‖α(q) q̇‖∞ with q̇ = Γη, from the model's own α (hamel-sim reports its maximum over the
    /// outputs as the constraint drift).
    fn constraint_residual(&self, _t: f64, y: &[f64]) -> Option<f64> {
        let e = self.at(y).ok()?;
        hamel_oracle::constraint_residual(&self.numeric, &y[..self.ell], &e.q_dot).ok()
    }
    /// Exact Jacobian: the structured right-hand side over dual numbers, one column per
    /// state component (used by the implicit Gauss–Legendre method).
    fn jacobian(&self, t: f64, y: &[f64], jac: &mut [f64]) -> Option<Result<(), SystemError>> {
        use hamel_expr::Dual;
        let n = y.len();
        for j in 0..n {
            let yd: Vec<Dual> = y
                .iter()
                .enumerate()
                .map(|(i, &v)| Dual::new(v, if i == j { 1.0 } else { 0.0 }))
                .collect();
            let (q, eta) = yd.split_at(self.ell);
            let r = match self.compiled.rhs::<Dual>(q, eta, &self.params) {
                Ok(r) => r,
                Err(e) => return Some(Err(SystemError::new(format!("at t = {t}: {e}")))),
            };
            for (i, v) in r.q_dot.iter().chain(&r.eta_dot).enumerate() {
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

/// Run the scene; returns the trajectory (possibly incomplete) and, on failure, the error.
pub fn run(scene_path: &Path) -> Result<(Trajectory, Option<ModelError>), ModelError> {
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
    let err = |span: Option<std::ops::Range<usize>>, key: Option<&str>, m: String| {
        ModelError::new(&name, source.clone(), span, key, m)
    };
    let scene: Scene =
        toml::from_str(&text).map_err(|e| err(e.span(), None, e.message().to_string()))?;
    let model_path = scene_path
        .parent()
        .unwrap_or(Path::new("."))
        .join(&scene.model);
    let model = Model::load(&model_path)?;
    let choice = model.choice(scene.eta.as_deref())?.name.clone();
    let d = hamel_derive::derive(&model, Some(&choice))?;
    let compiled = d
        .compile()
        .map_err(|e| err(None, Some("eta"), e.to_string()))?;
    let params = d
        .parameters_with(&scene.parameters)
        .map_err(|e| err(None, Some("parameters"), e.to_string()))?;
    let mut y0 = Vec::new();
    for c in &d.coordinates {
        y0.push(
            *scene
                .initial
                .q
                .get(c)
                .ok_or_else(|| err(None, Some("initial.q"), format!("missing coordinate `{c}`")))?,
        );
    }
    if let Some(extra) = scene.initial.q.keys().find(|k| !d.coordinates.contains(k)) {
        return Err(err(
            None,
            Some("initial.q"),
            format!("`{extra}` is not a coordinate of the model"),
        ));
    }
    if scene.initial.eta.len() != d.sigma {
        return Err(err(
            None,
            Some("initial.eta"),
            format!(
                "needs σ = {} values, found {}",
                d.sigma,
                scene.initial.eta.len()
            ),
        ));
    }
    y0.extend(&scene.initial.eta);
    if !(scene.t_end.is_finite() && scene.t0.is_finite()) || scene.t_end == scene.t0 {
        return Err(err(
            None,
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
                None,
                Some("outputs"),
                format!("needs at least 2 output times, got {n}"),
            ));
        }
        Outputs::Times(t) => t.clone(),
    };
    let i = &scene.integrator;
    let method = match i.method.as_str() {
        "rk4" => Method::Rk4 {
            step: i
                .step
                .ok_or_else(|| err(None, Some("integrator.step"), "rk4 needs a step".into()))?,
        },
        "dopri5" => Method::Dopri5,
        "dop853" => Method::Dop853,
        "gauss-legendre" => Method::GaussLegendre {
            stages: i.stages.unwrap_or(3),
            step: i.step,
        },
        other => {
            return Err(err(
                None,
                Some("integrator.method"),
                format!("unknown method `{other}` (rk4, dopri5, dop853, gauss-legendre)"),
            ));
        }
    };
    let options = Options {
        rtol: i.rtol,
        atol: i.atol,
        max_steps: i.max_steps.unwrap_or(Options::default().max_steps),
        ..Options::default()
    };
    let delta0 = compiled
        .evaluate(&y0[..d.ell], &y0[d.ell..], &params)
        .map_err(|e| err(None, Some("initial"), e.to_string()))?
        .delta;
    let numeric = hamel_model::NumericModel::new(&model, &params)
        .map_err(|e| err(None, Some("parameters"), e.to_string()))?;
    let system = System {
        compiled: &compiled,
        params,
        names: &d.coordinates,
        ell: d.ell,
        sigma: d.sigma,
        delta_sign: delta0.signum(),
        numeric,
    };
    let (solution, failure): (Solution, Option<ModelError>) =
        match hamel_sim::integrate(&system, method, scene.t0, &y0, &times, &options) {
            Ok(s) => (s, None),
            Err(e) => {
                let m = err(None, Some("integrator"), e.to_string());
                (*e.partial, Some(m))
            }
        };
    let traj = Trajectory {
        model: d.model.clone(),
        eta_name: d.eta_name.clone(),
        method: i.method.clone(),
        t: solution.t.clone(),
        q: d.coordinates
            .iter()
            .enumerate()
            .map(|(k, c)| (c.clone(), solution.y.iter().map(|y| y[k]).collect()))
            .collect(),
        eta: solution.y.iter().map(|y| y[d.ell..].to_vec()).collect(),
        energy: solution.energy.clone(),
        stats: StatsOut {
            steps: solution.stats.steps,
            rejected: solution.stats.rejected,
            rhs_evals: solution.stats.rhs_evals,
            energy_drift: solution.stats.energy_drift,
            constraint_drift: solution.stats.constraint_drift,
        },
        complete: failure.is_none() && solution.complete,
        error: failure.as_ref().map(|e| e.message().to_string()),
    };
    Ok((traj, failure))
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
        )
    }

    /// CSV: t, the coordinates, eta1…, energy (a `# incomplete` comment first when cut short).
    pub fn to_csv(&self) -> String {
        let mut o = String::new();
        if let Some(e) = &self.error {
            o.push_str(&format!("# incomplete: {}\n", e.replace('\n', " ")));
        }
        let sigma = self.eta.first().map_or(0, Vec::len);
        let mut header = vec!["t".to_string()];
        header.extend(self.q.keys().cloned());
        header.extend((1..=sigma).map(|i| format!("eta{i}")));
        header.push("energy".into());
        o.push_str(&header.join(","));
        o.push('\n');
        for (j, t) in self.t.iter().enumerate() {
            let mut row = vec![format!("{t:e}")];
            row.extend(self.q.values().map(|v| format!("{:e}", v[j])));
            row.extend(self.eta[j].iter().map(|v| format!("{v:e}")));
            row.push(self.energy[j].map_or(String::new(), |e| format!("{e:e}")));
            o.push_str(&row.join(","));
            o.push('\n');
        }
        o
    }
}
