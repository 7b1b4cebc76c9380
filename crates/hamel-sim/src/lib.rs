//! Numeric integration of ordinary differential equations for hamel.
//!
//! **Job**: integrate `dy/dt = f(t, y)` and report the state at requested output times, with
//! work counters and drift of monitored invariants. Methods ([`Method`]): fixed-step classical
//! RK4; adaptive Dormand–Prince 5(4), DOP853 and Verner's 9(8) with dense output, Hairer's step-size
//! controllers and published tableaus; implicit Gauss–Legendre collocation (2 or 3 stages,
//! orders 4 and 6; symmetric and symplectic) with a fixed step or step-doubling control; the
//! Taylor method ([`taylor`]) for systems that give their series; the discrete
//! Lagrange–d'Alembert method ([`dla`]) for conservative nonholonomic systems over long
//! horizons. Events ([`events`], [`integrate_with_events`]): zero crossings of conditions of the
//! state, located on the continuous extensions, terminal or not.
//!
//! Many runs at once (Monte Carlo over initial states and parameters, sweeps):
//! [`integrate_many`] on a rayon pool, outcomes in member order.
//!
//! **Inputs**: an [`OdeSystem`] (right-hand side; optionally its Jacobian, energy and
//! constraint residual), a [`Method`], `t0`, `y0`, output times and [`Options`].
//! **Outputs**: a [`Solution`] (states, invariants and [`Stats`]), or an [`IntegrationError`]
//! naming the cause and carrying the partial solution reached before it.
//!
//! **Invariant**: outputs never contain NaN or infinities, and no input makes [`integrate`]
//! panic or run without bound: attempts are capped by `max_steps`, and every step reduction
//! ends in an underflow error. A run allocates a fixed number of buffers, none per step or
//! output ([`States`]), and `integrate` is generic over the system, so a compiled right-hand
//! side inlines into the steps (`cargo bench -p hamel-sim --bench integrate`).
//!
//! ```
//! use hamel_sim::{Method, OdeSystem, Options, SystemError, integrate};
//!
//! /// The harmonic oscillator `x'' = −x`, state `(x, v)`.
//! struct Oscillator;
//!
//! impl OdeSystem for Oscillator {
//!     fn dim(&self) -> usize {
//!         2
//!     }
//!     fn rhs(&self, _t: f64, y: &[f64], dy: &mut [f64]) -> Result<(), SystemError> {
//!         dy[0] = y[1];
//!         dy[1] = -y[0];
//!         Ok(())
//!     }
//!     fn energy(&self, _t: f64, y: &[f64]) -> Option<f64> {
//!         Some(0.5 * (y[0] * y[0] + y[1] * y[1]))
//!     }
//! }
//!
//! let options = Options { rtol: 1e-10, atol: 1e-10, ..Options::default() };
//! let solution = integrate(&Oscillator, Method::Dop853, 0.0, &[1.0, 0.0], &[1.0, 2.0], &options)?;
//! assert!((solution.y[1][0] - 2f64.cos()).abs() < 1e-8);
//! assert!(solution.stats.energy_drift.unwrap() < 1e-8);
//! # Ok::<(), hamel_sim::IntegrationError>(())
//! ```
#![warn(missing_docs)]

mod control;
pub mod dla;
mod dop853;
mod dopri5;
mod driver;
mod ensemble;
pub mod events;
mod explicit;
mod gauss;
pub mod job;
mod live;
mod rk4;
mod solution;
mod states;
mod step;
mod system;
pub mod taylor;
#[cfg(test)]
mod testing;
mod vern9;
mod work;

pub use driver::{Method, MethodName, Options, integrate, integrate_with_events};
pub use ensemble::{Ensemble, EnsembleError, Shard, integrate_many};
pub use events::{Crossing, Event, EventHit};
pub use live::{Interpolation, Live, Outside, Samples, Table, TableError, live_values};
pub use solution::{ErrorKind, IntegrationError, Solution, Stats};
pub use states::States;
pub use system::{OdeSystem, SystemError};
