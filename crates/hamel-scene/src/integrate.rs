//! One integration of a loaded scene: on the interpreted evaluator ([`crate::system`]) or on the
//! scene's compiled core ([`crate::cache`]), with the singular set watched.

use hamel_model::ModelError;
use hamel_sim::{Method, Options, Solution};
use indexmap::IndexMap;
use serde::Serialize;

use crate::cache;
use crate::load::Loaded;
use crate::system::System;

/// What evaluates the right-hand side.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Engine {
    /// The scene's generated core, compiled and cached ([`crate::cache`]).
    Compiled,
    /// The structured evaluator of the derivation (a tape interpreter).
    Interpreted,
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

impl Loaded {
    /// The engine that can run this scene: `engine`, or the interpreted evaluator (with a
    /// warning on stderr) when the scene's compiled core cannot be built; and whether this call
    /// built the core.
    pub fn usable(&self, engine: Engine) -> (Engine, bool) {
        if engine == Engine::Interpreted {
            return (engine, false);
        }
        match self.core().and_then(cache::binary) {
            Ok((_, built)) => (Engine::Compiled, built),
            Err(e) => {
                log::warn!(
                    "the scene's compiled core is not available, using the interpreted evaluator: {e}"
                );
                (Engine::Interpreted, false)
            }
        }
    }

    /// Whether the integration projects onto the holonomic constraints: the model has some, and
    /// the state holds every coordinate they depend on.
    pub fn projects(&self) -> bool {
        let c = &self.model.completion;
        !c.is_empty()
            && (0..self.d.ell)
                .filter(|&k| c.mentions(k))
                .all(|k| self.state.contains(&k))
    }

    /// Integrate the planned state with `method`; on failure, what was computed and the error.
    pub fn integrate(&self, method: Method, options: &Options) -> Result<Run, ModelError> {
        let numeric = hamel_model::NumericModel::new(&self.model, &self.params)
            .map_err(|e| self.error("parameters", e.to_string()))?;
        let system = System {
            compiled: &self.compiled,
            params: self.params.clone(),
            live: self
                .model
                .live
                .iter()
                .cloned()
                .zip(self.live.iter().cloned())
                .collect(),
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
            holonomic: self.projects().then_some(&self.model.completion),
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
                let m = self.error("integrator", e.to_string());
                (*e.partial, Some(m))
            }
        };
        Ok(Run {
            solution,
            failure,
            max_condition: system.watch.get(),
        })
    }

    /// A state in the plan's order (integrated, then reconstructed coordinates, then η) in the
    /// order of the scene's core (the kept coordinates in model order, then η).
    pub(crate) fn to_core(&self, y: &[f64]) -> Vec<f64> {
        let n = self.state.len();
        let mut kept: Vec<(usize, f64)> =
            self.state.iter().copied().zip(y.iter().copied()).collect();
        kept.sort_unstable_by_key(|&(k, _)| k);
        kept.into_iter()
            .map(|(_, v)| v)
            .chain(y[n..].iter().copied())
            .collect()
    }

    /// The states of a solution of the scene's core back in the plan's order ([`Self::to_core`]
    /// undone).
    pub(crate) fn back_from_core(&self, solution: &mut Solution) {
        let mut kept = self.state.clone();
        kept.sort_unstable();
        let from: Vec<usize> = self
            .state
            .iter()
            .map(|k| kept.iter().position(|x| x == k).expect("state = kept"))
            .collect();
        let mut row = vec![0.0; solution.y.dim()];
        for y in solution.y.iter_mut() {
            row.copy_from_slice(y);
            for (j, &i) in from.iter().enumerate() {
                y[j] = row[i];
            }
        }
    }

    /// Integrate the planned state on the scene's compiled core ([`crate::cache`]: built
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
    ) -> Result<(Run, f64, bool), cache::CacheError> {
        let (exe, built) = cache::binary(self.core()?)?;
        let job = cache::Job {
            t0: self.scene.t0,
            times: &self.times,
            y0: self.to_core(&self.y0),
            method,
            options: *options,
            reference: self.reference,
            energy: self.request.energy,
            residual: self.request.constraint_residual,
            repeat,
            params: IndexMap::new(),
            live: self.live.clone(),
            members: Vec::new(),
            save: None,
        };
        let (mut solution, error, seconds) = cache::run(&exe, &job)?;
        self.back_from_core(&mut solution);
        let (crossing, max_condition) =
            self.watch_singular(&mut solution, &self.params, self.delta0);
        let failure = crossing.or(error).map(|m| self.error("integrator", m));
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

    /// Watch the singular set at the output states of a compiled run started with
    /// δ = `delta0` (parameters `params`): a sign change of δ = det[Z; α] ends the output
    /// before it, with the message returned; and the largest condition number of [Z; α] once
    /// |δ| has fallen below 1e-3 of its start, and when.
    pub(crate) fn watch_singular(
        &self,
        solution: &mut Solution,
        params: &IndexMap<String, f64>,
        delta0: f64,
    ) -> (Option<String>, Option<(f64, f64)>) {
        let mut max_condition: Option<(f64, f64)> = None;
        for j in 0..solution.t.len() {
            let y = &solution.y[j];
            let q = self.full_q(y);
            let delta = self.compiled.delta(&q, params);
            if let Ok(delta) = delta
                && delta.signum() != delta0.signum()
            {
                let message = format!(
                    "the path crosses the singular set of the quasi-velocities, det[Z; α] = 0, between t = {} and t = {} (δ = {delta:.3e} changed sign); choose other quasi-velocities there",
                    solution.t[j.saturating_sub(1)],
                    solution.t[j]
                );
                solution.t.truncate(j);
                solution.y.truncate(j);
                solution.energy.truncate(j);
                solution.work.truncate(j);
                solution.constraint.truncate(j);
                solution.complete = false;
                return (Some(message), max_condition);
            }
            if delta.is_ok_and(|d| d.abs() < 1e-3 * delta0.abs())
                && let Ok(cond) = self.compiled.condition(&q, params)
                && max_condition.is_none_or(|(c, _)| cond > c)
            {
                max_condition = Some((cond, solution.t[j]));
            }
        }
        (None, max_condition)
    }
}
