//! The places of a sheet's groups ([`Sheet::candidates`](crate::Sheet)): every group of the
//! entries, outer before inner, each with a hash of its form made bottom-up, so that counting
//! equal groups hashes each form once instead of once per group that holds it.

use std::hash::{BuildHasher, Hash, Hasher};

use crate::form::{Factor, Form};
use crate::q::Q;

/// A group's place ([`hashed_groups`]): its form with its hash, where its inner places end,
/// and whether a velocity occurs in it. Hashed by the hash, compared by the form.
#[derive(Clone, Copy)]
pub(crate) struct Keyed<'a> {
    pub(crate) hash: u64,
    pub(crate) form: &'a Form,
    /// The index after its last inner place.
    pub(crate) end: usize,
    pub(crate) velocity: bool,
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
/// the hash of `f`, and whether a velocity occurs in it (in an atom or a name of its, as
/// `velocity` says). Equal forms have equal hashes.
pub(crate) fn hashed_groups<'a>(
    f: &'a Form,
    out: &mut Vec<Keyed<'a>>,
    velocity: &dyn Fn(&Factor) -> bool,
) -> (u64, bool) {
    match f {
        Form::Product { coef, factors } => {
            let (mut h, mut v) = (mix(q_hash(coef), 1), false);
            for x in factors {
                let (hx, vx) = match x {
                    Factor::Atom { index, power } => {
                        (mix(*index as u64, u64::from(*power)), velocity(x))
                    }
                    Factor::Group(g) => place(g, out, velocity),
                    Factor::Name { index } => (mix(*index as u64, 2), velocity(x)),
                };
                h = mix(h, hx);
                v |= vx;
            }
            (h, v)
        }
        Form::Sum(terms) => terms.iter().fold((3, false), |(h, v), t| {
            let (ht, vt) = hashed_groups(t, out, velocity);
            (mix(h, ht), v || vt)
        }),
        Form::Quotient(a, b) => {
            let a = hashed_groups(a, out, velocity);
            let b = if matches!(**b, Form::Sum(_)) {
                place(b, out, velocity)
            } else {
                hashed_groups(b, out, velocity)
            };
            (mix(mix(a.0, 4), b.0), a.1 || b.1)
        }
    }
}

/// `g` as a place: listed before its inner groups, its hash, end and velocity filled in after
/// them.
pub(crate) fn place<'a>(
    g: &'a Form,
    out: &mut Vec<Keyed<'a>>,
    velocity: &dyn Fn(&Factor) -> bool,
) -> (u64, bool) {
    let slot = out.len();
    out.push(Keyed {
        hash: 0,
        form: g,
        end: 0,
        velocity: false,
    });
    let (hash, v) = hashed_groups(g, out, velocity);
    out[slot].hash = hash;
    out[slot].end = out.len();
    out[slot].velocity = v;
    (hash, v)
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
