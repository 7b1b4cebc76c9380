//! Models from bodies, frames, rolling wheels and rolling bodies.
//!
//! **Job**: turn a [`Mechanism`] (the world's up direction and gravity, a tree of frames with
//! rotations and origins, rigid bodies with masses and inertias, rolling wheels and tyres,
//! rolling bodies with a curved surface (spheres, ellipsoids), blades and holonomic
//! constraints) into what the rest of hamel starts from: the kinetic energy's matrix A
//! (T = ½ q̇ᵀAq̇), the potential U (L = T + U), the rows of α and the holonomic constraints
//! h(q) = 0 with their dependent coordinates, and the generalised forces F of the loads and
//! dampers (springs enter U) ([`expand`] → [`Expansion`]).
//!
//! **Inputs**: a [`Mechanism`] whose expressions are [`hamel_expr::Expr`] trees in the
//! coordinates and parameters (names resolved by the caller, `hamel-model`), and the default
//! parameter values. **Outputs**: an [`Expansion`], or a [`BodiesError`] naming the place in the
//! description ([`Place`]: section, entry, field) and the reason.
//!
//! **Invariants**: everything is exact. Velocities are linear forms in q̇ built frame by frame
//! (angular velocities composed from rotation rates, never read off differentiated rotation
//! matrices), positions are differentiated exactly, and nothing is expanded: A, U and α come
//! out structured, the size of the description, for the symbolic stage to put in canonical
//! form. The one simplification that is not an identity, |k| = ±k_i for a wheel whose k has one
//! nonzero component, takes the branch of the reference configuration (q = 0) and is reported in
//! [`Expansion::notes`]. Numbers serve checks only (at the default parameters: positive masses,
//! positive definite inertias, unit axes, wheels on the ground, holonomic constraints that
//! determine their coordinates).
#![warn(missing_docs)]

mod carry;
mod contact;
mod elements;
mod error;
mod expand;
mod frames;
mod loads;
mod mechanism;
mod motion;
mod numeric;
mod reactions;
mod symmetry;
pub mod vector;

pub use contact::Row;
pub use error::{BodiesError, Place, Problem, Section};
pub use expand::{Expansion, HolonomicConstraint, HolonomicRows, expand, holonomic_rows, supports};
pub use frames::order as frames_in_order;
pub use mechanism::{
    Anchor, Axis, Blade, Body, Damper, Direction, Frame, Geometry, Holonomic, Inertia, Load,
    LoadKind, Mechanism, Roller, Rotation, Shape, Spring, Stretch, Surface, WORLD, Wheel, World,
};
pub use numeric::{Completion, CompletionError, Point};
pub use reactions::{Contact, ContactForces, ContactKind, Normal, Support, WheelForce};
pub use symmetry::{Symmetry, vertical_rotation};
