//! Reading a sheet's entries: canonical expressions to fractions over the sheet's atoms.
//!
//! The atoms are numbered in the order they are first met, entry after entry, depth first
//! (the numbering decides the order of a polynomial's terms, and so which sign a sum is
//! printed with). Numbering is cheap and done first, in order, on the calling thread: a
//! canonical form's atoms are numbered as its terms meet them, which its first terms
//! mostly settle (a tree is read whole then). The canonical forms are then read in the
//! sheet's numbering, on printing's pool when they are many, in any order: each entry's
//! reading depends on its numbering alone.

use hamel_expr::{Canonical, Expr};

use crate::atoms::Atoms;
use crate::factored::Factored;
use crate::poly::{Fraction, PolyError};

/// What an entry is read from: its tree, or the polynomials the computer algebra wrote the
/// tree from (read alike, atoms met in the same order, without taking a tree apart).
#[derive(Clone, Copy)]
pub(crate) enum Source<'e> {
    /// A canonical tree.
    Tree(&'e Expr),
    /// An exported canonical form.
    Canonical(&'e Canonical),
}

/// The entries `es` (each with how often it is shown) read in the sheet's `atoms`, which
/// number them and are weighed by them (an entry as often as it is shown); on printing's
/// pool when `parallel`.
///
/// # Errors
/// An entry with no rational form over its atoms, or one too large to print
/// ([`PolyError::TooLarge`]): the first in order.
pub(crate) fn entries(
    es: &[(Source<'_>, usize)],
    parallel: bool,
    atoms: &mut Atoms,
) -> Result<Vec<Factored>, PolyError> {
    // The canonical forms' maps of atoms, one after another in one vector.
    let mut maps = Vec::with_capacity(
        es.iter()
            .map(|(e, _)| match e {
                Source::Canonical(c) => c.atoms.len(),
                Source::Tree(_) => 0,
            })
            .sum(),
    );
    let mut numbered = Vec::with_capacity(es.len());
    for (e, _) in es {
        numbered.push(match *e {
            Source::Tree(t) => Numbered::Read(Fraction::read(t, atoms)?),
            Source::Canonical(c) => {
                let start = maps.len();
                Fraction::numbering_into(c, atoms, &mut maps);
                Numbered::Mapped(c, start..maps.len())
            }
        });
    }
    let len = atoms.len();
    let read = crate::par::map_init_owned(
        numbered,
        Numbered::terms,
        parallel,
        || vec![0; len],
        |counts, n| {
            let f = match n {
                Numbered::Read(f) => Factored::from(f),
                Numbered::Mapped(c, map) => Factored::read_mapped(c, &maps[map]),
            };
            let weights = weights(&f, counts);
            (f, weights)
        },
    );
    let mut out = Vec::with_capacity(read.len());
    for ((f, weights), (_, count)) in read.into_iter().zip(es) {
        if !f.polys().all(crate::poly::Poly::is_exact) {
            return Err(PolyError::TooLarge);
        }
        for (i, w) in weights {
            atoms.weigh(i, w * count);
        }
        out.push(f);
    }
    Ok(out)
}

/// An entry whose atoms the sheet has numbered: read already (a tree), or a canonical form
/// with the sheet's number of each of its atoms.
enum Numbered<'e> {
    Read(Fraction),
    /// A canonical form and where its map of atoms is in the maps of all.
    Mapped(&'e Canonical, std::ops::Range<usize>),
}

impl Numbered<'_> {
    /// About how many terms it has (what the pool takes the largest entries first by).
    fn terms(&self) -> usize {
        match self {
            Numbered::Read(f) => f.num.size() + f.den.size(),
            Numbered::Mapped(c, _) => terms(&Source::Canonical(c)),
        }
    }
}

/// An entry's atoms with the number of its terms each occurs in: a few, held in place.
type Weights = smallvec::SmallVec<[(usize, usize); 12]>;

/// In how many of `f`'s terms (numerator and the denominator's factors) each of its atoms
/// occurs, atoms in the order met; `counts` is zeros, one per atom, and left so.
fn weights(f: &Factored, counts: &mut [usize]) -> Weights {
    let mut weights = Weights::new();
    for m in f.polys().flat_map(crate::poly::Poly::monomials) {
        for i in m.atoms() {
            if counts[i] == 0 {
                weights.push((i, 0));
            }
            counts[i] += 1;
        }
    }
    for (i, w) in &mut weights {
        *w = std::mem::take(&mut counts[*i]);
    }
    weights
}

/// About how many terms `e` has (what decides whether reading it is worth the pool).
pub(crate) fn terms(e: &Source<'_>) -> usize {
    match e {
        Source::Tree(e) => tree_terms(e),
        Source::Canonical(c) => c.num.len() + c.factors.iter().map(|(t, _)| t.len()).sum::<usize>(),
    }
}

/// [`terms`] of a tree: as many as expanding it would make.
fn tree_terms(e: &Expr) -> usize {
    match e {
        Expr::Add(v) => v.len(),
        Expr::Div(a, b) => tree_terms(a) + tree_terms(b),
        Expr::Neg(a) => tree_terms(a),
        Expr::Mul(v) => v.iter().map(tree_terms).fold(1, usize::saturating_mul),
        Expr::Pow(b, _) => tree_terms(b),
        _ => 1,
    }
}

#[cfg(test)]
mod tests {
    use hamel_expr::parse;
    use num_bigint::BigInt;

    use super::*;
    use crate::atoms::Vocabulary;

    fn atoms() -> Atoms {
        let names = |v: &[&str]| v.iter().map(|s| s.to_string()).collect();
        Atoms::new(Vocabulary {
            parameters: names(&["a", "b", "m"]),
            coordinates: names(&["x", "y"]),
            velocities: names(&["eta1"]),
        })
    }

    /// Terms by hand: coefficient, `(atom, exponent)` pairs.
    type Hand<'a> = &'a [(i64, &'a [(u32, u32)])];

    /// A canonical form by hand: `(terms) / (scale · factors)`, atoms given as text.
    fn canonical(atoms: &[&str], num: Hand<'_>, factors: &[(Hand<'_>, u32)]) -> Canonical {
        let terms = |ts: Hand<'_>| {
            ts.iter()
                .map(|(c, p)| hamel_expr::Term {
                    coef: (*c).into(),
                    powers: hamel_expr::Powers::from_slice(p),
                })
                .collect()
        };
        Canonical {
            atoms: atoms.iter().map(|t| parse(t).unwrap().expr).collect(),
            ids: vec![],
            num: terms(num),
            scale: BigInt::from(2),
            factors: factors.iter().map(|(t, e)| (terms(t), *e)).collect(),
        }
    }

    /// Entries read together, on the pool or not, are what reading them one after another in
    /// one numbering gives: the fractions, the atoms' numbering and their weights (the order
    /// a sheet's text depends on).
    #[test]
    fn entries_read_as_one_reading_in_order_does() {
        let texts = [
            "a*sin(x)*eta1 + b*cos(y)^2",
            "m*cos(y)*sin(x) - f(x, y)*a",
            "(b*x^(1/2) + m*eta1)/(a + cos(y))",
        ];
        let trees: Vec<Expr> = texts.iter().map(|t| parse(t).unwrap().expr).collect();
        let canonicals = [
            canonical(
                &["g(y)", "sin(x)", "b"],
                &[(3, &[(1, 2), (0, 1)]), (-1, &[(2, 1)])],
                &[],
            ),
            canonical(
                &["m", "cos(x)", "a", "sin(x)"],
                &[(1, &[(0, 1), (1, 1)]), (5, &[(2, 2)])],
                &[(&[(1, &[(3, 1)]), (1, &[(2, 1)])], 2)],
            ),
        ];
        let sources = [
            Source::Tree(&trees[0]),
            Source::Canonical(&canonicals[0]),
            Source::Tree(&trees[1]),
            Source::Canonical(&canonicals[1]),
            Source::Tree(&trees[2]),
        ];
        let es: Vec<(Source<'_>, usize)> = sources.iter().copied().zip([1, 2, 1, 3, 1]).collect();
        let mut one = atoms();
        let expected: Vec<Factored> = es
            .iter()
            .map(|(e, n)| {
                let f = match *e {
                    Source::Tree(t) => Factored::from(Fraction::from_expr(t, &mut one).unwrap()),
                    Source::Canonical(c) => Factored::from_canonical(c, &mut one),
                };
                for m in f.polys().flat_map(crate::poly::Poly::monomials) {
                    for i in m.atoms() {
                        one.weigh(i, *n);
                    }
                }
                f
            })
            .collect();
        let summary = |a: &Atoms| -> Vec<(String, usize)> {
            (0..a.len())
                .map(|i| (a.get(i).key.clone(), a.weight(i)))
                .collect()
        };
        for parallel in [false, true] {
            let mut sheet = atoms();
            assert_eq!(entries(&es, parallel, &mut sheet).unwrap(), expected);
            assert_eq!(summary(&sheet), summary(&one), "parallel: {parallel}");
        }
        // The same canonical forms with the exporter's numbers of their atoms (one number
        // for each tree, whichever form holds it) read as they do without.
        let texts: Vec<String> = canonicals
            .iter()
            .flat_map(|c| c.atoms.iter().map(Expr::to_string))
            .collect();
        let numbered: Vec<Canonical> = canonicals
            .iter()
            .map(|c| {
                let id = |a: &Expr| texts.iter().position(|t| *t == a.to_string()).unwrap();
                let ids = c.atoms.iter().map(|a| 7 + id(a) as u64).collect();
                Canonical { ids, ..c.clone() }
            })
            .collect();
        let sources = [
            sources[0],
            Source::Canonical(&numbered[0]),
            sources[2],
            Source::Canonical(&numbered[1]),
            sources[4],
        ];
        let es: Vec<(Source<'_>, usize)> = sources.iter().copied().zip([1, 2, 1, 3, 1]).collect();
        let mut sheet = atoms();
        assert_eq!(entries(&es, false, &mut sheet).unwrap(), expected);
        assert_eq!(summary(&sheet), summary(&one), "numbered atoms");
    }
}
