//! Printing forms of derived expressions: what a paper would print.
//!
//! **Job**: turn a canonical (expanded) expression into the form a mechanician writes
//! (issue 22): the terms collected over the monomials in the coordinates' functions (sines,
//! cosines, velocities), each coefficient a factored polynomial in the parameters; common
//! factors and the rational content pulled out; parameters written before functions, rationals
//! as `\tfrac`, no parentheses around a negated product.
//!
//! A [`Sheet`] prints many expressions together and names, once, in a where-list, what recurs or
//! is too wide for a line (κₙ, Fₙ(q…), or a model's `[abbreviations]`), as a paper does.
//!
//! **Inputs**: an [`Expr`](hamel_expr::Expr) in canonical form (as `hamel-derive` exports it) and a
//! [`Vocabulary`] saying which names are parameters, coordinates and velocities; or a whole
//! `Derivation` ([`derivation`]) or `Reduction` ([`reduction`]), whose entries are read from
//! the polynomials they were exported as where they kept them ([`Fraction::from_canonical`]).
//! **Outputs**: a [`Printed`] form, rendered as text ([`Printed::text`]) or LaTeX
//! ([`Printed::latex`]), and back as an expression ([`Printed::to_expr`]); `hamel derive`'s text,
//! JSON and LaTeX document ([`derivation::text`], [`derivation::json`], [`derivation::latex`]);
//! `hamel reduce`'s text ([`reduction::text`]).
//!
//! **Invariant**: printing never decides anything. A printed form equals the canonical form it
//! came from, exactly: both expand to the same polynomial in the atoms ([`Poly`], a canonical
//! form for the polynomial and rational expressions derivations produce), which
//! [`Printed::check`] and [`Sheet::check`] verify and the tests assert for every entry of every
//! seed model. Before anything is written, `hamel derive` checks every entry at a random point
//! modulo a prime (exact arithmetic; a wrong form passes with probability below 10⁻¹⁶,
//! `modular.rs`), expanding only where the point is a pole.
//! Deciding (what is free of a coordinate, which hypotheses hold) stays on the CAS's canonical
//! forms.
#![warn(missing_docs)]

mod atoms;
mod collect;
pub mod derivation;
mod document;
mod factored;
mod form;
mod layout;
mod memo;
mod modular;
mod mono;
mod naming;
mod par;
mod places;
mod poly;
mod positive;
mod printed;
mod printing;
mod q;
mod read;
pub mod reduction;
mod sheet;
mod tex_width;
mod wide;

pub use atoms::{Atom, Atoms, Kind, Vocabulary};
pub use factored::Factored;
pub use form::{Definition, Factor, Form};
pub use layout::{LINE, width, width_at_least};
pub use poly::{Fraction, Mono, Poly, PolyError};
pub use printed::Printed;
pub use q::Q;
pub use sheet::Sheet;

#[cfg(test)]
mod tests;
