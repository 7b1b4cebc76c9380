//! An entry's canonical form as the computer algebra exported it: a numerator over an integer
//! times powers of factors, `num / (scale · ∏ fₖ^eₖ)`.
//!
//! Printing keeps the denominator so: a paper writes `δ³`, not the twenty terms of its
//! expansion, and a derivation's denominators are powers of a few factors (the unicycle's
//! `momenta` divide by powers of one factor of twenty terms). Collection writes each factor
//! once (`collect::factored_in`), the check values it at a point without expanding it
//! (`modular.rs`); only the exact check at a pole expands it ([`Factored::expanded`]).

use hamel_expr::{Canonical, Terms};

use crate::atoms::Atoms;
use crate::poly::{Fraction, Mono, Poly};
use crate::q::Q;

/// `num / (scale · ∏ fₖ^eₖ)`: the factors as exported (each once, exponents ≥ 1), the scale
/// as exported too (collection divides the numerator's content by it, once, not each
/// coefficient).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Factored {
    /// The numerator.
    pub num: Poly,
    /// The denominator's rational factor (nonzero).
    pub scale: Q,
    /// The denominator's polynomial factors with their exponents.
    pub factors: Vec<(Poly, u32)>,
}

impl From<Fraction> for Factored {
    /// A fraction read from a tree: its denominator one factor (none when constant).
    fn from(f: Fraction) -> Factored {
        let f = f.normalised();
        let factors = if f.den.is_one() {
            Vec::new()
        } else {
            vec![(f.den, 1)]
        };
        Factored {
            num: f.num,
            scale: Q::one(),
            factors,
        }
    }
}

impl Factored {
    /// [`Fraction::from_canonical`] with the denominator kept in its factors.
    pub fn from_canonical(c: &Canonical, atoms: &mut Atoms) -> Factored {
        Factored::read_mapped(c, &Fraction::numbering(c, atoms))
    }

    /// `c` with its atom `a` numbered `map[a]` (atoms two of which share a number are one).
    pub(crate) fn read_mapped(c: &Canonical, map: &[usize]) -> Factored {
        Factored {
            num: read_terms(&c.num, map),
            scale: Q::integer(&c.scale),
            factors: c
                .factors
                .iter()
                .map(|(t, e)| (read_terms(t, map), *e))
                .collect(),
        }
    }

    /// The same fraction, its denominator expanded.
    pub fn expanded(&self) -> Fraction {
        let Some(den) = self
            .factors
            .iter()
            .map(|(p, e)| p.pow(*e))
            .reduce(|a, b| a.mul(&b))
        else {
            return Fraction::from(self.num.scale(&self.scale.recip()));
        };
        Fraction {
            num: self.num.clone(),
            den: den.scale(&self.scale),
        }
    }

    /// How many terms the numerator and the denominator's factors have.
    pub(crate) fn terms(&self) -> usize {
        self.polys().map(Poly::size).sum()
    }

    /// The numerator and the denominator's factors.
    pub(crate) fn polys(&self) -> impl Iterator<Item = &Poly> {
        std::iter::once(&self.num).chain(self.factors.iter().map(|(p, _)| p))
    }
}

impl Fraction {
    /// The fraction of `c`, the polynomials the computer algebra exported: the same as
    /// [`Fraction::from_expr`] of its tree (`c.to_expr()`), the atoms numbered in the same
    /// order, without taking the tree apart.
    pub fn from_canonical(c: &Canonical, atoms: &mut Atoms) -> Fraction {
        Factored::from_canonical(c, atoms).expanded()
    }
}

/// Exported terms, atom `a` numbered `map[a]`.
fn read_terms(terms: &Terms, map: &[usize]) -> Poly {
    let terms = terms.iter().map(|t| {
        let m = Mono::from_unsorted(t.powers.iter().map(|&(a, e)| (map[a as usize], e)));
        (m, Q::from(&t.coef))
    });
    Poly::from_terms(terms.collect())
}
