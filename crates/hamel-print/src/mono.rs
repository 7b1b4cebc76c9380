//! Monomials: `(atom, exponent)` pairs, sorted by atom, each packed in one 32-bit word.
//!
//! A pair is packed as `atom << 16 | exponent`: the words order as the pairs do, and a
//! monomial compares, hashes and tests equal as one slice of machine integers. A monomial
//! holds eight pairs inline, in 40 bytes (a term of a polynomial, with its coefficient, is
//! one cache line): half what a word per pair of 64 bits took, and printing is mostly moving
//! terms about.
//!
//! An atom index or an exponent is stored up to [`MAX`] − 1; one of [`MAX`] or more is
//! stored as [`MAX`], which means "this large or larger" ([`Mono::is_exact`]). Nothing
//! overflows: sums of exponents saturate at [`MAX`]. What printing reads is checked exact
//! (`PolyError::TooLarge`: no mechanical model comes near 65,535 atoms on one sheet or an
//! exponent of 65,535), and printing makes its forms by dividing and splitting what it read,
//! so a printed form is always exact; only a product of what was read (the exact check's
//! expansions) could saturate.

use smallvec::SmallVec;

/// A monomial: `(atom, exponent)` pairs, sorted by atom, each atom once, exponents ≥ 1.
#[derive(Debug, Default, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct Mono(Words);

/// A monomial's pairs, packed.
type Words = SmallVec<[u32; 8]>;

/// The stored value of an atom index or exponent this large or larger.
pub const MAX: u32 = 0xFFFF;

/// The pair `(i, e)` in one word, `i` high, so that words order as pairs do; each saturated
/// at [`MAX`].
fn pack(i: u32, e: u32) -> u32 {
    (i.min(MAX) << 16) | e.min(MAX)
}

/// A packed pair as `(i, e)`.
fn unpack(p: u32) -> (u32, u32) {
    (p >> 16, p & MAX)
}

/// An atom's index as a monomial stores it (saturated in [`pack`]).
fn stored(i: usize) -> u32 {
    u32::try_from(i).unwrap_or(u32::MAX)
}

impl Clone for Mono {
    /// The words copied whole (smallvec's own clone pushes them one at a time: a monomial is
    /// cloned for every term that collection moves).
    fn clone(&self) -> Mono {
        Mono(Words::from_slice(&self.0))
    }
}

impl Mono {
    /// The atom `i` to the first power.
    pub fn atom(i: usize) -> Mono {
        Mono::from_pairs([(i, 1)])
    }

    /// The monomial with these `(atom, exponent)` pairs, given sorted by atom, each atom
    /// once, exponents ≥ 1.
    pub fn from_pairs(pairs: impl IntoIterator<Item = (usize, u32)>) -> Mono {
        Mono(pairs.into_iter().map(|(i, e)| pack(stored(i), e)).collect())
    }

    /// The monomial with these `(atom, exponent)` pairs, in any order, an atom possibly more
    /// than once (its exponents added).
    pub(crate) fn from_unsorted(pairs: impl IntoIterator<Item = (usize, u32)>) -> Mono {
        Mono::from_packed(
            pairs
                .into_iter()
                .map(|(i, e)| Mono::pack_pair(i, e))
                .collect(),
        )
    }

    /// The monomial of the words of [`Mono::pack_pair`]s, in any order, an atom possibly more
    /// than once (its exponents added).
    pub(crate) fn from_packed(mut words: Words) -> Mono {
        merge(&mut words);
        Mono(words)
    }

    /// The pair `(i, e)` as [`Mono::from_packed`] takes it.
    pub(crate) fn pack_pair(i: usize, e: u32) -> u32 {
        pack(stored(i), e)
    }

    /// Whether every atom index and exponent is below [`MAX`] (none saturated).
    pub fn is_exact(&self) -> bool {
        self.0.iter().all(|&p| p < MAX << 16 && p & MAX != MAX)
    }

    /// The `(atom, exponent)` pairs, sorted by atom.
    pub fn pairs(&self) -> impl ExactSizeIterator<Item = (usize, u32)> + Clone + '_ {
        self.0.iter().map(|&p| {
            let (i, e) = unpack(p);
            (i as usize, e)
        })
    }

    /// The atoms, in order.
    pub fn atoms(&self) -> impl ExactSizeIterator<Item = usize> + Clone + '_ {
        self.0.iter().map(|&p| unpack(p).0 as usize)
    }

    /// Whether this is the monomial 1 (no atom).
    pub fn is_one(&self) -> bool {
        self.0.is_empty()
    }

    /// The product of two monomials (a merge of the sorted pairs).
    pub fn mul(&self, other: &Mono) -> Mono {
        let (a, b) = (&self.0, &other.0);
        let mut out = Words::with_capacity(a.len() + b.len());
        let (mut i, mut j) = (0, 0);
        while i < a.len() && j < b.len() {
            let ((x, e), (y, f)) = (unpack(a[i]), unpack(b[j]));
            match x.cmp(&y) {
                std::cmp::Ordering::Less => {
                    out.push(a[i]);
                    i += 1;
                }
                std::cmp::Ordering::Greater => {
                    out.push(b[j]);
                    j += 1;
                }
                std::cmp::Ordering::Equal => {
                    out.push(pack(x, e + f));
                    i += 1;
                    j += 1;
                }
            }
        }
        out.extend_from_slice(&a[i..]);
        out.extend_from_slice(&b[j..]);
        Mono(out)
    }

    /// `self / other`, when `other` divides `self`.
    pub fn div(&self, other: &Mono) -> Option<Mono> {
        let mut out = Words::with_capacity(self.0.len());
        let mut theirs = other.0.iter().map(|&p| unpack(p)).peekable();
        for (i, e) in self.0.iter().map(|&p| unpack(p)) {
            let f = match theirs.peek() {
                Some(&(k, f)) if k == i => {
                    theirs.next();
                    f
                }
                Some(&(k, _)) if k < i => return None,
                _ => 0,
            };
            let left = e.checked_sub(f)?;
            if left > 0 {
                out.push(pack(i, left));
            }
        }
        theirs.next().is_none().then_some(Mono(out))
    }

    /// `self` made the greatest common divisor of itself and `other`, in place.
    pub(crate) fn retain_common(&mut self, other: &Mono) {
        let mut theirs = other.0.iter().map(|&p| unpack(p)).peekable();
        let mut kept = 0;
        for k in 0..self.0.len() {
            let (i, e) = unpack(self.0[k]);
            while theirs.next_if(|&(j, _)| j < i).is_some() {}
            if let Some((_, f)) = theirs.next_if(|&(j, _)| j == i) {
                self.0[kept] = pack(i, e.min(f));
                kept += 1;
            }
        }
        self.0.truncate(kept);
    }

    /// The exponent of atom `i`.
    pub fn exponent(&self, i: usize) -> u32 {
        self.pairs().find(|&(a, _)| a == i).map_or(0, |(_, e)| e)
    }

    /// [`Mono::split`] of `self / g` (`g` divides `self`), without making the quotient.
    pub(crate) fn split_divided(&self, g: &Mono, keep: impl Fn(usize) -> bool) -> (Mono, Mono) {
        if g.is_one() {
            return self.split(keep);
        }
        let (mut kept, mut rest) = (Words::new(), Words::new());
        let mut theirs = g.0.iter().map(|&p| unpack(p)).peekable();
        for (i, e) in self.0.iter().map(|&p| unpack(p)) {
            let f = theirs.next_if(|&(k, _)| k == i).map_or(0, |(_, f)| f);
            let left = e - f;
            if left == 0 {
                continue;
            }
            if keep(i as usize) {
                kept.push(pack(i, left));
            } else {
                rest.push(pack(i, left));
            }
        }
        (Mono(kept), Mono(rest))
    }

    /// The part made of atoms for which `keep` holds, and the rest (their product is
    /// `self`).
    pub(crate) fn split(&self, keep: impl Fn(usize) -> bool) -> (Mono, Mono) {
        let (mut kept, mut rest) = (Words::new(), Words::new());
        for &p in &self.0 {
            if keep(unpack(p).0 as usize) {
                kept.push(p);
            } else {
                rest.push(p);
            }
        }
        (Mono(kept), Mono(rest))
    }
}

/// Packed pairs sorted by atom, an atom's pairs merged into one (exponents added): a
/// monomial's pairs from factors met in any order.
fn merge(words: &mut Words) {
    words.sort_unstable();
    words.dedup_by(|later, earlier| {
        let ((i, e), (j, f)) = (unpack(*later), unpack(*earlier));
        if i != j {
            return false;
        }
        *earlier = pack(i, e + f);
        true
    });
}

#[cfg(test)]
mod tests {
    use super::{MAX, Mono, pack, unpack};

    /// Packed pairs order as the pairs do (what keeps a polynomial's terms, and so the
    /// printed forms, in the order they had), and unpack to themselves.
    #[test]
    fn packed_pairs_order_as_pairs() {
        let values = [0, 1, 2, 7, 255, 0x7FFF, MAX - 1];
        let pairs: Vec<(u32, u32)> = values
            .iter()
            .flat_map(|&i| values.iter().map(move |&e| (i, e)))
            .collect();
        for &a in &pairs {
            assert_eq!(unpack(pack(a.0, a.1)), a);
            for &b in &pairs {
                assert_eq!(
                    pack(a.0, a.1).cmp(&pack(b.0, b.1)),
                    a.cmp(&b),
                    "{a:?} {b:?}"
                );
            }
        }
    }

    /// An atom index or exponent of [`MAX`] or more saturates, and says so: nothing
    /// overflows into the next pair, and exact monomials stay exact through what printing
    /// does to them (dividing, splitting, common divisors).
    #[test]
    fn large_pairs_saturate_and_say_so() {
        let x = |e: u32| Mono::from_pairs([(3, e), (5, 1)]);
        assert!(x(MAX - 1).is_exact());
        let big = x(MAX - 1).mul(&x(2));
        assert_eq!(big.pairs().collect::<Vec<_>>(), [(3, MAX), (5, 2)]);
        assert!(!big.is_exact());
        assert!(!Mono::from_pairs([(70_000, 1)]).is_exact());
        assert!(!Mono::from_unsorted([(1, MAX - 1), (1, 1)]).is_exact());
        assert_eq!(Mono::from_unsorted([(5, 1), (3, 2), (3, 1)]), x(3));
        let (kept, rest) = x(40).split_divided(&Mono::from_pairs([(3, 8)]), |i| i == 3);
        assert_eq!((kept, rest), (Mono::from_pairs([(3, 32)]), Mono::atom(5)));
        let mut common = x(40);
        common.retain_common(&x(7));
        assert_eq!(common, x(7));
    }
}
