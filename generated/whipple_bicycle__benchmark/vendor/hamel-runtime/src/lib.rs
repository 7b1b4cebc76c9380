//! The one numeric runtime of hamel.
//!
//! **Job**: the arithmetic every numeric part of hamel shares: the [`Scalar`] types (f64,
//! dual numbers [`Dual`] and [`DualN`] for exact derivatives, double-double [`DD`]), LU with
//! partial pivoting over any scalar ([`lu`]), [`Lanes`] (four f64 evaluated together, for
//! monitors over many states: [`over_rows`]), and the structured Boltzmann–Hamel right-hand
//! side (6), (9), (11) assembled from the ingredients Z, α, A, U, ∇U, ∂A/∂q, ∂Z/∂q, ∂α/∂q
//! ([`Structured`]), with its f64 error estimate; for a structured derivation's core, the
//! derivative blocks of Z, α, A by dual numbers at run time ([`ingredients_by_partials`]); after an evaluation, the constraints'
//! multipliers and q̈ ([`Structured::constraint_force`]) and the normal forces of the wheels a
//! frame carries ([`support_normals`], issue 58).
//!
//! **Inputs**: the ingredients at a configuration (from generated straight-line code, or from
//! an interpreted tape) and η. **Outputs**: η̇ (true and the paper's), q̇ = Γη, A_Γ, F, the
//! energy, Γ; [`EvalError`] where [Z; α] or A_Γ is numerically singular.
//!
//! **Invariants**: `std` only, no dependencies, so that every generated crate vendors these
//! sources unchanged (`hamel codegen`) and runs without computer algebra; the structured
//! evaluation allocates nothing, its storage is the caller's ([`Storage`] on the stack for
//! sizes known at compile time, [`Buffers`] otherwise); the generated cores, `hamel eval`
//! (`hamel_derive::Compiled`) and the simulator evaluate the same code.
#![warn(missing_docs)]

mod cold;
mod dd;
mod dual;
mod error;
mod fixed;
mod jet;
mod lanes;
pub mod lu;
mod partials;
pub mod recur;
mod scalar;
mod series;
mod structured;
mod support;

pub use cold::Cold;
pub use dd::DD;
pub use dual::{Dual, DualN};
pub use error::{EvalError, cold_error, finite};
pub use fixed::{Buffers, Fixed, Precision, Rhs, Storage};
pub use jet::{JET_CAPACITY, Jet, JetFailure, taylor_by_jets};
pub use lanes::{LANES, LaneFn, Lanes, abs_max, max_abs, over_rows};
pub use lu::{Lu, solve_system};
pub use partials::{Partials, ingredients_by_partials};
pub use scalar::{RationalParts, Scalar, power_by_squaring, widen};
pub use series::{Node as SeriesNode, SeriesFailure, Traced, taylor_by_program, taylor_by_trace};
pub use structured::{
    DOUBLE_DOUBLE_ABOVE, Dims, Failure, KEPT_ROWS_PIVOT, Layout, Structured, select as select_rows,
};
pub use support::{SupportLayout, support_equations, support_normals};
