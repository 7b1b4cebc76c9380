//! Rational coefficients that stay machine integers while they fit: the coefficients of the
//! printing polynomials are almost all small, and a big rational's every operation allocates
//! and takes a gcd of big integers. Exact either way: an operation whose result does not fit
//! is done in big integers.

use hamel_expr::Rational;
use num_bigint::BigInt;
use num_integer::Integer;
use num_traits::{One, Signed, ToPrimitive, Zero};

/// An exact rational. Canonical: `Small(n, d)` with `d > 0` and gcd(n, d) = 1 whenever both
/// fit in an `i64`, `Big` only when they do not, so the derived equality, order and hash are
/// those of the value (the order is a total order, not the numeric one).
#[derive(Clone, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Q {
    /// `n / d` in machine integers.
    Small(i64, i64),
    /// Anything larger (boxed, so that a coefficient is three words).
    Big(Box<Rational>),
}

impl Q {
    /// Zero.
    pub fn zero() -> Q {
        Q::Small(0, 1)
    }

    /// One.
    pub fn one() -> Q {
        Q::Small(1, 1)
    }

    /// Whether this is zero.
    pub fn is_zero(&self) -> bool {
        matches!(self, Q::Small(0, _))
    }

    /// Whether this is one.
    pub fn is_one(&self) -> bool {
        matches!(self, Q::Small(1, 1))
    }

    /// Whether this is negative.
    pub fn is_negative(&self) -> bool {
        match self {
            Q::Small(n, _) => *n < 0,
            Q::Big(r) => r.is_negative(),
        }
    }

    /// Whether this is positive.
    pub fn is_positive(&self) -> bool {
        match self {
            Q::Small(n, _) => *n > 0,
            Q::Big(r) => r.is_positive(),
        }
    }

    /// Whether this is an integer.
    pub fn is_integer(&self) -> bool {
        match self {
            Q::Small(_, d) => *d == 1,
            Q::Big(r) => r.is_integer(),
        }
    }

    /// Whether this is 1 or −1.
    pub fn is_unit(&self) -> bool {
        matches!(self, Q::Small(1 | -1, 1))
    }

    /// The value as a big rational.
    pub fn to_rational(&self) -> Rational {
        match self {
            Q::Small(n, d) => Rational::new_raw(BigInt::from(*n), BigInt::from(*d)),
            Q::Big(r) => (**r).clone(),
        }
    }

    /// The canonical form of `n / d` (`d ≠ 0`) given in 128-bit integers.
    fn from_i128(n: i128, d: i128) -> Q {
        if d == 1
            && let Ok(n) = i64::try_from(n)
        {
            return Q::Small(n, 1);
        }
        let g = n.gcd(&d);
        let (mut n, mut d) = (n / g, d / g);
        if d < 0 {
            n = -n;
            d = -d;
        }
        match (i64::try_from(n), i64::try_from(d)) {
            (Ok(n), Ok(d)) => Q::Small(n, d),
            _ => Q::Big(Box::new(Rational::new(BigInt::from(n), BigInt::from(d)))),
        }
    }

    /// `(n, d)` as 128-bit integers, when small.
    fn small(&self) -> Option<(i128, i128)> {
        match self {
            Q::Small(n, d) => Some((i128::from(*n), i128::from(*d))),
            Q::Big(_) => None,
        }
    }

    /// `self + other`.
    pub fn add(&self, other: &Q) -> Q {
        if let (Q::Small(a, 1), Q::Small(c, 1)) = (self, other)
            && let Some(n) = a.checked_add(*c)
        {
            return Q::Small(n, 1);
        }
        if let (Some((a, b)), Some((c, d))) = (self.small(), other.small()) {
            if b == 1 && d == 1 {
                return Q::from_i128(a + c, 1);
            }
            if let Some(n) = a
                .checked_mul(d)
                .zip(c.checked_mul(b))
                .and_then(|(x, y)| x.checked_add(y))
            {
                return Q::from_i128(n, b * d);
            }
        }
        Q::from(self.to_rational() + other.to_rational())
    }

    /// `self · other`.
    pub fn mul(&self, other: &Q) -> Q {
        if self.is_one() {
            return other.clone();
        }
        if other.is_one() {
            return self.clone();
        }
        if let (Q::Small(a, b), Q::Small(c, d)) = (self, other) {
            return mul_small(*a, *b, *c, *d).unwrap_or_else(|| {
                Q::from_i128(
                    i128::from(*a) * i128::from(*c),
                    i128::from(*b) * i128::from(*d),
                )
            });
        }
        Q::from(self.to_rational() * other.to_rational())
    }

    /// `-self`.
    pub fn neg(&self) -> Q {
        match self {
            Q::Small(n, d) if *n != i64::MIN => Q::Small(-n, *d),
            _ => Q::from(-self.to_rational()),
        }
    }

    /// `1 / self` (`self ≠ 0`).
    pub fn recip(&self) -> Q {
        match self {
            // Already in lowest terms: only the sign moves.
            Q::Small(n, d) if *n > 0 => Q::Small(*d, *n),
            Q::Small(n, d) if *n != i64::MIN => Q::Small(-d, -n),
            _ => Q::from(self.to_rational().recip()),
        }
    }

    /// `self / other` (`other ≠ 0`).
    pub fn div(&self, other: &Q) -> Q {
        self.mul(&other.recip())
    }

    /// The content of a list of coefficients: gcd of the numerators over lcm of the
    /// denominators (positive; zero for none).
    pub fn content<'a>(qs: impl Iterator<Item = &'a Q> + Clone) -> Q {
        let small: Option<(u64, u64)> = qs.clone().try_fold((0u64, 1u64), |(g, l), q| {
            let Q::Small(n, d) = q else { return None };
            let d = d.unsigned_abs();
            let l = l.checked_mul(d / gcd(l, d))?;
            Some((gcd(g, n.unsigned_abs()), l))
        });
        match small {
            // A prime of l divides some denominator, so not its numerator, so not g: g/l is
            // in lowest terms.
            Some((g, l)) if g != 0 => match (i64::try_from(g), i64::try_from(l)) {
                (Ok(g), Ok(l)) => Q::Small(g, l),
                _ => Q::from_i128(i128::from(g), i128::from(l)),
            },
            Some(_) => Q::zero(),
            None => {
                let (g, l) = qs.fold((BigInt::zero(), BigInt::one()), |(g, l), q| {
                    let r = q.to_rational();
                    (g.gcd(r.numer()), l.lcm(r.denom()))
                });
                if g.is_zero() {
                    Q::zero()
                } else {
                    Q::from(Rational::new(g, l))
                }
            }
        }
    }
}

/// `(a/b)·(c/d)` of two canonical small rationals, when it is small: each numerator reduced
/// against the other's denominator first, so the product is in lowest terms.
fn mul_small(a: i64, b: i64, c: i64, d: i64) -> Option<Q> {
    if a == 0 || c == 0 {
        return Some(Q::zero());
    }
    // An integer's denominator shares nothing (most coefficients are integers).
    let g1 = if d == 1 {
        1
    } else {
        i64::try_from(gcd(a.unsigned_abs(), d.unsigned_abs())).ok()?
    };
    let g2 = if b == 1 {
        1
    } else {
        i64::try_from(gcd(c.unsigned_abs(), b.unsigned_abs())).ok()?
    };
    let n = (a / g1).checked_mul(c / g2)?;
    let den = (b / g2).checked_mul(d / g1)?;
    Some(Q::Small(n, den))
}

/// The greatest common divisor (binary: no division); gcd(0, n) = n.
fn gcd(mut a: u64, mut b: u64) -> u64 {
    if a == 0 || b == 0 {
        return a | b;
    }
    // A content reaches one after a term or two: what follows is then one at once.
    if a == 1 || b == 1 {
        return 1;
    }
    let shift = (a | b).trailing_zeros();
    a >>= a.trailing_zeros();
    loop {
        b >>= b.trailing_zeros();
        if a > b {
            std::mem::swap(&mut a, &mut b);
        }
        b -= a;
        if b == 0 {
            return a << shift;
        }
    }
}

impl From<Rational> for Q {
    fn from(r: Rational) -> Q {
        match (r.numer().to_i64(), r.denom().to_i64()) {
            (Some(n), Some(d)) => Q::Small(n, d),
            _ => Q::Big(Box::new(r)),
        }
    }
}

impl From<&Rational> for Q {
    fn from(r: &Rational) -> Q {
        // Read without cloning the big integers (a canonical form's every term has one).
        match (r.numer().to_i64(), r.denom().to_i64()) {
            (Some(n), Some(d)) => Q::Small(n, d),
            _ => Q::Big(Box::new(r.clone())),
        }
    }
}

impl Q {
    /// The integer `n`.
    pub fn integer(n: &BigInt) -> Q {
        match n.to_i64() {
            Some(n) => Q::Small(n, 1),
            None => Q::Big(Box::new(Rational::from_integer(n.clone()))),
        }
    }
}

impl From<i64> for Q {
    fn from(n: i64) -> Q {
        Q::Small(n, 1)
    }
}

impl From<&hamel_expr::Coef> for Q {
    /// A canonical term's coefficient.
    fn from(c: &hamel_expr::Coef) -> Q {
        match c {
            hamel_expr::Coef::Small(n) => Q::Small(*n, 1),
            hamel_expr::Coef::Big(n) => Q::integer(n),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn r(n: i64, d: i64) -> Rational {
        Rational::new(n.into(), d.into())
    }

    /// Every operation agrees with big rationals, across the edge where machine integers
    /// overflow, and the result is canonical (small exactly when it fits).
    #[test]
    fn operations_agree_with_big_rationals() {
        let values = [
            r(0, 1),
            r(1, 1),
            r(-1, 1),
            r(3, 4),
            r(-5, 6),
            r(i64::MAX, 1),
            r(i64::MIN + 1, 1),
            r(1, i64::MAX),
            r(i64::MAX, 3),
            r(i64::MIN, 1),
            r(6, 1),
            r(-4, 9),
            r(2, 3),
            Rational::new(BigInt::one(), BigInt::from(i64::MIN)),
            Rational::new(BigInt::from(i64::MAX) * 5, 7.into()),
        ];
        for a in &values {
            for b in &values {
                let (x, y) = (Q::from(a), Q::from(b));
                assert_eq!(x.add(&y), Q::from(a + b), "{a} + {b}");
                assert_eq!(x.mul(&y), Q::from(a * b), "{a} · {b}");
                if !b.is_zero() {
                    assert_eq!(x.div(&y), Q::from(a / b), "{a} / {b}");
                }
                assert_eq!(x.neg(), Q::from(-a));
                assert_eq!(x.add(&y).to_rational(), a + b);
                if !a.is_zero() {
                    assert_eq!(x.recip(), Q::from(a.recip()), "1 / {a}");
                }
            }
        }
        let qs: Vec<Q> = [r(6, 5), r(-9, 10), r(3, 4)].iter().map(Q::from).collect();
        assert_eq!(Q::content(qs.iter()), Q::from(r(3, 20)));
        let big: Vec<Q> = [Rational::new(BigInt::from(i64::MAX) * 6, 1.into()), r(4, 1)]
            .iter()
            .map(Q::from)
            .collect();
        assert_eq!(Q::content(big.iter()), Q::from(r(2, 1)));
    }
}
