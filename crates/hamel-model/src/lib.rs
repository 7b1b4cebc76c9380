//! Model files.
//!
//! **Job**: read a model file (TOML, format in `docs/model-format.md`), parse every expression,
//! resolve every name (coordinates, parameters, velocities `der(q)`, free functions), and check
//! what can be checked without computer algebra: counts (ℓ > μ, ℓ − μ quasi-velocities per
//! choice), names, and positive definiteness of A at the default parameters and at sample
//! configurations (numerically, from T).
//!
//! **Inputs**: a path or a string. **Outputs**: a [`Model`] whose expressions are
//! [`hamel_expr::Expr`] trees, each with its [`Site`] (key and byte span in the file), or a
//! [`ModelError`] that names the file, the line and column, and the reason.
//!
//! **Invariant**: the algebraic checks (T quadratic in velocities, constraints linear and
//! homogeneous, rank of α, det[Z; α] not identically zero) are decided exactly downstream by the
//! symbolic stage, which reports them through [`Model::error_at`] so that every error, whatever
//! stage finds it, points into the file the same way.
#![warn(missing_docs)]

mod bodies;
mod control;
pub mod default_choice;
mod error;
mod expand;
pub mod files;
mod index;
mod loader;
mod model;
mod numeric;
mod parameters;
mod rank;
mod schema;
mod shapes;
pub mod states;
mod steady;
mod symmetry;

pub use control::{Control, ControlError, Law, TIME};
pub use default_choice::combinations;
pub use error::{ErrorKind, ModelError};
pub use hamel_bodies::{
    Completion, CompletionError, ContactForces, ContactKind, HolonomicConstraint,
};
pub use index::{Coord, Param};
pub use loader::{Item, Kinetic, Origin, Site};
pub use model::{ChoiceOrigin, MAX_COORDINATES, Model, QuasiVelocityChoice};
pub use numeric::{NumericModel, sample_configurations};
pub use parameters::{SetError, parse_assignment};
pub use rank::DependentRow;
pub use steady::{Steady, SteadyCheck};
pub use symmetry::Symmetry;
