//! What an integration returns: states at the output times, statistics, errors.

use serde::{Deserialize, Serialize};

use crate::states::States;

/// States at the requested output times, with monitored invariants and statistics.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Solution {
    /// Output times reached, in the order requested.
    pub t: Vec<f64>,
    /// State at each output time (`y[j]`, a slice); every entry is finite.
    pub y: States,
    /// [`OdeSystem::energy`](crate::OdeSystem::energy) at each output (None where the system
    /// gives no finite value).
    pub energy: Vec<Option<f64>>,
    /// [`OdeSystem::constraint_residual`](crate::OdeSystem::constraint_residual) at each output
    /// (None where the system gives no finite value).
    pub constraint: Vec<Option<f64>>,
    /// For a system whose forces do work ([`OdeSystem::does_work`](crate::OdeSystem::does_work)):
    /// W(t) = ∫ power dt at each output, so that E(t) − W(t) is conserved; empty otherwise.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub work: Vec<f64>,
    /// The events found ([`crate::integrate_with_events`]), in time order; a terminal one is
    /// last.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub events: Vec<crate::EventHit>,
    /// Counters and invariant drift.
    pub stats: Stats,
    /// Whether every requested output time was reached.
    pub complete: bool,
}

impl Solution {
    /// Keep the first `n` outputs only (a monitor ended the run there): incomplete.
    pub fn truncate(&mut self, n: usize) {
        self.t.truncate(n);
        self.y.truncate(n);
        self.energy.truncate(n);
        self.work.truncate(n);
        self.constraint.truncate(n);
        self.complete = false;
    }
}

/// Work counters and invariant drift of one integration.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Stats {
    /// Accepted steps.
    pub steps: usize,
    /// Attempted steps not accepted (error test, Newton failure, system error or non-finite
    /// values in the trial step); `steps + rejected` is the number of attempts.
    pub rejected: usize,
    /// Calls of [`OdeSystem::rhs`](crate::OdeSystem::rhs), including those made for
    /// finite-difference Jacobians.
    pub rhs_evals: usize,
    /// Evaluations of the solution's Taylor series (the Taylor method: one per step, each
    /// costing about order²/2 times an evaluation of f).
    #[serde(default, skip_serializing_if = "is_zero")]
    pub series_evals: usize,
    /// Of those, the series a compiled scene core computed by tracing its right-hand side at
    /// the step's state (`runtime::taylor_by_trace`) instead of by its compiled recurrences:
    /// where it has neither a closed form nor a trace of the scene's start, or that trace's
    /// guards fail at the state. Set by the scene cores only (0 elsewhere).
    #[serde(default, skip_serializing_if = "is_zero")]
    pub series_traced: usize,
    /// Jacobian evaluations, analytic or by finite differences.
    pub jacobian_evals: usize,
    /// Simplified-Newton iterations (implicit methods).
    pub newton_iterations: usize,
    /// Newton solves that did not converge.
    pub newton_failures: usize,
    /// `max |E(t) − E(t0)| / max(|E(t0)|, f64::MIN_POSITIVE)` over the outputs, if the system
    /// has an energy; for a system whose forces do work, the same of the balance E − W (W(t0)
    /// = 0).
    pub energy_drift: Option<f64>,
    /// `max |residual|` over the outputs, if the system has a constraint residual.
    pub constraint_drift: Option<f64>,
    /// Steps after which the state was projected ([`OdeSystem::project`](crate::OdeSystem::project)).
    #[serde(default, skip_serializing_if = "is_zero")]
    pub projections: usize,
    /// The largest residual found before a projection (the drift one step makes), if the
    /// system projects.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub projection_drift: Option<f64>,
}

fn is_zero(n: &usize) -> bool {
    *n == 0
}

/// Why an integration stopped early.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, thiserror::Error)]
pub enum ErrorKind {
    /// Inconsistent input (dimensions, non-finite values, unordered output times, bad step).
    #[error("invalid input")]
    InvalidInput,
    /// Tolerances tighter than f64 arithmetic can deliver.
    #[error("tolerance too small")]
    ToleranceTooSmall,
    /// The system returned a [`SystemError`](crate::SystemError) that no step reduction avoided.
    #[error("system error")]
    System,
    /// The step size became negligible relative to the time.
    #[error("step size underflow")]
    StepSizeUnderflow,
    /// The state became NaN or infinite.
    #[error("non-finite state")]
    NonFiniteState,
    /// The Newton iteration of an implicit method did not converge.
    #[error("Newton iteration failed")]
    NewtonFailure,
    /// More than `max_steps` step attempts were needed.
    #[error("too many steps")]
    MaxStepsExceeded,
}

/// An integration that stopped early: why, where, and everything computed until then.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("{kind} at t = {time}: {message}")]
pub struct IntegrationError {
    /// The cause.
    pub kind: ErrorKind,
    /// Time of the last valid state (the initial time for input errors).
    pub time: f64,
    /// The last valid state, at `time`.
    pub state: Vec<f64>,
    /// What happened, in words.
    pub message: String,
    /// The outputs reached before the failure (`complete == false`), with statistics.
    pub partial: Box<Solution>,
}
