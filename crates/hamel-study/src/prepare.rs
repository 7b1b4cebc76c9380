//! [`Study::prepare`]: the one symbolic pass (derivation, and which coordinates drop out), and
//! what the numeric stages need from it.

use hamel_eval::Compiled;
use hamel_model::{Model, ModelError, Steady};
use indexmap::IndexMap;

use crate::StudyError;

/// A steady motion of a model, ready to be linearised at any parameter values: the compiled
/// equations, and which coordinates are in the state.
#[derive(Clone, Debug)]
pub struct Study {
    pub(crate) model: Model,
    pub(crate) steady: Steady,
    pub(crate) compiled: Compiled,
    pub(crate) eta_name: String,
    /// The quasi-velocities as written (η = Z q̇).
    pub(crate) eta: Vec<String>,
    /// Coordinates in the state (kept, not dependent), by index.
    pub(crate) state_q: Vec<usize>,
    /// Kept coordinates completed from the holonomic constraints, by index.
    pub(crate) dependent: Vec<usize>,
    /// Coordinates the equations are free of, dropped (their proof in `dropped_because`).
    pub(crate) dropped: Vec<usize>,
    /// Why the dropped coordinates drop out (from `hamel reduce`'s ground truth).
    pub(crate) dropped_because: Vec<String>,
    /// The parameter that enters only through U, linearly (gravity), if there is one.
    pub(crate) gravity: Option<String>,
    /// How the steady motion is known to be one.
    pub(crate) steady_check: crate::SteadyCheck,
    /// Threads of the pool that sweeps and maps run on.
    pub(crate) threads: usize,
}

impl Study {
    #[cfg(feature = "cas")]
    /// Derive the equations of the choice `eta` (the model's first when `None`), decide exactly
    /// which coordinates they are free of, and compile them for the steady motion `steady`.
    /// This is the only step that uses the computer algebra.
    pub fn prepare(model: &Model, eta: Option<&str>, steady: &str) -> Result<Study, ModelError> {
        let steady = model.steady(steady)?.clone();
        // the loads at the steady motion need the wheels' supports (not for a closed loop)
        let with_supports = match model.control.is_empty() {
            true => model.with_supports()?,
            false => model.clone(),
        };
        let (d, reduction) = hamel_reduce::derive_and_drop(&with_supports, eta)?;
        let compiled = match d.contact_forces.released {
            true => d.compile_with_constraint_forces(),
            false => d.compile(),
        }
        .map_err(|e| model.error(format!("the equations cannot be compiled: {e}")))?;
        let index = |n: &String| model.coordinates.iter().position(|c| c == n);
        let (dropped, dropped_because) = match &reduction {
            Some(r) => (
                r.ground_truth.absent.iter().filter_map(index).collect(),
                r.findings.clone(),
            ),
            None => (Vec::new(), Vec::new()),
        };
        let completion = &model.completion;
        let dependent: Vec<usize> = completion
            .dependent()
            .iter()
            .copied()
            .filter(|k| !dropped.contains(k))
            .collect();
        if let Some(&k) = dropped.iter().find(|&&k| completion.mentions(k)) {
            return Err(model.error(format!(
                "the holonomic constraints mention `{}`, which the equations are free of: hamel cannot drop it and complete the dependent coordinates without it",
                model.coordinates[k]
            )));
        }
        let state_q: Vec<usize> = (0..model.coordinates.len())
            .filter(|k| !dropped.contains(k) && !completion.dependent().contains(k))
            .collect();
        let steady_check = crate::exact::check(&crate::exact::Inputs {
            model,
            steady: &steady,
            derivation: &d,
            state_q: &state_q,
            dependent: &dependent,
        });
        Ok(Study {
            gravity: gravity(model),
            model: model.clone(),
            steady,
            compiled,
            eta_name: d.eta_name.clone(),
            eta: d.eta.clone(),
            state_q,
            dependent,
            dropped,
            dropped_because,
            steady_check,
            threads: std::thread::available_parallelism().map_or(1, |n| n.get()),
        })
    }

    /// The same study with sweeps and maps on `threads` threads (at least one; the default is
    /// every core).
    pub fn with_threads(mut self, threads: usize) -> Study {
        self.threads = threads.max(1);
        self
    }

    /// The model.
    pub fn model(&self) -> &Model {
        &self.model
    }

    /// The steady motion.
    pub fn steady(&self) -> &Steady {
        &self.steady
    }

    /// How the steady motion is known to be one.
    pub fn steady_check(&self) -> &crate::SteadyCheck {
        &self.steady_check
    }

    /// The quasi-velocity choice's name.
    pub fn eta_name(&self) -> &str {
        &self.eta_name
    }

    /// The names of the state: the coordinates kept (not dependent), then `eta1`…`etaσ`.
    pub fn state_names(&self) -> Vec<String> {
        let q = self
            .state_q
            .iter()
            .map(|&k| self.model.coordinates[k].clone());
        q.chain((1..=self.eta.len()).map(|i| format!("eta{i}")))
            .collect()
    }

    /// The coordinates dropped (the equations are free of them), with the reasons.
    pub fn dropped(&self) -> (Vec<String>, &[String]) {
        let names = self.dropped.iter();
        let names = names.map(|&k| self.model.coordinates[k].clone()).collect();
        (names, &self.dropped_because)
    }

    /// The kept coordinates completed from the holonomic constraints.
    pub fn dependent(&self) -> Vec<String> {
        let names = self.dependent.iter();
        names.map(|&k| self.model.coordinates[k].clone()).collect()
    }

    /// The quasi-velocities as written in the model.
    pub fn eta(&self) -> &[String] {
        &self.eta
    }

    /// The parameter values of a point: the model's (derived ones evaluated again) with the
    /// overrides that name model parameters, and the steady parameters (defaults overridden).
    /// Unknown names are errors.
    pub(crate) fn values(
        &self,
        overrides: &IndexMap<String, f64>,
    ) -> Result<(IndexMap<String, f64>, Vec<f64>), StudyError> {
        let (steady, model): (Vec<_>, Vec<_>) = overrides
            .iter()
            .partition(|(k, _)| self.steady.parameters.contains_key(*k));
        let model: IndexMap<String, f64> =
            model.into_iter().map(|(k, v)| (k.clone(), *v)).collect();
        let params = self
            .model
            .parameter_values(&model)
            .map_err(|e| StudyError::Parameter(e.to_string()))?;
        let s = self
            .steady
            .parameters
            .iter()
            .map(|(k, v)| {
                steady
                    .iter()
                    .find(|(n, _)| *n == k)
                    .map_or(*v, |(_, x)| **x)
            })
            .collect();
        Ok((params, s))
    }

    /// A [`StudyError`] as a model error located at the steady motion (or the value it names).
    pub fn locate(&self, e: &StudyError) -> ModelError {
        let site = match e {
            StudyError::Value { key, .. } => self
                .steady
                .q
                .iter()
                .chain(&self.steady.velocities)
                .map(|(_, item)| &item.site)
                .find(|s| &s.key == key)
                .unwrap_or(&self.steady.site),
            _ => &self.steady.site,
        };
        self.model.error_at(site, e.to_string())
    }
}

/// The parameter that enters the model only through U, and linearly (U's derivative by it is
/// free of it), such as g: the stiffness K then splits as g K0 plus the rest. Decided on the
/// model's expressions as written (a name that does not occur is absent; a derivative that
/// does not mention it is free of it). `None` when no parameter, or more than one, qualifies.
#[cfg(feature = "cas")]
fn gravity(model: &Model) -> Option<String> {
    let u = &model.potential.expr;
    let elsewhere = |p: &str| {
        let kinetic = match &model.kinetic {
            hamel_model::Kinetic::Energy(t) => t.expr.mentions(p),
            hamel_model::Kinetic::MassMatrix(rows) => {
                rows.iter().flatten().any(|a| a.expr.mentions(p))
            }
        };
        kinetic
            || model.constraints.iter().any(|(_, c)| c.expr.mentions(p))
            || model.forces.iter().any(|f| f.expr.mentions(p))
            || model.holonomic.iter().any(|h| h.h.mentions(p))
            || model.derived.values().any(|d| d.expr.mentions(p))
            || model
                .choices
                .iter()
                .flat_map(|c| &c.eta)
                .any(|e| e.expr.mentions(p))
    };
    let linear = |p: &str| u.diff(p).is_ok_and(|d| !d.mentions(p));
    let mut found = model
        .parameters
        .keys()
        .filter(|p| !model.derived.contains_key(*p) && !model.inputs.contains(p))
        .filter(|p| u.mentions(p) && linear(p) && !elsewhere(p));
    match (found.next(), found.next()) {
        (Some(p), None) => Some(p.clone()),
        _ => None,
    }
}
