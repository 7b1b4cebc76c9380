//! The driver: input checks, the fixed-step and adaptive step loops, outputs and failures.

use serde::{Deserialize, Serialize};

use crate::control::{Tolerances, Verdict, initial_step};
use crate::dop853::Dop853;
use crate::dopri5::Dopri5;
use crate::events::{Event, EventHit, Watch};
use crate::gauss::Gauss;
use crate::rk4::Rk4;
use crate::solution::{ErrorKind, IntegrationError, Solution, Stats};
use crate::states::States;
use crate::step::{AdaptiveStep, FixedStep};
use crate::system::{Evaluator, OdeSystem, StepFailure};
use crate::vern9::Vern9;

/// An integration method.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub enum Method {
    /// Classical fourth-order Runge–Kutta with a fixed step (the last step before each output
    /// time is shortened to land on it).
    Rk4 {
        /// Step size (positive; the direction comes from the output times).
        step: f64,
    },
    /// Adaptive Dormand–Prince 5(4) with fourth-order dense output (Hairer's dopri5).
    Dopri5,
    /// Adaptive Dormand–Prince 8(5,3) with seventh-order dense output (Hairer's dop853).
    Dop853,
    /// Adaptive Verner 9(8) ("most efficient" pair, 2010) with a lazy eighth-order continuous
    /// extension: fewer evaluations than DOP853 at tight tolerances (DifferentialEquations.jl's
    /// `Vern9`).
    Vern9,
    /// The Taylor method (Jorba & Zou 2005, as TIDES and heyoka): the solution's own series to
    /// an order and over a step chosen from the tolerance, dense output from the series; for
    /// systems that give their series ([`OdeSystem::taylor_coefficients`], `crate::taylor`).
    Taylor,
    /// The discrete Lagrange–d'Alembert method ([`crate::dla`]) with a fixed step, for
    /// conservative nonholonomic systems over long horizons: it integrates a
    /// [`crate::dla::Nonholonomic`] system ([`crate::dla::integrate`]), not an [`OdeSystem`],
    /// so [`integrate`] refuses it; hamel-run runs scenes' models on it.
    Dla {
        /// Step size (positive).
        step: f64,
        /// Where the discrete constraint is taken.
        #[serde(default)]
        variant: crate::dla::Variant,
    },
    /// Implicit Gauss–Legendre collocation: symmetric and symplectic, order `2·stages`.
    GaussLegendre {
        /// 2 (order 4) or 3 (order 6).
        stages: usize,
        /// Fixed step size, or None for step-doubling error control (steps then end on every
        /// output time, as the method has no dense output).
        step: Option<f64>,
    },
}

/// An integrator by name, as scene files and reports spell it (`rk4`, `dopri5`, `dop853`,
/// `vern9`, `gauss-legendre`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum MethodName {
    /// [`Method::Rk4`].
    Rk4,
    /// [`Method::Dopri5`].
    Dopri5,
    /// [`Method::Dop853`].
    Dop853,
    /// [`Method::Vern9`].
    Vern9,
    /// [`Method::GaussLegendre`].
    GaussLegendre,
    /// [`Method::Taylor`].
    Taylor,
    /// [`Method::Dla`].
    Dla,
}

impl MethodName {
    /// Every integrator.
    pub const ALL: [MethodName; 7] = [
        MethodName::Rk4,
        MethodName::Dopri5,
        MethodName::Dop853,
        MethodName::Vern9,
        MethodName::GaussLegendre,
        MethodName::Taylor,
        MethodName::Dla,
    ];

    /// The name as written.
    pub fn as_str(self) -> &'static str {
        match self {
            MethodName::Rk4 => "rk4",
            MethodName::Dopri5 => "dopri5",
            MethodName::Dop853 => "dop853",
            MethodName::Vern9 => "vern9",
            MethodName::GaussLegendre => "gauss-legendre",
            MethodName::Taylor => "taylor",
            MethodName::Dla => "dla",
        }
    }
}

impl std::fmt::Display for MethodName {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.as_str())
    }
}

impl Method {
    /// The integrator's name.
    pub fn name(&self) -> MethodName {
        match self {
            Method::Rk4 { .. } => MethodName::Rk4,
            Method::Dopri5 => MethodName::Dopri5,
            Method::Dop853 => MethodName::Dop853,
            Method::Vern9 => MethodName::Vern9,
            Method::GaussLegendre { .. } => MethodName::GaussLegendre,
            Method::Taylor => MethodName::Taylor,
            Method::Dla { .. } => MethodName::Dla,
        }
    }

    /// Whether the step is chosen by error control (the tolerances apply), rather than fixed.
    pub fn is_adaptive(&self) -> bool {
        match self {
            Method::Rk4 { .. } | Method::Dla { .. } => false,
            Method::Dopri5 | Method::Dop853 | Method::Vern9 | Method::Taylor => true,
            Method::GaussLegendre { step, .. } => step.is_none(),
        }
    }
}

/// Tolerances and step-size limits.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Options {
    /// Relative tolerance; adaptive methods require `rtol > 10·f64::EPSILON`.
    pub rtol: f64,
    /// Absolute tolerance (positive). Fixed-step Gauss–Legendre uses the pair only to scale
    /// its Newton increments.
    pub atol: f64,
    /// Initial step of the adaptive methods (default: Hairer's heuristic).
    pub h0: Option<f64>,
    /// Largest step of the adaptive methods (default: the whole interval).
    pub h_max: Option<f64>,
    /// Most step attempts (accepted plus rejected).
    pub max_steps: usize,
    /// Lund stabilisation parameter β of the DOPRI5/DOP853 controllers, in [0, 0.2] (default:
    /// Hairer's 0.04 for DOPRI5, 0 for DOP853).
    pub beta: Option<f64>,
}

impl Default for Options {
    /// `rtol = 1e-6`, `atol = 1e-9`, at most 100 000 steps (dopri5.f's `NMAX`).
    fn default() -> Self {
        Options {
            rtol: 1e-6,
            atol: 1e-9,
            h0: None,
            h_max: None,
            max_steps: 100_000,
            beta: None,
        }
    }
}

/// Integrates `system` from `(t0, y0)` with `method` and returns the states at `output_times`.
///
/// Output times must be finite and ordered away from `t0` (non-decreasing to integrate forward,
/// non-increasing backward); an output time equal to `t0` yields `y0`. Adaptive methods reach
/// the outputs by dense output and end their last step on the final one; fixed-step methods
/// step onto each output time.
///
/// # Errors
/// Invalid input, tolerances below f64 resolution, or a failure during the integration (a
/// [`SystemError`] no step reduction avoids, step-size underflow, a non-finite state, Newton
/// non-convergence with a fixed step, more than `max_steps` attempts) return an
/// [`IntegrationError`] whose `partial` solution holds the outputs reached.
pub fn integrate<S: OdeSystem + ?Sized>(
    system: &S,
    method: Method,
    t0: f64,
    y0: &[f64],
    output_times: &[f64],
    options: &Options,
) -> Result<Solution, IntegrationError> {
    integrate_with_events(system, method, t0, y0, output_times, options, &[])
}

/// [`integrate`], watching `events` ([`crate::events`]): each crossing found is in the
/// solution's `events`, located on the step's continuous extension; a terminal one ends the
/// integration at its time (the outputs before it recorded, `complete` false). Events need a
/// method with a continuous extension: DOPRI5, DOP853, Vern9 or the Taylor method.
///
/// # Errors
/// As [`integrate`]; events with another method are invalid input.
pub fn integrate_with_events<S: OdeSystem + ?Sized>(
    system: &S,
    method: Method,
    t0: f64,
    y0: &[f64],
    output_times: &[f64],
    options: &Options,
    events: &[Event<'_>],
) -> Result<Solution, IntegrationError> {
    let start = Start {
        method,
        t0,
        output_times,
        options,
        events,
    };
    if system.does_work() {
        let mut y = y0.to_vec();
        y.push(0.0);
        let wrapped = crate::work::with_work(system);
        let result = integrate_state(&wrapped, &start, &y, y0.len());
        return crate::work::split_result(result, y0.len());
    }
    integrate_state(system, &start, y0, y0.len())
}

/// What an integration is asked for, apart from the system and its initial state.
struct Start<'s, 'e, 'a> {
    method: Method,
    t0: f64,
    output_times: &'s [f64],
    options: &'s Options,
    events: &'e [Event<'a>],
}

/// [`integrate`] of the state as it is (the work of the forces, if any, already in it: the
/// events see the first `dim` components).
fn integrate_state<S: OdeSystem + ?Sized>(
    system: &S,
    start: &Start<'_, '_, '_>,
    y0: &[f64],
    dim: usize,
) -> Result<Solution, IntegrationError> {
    let Start {
        method,
        t0,
        output_times,
        options,
        events,
    } = *start;
    let checked = validate(system, method, t0, y0, output_times, options)
        .and_then(|()| validate_events(method, events));
    if let Err((kind, message)) = checked {
        let failure = Failure {
            kind,
            time: t0,
            state: y0.to_vec(),
            message,
        };
        return Err(failure.into_error(Solution::default()));
    }
    let mut recorder = Recorder::new(system, t0, y0, output_times.len());
    let mut ev = Evaluator::new(system);
    let n = y0.len();
    let tol = Tolerances {
        rtol: options.rtol,
        atol: options.atol,
    };
    let start = output_times.iter().take_while(|&&t| t == t0).count();
    for &t in &output_times[..start] {
        recorder.push(t, y0);
    }
    let outputs = &output_times[start..];
    let outcome = if outputs.is_empty() {
        Ok(())
    } else {
        let gauss = |stages| Gauss::new(stages, n, tol).expect("stage count validated");
        let mut run = Run {
            ev: &mut ev,
            recorder: &mut recorder,
            t: t0,
            y: y0.to_vec(),
            outputs,
            options,
            watch: Watch::new(events, t0, y0, dim),
        };
        match method {
            Method::Rk4 { step } => run.fixed(&mut Rk4::new(n), step),
            Method::GaussLegendre {
                stages,
                step: Some(step),
            } => run.fixed(&mut gauss(stages), step),
            Method::GaussLegendre { stages, step: None } => run.adaptive(&mut gauss(stages), &tol),
            Method::Dopri5 => run.adaptive(&mut Dopri5::new(n), &tol),
            Method::Dop853 => run.adaptive(&mut Dop853::new(n), &tol),
            Method::Vern9 => run.adaptive(&mut Vern9::new(n), &tol),
            Method::Taylor => run.taylor(&tol),
            // refused by `validate` before anything runs
            Method::Dla { .. } => Err(run.fail(ErrorKind::InvalidInput, "dla".into())),
        }
    };
    let solution = recorder.finish(ev.stats, outcome.is_ok());
    match outcome {
        Ok(()) => Ok(solution),
        Err(failure) => Err(failure.into_error(solution)),
    }
}

/// The reason, time and state of a failed integration.
struct Failure {
    kind: ErrorKind,
    time: f64,
    state: Vec<f64>,
    message: String,
}

impl Failure {
    fn into_error(self, partial: Solution) -> IntegrationError {
        IntegrationError {
            kind: self.kind,
            time: self.time,
            state: self.state,
            message: self.message,
            partial: Box::new(partial),
        }
    }
}

/// One integration in progress: the current point and the outputs still to reach.
struct Run<'r, 'a, S: ?Sized> {
    ev: &'r mut Evaluator<'a, S>,
    recorder: &'r mut Recorder<'a, S>,
    t: f64,
    y: Vec<f64>,
    outputs: &'r [f64],
    options: &'r Options,
    watch: Watch<'r, 'r>,
}

impl<S: OdeSystem + ?Sized> Run<'_, '_, S> {
    fn fail(&self, kind: ErrorKind, message: String) -> Failure {
        Failure {
            kind,
            time: self.t,
            state: self.y.clone(),
            message,
        }
    }

    /// The failure a step failure ends a fixed-step integration with.
    fn step_failure(&self, failure: StepFailure, h: f64) -> Failure {
        match failure {
            StepFailure::System { t, error } => self.fail(
                ErrorKind::System,
                format!("the system failed at t = {t}: {error}"),
            ),
            StepFailure::Newton => self.fail(
                ErrorKind::NewtonFailure,
                format!("the stage equations did not converge with step {h}; use a smaller step"),
            ),
            StepFailure::NonFinite => self.fail(
                ErrorKind::NonFiniteState,
                format!("a step of {h} produced NaN or infinite values"),
            ),
        }
    }

    fn too_many_steps(&self) -> Failure {
        let max = self.options.max_steps;
        self.fail(
            ErrorKind::MaxStepsExceeded,
            format!("more than max_steps = {max} steps needed"),
        )
    }

    /// Fixed steps of size `step`; the step before each output time is shortened to end on it.
    fn fixed(&mut self, stepper: &mut impl FixedStep, step: f64) -> Result<(), Failure> {
        let mut y_new = vec![0.0; self.y.len()];
        for &t_out in self.outputs {
            let t_start = self.t;
            let direction = (t_out - t_start).signum();
            // Step count with the roundoff of the times and of their ratio forgiven, so an
            // output on the step grid is reached by full steps, not full steps plus a sliver.
            let slack = 16.0 * f64::EPSILON * t_start.abs().max(t_out.abs());
            let span = (t_out - t_start).abs();
            let steps = if span == 0.0 {
                0
            } else {
                (((span - slack) / step * (1.0 - 1e-12)).ceil() as usize).max(1)
            };
            for k in 1..=steps {
                if self.ev.stats.steps >= self.options.max_steps {
                    return Err(self.too_many_steps());
                }
                let t_next = if k == steps {
                    t_out
                } else {
                    t_start + direction * step * k as f64
                };
                let h = t_next - self.t;
                stepper
                    .step(self.ev, self.t, &self.y, h, &mut y_new)
                    .map_err(|failure| self.step_failure(failure, h))?;
                if !y_new.iter().all(|v| v.is_finite()) {
                    return Err(self.step_failure(StepFailure::NonFinite, h));
                }
                self.ev.stats.steps += 1;
                self.ev
                    .project(t_next, &mut y_new, true)
                    .map_err(|failure| self.step_failure(failure, h))?;
                self.t = t_next;
                std::mem::swap(&mut self.y, &mut y_new);
            }
            self.recorder.push(t_out, &self.y);
        }
        Ok(())
    }

    /// Taylor steps ([`crate::taylor`]): the series at each step, its step from the
    /// coefficients, the outputs inside the step read off the series.
    fn taylor(&mut self, tol: &Tolerances) -> Result<(), Failure> {
        let t_end = *self.outputs.last().expect("outputs not empty");
        let direction = (t_end - self.t).signum();
        let h_max = self.options.h_max.unwrap_or((t_end - self.t).abs());
        let order = crate::taylor::order(tol.rtol);
        let (n, mut series) = (self.y.len(), Vec::new());
        let (mut y_out, mut y_at) = (vec![0.0; n], vec![0.0; n]);
        let mut next = 0;
        while next < self.outputs.len() {
            if self.ev.stats.steps >= self.options.max_steps {
                return Err(self.too_many_steps());
            }
            self.ev
                .series(self.t, &self.y, order, &mut series)
                .map_err(|failure| self.step_failure(failure, 0.0))?;
            if !series.iter().all(|v| v.is_finite()) {
                return Err(self.step_failure(StepFailure::NonFinite, 0.0));
            }
            let h =
                crate::taylor::step(&series, n, order, (tol.rtol, tol.atol), &self.y).min(h_max);
            if 0.1 * h <= f64::EPSILON * self.t.abs().max((t_end - self.t).abs()) {
                return Err(self.underflow(h, None));
            }
            let t_next = if (self.t + direction * h - t_end) * direction >= 0.0 {
                t_end
            } else {
                self.t + direction * h
            };
            let h = t_next - self.t;
            crate::taylor::sum(&series, n, h, &mut y_out);
            self.ev.stats.steps += 1;
            self.ev
                .project(t_next, &mut y_out, true)
                .map_err(|failure| self.step_failure(failure, h))?;
            let terminal = self.events(h, t_next, &y_out, &mut |theta, out| {
                crate::taylor::sum(&series, n, theta * h, out)
            })?;
            let t_stop = terminal.unwrap_or(t_next);
            let mut extension =
                |theta: f64, out: &mut [f64]| crate::taylor::sum(&series, n, theta * h, out);
            let step = (h, t_next, t_stop);
            next = self.outputs_in(step, &y_out, next, &mut extension, &mut y_at)?;
            if terminal.is_some() {
                return Ok(());
            }
            self.t = t_next;
            self.y.copy_from_slice(&y_out);
        }
        Ok(())
    }

    /// Adaptive steps (dopri5.f/dop853.f step loop). A failed attempt (system error,
    /// non-finite values, Newton failure) is a rejection with the largest step reduction;
    /// when the step underflows, the last such failure is reported.
    fn adaptive(
        &mut self,
        stepper: &mut impl AdaptiveStep,
        tol: &Tolerances,
    ) -> Result<(), Failure> {
        let t0 = self.t;
        let t_end = *self.outputs.last().expect("outputs not empty");
        let direction = (t_end - t0).signum();
        let h_max = self.options.h_max.unwrap_or((t_end - t0).abs());
        let mut controller = stepper.controller(self.options.beta, h_max);
        let n = self.y.len();
        let (mut y_new, mut dense_out) = (vec![0.0; n], vec![0.0; n]);

        let mut f0 = vec![0.0; n];
        self.ev
            .rhs(t0, &self.y, &mut f0)
            .map_err(|failure| self.step_failure(failure, 0.0))?;
        if !f0.iter().all(|v| v.is_finite()) {
            return Err(self.fail(
                ErrorKind::NonFiniteState,
                format!("f(t0, y0) is not finite: {f0:?}"),
            ));
        }
        stepper.start(&f0);
        let mut h = match self.options.h0 {
            Some(h0) => h0.abs().min(h_max).copysign(direction),
            None => initial_step(
                self.ev,
                tol,
                t0,
                &self.y,
                &f0,
                direction,
                stepper.order(),
                h_max,
            ),
        };
        let has_dense = stepper.interpolant().is_some();
        // Hairer's underflow test `0.1|h| ≤ u|t|`, with |t| no smaller than the interval.
        let time_scale = (t_end - t0).abs();
        let mut next = 0;
        let mut after_reject = false;
        let mut last_failure: Option<StepFailure> = None;

        while next < self.outputs.len() {
            if self.ev.stats.steps + self.ev.stats.rejected >= self.options.max_steps {
                return Err(self.too_many_steps());
            }
            if 0.1 * h.abs() <= f64::EPSILON * self.t.abs().max(time_scale) {
                return Err(self.underflow(h, last_failure));
            }
            let stop = if has_dense { t_end } else { self.outputs[next] };
            let hits_stop = (self.t + 1.01 * h - stop) * direction > 0.0;
            let h_try = if hits_stop { stop - self.t } else { h };

            let attempt = stepper
                .attempt(self.ev, tol, self.t, &self.y, h_try, &mut y_new)
                .and_then(|err| {
                    let finite = err.is_finite() && y_new.iter().all(|v| v.is_finite());
                    if finite {
                        Ok(err)
                    } else {
                        Err(StepFailure::NonFinite)
                    }
                });
            let err = match attempt {
                Ok(err) => err,
                Err(failure) => {
                    self.ev.stats.rejected += 1;
                    (h, after_reject, last_failure) =
                        (h_try * controller.shrink(), true, Some(failure));
                    continue;
                }
            };
            let h_new = match controller.verdict(h_try, err, after_reject) {
                Verdict::Accept(h_new) => h_new,
                Verdict::Reject(h_new) => {
                    self.ev.stats.rejected += 1;
                    (h, after_reject, last_failure) = (h_new, true, None);
                    continue;
                }
            };
            let t_new = if hits_stop { stop } else { self.t + h_try };
            let dense = has_dense
                && (!self.watch.is_empty()
                    || self
                        .outputs
                        .get(next)
                        .is_some_and(|&t_out| (t_out - t_new) * direction < 0.0));
            if let Err(failure) = stepper.accept(self.ev, self.t, &self.y, h_try, &y_new, dense) {
                self.ev.stats.rejected += 1;
                (h, after_reject, last_failure) =
                    (h_try * controller.shrink(), true, Some(failure));
                continue;
            }
            controller.accepted(err);
            self.ev.stats.steps += 1;
            let projected = self
                .ev
                .project(t_new, &mut y_new, true)
                .map_err(|failure| self.step_failure(failure, h_try))?;
            let terminal = match stepper.interpolant() {
                Some(interpolant) => self.events(h_try, t_new, &y_new, &mut |theta, out| {
                    interpolant.interpolate(theta, out)
                })?,
                None => None,
            };
            let t_stop = terminal.unwrap_or(t_new);
            let mut extension = |theta: f64, out: &mut [f64]| {
                let interpolant = stepper.interpolant().expect("dense output prepared");
                interpolant.interpolate(theta, out)
            };
            let step = (h_try, t_new, t_stop);
            next = self.outputs_in(step, &y_new, next, &mut extension, &mut dense_out)?;
            if terminal.is_some() {
                return Ok(());
            }
            // After the outputs: the continuous extension may read the step's last stage.
            if projected {
                self.ev
                    .rhs(t_new, &y_new, &mut f0)
                    .map_err(|failure| self.step_failure(failure, h_try))?;
                stepper.start(&f0);
            }
            self.t = t_new;
            std::mem::swap(&mut self.y, &mut y_new);
            // A step cut short to land on an output says nothing against the step proposed before.
            h = if hits_stop {
                h_new.abs().max(h.abs()).min(h_max).copysign(direction)
            } else {
                h_new
            };
            (after_reject, last_failure) = (false, None);
        }
        Ok(())
    }

    /// The outputs from `next` on up to `t_stop` in the accepted step from `self.t` by `h` to
    /// `(t_new, y_new)`: the step's end itself, or read off its continuous extension
    /// `state(θ, out)` (checked finite, projected) through `buffer`. The next output's index.
    fn outputs_in(
        &mut self,
        (h, t_new, t_stop): (f64, f64, f64),
        y_new: &[f64],
        mut next: usize,
        state: &mut dyn FnMut(f64, &mut [f64]),
        buffer: &mut [f64],
    ) -> Result<usize, Failure> {
        let direction = h.signum();
        while let Some(&t_out) = self.outputs.get(next) {
            if (t_out - t_stop) * direction > 0.0 {
                break;
            }
            if t_out == t_new {
                self.recorder.push(t_out, y_new);
            } else {
                state((t_out - self.t) / h, buffer);
                if !buffer.iter().all(|v| v.is_finite()) {
                    return Err(self.fail(
                        ErrorKind::NonFiniteState,
                        format!("dense output at t = {t_out} is not finite"),
                    ));
                }
                self.ev
                    .project(t_out, buffer, false)
                    .map_err(|failure| self.step_failure(failure, h))?;
                self.recorder.push(t_out, buffer);
            }
            next += 1;
        }
        Ok(next)
    }

    /// The events over the accepted step from `self.t` by `h` to `(t_new, y_new)` (projected),
    /// located on `state(θ, out)`, the step's continuous extension: each recorded, its state
    /// projected as an output's is; the time of a terminal one, if any (the run ends there).
    fn events(
        &mut self,
        h: f64,
        t_new: f64,
        y_new: &[f64],
        state: &mut dyn FnMut(f64, &mut [f64]),
    ) -> Result<Option<f64>, Failure> {
        if self.watch.is_empty() {
            return Ok(None);
        }
        let mut y = std::mem::take(&mut self.watch.lent);
        let count = self.watch.step(self.t, h, y_new, state);
        for k in 0..count {
            let found = self.watch.found[k];
            let t = if found.theta == 1.0 {
                y.copy_from_slice(y_new);
                t_new
            } else {
                state(found.theta, &mut y);
                let t = self.t + found.theta * h;
                self.ev
                    .project(t, &mut y, false)
                    .map_err(|failure| self.step_failure(failure, h))?;
                t
            };
            let terminal = self.watch.terminal(found.event);
            self.recorder.solution.events.push(EventHit {
                event: found.event,
                t,
                y: y[..self.watch.dim()].to_vec(),
                terminal,
            });
            if terminal {
                self.recorder.terminated = true;
                return Ok(Some(t));
            }
        }
        self.watch.lent = y;
        Ok(None)
    }

    /// The failure reported when the step size underflows, naming the last failed attempt.
    fn underflow(&self, h: f64, cause: Option<StepFailure>) -> Failure {
        let t = self.t;
        match cause {
            Some(StepFailure::System { t: t_eval, error }) => self.fail(
                ErrorKind::System,
                format!("the system failed at t = {t_eval}: {error} (no step from t = {t} avoids it; step {h:e})"),
            ),
            Some(StepFailure::NonFinite) => self.fail(
                ErrorKind::NonFiniteState,
                format!("every step from t = {t} produces NaN or infinite values, down to step {h:e}"),
            ),
            Some(StepFailure::Newton) => self.fail(
                ErrorKind::NewtonFailure,
                format!("the stage equations do not converge from t = {t}, down to step {h:e}"),
            ),
            None => self.fail(
                ErrorKind::StepSizeUnderflow,
                format!("step size {h:e} is negligible at t = {t} (the solution may blow up here)"),
            ),
        }
    }
}

/// The most outputs whose room is taken before the run (more grow as they come: a run that
/// fails early does not hold memory for outputs it never reached).
const RESERVED_OUTPUTS: usize = 1 << 16;

/// Collects the outputs; their monitored invariants are evaluated all at once when the run
/// ends ([`OdeSystem::energies`], [`OdeSystem::constraint_residuals`]).
struct Recorder<'a, S: ?Sized> {
    system: &'a S,
    energy0: Option<f64>,
    solution: Solution,
    /// Whether a terminal event ended the run.
    terminated: bool,
}

impl<'a, S: OdeSystem + ?Sized> Recorder<'a, S> {
    /// Room for `outputs` outputs (at most [`RESERVED_OUTPUTS`]) is taken at once: recording
    /// them allocates nothing.
    fn new(system: &'a S, t0: f64, y0: &[f64], outputs: usize) -> Self {
        let outputs = outputs.min(RESERVED_OUTPUTS);
        // Evaluated as the outputs will be, so that an output at t0 has drift 0 exactly.
        let mut energy0 = [None];
        system.energies(&[t0], y0, &mut energy0);
        Recorder {
            system,
            energy0: finite(energy0[0]),
            solution: Solution {
                t: Vec::with_capacity(outputs),
                y: States::with_capacity(y0.len(), outputs),
                ..Solution::default()
            },
            terminated: false,
        }
    }

    #[inline]
    fn push(&mut self, t: f64, y: &[f64]) {
        self.solution.t.push(t);
        self.solution.y.push(y);
    }

    /// The solution with its monitors evaluated at every output, and `stats` completed by the
    /// invariant drift.
    fn finish(self, mut stats: Stats, complete: bool) -> Solution {
        let mut solution = self.solution;
        let (t, rows) = (&solution.t, solution.y.as_flat());
        solution.energy.resize(t.len(), None);
        self.system.energies(t, rows, &mut solution.energy);
        solution.constraint.resize(t.len(), None);
        self.system
            .constraint_residuals(t, rows, &mut solution.constraint);
        // max |E − E0| / scale: the largest difference divided once (division is monotone).
        let e0 = self.energy0;
        let energy = keep_finite(&mut solution.energy, |e| (e - e0.unwrap_or(e)).abs());
        let scale = e0.map(|e0| e0.abs().max(f64::MIN_POSITIVE));
        stats.energy_drift = energy.zip(scale).map(|(d, scale)| d / scale);
        stats.constraint_drift = keep_finite(&mut solution.constraint, f64::abs);
        Solution {
            stats,
            complete: complete && !self.terminated,
            ..solution
        }
    }
}

/// Keeps the finite values (None for the others) and returns the largest `of(v)` over them,
/// `of(v)` ≥ 0 (four running maxima, so that the comparisons do not wait on each other).
#[inline]
fn keep_finite(values: &mut [Option<f64>], of: impl Fn(f64) -> f64) -> Option<f64> {
    let mut largest = [-1.0_f64; 4];
    for group in values.chunks_mut(4) {
        for (m, v) in largest.iter_mut().zip(group) {
            *v = finite(*v);
            let d = v.map_or(-1.0, &of);
            *m = if d > *m { d } else { *m };
        }
    }
    let m = largest.into_iter().fold(-1.0, f64::max);
    (m >= 0.0).then_some(m)
}

#[inline]
fn finite(value: Option<f64>) -> Option<f64> {
    value.filter(|v| v.is_finite())
}

/// Checks the input before anything is evaluated.
fn validate<S: OdeSystem + ?Sized>(
    system: &S,
    method: Method,
    t0: f64,
    y0: &[f64],
    output_times: &[f64],
    options: &Options,
) -> Result<(), (ErrorKind, String)> {
    let invalid = |message: String| Err((ErrorKind::InvalidInput, message));
    if system.dim() == 0 {
        return invalid("the system has no state (dim() = 0)".to_string());
    }
    if y0.len() != system.dim() {
        return invalid(format!(
            "y0 has {} components, the system {}",
            y0.len(),
            system.dim()
        ));
    }
    if !t0.is_finite() {
        return invalid(format!("t0 = {t0} is not finite"));
    }
    if let Some(i) = y0.iter().position(|v| !v.is_finite()) {
        return invalid(format!("y0[{i}] = {} is not finite", y0[i]));
    }
    let direction = output_times
        .iter()
        .find(|&&t| t != t0)
        .map(|&t| (t - t0).signum());
    let mut previous = t0;
    for (i, &t) in output_times.iter().enumerate() {
        if !t.is_finite() {
            return invalid(format!("output_times[{i}] = {t} is not finite"));
        }
        if direction.is_some_and(|d| (t - previous) * d < 0.0) {
            return invalid(format!(
                "output_times[{i}] = {t} is out of order: output times must move away from t0 = {t0} monotonically"
            ));
        }
        previous = t;
    }
    match method {
        Method::Dla { .. } => {
            return invalid(
                "the discrete Lagrange–d'Alembert method integrates a nonholonomic system (hamel_sim::dla::integrate), not an OdeSystem".into(),
            );
        }
        Method::Rk4 { step }
        | Method::GaussLegendre {
            step: Some(step), ..
        } if !(step.is_finite() && step > 0.0) => {
            return invalid(format!(
                "the fixed step must be positive and finite, not {step}"
            ));
        }
        Method::GaussLegendre { stages, .. } if !(2..=3).contains(&stages) => {
            return invalid(format!(
                "Gauss–Legendre with {stages} stages: only 2 and 3 are available"
            ));
        }
        _ => {}
    }
    let (rtol, atol) = (options.rtol, options.atol);
    if !(rtol.is_finite() && rtol > 0.0 && atol.is_finite() && atol > 0.0) {
        return invalid(format!(
            "rtol = {rtol} and atol = {atol} must be positive and finite"
        ));
    }
    if let Some(h0) = options.h0.filter(|h0| !(h0.is_finite() && *h0 != 0.0)) {
        return invalid(format!("h0 = {h0} must be finite and non-zero"));
    }
    if let Some(h_max) = options.h_max.filter(|h| !(h.is_finite() && *h > 0.0)) {
        return invalid(format!("h_max = {h_max} must be positive and finite"));
    }
    if let Some(beta) = options.beta.filter(|b| !(0.0..=0.2).contains(b)) {
        return invalid(format!("beta = {beta} must lie in [0, 0.2]"));
    }
    // The Taylor method sums its series without error control: it can be asked for ε itself.
    let floor = match method {
        Method::Taylor => f64::EPSILON,
        _ => 10.0 * f64::EPSILON,
    };
    if method.is_adaptive() && rtol < floor * (1.0 + f64::EPSILON) {
        return Err((
            ErrorKind::ToleranceTooSmall,
            format!(
                "rtol = {rtol:e} is below what f64 arithmetic can deliver: it must exceed {} ≈ {floor:.1e}",
                if floor > f64::EPSILON { "10·ε" } else { "ε" }
            ),
        ));
    }
    Ok(())
}

/// Events need a continuous extension to be located on.
fn validate_events(method: Method, events: &[Event<'_>]) -> Result<(), (ErrorKind, String)> {
    match method {
        Method::Dopri5 | Method::Dop853 | Method::Vern9 | Method::Taylor => Ok(()),
        _ if events.is_empty() => Ok(()),
        _ => Err((
            ErrorKind::InvalidInput,
            format!(
                "events are located on a continuous extension, which {} has none of: use dopri5, dop853, vern9 or taylor",
                method.name()
            ),
        )),
    }
}
