//! Expressions as hamel reads and writes them.
//!
//! **Job**: the plain, engine-free representation of a mathematical expression: the abstract
//! syntax tree [`Expr`] with exact rational literals, the parser for the model-file expression
//! grammar (with byte spans for error messages), a printer in the same syntax, builders that
//! fold exact zeros ([`build`]), exact differentiation ([`Expr::diff`]), and numeric
//! evaluation over any [`Scalar`] of the numeric runtime (plain `f64`, the dual numbers
//! [`Dual`] for exact directional derivatives, double-double [`DD`]).
//!
//! **Inputs**: expression text (from model files, state files, scenes), or trees built by the
//! symbolic stage when it exports its canonical results.
//! **Outputs**: [`Expr`] trees, [`ParseError`]s with spans, numbers; and [`Canonical`], the
//! polynomials a derived value is exported as, from which its tree is written.
//!
//! **Invariant**: this crate knows nothing of the computer-algebra engine; everything numeric in
//! hamel (the independent oracle, `hamel eval`, generated code) can be built on it alone.
#![warn(missing_docs)]

mod ast;
mod atan;
pub mod build;
mod canonical;
mod diff;
mod display;
mod eval;
mod horner;
mod latex;
pub mod limits;
mod parse;
mod specialise;
mod tape;
mod tape_data;
pub mod taylor;
mod trace;

pub use ast::{Expr, Func, Rational, SubstituteError};
pub use canonical::{Canonical, Coef, Powers, Term, Terms};
pub use diff::DiffError;
pub use eval::{Env, EvalError, rational_parts};
/// The numeric runtime's scalars and LU (`hamel-runtime`), re-exported: expressions evaluate
/// over them.
pub use hamel_runtime::{DD, Dual, Lu, Scalar, power_by_squaring, solve_system as solve};
pub use latex::latex_name;
pub use parse::{Occurrence, OccurrenceKind, ParseError, Parsed, parse};
pub use specialise::rational_of_f64;
pub use tape::{Op, Tape, TapeError};
pub use tape_data::{OpData, TapeData};
pub use trace::{Guard, Guarded, TraceError, Traced, trace, trace_guarded};
