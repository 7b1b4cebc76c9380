//! The interpreted numeric core: a derivation evaluated without the computer-algebra engine.
//!
//! **Job**: structured evaluation ([`Compiled`], used by `hamel eval`, the interpreted
//! simulation engine and code generation's accuracy checks). The expanded normal forms of Q
//! are exact but, written over sin/cos reduced modulo sin² + cos² = 1 and multiplied out,
//! they cancel catastrophically in floating point (terms of 10¹³ summing to 10⁻⁵ were
//! observed at well-conditioned states). So the equations (11) are evaluated from small exact
//! ingredients on a [`hamel_expr::Tape`], with the linear algebra done numerically by the
//! runtime's [`hamel_runtime::Structured`], the very code every generated core runs. Also the
//! expanded forms themselves ([`SymbolicCompiled`]), for checking them.
//!
//! **Inputs**: tapes of the ingredients (built by `hamel_derive::Derivation::compile`), states
//! (q, η), parameter values. **Outputs**: [`Evaluation`]s (η̇ true and the paper's, q̇, energy,
//! the conditioning of [Z; α], δ, the arithmetic used), [`Rhs`] in any scalar type.
//!
//! **Invariants**: engine-free; singular configurations and non-finite values are errors,
//! never NaN; an f64 evaluation that may have lost more than 16 units of rounding is repeated
//! in double-double (docs/stability.md).
#![warn(missing_docs)]

mod compiled;
mod contact;
mod contact_map;
mod symbolic;

pub use compiled::{
    Compiled, CompiledData, ConstraintForce, Evaluation, Forces, ForcesData, NumericError,
    RankLoss, RankLossData, serialize_precision,
};
pub use contact_map::{Contacts, ForceComponent, NormalSlot, Pushes, Report, SupportSlots};
pub use hamel_runtime::DOUBLE_DOUBLE_ABOVE;
pub use hamel_runtime::{Precision, Rhs};
pub use symbolic::{SymbolicCompiled, SymbolicLayout};
