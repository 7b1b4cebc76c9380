//! Collection's memos: polynomials and what collection made of them, found by the
//! polynomial's terms wherever they lie.
//!
//! A memo is keyed by a hash of the terms, made once per lookup (not again when the table
//! grows), and holds the polynomials with that hash. A lookup reads the terms where they are
//! (a group's coefficient is a run of a sorted vector of terms): a polynomial is made only
//! for what is new to the memo, which keeps it.

use std::hash::{BuildHasher, Hash, Hasher};

use foldhash::HashMap;
use smallvec::SmallVec;

use crate::poly::{Mono, Poly};
use crate::q::Q;

/// Polynomials and their values, by the hash of their terms.
pub(crate) struct Memo<V> {
    by_hash: HashMap<u64, SmallVec<[(Poly, V); 1]>>,
}

impl<V> Default for Memo<V> {
    fn default() -> Memo<V> {
        Memo {
            by_hash: HashMap::default(),
        }
    }
}

impl<V: Clone> Memo<V> {
    /// The value kept for the polynomial with these terms (in monomial order), and their
    /// hash (what [`Memo::insert`] takes) whether or not one is kept.
    pub(crate) fn get<'t, T>(&self, terms: T) -> (u64, Option<V>)
    where
        T: Iterator<Item = (&'t Mono, &'t Q)> + Clone,
    {
        let hash = hash_of(terms.clone());
        let kept = self.by_hash.get(&hash).and_then(|same| {
            same.iter()
                .find(|(p, _)| same_terms(p, terms.clone()))
                .map(|(_, v)| v.clone())
        });
        (hash, kept)
    }

    /// Keeps `v` for `p`, whose terms hash to `hash` ([`Memo::get`]).
    pub(crate) fn insert(&mut self, hash: u64, p: Poly, v: V) {
        self.by_hash.entry(hash).or_default().push((p, v));
    }
}

/// Whether `p` has these terms.
fn same_terms<'t>(p: &Poly, terms: impl Iterator<Item = (&'t Mono, &'t Q)>) -> bool {
    let mut mine = p.terms();
    for (n, d) in terms {
        match mine.next() {
            Some((m, c)) if m == n && c == d => {}
            _ => return false,
        }
    }
    mine.next().is_none()
}

/// The hash of a polynomial's terms.
fn hash_of<'t>(terms: impl Iterator<Item = (&'t Mono, &'t Q)>) -> u64 {
    let mut state = foldhash::fast::FixedState::with_seed(0).build_hasher();
    for (m, c) in terms {
        m.hash(&mut state);
        c.hash(&mut state);
    }
    state.finish()
}

#[cfg(test)]
mod tests {
    use super::Memo;
    use crate::poly::{Mono, Poly};
    use crate::q::Q;

    /// A polynomial is found by its terms wherever they lie, and only by equal terms: two
    /// polynomials kept under one hash are told apart.
    #[test]
    fn memo_finds_polynomials_by_their_terms() {
        let p = Poly::from_terms(vec![(Mono::atom(0), Q::one()), (Mono::atom(1), Q::from(2))]);
        let q = Poly::from_terms(vec![(Mono::atom(0), Q::one()), (Mono::atom(1), Q::from(3))]);
        let mut memo: Memo<&str> = Memo::default();
        let (hash, kept) = memo.get(p.terms());
        assert_eq!(kept, None);
        memo.insert(hash, p.clone(), "p");
        // q kept under p's hash, as a colliding polynomial would be.
        memo.insert(hash, q.clone(), "q");
        let run = [
            (Mono::atom(7), Mono::atom(0), Q::one()),
            (Mono::atom(7), Mono::atom(1), Q::from(2)),
        ];
        assert_eq!(
            memo.get(run.iter().map(|(_, m, c)| (m, c))),
            (hash, Some("p"))
        );
        assert_eq!(memo.get(p.terms()).1, Some("p"));
        assert_eq!(memo.get(q.terms()).1, None, "q's own hash differs from p's");
    }
}
