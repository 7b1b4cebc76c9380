//! The trajectory of a scene's requested outputs, as written (CSV, JSON) and summarised.

use hamel_sim::MethodName;
use indexmap::IndexMap;
use serde::Serialize;

use crate::initial::{Completed, Projection};
use crate::integrate::{Engine, Run};
use crate::load::Loaded;

/// The trajectory as written (`--format json`).
#[derive(Serialize)]
pub struct Trajectory {
    pub model: String,
    pub eta_name: String,
    pub method: MethodName,
    /// What evaluated the right-hand side.
    pub engine: Engine,
    pub t: Vec<f64>,
    pub q: IndexMap<String, Vec<f64>>,
    /// η at the output times (empty when not requested).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub eta: Vec<Vec<f64>>,
    /// The energy (absent when not requested).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub energy: Option<Vec<Option<f64>>>,
    /// W(t), the work the forces have done since the start (with the energy, for a model whose
    /// forces do work): E(t) − W(t) is conserved.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub work: Option<Vec<f64>>,
    /// ‖α(q)q̇‖∞ at the output times (absent when not requested; null where the state holds
    /// too few coordinates to evaluate it).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub constraint_residual: Option<Vec<Option<f64>>>,
    /// The requested `[expressions]` at the output times (null where an expression cannot be
    /// evaluated, e.g. outside its domain; stderr says where).
    #[serde(skip_serializing_if = "IndexMap::is_empty")]
    pub expressions: IndexMap<String, Vec<Option<f64>>>,
    /// The requested constraint forces (`force.NAME.COMPONENT`) at the output times (null
    /// where they cannot be computed).
    #[serde(skip_serializing_if = "IndexMap::is_empty")]
    pub forces: IndexMap<String, Vec<Option<f64>>>,
    /// What the friction monitor found (`[friction]`): by wheel, the largest friction ratio
    /// and the smallest normal force, and the first violation.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub friction: Option<crate::forces::Monitored>,
    pub stats: StatsOut,
    pub complete: bool,
    /// When the initial velocities were given as q̇: their projection onto the constraints.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub initial_projection: Option<Projection>,
    /// The dependent coordinates of holonomic constraints, completed from h(q) = 0 at the start.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub initial_completion: Vec<Completed>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub error: Option<String>,
}

#[derive(Serialize)]
pub struct StatsOut {
    pub steps: usize,
    pub rejected: usize,
    pub rhs_evals: usize,
    /// The Taylor method's series (each costs about its order's square in right-hand sides).
    #[serde(skip_serializing_if = "is_zero")]
    pub series_evals: usize,
    /// Of those, the series a compiled core traced at run time instead of running its compiled
    /// recurrences (`hamel_sim::Stats::series_traced`).
    #[serde(skip_serializing_if = "is_zero")]
    pub series_traced: usize,
    /// max |E − E(t0)| / |E(t0)| over the outputs: for a model whose forces do no work (None
    /// when they do: see `energy_balance_drift`).
    pub energy_drift: Option<f64>,
    /// For a model whose forces do work: max |E − W − E(t0)| / |E(t0)|, W the work of the
    /// forces integrated beside the state (the energy balance).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub energy_balance_drift: Option<f64>,
    pub constraint_drift: Option<f64>,
    /// The largest condition number of [Z; α] over the output states, and where.
    pub max_condition: Option<f64>,
    pub max_condition_t: Option<f64>,
    /// Estimated global error on the requested outputs (max |y − y_c| / max(1, |y_c|) over the
    /// output times, y_c a check run at 1/1000 of the tolerances or half the step), computed
    /// for loose tolerances and on `--estimate-error`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub error_estimate: Option<f64>,
    /// How the check run was made.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub error_estimate_by: Option<String>,
    /// Holonomic constraints: steps after which the state was projected back onto h(q) = 0,
    /// the largest max |h| found before a projection, and max |h| over the output states.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub holonomic: Option<HolonomicDrift>,
}

/// How well h(q) = 0 was kept.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct HolonomicDrift {
    /// Steps after which the state was projected.
    pub projections: usize,
    /// The largest max |h| found before a projection (what one step lets drift).
    pub before_projection: f64,
    /// max |h| over the output states.
    pub at_outputs: f64,
}

impl Loaded {
    /// The trajectory of the requested outputs.
    pub fn trajectory(&self, method: MethodName, run: &Run) -> Trajectory {
        let (solution, failure) = (&run.solution, run.failure.as_ref());
        let n = self.state.len();
        let d = &self.d;
        Trajectory {
            model: d.model.clone(),
            eta_name: d.eta_name.clone(),
            method,
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
                        .position(|&s| s == k.index())
                        .expect("requested ⊆ state");
                    (
                        d.coordinates[k.index()].clone(),
                        solution.y.iter().map(|y| y[i]).collect(),
                    )
                })
                .collect(),
            eta: if self.request.eta {
                solution.y.iter().map(|y| y[n..].to_vec()).collect()
            } else {
                Vec::new()
            },
            energy: self.request.energy.then(|| solution.energy.clone()),
            work: (!solution.work.is_empty()).then(|| solution.work.clone()),
            constraint_residual: self
                .request
                .constraint_residual
                .then(|| solution.constraint.clone()),
            expressions: self.expression_values(solution),
            forces: (self.forces.columns.iter())
                .map(|c| {
                    let at = |v: &Option<Vec<f64>>| v.as_ref().map(|v| v[c.index]);
                    (
                        c.name.clone(),
                        run.constraint_forces.iter().map(at).collect(),
                    )
                })
                .collect(),
            friction: run.monitored.clone(),
            stats: StatsOut {
                steps: solution.stats.steps,
                rejected: solution.stats.rejected,
                rhs_evals: solution.stats.rhs_evals,
                series_evals: solution.stats.series_evals,
                series_traced: solution.stats.series_traced,
                energy_drift: (solution.work.is_empty())
                    .then_some(solution.stats.energy_drift)
                    .flatten(),
                energy_balance_drift: (!solution.work.is_empty())
                    .then_some(solution.stats.energy_drift)
                    .flatten(),
                constraint_drift: solution.stats.constraint_drift,
                max_condition: run.max_condition.map(|c| c.0),
                max_condition_t: run.max_condition.map(|c| c.1),
                error_estimate: None,
                error_estimate_by: None,
                holonomic: self.holonomic_drift(solution),
            },
            complete: failure.is_none() && solution.complete,
            initial_projection: self.projection.clone(),
            initial_completion: self.completed.clone(),
            error: failure.map(|e| e.message().to_string()),
        }
    }
}

impl Loaded {
    /// The drift of the holonomic constraints over a run that projected onto them.
    fn holonomic_drift(&self, solution: &hamel_sim::Solution) -> Option<HolonomicDrift> {
        if !self.projects() {
            return None;
        }
        let at_outputs = solution.y.iter().fold(0.0_f64, |m, y| {
            let r = self
                .model
                .completion
                .residual(&self.full_q(y), &self.params);
            m.max(r.unwrap_or(f64::NAN))
        });
        Some(HolonomicDrift {
            projections: solution.stats.projections,
            before_projection: solution.stats.projection_drift.unwrap_or(0.0),
            at_outputs,
        })
    }
}

impl Trajectory {
    /// One line for stderr.
    pub fn summary(&self) -> String {
        let s = &self.stats;
        format!(
            "{} ({}), {}: {} steps ({} rejected), {}, {}, constraint drift {}{}",
            self.model,
            self.eta_name,
            self.method,
            s.steps,
            s.rejected,
            if s.series_traced > 0 {
                format!(
                    "{} Taylor series ({} traced at run time, not compiled)",
                    s.series_evals, s.series_traced
                )
            } else if s.series_evals > 0 {
                format!("{} Taylor series", s.series_evals)
            } else {
                format!("{} RHS evaluations", s.rhs_evals)
            },
            match (s.energy_balance_drift, s.energy_drift) {
                (Some(b), _) => format!(
                    "energy balance drift {b:.2e} (E − W, W the work of the forces)"
                ),
                (None, d) => format!(
                    "energy drift {}",
                    d.map_or("n/a".into(), |x| format!("{x:.2e}"))
                ),
            },
            s.constraint_drift
                .map_or("not requested".into(), |x| format!("{x:.2e}")),
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
            + self
                .stats
                .holonomic
                .map_or(String::new(), |h| {
                    format!(
                        "\nholonomic constraints: projected after {} steps (largest |h| before projection {:.2e}); max |h| at the outputs {:.2e}",
                        h.projections, h.before_projection, h.at_outputs
                    )
                })
                .as_str()
            + self.friction.as_ref().map_or(String::new(), friction_summary).as_str()
            + self
                .initial_completion
                .iter()
                .map(|c| {
                    format!(
                        "\n{} completed from the holonomic constraints: {} → {:.15}",
                        c.coordinate,
                        c.given.map_or("not given".into(), |g| g.to_string()),
                        c.value
                    )
                })
                .collect::<String>()
                .as_str()
    }

    /// CSV: t, the coordinates, eta1…, energy, work, constraint_residual, the expressions, the
    /// constraint forces (a `# incomplete` comment first when cut short).
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
        if self.work.is_some() {
            header.push("work".into());
        }
        if self.constraint_residual.is_some() {
            header.push("constraint_residual".into());
        }
        header.extend(self.expressions.keys().cloned());
        header.extend(self.forces.keys().map(|k| crate::ensemble::csv_quote(k)));
        o.push_str(&header.join(","));
        o.push('\n');
        for (j, t) in self.t.iter().enumerate() {
            let mut row = vec![format!("{t:e}")];
            row.extend(self.q.values().map(|v| format!("{:e}", v[j])));
            if let Some(eta) = self.eta.get(j) {
                row.extend(eta.iter().map(|v| format!("{v:e}")));
            }
            if let Some(e) = &self.energy {
                row.push(e[j].map_or(String::new(), |e| format!("{e:e}")));
            }
            if let Some(w) = &self.work {
                row.push(format!("{:e}", w[j]));
            }
            if let Some(r) = &self.constraint_residual {
                row.push(r[j].map_or(String::new(), |e| format!("{e:e}")));
            }
            row.extend(
                (self.expressions.values().chain(self.forces.values()))
                    .map(|v| v[j].map_or(String::new(), |x| format!("{x:e}"))),
            );
            o.push_str(&row.join(","));
            o.push('\n');
        }
        o
    }
}

/// The friction monitor's findings, one line per wheel.
fn friction_summary(m: &crate::forces::Monitored) -> String {
    let num = |x: Option<f64>, t: Option<f64>| match (x, t) {
        (Some(x), Some(t)) => format!("{x:.4} (t = {t})"),
        _ => "n/a".into(),
    };
    (m.contacts.iter())
        .map(|(wheel, l)| {
            format!(
                "\nfriction: wheel {wheel}: largest friction ratio {} against μ = {}, smallest normal force {} N",
                num(l.largest_friction_ratio, l.largest_friction_ratio_t),
                l.mu,
                num(l.smallest_normal, l.smallest_normal_t)
            )
        })
        .collect()
}

fn is_zero(n: &usize) -> bool {
    *n == 0
}
