//! `hamel simulate`: run a loaded scene end to end — the integrator its `[accuracy]` target
//! needs, the engine, the diagnosis of a failure, the error estimate of a loose run.

use crate::integrate::Timed;
use std::path::Path;

use hamel_model::ModelError;
use hamel_sim::{Method, Options, Solution};

use crate::compare::{errors, outputs};
use crate::integrate::Engine;
use crate::load::{Loaded, load};
use crate::tradeoff;
use crate::trajectory::Trajectory;

/// At or above this rtol or atol an adaptive run is *loose*: `hamel simulate` estimates its
/// global error with a check run and says so (issue 5 §4, docs/stability.md).
pub const LOOSE_TOLERANCE: f64 = 1e-3;

/// Above this condition number of [Z; α] along the path, `hamel simulate` warns: the singular
/// set of the quasi-velocities is near and accuracy degrades like cond·ε (docs/stability.md).
pub const CONDITION_WARNING: f64 = 1e6;

/// A scene's run: its trajectory, complete or as far as it got, and why it stopped early.
pub struct Simulated {
    /// The trajectory (up to the failure, when there is one).
    pub trajectory: Trajectory,
    /// Why the run ended before its last output time.
    pub failure: Option<ModelError>,
    /// Every coordinate at each output time, when the state holds them all (none dropped:
    /// requested, or kept by [`crate::LoadOptions::every_coordinate`]).
    pub configurations: Option<Vec<Vec<f64>>>,
}

/// Load the scene at `scene_path` and [`run_loaded`] it.
pub fn run(
    scene_path: &Path,
    engine: Engine,
    estimate_error: bool,
) -> Result<Simulated, ModelError> {
    run_loaded(&load(scene_path)?, engine, estimate_error)
}

/// [`run`] with parameter values set on top of the scene's (`--set`, [`crate::load_with`]).
pub fn run_with(
    scene_path: &Path,
    overrides: &indexmap::IndexMap<String, f64>,
    engine: Engine,
    estimate_error: bool,
) -> Result<Simulated, ModelError> {
    run_loaded(
        &crate::load_with(scene_path, overrides)?,
        engine,
        estimate_error,
    )
}

/// Run a loaded scene; returns the trajectory (possibly incomplete) and, on failure, the error.
/// A scene with an `[accuracy]` target and no integrator runs the fastest adaptive setting that
/// meets it (`hamel tradeoff`'s recommendation among DOP853, DOPRI5 and Vern9; stderr says which).
/// A run at loose tolerances, or with `estimate_error`, has its global error estimated.
pub fn run_loaded(
    loaded: &Loaded,
    engine: Engine,
    estimate_error: bool,
) -> Result<Simulated, ModelError> {
    // The compiled core is built (or found) first: the accuracy measurement below runs on it
    // too. The discrete Lagrange–d'Alembert method runs on the model's ingredients, not a core.
    let engine = match loaded.integrator.method {
        Method::Dla { .. } => Engine::Interpreted,
        _ => engine,
    };
    let crate::integrate::Usable { engine, built } = loaded.usable(engine);
    let (method, options) = integrator_for(loaded, engine)?;
    let (run, engine) = integrate_on(loaded, engine, built, method, &options)?;
    if let Some((cond, t)) = run.max_condition
        && cond > CONDITION_WARNING
    {
        log::warn!(
            "the path comes near the singular set of the quasi-velocities: the condition number of [Z; α] reaches {cond:.1e} at t = {t} (accuracy degrades like cond·ε; docs/stability.md)"
        );
    }
    let mut traj = loaded.trajectory(method.name(), &run);
    traj.engine = engine;
    let loose = options.rtol.max(options.atol) >= LOOSE_TOLERANCE && method.is_adaptive();
    if run.failure.is_none() && (estimate_error || loose) {
        match loaded.error_estimate(&run.solution, engine, method, &options) {
            Ok((error, by)) => {
                if loose {
                    log::warn!(
                        "rtol = {:.0e}, atol = {:.0e} is loose: the error on the requested outputs is about {error:.1e} (difference from a run {by})",
                        options.rtol,
                        options.atol
                    );
                } else {
                    log::info!(
                        "error estimate: {error:.1e} on the requested outputs (difference from a run {by})"
                    );
                }
                traj.stats.error_estimate = Some(error);
                traj.stats.error_estimate_by = Some(by);
            }
            // The trajectory stands; only its estimate is missing, and stderr says why.
            Err(e) => log::warn!("no error estimate: {}", e.message()),
        }
    }
    let configurations = (loaded.state.len() == loaded.d.ell)
        .then(|| run.solution.y.iter().map(|y| loaded.full_q(y)).collect());
    Ok(Simulated {
        trajectory: traj,
        failure: run.failure,
        configurations,
    })
}

/// The integrator to run: the scene's, or for an `[accuracy]` target the fastest adaptive
/// setting measured to meet it (DOP853 at the target's tolerances when none does).
pub(crate) fn integrator_for(
    loaded: &Loaded,
    engine: Engine,
) -> Result<(Method, Options), ModelError> {
    let crate::check::Integration {
        mut method,
        mut options,
    } = loaded.integrator;
    if let Some(crate::file::Accuracy { rtol, atol }) = loaded.accuracy {
        let table = tradeoff::table(loaded, tradeoff::Range::Adaptive, engine)?;
        match table.recommended {
            Some(i) => {
                let row = &table.rows[i];
                log::info!(
                    "accuracy rtol = {rtol:.0e}, atol = {atol:.0e}: using {} (error {:.1e} of the target against a DOP853 reference at 1e-14, the fastest of {} adaptive settings that meet it)",
                    row.setting(),
                    row.target_ratio,
                    table.rows.len()
                );
                (method, options) = row.method();
            }
            None => log::warn!(
                "no adaptive setting measured meets rtol = {rtol:.0e}, atol = {atol:.0e}; using DOP853 at those tolerances"
            ),
        }
    }
    Ok((method, options))
}

/// Integrate on `engine` (`built`: this run compiled the core); a compiled run that fails is
/// repeated on the interpreted evaluator, which names the cause. The run and the engine used.
fn integrate_on(
    loaded: &Loaded,
    engine: Engine,
    built: bool,
    method: Method,
    options: &Options,
) -> Result<(crate::Run, Engine), ModelError> {
    Ok(match engine {
        Engine::Interpreted => (loaded.integrate(method, options)?, Engine::Interpreted),
        Engine::Compiled => match loaded.integrate_compiled(method, options, 1) {
            // The compiled core sees a singularity only as a failed step or a value that is
            // not finite; the interpreted evaluator checks δ and A_Γ at every evaluation and
            // names the cause, so a failed run is repeated with it for the diagnosis.
            Ok(Timed { run, .. }) if run.failure.is_some() && !run.stopped_by_friction() => {
                log::info!(
                    "note: the compiled core stopped ({}); integrating again with the interpreted evaluator, which watches the singular set at every evaluation",
                    run.failure.as_ref().map_or("", |e| e.message())
                );
                (loaded.integrate(method, options)?, Engine::Interpreted)
            }
            Ok(Timed { run, .. }) => {
                if let Ok(core) = loaded.core() {
                    log::info!(
                        "compiled core ({} operations): {} {}",
                        core.meta.ops,
                        if built { "built into" } else { "cached in" },
                        core.dir.display()
                    );
                }
                (run, Engine::Compiled)
            }
            Err(e) => {
                log::warn!(
                    "the scene's compiled core is not available, using the interpreted evaluator: {e}"
                );
                (loaded.integrate(method, options)?, Engine::Interpreted)
            }
        },
    })
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
            Method::Dla { step, variant } => (
                Method::Dla {
                    step: step / 2.0,
                    variant,
                },
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
                .map(|t| t.run)
                .map_err(|e| self.core_error(e, "the check run failed"))?,
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
        let got = outputs(self, solution, true);
        let reference = outputs(self, &run.solution, true);
        Ok((errors(&got, &reference, (1.0, 1.0)).span, by))
    }
}
