//! The places of a sheet's groups (`naming.rs`): every group of the entries, outer before
//! inner, each with a hash of its form made bottom-up (each form is hashed once, not once per
//! group that holds it), where its inner places end, and whether a velocity occurs in it; and
//! the places' kinds ([`kinds`]): equal forms share one, found inner places first so that two
//! forms are compared down to their groups only.

use std::hash::BuildHasher;
use std::sync::Arc;

use foldhash::HashMap;
use smallvec::SmallVec;

use crate::form::{Factor, Form};
use crate::q::Q;

/// A group's place ([`hashed_groups`]): its form with its hash, where its inner places end,
/// and whether a velocity occurs in it.
#[derive(Clone, Copy)]
pub(crate) struct Keyed<'a> {
    pub(crate) hash: u64,
    pub(crate) form: &'a Form,
    /// The index after its last inner place.
    pub(crate) end: usize,
    pub(crate) velocity: bool,
}

/// Finds the places of one form's groups ([`Places::hashed_groups`]), in `out`.
pub(crate) struct Places<'a, 'v> {
    pub(crate) out: Vec<Keyed<'a>>,
    velocity: &'v dyn Fn(&Factor) -> bool,
    /// The first place of each group shared by several (one `Arc`), by address: its later
    /// places copy its inner places instead of walking it again.
    shared: HashMap<usize, usize>,
}

impl<'a, 'v> Places<'a, 'v> {
    /// None found yet; `velocity` says whether a velocity occurs in an atom or a name.
    pub(crate) fn new(velocity: &'v dyn Fn(&Factor) -> bool) -> Places<'a, 'v> {
        Places {
            out: Vec::new(),
            velocity,
            shared: HashMap::default(),
        }
    }

    /// The places of an entry `f` (a sum is a place itself).
    pub(crate) fn entry(&mut self, f: &'a Form) {
        if matches!(f, Form::Sum(_)) {
            self.place(f);
        } else {
            self.hashed_groups(f);
        }
    }

    /// Every group of `f`, outer before inner (the sums in parentheses, and the denominators
    /// that are sums: the places of [`Sheet::candidates`](crate::Sheet)), each with its hash;
    /// returns the hash of `f`, and whether a velocity occurs in it. Equal forms have equal
    /// hashes.
    pub(crate) fn hashed_groups(&mut self, f: &'a Form) -> (u64, bool) {
        match f {
            Form::Product { coef, factors } => {
                let (mut h, mut v) = (mix(q_hash(coef), 1), false);
                for x in factors {
                    let (hx, vx) = match x {
                        Factor::Atom { index, power } => {
                            (mix(*index as u64, u64::from(*power)), (self.velocity)(x))
                        }
                        Factor::Group(g) if Arc::strong_count(g) > 1 => self.place_shared(g),
                        Factor::Group(g) => self.place(g),
                        Factor::Name { index } => (mix(*index as u64, 2), (self.velocity)(x)),
                    };
                    h = mix(h, hx);
                    v |= vx;
                }
                (h, v)
            }
            Form::Sum(terms) => terms.iter().fold((3, false), |(h, v), t| {
                let (ht, vt) = self.hashed_groups(t);
                (mix(h, ht), v || vt)
            }),
            Form::Quotient(a, b) => {
                let a = self.hashed_groups(a);
                let b = if matches!(**b, Form::Sum(_)) {
                    self.place(b)
                } else {
                    self.hashed_groups(b)
                };
                (mix(mix(a.0, 4), b.0), a.1 || b.1)
            }
        }
    }

    /// `g` as a place: listed before its inner groups, its hash, end and velocity filled in
    /// after them.
    pub(crate) fn place(&mut self, g: &'a Form) -> (u64, bool) {
        let slot = self.out.len();
        self.out.push(Keyed {
            hash: 0,
            form: g,
            end: 0,
            velocity: false,
        });
        let (hash, v) = self.hashed_groups(g);
        let end = self.out.len();
        let k = &mut self.out[slot];
        (k.hash, k.end, k.velocity) = (hash, end, v);
        (hash, v)
    }

    /// [`Places::place`] of a group that several places share: its first place walked, the
    /// later ones copied from it.
    fn place_shared(&mut self, g: &'a Arc<Form>) -> (u64, bool) {
        let address = Arc::as_ptr(g) as usize;
        let Some(&first) = self.shared.get(&address) else {
            self.shared.insert(address, self.out.len());
            return self.place(g);
        };
        let (end, offset) = (self.out[first].end, self.out.len() - first);
        for i in first..end {
            let k = self.out[i];
            self.out.push(Keyed {
                end: k.end + offset,
                ..k
            });
        }
        (self.out[first].hash, self.out[first].velocity)
    }
}

/// Each place's kind: places whose forms are equal share one, numbered as met from the last
/// place back. Inner places are met first, so two forms of equal hash are compared down to
/// their groups only, whose kinds are known by then: each form is walked about once, not once
/// per group that holds it.
pub(crate) fn kinds(found: &[Keyed<'_>]) -> Vec<usize> {
    let mut kind = vec![usize::MAX; found.len()];
    let mut first: Vec<usize> = Vec::new();
    let mut by_hash: HashMap<u64, SmallVec<[usize; 1]>> = HashMap::default();
    by_hash.reserve(found.len());
    for p in (0..found.len()).rev() {
        let bucket = by_hash.entry(found[p].hash).or_default();
        let known = bucket
            .iter()
            .copied()
            .find(|&k| same(found, &kind, first[k], p));
        kind[p] = known.unwrap_or_else(|| {
            first.push(p);
            bucket.push(first.len() - 1);
            first.len() - 1
        });
    }
    kind
}

/// Whether the forms at places `a` and `b` are equal, their groups' kinds known.
fn same(found: &[Keyed<'_>], kind: &[usize], a: usize, b: usize) -> bool {
    let (mut next_a, mut next_b) = (a + 1, b + 1);
    // One group shared by two places (collection shares a coefficient or a factor that
    // recurs) is equal to itself.
    std::ptr::eq(found[a].form, found[b].form)
        || found[a].end - a == found[b].end - b
            && Walk { found, kind }.equal(found[a].form, &mut next_a, found[b].form, &mut next_b)
}

/// Two forms walked side by side, each with the place its next group has.
struct Walk<'k, 'a> {
    found: &'k [Keyed<'a>],
    kind: &'k [usize],
}

impl Walk<'_, '_> {
    fn equal(&self, f: &Form, nf: &mut usize, g: &Form, ng: &mut usize) -> bool {
        match (f, g) {
            (
                Form::Product { coef, factors },
                Form::Product {
                    coef: other,
                    factors: theirs,
                },
            ) => {
                coef == other
                    && factors.len() == theirs.len()
                    && factors.iter().zip(theirs).all(|pair| match pair {
                        (Factor::Group(_), Factor::Group(_)) => self.group(nf, ng),
                        (x, y) => x == y,
                    })
            }
            (Form::Sum(ts), Form::Sum(us)) => {
                ts.len() == us.len() && ts.iter().zip(us).all(|(t, u)| self.equal(t, nf, u, ng))
            }
            (Form::Quotient(a, b), Form::Quotient(c, d)) => {
                self.equal(a, nf, c, ng)
                    && match (matches!(**b, Form::Sum(_)), matches!(**d, Form::Sum(_))) {
                        (true, true) => self.group(nf, ng),
                        (false, false) => self.equal(b, nf, d, ng),
                        _ => false,
                    }
            }
            _ => false,
        }
    }

    /// Whether the groups at places `*nf` and `*ng` are of one kind; both moved past them.
    fn group(&self, nf: &mut usize, ng: &mut usize) -> bool {
        let (p, q) = (*nf, *ng);
        *nf = self.found[p].end;
        *ng = self.found[q].end;
        self.kind[p] == self.kind[q]
    }
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
