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
    /// Every reported constraint force at each output time, when the scene computes them
    /// (None where they could not be computed); empty otherwise.
    pub constraint_forces: Vec<Option<Vec<f64>>>,
    /// What the friction monitor found (`[friction]`).
    pub monitored: Option<crate::forces::Monitored>,
}

impl Run {
    /// Whether the friction monitor ended the run (its `failure` is the violation, not the
    /// integrator's).
    pub fn stopped_by_friction(&self) -> bool {
        self.failure
            .as_ref()
            .is_some_and(|e| e.key() == Some("friction"))
    }
}

/// The engine a scene runs on ([`Loaded::usable`]), and whether asking built its core.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Usable {
    /// The engine.
    pub engine: Engine,
    /// This call compiled the scene's core.
    pub built: bool,
}

/// A run on the compiled core ([`Loaded::integrate_compiled`]) and the median time of one
/// integration, measured inside the core.
pub struct Timed {
    /// The run.
    pub run: Run,
    /// Seconds.
    pub seconds: f64,
}

impl Loaded {
    /// The engine that can run this scene: `engine`, or the interpreted evaluator (with a
    /// warning on stderr) when the scene's compiled core cannot be built; and whether this call
    /// built the core.
    pub fn usable(&self, engine: Engine) -> Usable {
        let interpreted = Usable {
            engine: Engine::Interpreted,
            built: false,
        };
        if engine == Engine::Interpreted {
            return interpreted;
        }
        match self.core().and_then(cache::binary) {
            Ok(b) => Usable {
                engine: Engine::Compiled,
                built: b.built,
            },
            Err(e) => {
                log::warn!(
                    "the scene's compiled core is not available, using the interpreted evaluator: {e}"
                );
                interpreted
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

    /// Integrate the planned state with `method` (the discrete Lagrange–d'Alembert method on
    /// the model itself, [`Loaded::integrate_dla`]); on failure, what was computed and the error.
    pub fn integrate(&self, method: Method, options: &Options) -> Result<Run, ModelError> {
        if let Method::Dla { step, variant } = method {
            return self.integrate_dla(step, variant, options);
        }
        let system = self.system()?;
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
        let forces = if self.forces.is_empty() {
            Vec::new()
        } else {
            self.interpreted_forces(&solution)
        };
        Ok(self.watched(Run {
            solution,
            failure,
            max_condition: system.watch.get(),
            constraint_forces: forces,
            monitored: None,
        }))
    }

    /// The planned state's right-hand side on the interpreted evaluator, with the scene's
    /// monitors.
    pub(crate) fn system(&self) -> Result<System<'_>, ModelError> {
        let numeric = hamel_model::NumericModel::new(&self.model, &self.params)
            .map_err(|e| self.error("parameters", e.to_string()))?;
        Ok(System {
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
    /// on first use, cached): the run, and the median time of one integration measured inside
    /// the core over `repeat` runs. The singular set is
    /// watched at the output states (δ's sign, the condition number of [Z; α] once |δ| falls
    /// below 1e-3 of its start): a sign change ends the output before it, as an error.
    /// Errors: the core could not be built or run (the caller may fall back to [`Self::integrate`]).
    pub fn integrate_compiled(
        &self,
        method: Method,
        options: &Options,
        repeat: usize,
    ) -> Result<Timed, cache::CacheError> {
        let exe = cache::binary(self.core()?)?.path;
        let job = cache::Job {
            t0: self.scene.t0,
            times: self.times.clone(),
            y0: self.to_core(&self.y0),
            method,
            options: *options,
            reference: self.reference,
            energy: self.request.energy,
            residual: self.request.constraint_residual,
            forces: !self.forces.is_empty(),
            repeat,
            params: Default::default(),
            live: self.live.clone(),
            members: Vec::new(),
            save: Default::default(),
        };
        let cache::Answer {
            mut solution,
            stopped,
            seconds,
            mut constraint_forces,
            forces_failure,
        } = cache::run(&exe, &job)?;
        let expected = self.compiled.constraint_force_names().len();
        if let Some(v) = constraint_forces
            .iter()
            .flatten()
            .find(|v| v.len() != expected)
        {
            return Err(cache::CacheError::Core {
                binary: exe.clone(),
                why: format!(
                    "its constraint forces have {} components, the scene's derivation {expected}",
                    v.len()
                ),
            });
        }
        if let Some(e) = forces_failure {
            log::warn!("the constraint forces cannot be computed {e} (written as null)");
        }
        self.back_from_core(&mut solution);
        let (crossing, max_condition) =
            self.watch_singular(&mut solution, &self.params, self.delta0);
        constraint_forces.truncate(solution.t.len());
        let failure = crossing
            .or(stopped.map(|s| s.to_string()))
            .map(|m| self.error("integrator", m));
        let run = Run {
            solution,
            failure,
            max_condition,
            constraint_forces,
            monitored: None,
        };
        Ok(Timed {
            run: self.watched(run),
            seconds,
        })
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
                solution.truncate(j);
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

impl Loaded {
    /// The constraint forces at the output states of an interpreted run
    /// ([`hamel_derive::Compiled::constraint_forces_checked`]: double-double where f64 would
    /// lose digits); None where they cannot be computed, with a warning naming the first time.
    fn interpreted_forces(&self, solution: &Solution) -> Vec<Option<Vec<f64>>> {
        let n = self.state.len();
        let mut warned = false;
        let at = |t: f64, y: &[f64]| -> Result<Vec<f64>, String> {
            let mut params = self.params.clone();
            for (name, live) in self.model.live.iter().zip(&self.live) {
                params[name] = live.at(t).map_err(|e| e.to_string())?;
            }
            let pushed = (self.compiled)
                .constraint_forces_checked(&self.full_q(y), &y[n..], &params)
                .map_err(|e| e.to_string())?;
            Ok(pushed.forces.iter().map(|f| f.value).collect())
        };
        (solution.t.iter().zip(solution.y.iter()))
            .map(|(&t, y)| match at(t, y) {
                Ok(v) => Some(v),
                Err(e) => {
                    if !std::mem::replace(&mut warned, true) {
                        log::warn!("the constraint forces cannot be computed at t = {t}: {e} (written as null)");
                    }
                    None
                }
            })
            .collect()
    }

    /// `run` with its forces watched by `[friction]`: the largest friction ratio and smallest
    /// normal force of each wheel, and the first slip or lift-off, which ends the outputs
    /// there as an error (the violating output kept) or only warns, as the scene says.
    fn watched(&self, mut run: Run) -> Run {
        if self.forces.watched.is_empty() {
            return run;
        }
        let mut monitored = self.forces.monitor(&run.solution.t, &run.constraint_forces);
        if let Some(v) = &monitored.violation {
            let state: Vec<String> = (self.state_names().iter())
                .zip(&run.solution.y[v.output])
                .map(|(name, x)| format!("{name} = {x:.6}"))
                .collect();
            let message = format!("{} (state {})", v.message(), state.join(", "));
            match self.forces.on_violation {
                crate::forces::OnViolation::Warn => log::warn!("friction: {message}"),
                crate::forces::OnViolation::Stop => {
                    run.solution.truncate(v.output + 1);
                    run.constraint_forces.truncate(v.output + 1);
                    run.failure = Some(self.error("friction", message));
                    // the extremes over the outputs kept
                    monitored = self.forces.monitor(&run.solution.t, &run.constraint_forces);
                }
            }
        }
        run.monitored = Some(monitored);
        run
    }
}
