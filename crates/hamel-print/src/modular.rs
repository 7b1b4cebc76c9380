//! The check that a printed form is its canonical form, made cheap: both evaluated at a random
//! point, exactly, in the integers modulo the prime p = 2⁶¹ − 1.
//!
//! The check compares printed · denominator with numerator (· multiplier), polynomials in
//! the atoms of total degree d. Two different polynomials of degree at most d agree at a point
//! drawn uniformly from 𝔽ₚⁿ with probability at most d/p (Schwartz–Zippel), d · 4.4 · 10⁻¹⁹:
//! below 10⁻¹⁶ for any entry of degree under 200. A disagreement is certain; an agreement is
//! the identity but with that probability. Where the point hits a pole (a denominator, or a
//! coefficient's, that vanishes mod p) nothing is concluded and the caller falls back to
//! expanding ([`crate::Sheet::check`], exact, which the tests run on every entry of every seed
//! model). The point is drawn afresh for every sheet (a seed from the process's random hash
//! keys), so no fixed input can be made to pass; an atom's residue comes from the seed and
//! the atom's number alone, so that the canonical forms of a large sheet are evaluated on
//! printing's pool as they are read, and the printed forms after naming, at the same point.
//! Evaluation allocates nothing per term: the check is 2 % of printing, where expanding was 9
//! to 12 %.
//!
//! A sheet keeps a second point to tell its names apart (`Sheet::name_for`): two names whose
//! values differ there differ; names that agree there are compared exactly.

use std::hash::{BuildHasher, RandomState};

use num_traits::ToPrimitive;

use crate::factored::Factored;
use crate::form::{Definition, Factor, Form};
use crate::poly::Poly;
use crate::q::Q;

/// The modulus, a Mersenne prime.
const P: u64 = (1 << 61) - 1;

/// `a · b mod p`.
fn mul(a: u64, b: u64) -> u64 {
    let x = u128::from(a) * u128::from(b);
    // 2⁶¹ ≡ 1: fold the high bits onto the low ones.
    let folded = (x & u128::from(P)) + (x >> 61);
    reduce(u64::try_from(folded).unwrap_or(u64::MAX))
}

fn reduce(x: u64) -> u64 {
    let y = (x & P) + (x >> 61);
    if y >= P { y - P } else { y }
}

fn add(a: u64, b: u64) -> u64 {
    reduce(a + b)
}

fn neg(a: u64) -> u64 {
    if a == 0 { 0 } else { P - a }
}

fn pow(mut a: u64, mut n: u64) -> u64 {
    if n == 1 {
        return a;
    }
    let mut r = 1;
    while n > 0 {
        if n & 1 == 1 {
            r = mul(r, a);
        }
        a = mul(a, a);
        n >>= 1;
    }
    r
}

/// A signed machine integer mod p.
fn of_i64(n: i64) -> u64 {
    let m = reduce(n.unsigned_abs());
    if n < 0 { neg(m) } else { m }
}

/// A big integer mod p.
fn of_big(n: &num_bigint::BigInt) -> u64 {
    if let Some(small) = n.to_i64() {
        return of_i64(small);
    }
    let m = n % num_bigint::BigInt::from(P);
    of_i64(m.to_i64().expect("a residue fits"))
}

/// A value mod p kept as a fraction `(n, d)`, `d ≠ 0`, so that sums and quotients need no
/// inverse.
#[derive(Clone, Copy, Debug)]
pub(crate) struct V(u64, u64);

impl V {
    const ZERO: V = V(0, 1);

    fn plus(self, o: V) -> V {
        if self.1 == o.1 {
            return V(add(self.0, o.0), self.1);
        }
        V(add(mul(self.0, o.1), mul(o.0, self.1)), mul(self.1, o.1))
    }

    fn times(self, o: V) -> V {
        V(mul(self.0, o.0), mul(self.1, o.1))
    }

    /// `self / o`; none when `o` vanishes.
    fn over(self, o: V) -> Option<V> {
        (o.0 != 0).then(|| V(mul(self.0, o.1), mul(self.1, o.0)))
    }
}

/// Atom `i`'s residue at the point with `seed`: SplitMix64 from the seed and `i`, drawn
/// again until it lands in [1, p).
fn residue(seed: u64, i: usize) -> u64 {
    let mut state = seed ^ (i as u64).wrapping_mul(0xd1b5_4a32_d192_ed03);
    loop {
        state = state.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = state;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        let v = (z ^ (z >> 31)) >> 3;
        if v != 0 && v < P {
            return v;
        }
    }
}

/// A rational mod p; none when its denominator vanishes mod p.
fn of_q(q: &Q) -> Option<V> {
    let (n, d) = match q {
        Q::Small(n, d) => (of_i64(*n), of_i64(*d)),
        Q::Big(r) => (of_big(r.numer()), of_big(r.denom())),
    };
    (d != 0).then_some(V(n, d))
}

/// A point: a random residue for every atom (atom `i`'s drawn from the point's seed and `i`
/// alone, so that copies of a point on other threads agree), and the names' values there
/// (each computed once, when first met; a name's value never changes, whatever later naming
/// does to its definition's form).
#[derive(Clone, Debug)]
pub(crate) struct Point {
    seed: u64,
    atoms: Vec<u64>,
    named: Vec<Option<Option<V>>>,
    /// The values of groups shared between places, by address, when the forms valued stay as
    /// they are while the point is used ([`Point::keeping_groups`]).
    groups: Option<foldhash::HashMap<usize, Option<V>>>,
}

impl Point {
    /// A fresh random point (a new seed in each process and sheet).
    pub(crate) fn random() -> Point {
        Point {
            seed: RandomState::new().hash_one(0x0068_616d_656c_u64),
            atoms: Vec::new(),
            named: Vec::new(),
            groups: None,
        }
    }

    /// The same point, without the names' values (for the entries' canonical forms, which
    /// use none, on printing's pool).
    pub(crate) fn residues(&self) -> Point {
        Point {
            seed: self.seed,
            atoms: self.atoms.clone(),
            named: Vec::new(),
            groups: None,
        }
    }

    /// This point, keeping the value of each group that several places share (a memoised
    /// coefficient, a denominator's factor), by its address: for valuing forms that do not
    /// change while it is used.
    pub(crate) fn keeping_groups(mut self) -> Point {
        self.groups = Some(foldhash::HashMap::default());
        self
    }

    /// A group's value, kept when the group is shared and the point keeps groups.
    fn group(&mut self, g: &std::sync::Arc<Form>, names: &[Definition]) -> Option<V> {
        if std::sync::Arc::strong_count(g) == 1 || self.groups.is_none() {
            return self.form(g, names);
        }
        let address = std::sync::Arc::as_ptr(g) as usize;
        if let Some(v) = self.groups.as_ref().and_then(|k| k.get(&address)) {
            return *v;
        }
        let v = self.form(g, names);
        if let Some(kept) = &mut self.groups {
            kept.insert(address, v);
        }
        v
    }

    /// Atom `i`'s residue.
    fn atom(&mut self, i: usize) -> u64 {
        while self.atoms.len() <= i {
            let v = residue(self.seed, self.atoms.len());
            self.atoms.push(v);
        }
        self.atoms[i]
    }

    /// The value of a fraction with its denominator in factors; none at a pole.
    pub(crate) fn factored(&mut self, f: &Factored) -> Option<V> {
        let mut den = of_q(&f.scale)?;
        for (p, e) in &f.factors {
            let v = self.poly(p)?;
            for _ in 0..*e {
                den = den.times(v);
            }
        }
        self.poly(&f.num)?.over(den)
    }

    /// A polynomial's value; none if a coefficient's denominator vanishes.
    fn poly(&mut self, p: &Poly) -> Option<V> {
        let mut sum = V::ZERO;
        for (m, c) in p.terms() {
            let mut v = of_q(c)?;
            for (i, e) in m.pairs() {
                v.0 = mul(v.0, pow(self.atom(i), u64::from(e)));
            }
            sum = sum.plus(v);
        }
        Some(sum)
    }

    /// A form's value, `names` expanded; none at a pole.
    pub(crate) fn form(&mut self, f: &Form, names: &[Definition]) -> Option<V> {
        match f {
            Form::Product { coef, factors } => {
                let mut v = of_q(coef)?;
                for x in factors {
                    match x {
                        Factor::Atom { index, power } => {
                            v.0 = mul(v.0, pow(self.atom(*index), u64::from(*power)));
                        }
                        Factor::Group(g) => v = v.times(self.group(g, names)?),
                        Factor::Name { index } => v = v.times(self.name(*index, names)?),
                    }
                }
                Some(v)
            }
            Form::Sum(terms) => {
                let mut sum = V::ZERO;
                for t in terms {
                    sum = sum.plus(self.form(t, names)?);
                }
                Some(sum)
            }
            Form::Quotient(a, b) => self.form(a, names)?.over(self.form(b, names)?),
        }
    }

    /// Name `j`'s value; none at a pole.
    pub(crate) fn name(&mut self, j: usize, names: &[Definition]) -> Option<V> {
        if self.named.len() <= j {
            self.named.resize(j + 1, None);
        }
        if let Some(v) = self.named[j] {
            return v;
        }
        let v = self.form(&names[j].form, names);
        self.named[j] = Some(v);
        v
    }
}

/// Whether two values are equal.
pub(crate) fn equal(a: V, b: V) -> bool {
    mul(a.0, b.1) == mul(b.0, a.1)
}

/// Whether `form` (times `multiplier`'s inverse, when the entry was multiplied through) takes
/// the value `canonical` (its canonical form's, none at a pole) at the point: Some(true) or
/// Some(false) when decided, none at a pole.
pub(crate) fn agrees(
    point: &mut Point,
    names: &[Definition],
    form: &Form,
    multiplier: Option<&Form>,
    canonical: Option<V>,
) -> Option<bool> {
    let value = canonical?;
    let printed = point.form(form, names)?;
    let expected = match multiplier {
        Some(m) => value.times(point.form(m, names).filter(|v| v.0 != 0)?),
        None => value,
    };
    Some(equal(printed, expected))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn arithmetic_mod_the_mersenne_prime() {
        assert_eq!(mul(P - 1, P - 1), 1);
        assert_eq!(add(P - 1, 1), 0);
        assert_eq!(of_i64(-1), P - 1);
        // 2⁶³ = 4 · 2⁶¹ ≡ 4.
        assert_eq!(of_i64(i64::MAX), 3);
        assert_eq!(of_i64(i64::MIN), P - 4);
        for a in [2, 3, 12345, P - 2] {
            assert_eq!(mul(a, pow(a, P - 2)), 1);
        }
        let big = num_bigint::BigInt::from(P) * 3 + 5;
        assert_eq!(of_big(&big), 5);
        assert_eq!(of_big(&-big), P - 5);
        // 1/2 + 1/3 = 5/6, compared crosswise.
        let v = V(1, 2).plus(V(1, 3));
        assert_eq!(mul(v.0, 6), mul(5, v.1));
        assert!(V(1, 1).over(V::ZERO).is_none());
    }

    /// A polynomial's value is the sum of its terms' values; copies of a point agree on
    /// every atom.
    #[test]
    fn a_polynomial_is_the_sum_of_its_terms() {
        use crate::poly::Mono;
        let monomials: [&[(usize, u32)]; 7] = [
            &[],
            &[(0, 1)],
            &[(0, 1), (1, 2)],
            &[(0, 1), (1, 2), (4, 1)],
            &[(0, 1), (2, 1)],
            &[(0, 3), (2, 1)],
            &[(3, 5), (4, 1)],
        ];
        let terms = monomials
            .iter()
            .zip(1_i64..)
            .map(|(m, c)| (Mono::from_pairs(m.iter().copied()), Q::from(c * c - 20)))
            .collect();
        let p = Poly::from_terms(terms);
        let mut point = Point::random();
        let copy = point.residues();
        let mut expected = V::ZERO;
        for (m, c) in p.terms() {
            let mut v = of_q(c).unwrap();
            for (i, e) in m.pairs() {
                v = v.times(V(pow(point.atom(i), u64::from(e)), 1));
            }
            expected = expected.plus(v);
        }
        assert!(equal(point.poly(&p).unwrap(), expected));
        let mut copy = copy;
        assert!(equal(copy.poly(&p).unwrap(), expected));
        assert_eq!(copy.atoms, point.atoms);
    }
}
