//! The places of a sheet's groups ([`Sheet::candidates`](crate::Sheet)): every group of the
//! entries, outer before inner, each with a hash of its form made bottom-up, so that counting
//! equal groups hashes each form once instead of once per group that holds it.

use std::hash::{BuildHasher, Hash, Hasher};

use crate::form::{Factor, Form};
use crate::q::Q;

/// A group's form with its hash ([`hashed_groups`]): hashed by that, compared whole.
#[derive(Clone, Copy)]
pub(crate) struct Keyed<'a>(pub(crate) u64, pub(crate) &'a Form);

impl Hash for Keyed<'_> {
    fn hash<H: Hasher>(&self, state: &mut H) {
        state.write_u64(self.0);
    }
}

impl PartialEq for Keyed<'_> {
    fn eq(&self, other: &Self) -> bool {
        self.0 == other.0 && self.1 == other.1
    }
}

impl Eq for Keyed<'_> {}

/// Every group of `f`, outer before inner (the sums in parentheses, and the denominators that
/// are sums: the places of [`Sheet::candidates`](crate::Sheet)), each with its hash; returns
/// the hash of `f`. Equal forms have equal hashes.
pub(crate) fn hashed_groups<'a>(f: &'a Form, out: &mut Vec<Keyed<'a>>) -> u64 {
    match f {
        Form::Product { coef, factors } => factors.iter().fold(mix(q_hash(coef), 1), |h, x| {
            mix(
                h,
                match x {
                    Factor::Atom { index, power } => mix(*index as u64, u64::from(*power)),
                    Factor::Group(g) => place(g, out),
                    Factor::Name { index } => mix(*index as u64, 2),
                },
            )
        }),
        Form::Sum(terms) => terms.iter().fold(3, |h, t| mix(h, hashed_groups(t, out))),
        Form::Quotient(a, b) => {
            let a = hashed_groups(a, out);
            let b = if matches!(**b, Form::Sum(_)) {
                place(b, out)
            } else {
                hashed_groups(b, out)
            };
            mix(mix(a, 4), b)
        }
    }
}

/// `g` as a place: listed before its inner groups, its hash filled in after them.
pub(crate) fn place<'a>(g: &'a Form, out: &mut Vec<Keyed<'a>>) -> u64 {
    let slot = out.len();
    out.push(Keyed(0, g));
    let h = hashed_groups(g, out);
    out[slot].0 = h;
    h
}

fn q_hash(q: &Q) -> u64 {
    match q {
        Q::Small(n, d) => mix(*n as u64, *d as u64),
        Q::Big(r) => foldhash::fast::FixedState::with_seed(0).hash_one(r),
    }
}

fn mix(h: u64, x: u64) -> u64 {
    const K: u64 = 0x9e37_79b9_7f4a_7c15;
    (h.rotate_left(5) ^ x).wrapping_mul(K)
}

/// How many places [`hashed_groups`] finds in `f`.
pub(crate) fn places(f: &Form) -> usize {
    match f {
        Form::Product { factors, .. } => factors
            .iter()
            .map(|x| match x {
                Factor::Group(g) => 1 + places(g),
                _ => 0,
            })
            .sum(),
        Form::Sum(terms) => terms.iter().map(places).sum(),
        Form::Quotient(a, b) => places(a) + usize::from(matches!(**b, Form::Sum(_))) + places(b),
    }
}
