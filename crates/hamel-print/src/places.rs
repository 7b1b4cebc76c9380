//! The places of a sheet's groups ([`Sheet::candidates`](crate::Sheet)): every group of the
//! entries, outer before inner, each with a hash of its form made bottom-up, so that counting
//! equal groups hashes each form once instead of once per group that holds it.

use std::hash::{BuildHasher, Hash, Hasher};

use crate::form::{Factor, Form};
use crate::q::Q;

/// A group's place ([`hashed_groups`]): its form with its hash, and where its inner places
/// end. Hashed by the hash, compared by the form.
#[derive(Clone, Copy)]
pub(crate) struct Keyed<'a> {
    pub(crate) hash: u64,
    pub(crate) form: &'a Form,
    /// The index after its last inner place.
    pub(crate) end: usize,
}

impl Hash for Keyed<'_> {
    fn hash<H: Hasher>(&self, state: &mut H) {
        state.write_u64(self.hash);
    }
}

impl PartialEq for Keyed<'_> {
    fn eq(&self, other: &Self) -> bool {
        self.hash == other.hash && self.form == other.form
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

/// `g` as a place: listed before its inner groups, its hash and end filled in after them.
pub(crate) fn place<'a>(g: &'a Form, out: &mut Vec<Keyed<'a>>) -> u64 {
    let slot = out.len();
    out.push(Keyed {
        hash: 0,
        form: g,
        end: 0,
    });
    let hash = hashed_groups(g, out);
    out[slot].hash = hash;
    out[slot].end = out.len();
    hash
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
