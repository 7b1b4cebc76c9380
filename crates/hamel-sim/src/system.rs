//! The system interface, and the counting evaluator every integrator calls it through.

use crate::solution::Stats;

/// A failure of the system itself: a singularity, or a state outside the model's domain.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("{message}")]
pub struct SystemError {
    /// What went wrong and where (time, coordinate, value), in words.
    pub message: String,
}

impl SystemError {
    /// An error with the given message.
    pub fn new(message: impl Into<String>) -> Self {
        SystemError {
            message: message.into(),
        }
    }
}

/// An ordinary differential equation `dy/dt = f(t, y)` of fixed dimension.
pub trait OdeSystem {
    /// Length of the state vector `y`.
    fn dim(&self) -> usize;

    /// dy/dt = f(t, y); return Err on a singularity (message says what and where).
    fn rhs(&self, t: f64, y: &[f64], dy: &mut [f64]) -> Result<(), SystemError>;

    /// Optional analytic Jacobian df/dy (row-major dim×dim); default: None (finite differences used).
    fn jacobian(&self, _t: f64, _y: &[f64], _jac: &mut [f64]) -> Option<Result<(), SystemError>> {
        None
    }

    /// The Taylor coefficients of the solution through (t, y) up to `order`, for the Taylor
    /// method: `out` gets `order + 1` rows of `y.len()` values, row k holding y⁽ᵏ⁾(t)/k!. A
    /// system that [`does_work`](Self::does_work) is asked with the work W appended to its
    /// state (`dim + 1` values) and gives W's series too, W' = [`power`](Self::power). Default
    /// None: the system has no series, and [`crate::Method::Taylor`] refuses it.
    fn taylor_coefficients(
        &self,
        _t: f64,
        _y: &[f64],
        _order: usize,
        _out: &mut Vec<f64>,
    ) -> Option<Result<(), SystemError>> {
        None
    }

    /// Optional invariant to monitor: the energy at a state (default None).
    fn energy(&self, _t: f64, _y: &[f64]) -> Option<f64> {
        None
    }

    /// Whether the system's forces do work that the energy balance should account for
    /// (default false): then [`crate::integrate`] integrates W = ∫ [`power`](Self::power) dt
    /// beside the state, monitors E − W instead of E, and reports W
    /// ([`Solution::work`](crate::Solution::work)).
    fn does_work(&self) -> bool {
        false
    }

    /// The power of the forces at a state, dE/dt along the motion (default 0); read only when
    /// [`does_work`](Self::does_work).
    fn power(&self, _t: f64, _y: &[f64]) -> Result<f64, SystemError> {
        Ok(0.0)
    }

    /// [`rhs`](Self::rhs) and [`power`](Self::power) at once (a system that computes both in
    /// one evaluation overrides it).
    fn rhs_and_power(&self, t: f64, y: &[f64], dy: &mut [f64]) -> Result<f64, SystemError> {
        self.rhs(t, y, dy)?;
        self.power(t, y)
    }

    /// Optional invariant to monitor: the constraint residual at a state (default None).
    fn constraint_residual(&self, _t: f64, _y: &[f64]) -> Option<f64> {
        None
    }

    /// [`energy`](Self::energy) at many states at once, as the integrators ask for it after
    /// a run: `rows` holds the states one after another ([`dim`](Self::dim) values each),
    /// `t` their times, `out` one entry a state. The default evaluates them one by one; a
    /// system that evaluates several states together faster (the generated cores: four at a
    /// time in vector registers) overrides it.
    fn energies(&self, t: &[f64], rows: &[f64], out: &mut [Option<f64>]) {
        let states = rows.chunks_exact(self.dim());
        for ((o, &t), y) in out.iter_mut().zip(t).zip(states) {
            *o = self.energy(t, y);
        }
    }

    /// [`constraint_residual`](Self::constraint_residual) at many states at once, as
    /// [`energies`](Self::energies).
    fn constraint_residuals(&self, t: &[f64], rows: &[f64], out: &mut [Option<f64>]) {
        let states = rows.chunks_exact(self.dim());
        for ((o, &t), y) in out.iter_mut().zip(t).zip(states) {
            *o = self.constraint_residual(t, y);
        }
    }

    /// Optional projection onto a manifold the exact solution never leaves (holonomic
    /// constraints h(q) = 0), called after every accepted step: move `y` onto it and return
    /// the residual found before moving (for instance max |h_i|), or 0 when `y` was left
    /// unchanged. Default None: no projection.
    fn project(&self, _t: f64, _y: &mut [f64]) -> Option<Result<f64, SystemError>> {
        None
    }
}

/// The system as the integrators see it: every call counted in [`Stats`], failures tagged with
/// the time of the evaluation, Jacobians by finite differences when the system has none.
pub(crate) struct Evaluator<'a, S: ?Sized> {
    system: &'a S,
    pub(crate) stats: Stats,
    perturbed: Vec<f64>,
    column: Vec<f64>,
}

impl<'a, S: OdeSystem + ?Sized> Evaluator<'a, S> {
    pub(crate) fn new(system: &'a S) -> Self {
        let n = system.dim();
        Evaluator {
            system,
            stats: Stats::default(),
            perturbed: vec![0.0; n],
            column: vec![0.0; n],
        }
    }

    /// `dy = f(t, y)`.
    pub(crate) fn rhs(&mut self, t: f64, y: &[f64], dy: &mut [f64]) -> Result<(), StepFailure> {
        self.stats.rhs_evals += 1;
        self.system
            .rhs(t, y, dy)
            .map_err(|error| StepFailure::System { t, error })
    }

    /// The Taylor coefficients through (t, y) ([`OdeSystem::taylor_coefficients`]), counted
    /// in `series_evals`.
    pub(crate) fn series(
        &mut self,
        t: f64,
        y: &[f64],
        order: usize,
        out: &mut Vec<f64>,
    ) -> Result<(), StepFailure> {
        self.stats.series_evals += 1;
        let error = |message: &str| StepFailure::System {
            t,
            error: SystemError::new(message),
        };
        match self.system.taylor_coefficients(t, y, order, out) {
            None => Err(error("the system gives no Taylor series")),
            Some(result) => result.map_err(|error| StepFailure::System { t, error }),
        }
    }

    /// Project `y` (the state just accepted at `t`, or with `step` false an output read from
    /// the continuous extension) if the system asks for it; true when `y` moved, so that a
    /// derivative kept from before (FSAL) is stale. Only steps count in `projections`.
    pub(crate) fn project(
        &mut self,
        t: f64,
        y: &mut [f64],
        step: bool,
    ) -> Result<bool, StepFailure> {
        let Some(result) = self.system.project(t, y) else {
            return Ok(false);
        };
        let residual = result.map_err(|error| StepFailure::System { t, error })?;
        let drift = self.stats.projection_drift.get_or_insert(0.0);
        *drift = drift.max(residual);
        if residual > 0.0 && step {
            self.stats.projections += 1;
        }
        Ok(residual > 0.0)
    }

    /// `jac = df/dy (t, y)`, row-major; `f0` must be `f(t, y)`.
    ///
    /// Without an analytic Jacobian, forward differences with the increment of Hairer's
    /// radau5.f, `sqrt(u · max(1e-5, |y_j|))`, one right-hand side evaluation per column.
    pub(crate) fn jacobian(
        &mut self,
        t: f64,
        y: &[f64],
        f0: &[f64],
        jac: &mut [f64],
    ) -> Result<(), StepFailure> {
        self.stats.jacobian_evals += 1;
        if let Some(result) = self.system.jacobian(t, y, jac) {
            return result.map_err(|error| StepFailure::System { t, error });
        }
        let n = y.len();
        let mut perturbed = std::mem::take(&mut self.perturbed);
        let mut column = std::mem::take(&mut self.column);
        perturbed.copy_from_slice(y);
        let mut outcome = Ok(());
        for j in 0..n {
            let yj = y[j];
            perturbed[j] = yj + (f64::EPSILON * yj.abs().max(1e-5)).sqrt();
            let delta = perturbed[j] - yj;
            outcome = self.rhs(t, &perturbed, &mut column);
            if outcome.is_err() {
                break;
            }
            for i in 0..n {
                jac[i * n + j] = (column[i] - f0[i]) / delta;
            }
            perturbed[j] = yj;
        }
        self.perturbed = perturbed;
        self.column = column;
        outcome
    }
}

/// Why a step could not be completed.
#[derive(Debug)]
pub(crate) enum StepFailure {
    /// The system failed when evaluated at time `t`.
    System { t: f64, error: SystemError },
    /// The Newton iteration did not converge (or the iteration matrix was singular).
    Newton,
    /// The trial step or its error estimate is NaN or infinite.
    NonFinite,
}
