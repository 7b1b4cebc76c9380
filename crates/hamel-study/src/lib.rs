//! Studies of the motions: steady motions, the equations linearised about them, their
//! eigenvalues, and the parameter values where stability changes (mission step 6).
//!
//! **Job**: for a model, a quasi-velocity choice and a steady motion declared in the model file
//! (`[steady.NAME]`), build the steady state (dependent coordinates completed from the
//! holonomic constraints, dependent velocities from α(q)q̇ = 0), check that it is steady
//! (exactly on canonical forms where the closed form allows, [`SteadyCheck`]), and
//! linearise the reduced Boltzmann–Hamel equations (11) with q̇ = Γη (6) about it: the state is
//! the kept coordinates and η, the coordinates the equations are free of (decided exactly by
//! `hamel_reduce`) are dropped. Then the eigenvalues, with the structural zeros (dropped
//! coordinates, the steady family's own directions, zeros present along the whole family)
//! reported apart; sweeps over a parameter, the crossings where stability changes, refined by
//! root finding; maps over two parameters; and, where the state allows it, the second-order
//! form M q̈ + C q̇ + K q = B u with its dependence on the swept speed.
//!
//! **Inputs**: a checked [`hamel_model::Model`], the steady motion's name, the choice's name.
//! **Outputs**: [`Linearisation`] at a point, [`Sweep`] and [`Map`] (plain, serialisable data),
//! or a [`StudyError`] that [`Study::locate`] turns into a located model error.
//!
//! **Invariants**: the computer algebra runs once, in `Study::prepare` (feature `cas`: the
//! derivation, the exact decision of which coordinates drop out, the exact steady check);
//! everything after it is numeric and engine-free, so sweeps and maps run their points on a
//! rayon pool, and a study exported after that pass ([`Exported`]) runs in a process without the
//! computer algebra (the `hamel-sweep` worker, built without `cas`). Derivatives are exact (dual
//! numbers through the structured evaluation), never finite differences. Eigenvalues come from
//! nalgebra's real Schur form with an iteration cap: a failure is an error, never a hang.
#![warn(missing_docs)]

mod bar;
pub mod eigen;
mod error;
#[cfg(feature = "cas")]
mod export;
mod forms;
mod linear;
pub mod lqr;
mod mat;
#[cfg(feature = "cas")]
pub mod plot;
mod prepare;
mod render;
mod state;
pub mod sweep;

pub use bar::Bar;
pub use error::StudyError;
pub use export::{Exported, Outcome, Progress};
pub use forms::{Polynomial, SecondOrder, Symbolic};
pub use hamel_model::SteadyCheck;
pub use linear::{Linearisation, Point, Stability, Structural, StructuralKind};
pub use lqr::{Lqr, LqrError, Regulator, RegulatorError, lqr};
pub use prepare::{Dropped, Study};
pub use sweep::{Crossing, CrossingKind, Map, Range, Sweep, SweepPoint};
