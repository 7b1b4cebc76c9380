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
    /// which coordinates they are free of, check the steady motion exactly, and compile them
    /// for the steady motion `steady`: the one pass ([`hamel_reduce::pass`], from the
    /// derivation store when it holds it) is the only step that uses the computer algebra.
    pub fn prepare(model: &Model, eta: Option<&str>, steady: &str) -> Result<Study, StudyError> {
        Study::prepare_with(model, eta, steady, false)
    }

    #[cfg(feature = "cas")]
    /// [`Study::prepare`], the pass made anew (and stored) whatever the store holds when
    /// `fresh` (`--no-store`).
    pub fn prepare_with(
        model: &Model,
        eta: Option<&str>,
        steady: &str,
        fresh: bool,
    ) -> Result<Study, StudyError> {
        use hamel_reduce::pass::{Analysis, Job, obtain};
        let gravity = gravity(model);
        let steady = model.steady(steady)?.clone();
        let analysis = Analysis::Drop {
            steady: Some(steady.name.clone()),
        };
        // the loads at the steady motion need the wheels' supports (not for a closed loop)
        let job = Job::new(model, eta, analysis)?
            .with_supports(model.control.is_empty())
            .for_code();
        let mut artefact = obtain(&job, fresh)?;
        let (reduction, steady_check) = (artefact.reduction.take(), artefact.steady_check.take());
        let d = artefact.into_derivation()?;
        let compiled = match d.contact_forces.released {
            true => d.compile_with_constraint_forces(),
            false => d.compile(),
        }
        .map_err(|e| StudyError::Compile(e.to_string()))?;
        let reduction = reduction.as_ref();
        let partition = hamel_reduce::steady::partition(model, reduction)?;
        Ok(Study {
            gravity,
            model: model.clone(),
            steady,
            compiled,
            eta_name: d.eta_name.clone(),
            eta: d.eta.clone(),
            state_q: partition.state_q.iter().map(|k| k.index()).collect(),
            dependent: partition.dependent.iter().map(|k| k.index()).collect(),
            dropped: partition.dropped.iter().map(|k| k.index()).collect(),
            dropped_because: reduction.map_or(Vec::new(), |r| r.findings.clone()),
            steady_check: steady_check.unwrap_or(crate::SteadyCheck::Numeric {
                why: "the pass made no check".into(),
            }),
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
    pub fn dropped(&self) -> Dropped<'_> {
        let names = self.dropped.iter();
        Dropped {
            coordinates: names.map(|&k| self.model.coordinates[k].clone()).collect(),
            because: &self.dropped_because,
        }
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

/// The coordinates a study dropped, and why ([`Study::dropped`]).
pub struct Dropped<'a> {
    /// Their names.
    pub coordinates: Vec<String>,
    /// The reduction's findings that prove them absent.
    pub because: &'a [String],
}
