//! The symbolic engine.
//!
//! **Job**: exact symbolic algebra for the rest of hamel. It is the only crate that depends on
//! Symbolica. All of its work runs on one long-lived thread ([`run`]): Symbolica, unlicensed,
//! allows one thread per user at a time, so callers send jobs there and get plain data back.
//!
//! **Inputs**: expression trees ([`hamel_expr::Expr`]) and a [`FieldSpec`] naming the symbols.
//! **Outputs**: expressions [`Ex`] in normal form (inside jobs only) and, to leave a job, plain
//! trees ([`Ex::to_expr`]) and their text (`Display`).
//!
//! **Invariants**: every [`Ex`] is in the normal form described in [`field`] (lowest terms taken
//! in the half-angle ring, `half`), so zero tests, equality and "free of q" are exact decisions,
//! never samples, and without square-root kernels equal values have identical forms; [`Ex`] is `!Send` and cannot
//! escape the worker thread.
#![warn(missing_docs)]

mod bareiss;
mod convert;
pub mod evaluator;
mod export;
pub mod field;
mod half;
pub mod linalg;
pub mod manifold;
pub mod over;
mod print;
mod screen;
#[doc(hidden)]
pub mod selfcheck;
mod vars;
mod worker;

pub use field::{Ex, Field, FieldSpec};
pub use linalg::Matrix;
pub use manifold::Manifold;
pub use over::{Denominators, OMatrix, Over, sum_over};
pub use worker::{on_worker, run, started};

/// What can go wrong in symbolic work.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error, serde::Serialize, serde::Deserialize)]
pub enum CasError {
    /// Division by an expression that is identically zero.
    #[error("division by an expression that is identically zero")]
    DivisionByZero,
    /// A construct the engine does not handle (with the reason).
    #[error("{0}")]
    Unsupported(String),
    /// A transcendental function whose argument was not declared to the field (the function
    /// as written): inside another one, a nested function.
    #[error("{0} was not declared to the field")]
    Undeclared(String),
    /// An exact elimination that outgrew its budget of work ([`linalg::Budget`]): the caller
    /// decides another way (a certified evaluation, a structured form) instead of waiting.
    #[error(
        "exact elimination stopped: it would exceed its budget ({0} units of work, no product of operands larger than 10⁴ terms²)"
    )]
    TooLarge(usize),
    /// A bug or a failure of the worker thread.
    #[error("internal error: {0}")]
    Internal(String),
}
