//! What the step loops of [`crate::driver`] ask of a method: a fixed step, an attempted and
//! accepted adaptive step with its error estimate, a continuous extension.

use crate::control::{Controller, Tolerances};
use crate::system::{Evaluator, OdeSystem, StepFailure};

/// A one-step method used with a given step.
pub(crate) trait FixedStep {
    /// Advances `(t, y)` by `h` into `y_new`.
    fn step<S: OdeSystem + ?Sized>(
        &mut self,
        ev: &mut Evaluator<'_, S>,
        t: f64,
        y: &[f64],
        h: f64,
        y_new: &mut [f64],
    ) -> Result<(), StepFailure>;
}

/// A method with an error estimate, for the adaptive step loop.
pub(crate) trait AdaptiveStep {
    /// Order of the propagated solution (for the initial step heuristic).
    fn order(&self) -> u32;
    /// Hairer's step-size controller with this method's parameters.
    fn controller(&self, beta: Option<f64>, h_max: f64) -> Controller;
    /// Hands over `f(t0, y0)`.
    fn start(&mut self, f0: &[f64]);
    /// Attempts a step of size `h` from `(t, y)`: the candidate goes to `y_new`, the result is
    /// the error estimate in the tolerance-scaled norm (at most 1 to pass).
    fn attempt<S: OdeSystem + ?Sized>(
        &mut self,
        ev: &mut Evaluator<'_, S>,
        tol: &Tolerances,
        t: f64,
        y: &[f64],
        h: f64,
        y_new: &mut [f64],
    ) -> Result<f64, StepFailure>;
    /// Accepts the step just attempted; with `dense`, also prepares the continuous extension
    /// over it. After a failure the step counts as rejected and the method's state is as
    /// before the attempt.
    fn accept<S: OdeSystem + ?Sized>(
        &mut self,
        ev: &mut Evaluator<'_, S>,
        t: f64,
        y: &[f64],
        h: f64,
        y_new: &[f64],
        dense: bool,
    ) -> Result<(), StepFailure>;
    /// The continuous extension of the last step accepted with `dense`, or None for a method
    /// without one (the driver then ends a step on every output time).
    fn interpolant(&self) -> Option<&dyn Interpolant>;
}

/// A continuous extension over one step.
pub(crate) trait Interpolant {
    /// The state at `t_old + theta·h`, `0 ≤ theta ≤ 1`.
    fn interpolate(&self, theta: f64, out: &mut [f64]);
}
