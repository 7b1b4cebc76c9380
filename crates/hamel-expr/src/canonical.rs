//! A derived expression as the computer algebra holds it: polynomials over its atoms, before
//! they are written as a tree.
//!
//! The symbolic stage exports every derived value as a [`Canonical`] and writes its tree from
//! it ([`Canonical::to_expr`]), so the two never disagree. Whoever needs the polynomials
//! (printing collects terms over monomials) reads them here without taking the tree apart.

use num_bigint::BigInt;
use num_traits::{One, Signed, ToPrimitive};
use smallvec::SmallVec;

use crate::ast::{Expr, Rational};

/// A term: an integer coefficient times a product of atoms' powers. A term is held whole in
/// its polynomial's vector (its coefficient a machine integer where it fits, eight powers in
/// place): a reader of a derivation's thousands of terms reads them in order, not by two
/// pointers each.
#[derive(Clone, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct Term {
    /// The coefficient (never zero).
    pub coef: Coef,
    /// `(atom, exponent)` pairs: indices into [`Canonical::atoms`], ascending, exponents ≥ 1.
    pub powers: Powers,
}

/// A term's `(atom, exponent)` pairs.
pub type Powers = SmallVec<[(u32, u32); 8]>;

/// An integer coefficient: a machine integer where it fits (a derivation's almost always
/// do), else a big integer. Canonical: `Big` only for what does not fit in an `i64`, so the
/// derived equality is that of the value.
#[derive(Clone, Debug, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
pub enum Coef {
    /// Fits in an `i64`.
    Small(i64),
    /// Does not.
    Big(BigInt),
}

impl Coef {
    /// The coefficient as a big integer.
    pub fn to_bigint(&self) -> BigInt {
        match self {
            Coef::Small(n) => BigInt::from(*n),
            Coef::Big(n) => n.clone(),
        }
    }
}

impl From<BigInt> for Coef {
    fn from(n: BigInt) -> Coef {
        match n.to_i64() {
            Some(small) => Coef::Small(small),
            None => Coef::Big(n),
        }
    }
}

impl From<i64> for Coef {
    fn from(n: i64) -> Coef {
        Coef::Small(n)
    }
}

/// A polynomial: its terms, in the order the tree writes them.
pub type Terms = Vec<Term>;

/// `num / (scale · ∏ fᵢ^eᵢ)` over atoms: the numerator expanded, the denominator a nonzero
/// integer times powers of polynomial factors (none for a polynomial).
///
/// **Invariant**: the atoms are distinct, and a term's atoms ascend in the order the tree
/// writes a product's factors; the factors are in the order the tree writes them.
#[derive(Clone, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct Canonical {
    /// The atoms: symbols, velocities, sines and cosines, free functions, other functions.
    pub atoms: Vec<Expr>,
    /// A number for each atom, given by the exporter, or none (empty): two atoms of forms from
    /// one exporter with the same number are the same atom. A reader that meets the same atoms
    /// in many forms (printing numbers every entry's) tells them apart by these numbers
    /// without comparing trees.
    pub ids: Vec<u64>,
    /// The numerator's terms.
    pub num: Terms,
    /// The denominator's integer (nonzero).
    pub scale: BigInt,
    /// The denominator's factors with their exponents (≥ 1).
    pub factors: Vec<(Terms, u32)>,
}

impl Canonical {
    /// The tree: the numerator's terms (each a negation of a product when negative: number
    /// first, then the atoms' powers) over the denominator's product, the integer first;
    /// with no factors, the terms' coefficients divided by the integer.
    pub fn to_expr(&self) -> Expr {
        if self.factors.is_empty() {
            let scale = (!self.scale.is_one()).then_some(&self.scale);
            return self.sum(&self.num, scale);
        }
        let mut den: Vec<Expr> = Vec::with_capacity(self.factors.len() + 1);
        if !self.scale.is_one() {
            den.push(Expr::Num(Rational::from_integer(self.scale.clone())));
        }
        for (terms, e) in &self.factors {
            let base = self.sum(terms, None);
            den.push(if *e == 1 {
                base
            } else {
                Expr::powi(base, i64::from(*e))
            });
        }
        let den = if den.len() == 1 {
            den.pop().expect("one factor")
        } else {
            Expr::Mul(den)
        };
        Expr::Div(Box::new(self.sum(&self.num, None)), Box::new(den))
    }

    /// The factors ordered by their text (what makes a denominator's product the same
    /// whatever order the engine found its factors in).
    pub fn order_factors(&mut self) {
        if self.factors.len() < 2 {
            return;
        }
        let mut factors = std::mem::take(&mut self.factors);
        factors.sort_by_cached_key(|(terms, _)| self.sum(terms, None).to_string());
        self.factors = factors;
    }

    /// `terms / scale` as a sum.
    fn sum(&self, terms: &[Term], scale: Option<&BigInt>) -> Expr {
        let mut out: Vec<Expr> = terms.iter().map(|t| self.term(t, scale)).collect();
        match out.len() {
            0 => Expr::int(0),
            1 => out.pop().expect("one term"),
            _ => Expr::Add(out),
        }
    }

    /// One term as a (negated) product.
    fn term(&self, t: &Term, scale: Option<&BigInt>) -> Expr {
        let coef = match scale {
            Some(s) => Rational::new(t.coef.to_bigint(), s.clone()),
            None => Rational::from_integer(t.coef.to_bigint()),
        };
        let negative = coef.is_negative();
        let coef = coef.abs();
        let mut factors = Vec::with_capacity(t.powers.len() + 1);
        if !coef.is_one() || t.powers.is_empty() {
            factors.push(Expr::Num(coef));
        }
        for &(a, e) in &t.powers {
            let base = self.atoms[a as usize].clone();
            factors.push(if e == 1 {
                base
            } else {
                Expr::powi(base, i64::from(e))
            });
        }
        let term = if factors.len() == 1 {
            factors.pop().expect("one factor")
        } else {
            Expr::Mul(factors)
        };
        if negative {
            Expr::Neg(Box::new(term))
        } else {
            term
        }
    }

    /// The atoms' indices in the order a reading of the tree meets them first: the
    /// numerator's terms, then the factors' terms, each term's atoms in order.
    pub fn atoms_met(&self) -> Vec<usize> {
        let mut seen = vec![false; self.atoms.len()];
        let mut order = Vec::with_capacity(self.atoms.len());
        let all = self.factors.iter().flat_map(|(t, _)| t);
        for t in self.num.iter().chain(all) {
            for &(a, _) in &t.powers {
                let a = a as usize;
                if !std::mem::replace(&mut seen[a], true) {
                    order.push(a);
                }
            }
        }
        order
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn term(coef: i64, powers: &[(u32, u32)]) -> Term {
        Term {
            coef: Coef::from(coef),
            powers: Powers::from_slice(powers),
        }
    }

    /// A coefficient is a machine integer exactly when it fits in one, so equal values are
    /// equal coefficients; a big one is written whole.
    #[test]
    fn coefficients_are_small_exactly_when_they_fit() {
        let fits = BigInt::from(i64::MIN);
        assert_eq!(Coef::from(fits.clone()), Coef::Small(i64::MIN));
        let big = BigInt::from(i64::MAX) + BigInt::one();
        assert_eq!(Coef::from(big.clone()), Coef::Big(big.clone()));
        assert_eq!(Coef::from(big.clone()).to_bigint(), big);
        let c = Canonical {
            atoms: vec![Expr::sym("x")],
            ids: vec![],
            num: vec![Term {
                coef: Coef::from(big),
                powers: Powers::from_slice(&[(0, 2)]),
            }],
            scale: BigInt::one(),
            factors: vec![],
        };
        assert_eq!(c.to_expr().to_string(), "9223372036854775808*x^2");
    }

    #[test]
    fn trees_are_written_as_the_export_writes_them() {
        let c = Canonical {
            atoms: vec![Expr::sym("m"), Expr::call(crate::Func::Cos, Expr::sym("x"))],
            ids: vec![],
            num: vec![term(-3, &[(0, 1), (1, 2)]), term(2, &[])],
            scale: BigInt::from(4),
            factors: vec![],
        };
        assert_eq!(c.to_expr().to_string(), "-3/4*m*cos(x)^2 + 1/2");
        let d = Canonical {
            factors: vec![(vec![term(1, &[(0, 1)]), term(-1, &[])], 2)],
            scale: BigInt::from(2),
            ..c.clone()
        };
        assert_eq!(d.to_expr().to_string(), "(-3*m*cos(x)^2 + 2)/(2*(m - 1)^2)");
        assert_eq!(d.atoms_met(), vec![0, 1]);
        let zero = Canonical { num: vec![], ..c };
        assert_eq!(zero.to_expr(), Expr::int(0));
    }
}
