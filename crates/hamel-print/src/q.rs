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
        if let (Some((a, b)), Some((c, d))) = (self.small(), other.small()) {
            return Q::from_i128(a * c, b * d);
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
        match self.small() {
            Some((n, d)) => Q::from_i128(d, n),
            None => Q::from(self.to_rational().recip()),
        }
    }

    /// `self / other` (`other ≠ 0`).
    pub fn div(&self, other: &Q) -> Q {
        self.mul(&other.recip())
    }

    /// The content of a list of coefficients: gcd of the numerators over lcm of the
    /// denominators (positive; zero for none).
    pub fn content<'a>(qs: impl Iterator<Item = &'a Q> + Clone) -> Q {
        let small: Option<(i128, i128)> = qs.clone().try_fold((0i128, 1i128), |(g, l), q| {
            let (n, d) = q.small()?;
            let l = l.checked_mul(d / l.gcd(&d))?;
            Some((g.gcd(&n), l))
        });
        match small {
            Some((g, l)) if g != 0 => Q::from_i128(g, l),
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
    /// `n / d` (`d` ≠ 0), without big-integer arithmetic when both fit a machine integer.
    pub fn ratio(n: &BigInt, d: &BigInt) -> Q {
        match (n.to_i64(), d.to_i64()) {
            (Some(n), Some(1)) => Q::Small(n, 1),
            (Some(n), Some(d)) => Q::from(n).div(&Q::from(d)),
            _ => Q::from(Rational::new(n.clone(), d.clone())),
        }
    }
}

impl From<i64> for Q {
    fn from(n: i64) -> Q {
        Q::Small(n, 1)
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
