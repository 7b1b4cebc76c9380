//! Signs proved from the form alone: which denominators an equation may be multiplied through
//! by without turning it around (the paper writes a row times its positive denominator).
//!
//! The proof is by structure, and sound wherever the form is a factor of a denominator (so
//! not zero on the domain of the equations): a product's sign is its coefficient's times its
//! factors'; an even power is ≥ 0; a parameter the model declares positive, a square root
//! and an exponential are ≥ 0; a sum whose terms all have one sign has it; a name has its
//! definition's. ≥ 0 and not zero is > 0. Anything else (an odd power of cos θ, a sum of
//! mixed signs) is not proved, and the fraction stays. A group or a name
//! repeated an even number of times (a denominator's `δ²`) is ≥ 0 whatever its sign.

use std::collections::BTreeSet;

use hamel_expr::{Expr, Func};

use crate::form::{Ctx, Factor, Form};

/// A sign proved for every point of the domain.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Sign {
    /// ≥ 0 (> 0 where not zero).
    NonNegative,
    /// ≤ 0.
    NonPositive,
}

impl Sign {
    fn times(self, other: Sign) -> Sign {
        if self == other {
            Sign::NonNegative
        } else {
            Sign::NonPositive
        }
    }
}

/// The sign of `f` on the whole domain, if the structure proves one; `positive`: the names
/// of the parameters declared positive.
pub(crate) fn sign(f: &Form, ctx: Ctx<'_>, positive: &BTreeSet<String>) -> Option<Sign> {
    match f {
        Form::Product { coef, factors } => {
            let mut s = if coef.is_negative() {
                Sign::NonPositive
            } else {
                Sign::NonNegative
            };
            for (x, n) in crate::form::powers(factors) {
                if n % 2 == 1 {
                    s = s.times(factor_sign(x, ctx, positive)?);
                }
            }
            Some(s)
        }
        Form::Sum(terms) => {
            let mut signs = terms.iter().map(|t| sign(t, ctx, positive));
            let first = signs.next()??;
            signs.all(|s| s == Some(first)).then_some(first)
        }
        Form::Quotient(a, b) => Some(sign(a, ctx, positive)?.times(sign(b, ctx, positive)?)),
    }
}

fn factor_sign(x: &Factor, ctx: Ctx<'_>, positive: &BTreeSet<String>) -> Option<Sign> {
    match x {
        Factor::Atom { power, .. } if power % 2 == 0 => Some(Sign::NonNegative),
        Factor::Atom { index, .. } => {
            let known = match &ctx.atoms.get(*index).expr {
                Expr::Sym(name) => positive.contains(name),
                Expr::Call(Func::Sqrt | Func::Exp, _) => true,
                _ => false,
            };
            known.then_some(Sign::NonNegative)
        }
        Factor::Group(g) => sign(g, ctx, positive),
        Factor::Name { index } => sign(&ctx.names[*index].form, ctx, positive),
    }
}
