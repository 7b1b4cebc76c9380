//! Certified facts about matrices of expressions, proved by evaluation at one point in
//! interval arithmetic.
//!
//! **Job**: decide that a matrix of functions of (q, parameters) has full rank as a function
//! (so a square one has a determinant that is not identically zero) without eliminating it
//! symbolically. One point where the matrix is certainly nonsingular proves it: the rank of a
//! matrix of analytic functions is at least its rank at any point.
//!
//! **How**: every entry is evaluated in [`Interval`] arithmetic (each operation rounded
//! outwards, so the true value lies inside), and Gaussian elimination with complete pivoting
//! runs on the intervals. When every pivot's interval excludes zero, every matrix inside the
//! boxes is nonsingular, the true one included. This is a proof, not a sample: a failure
//! proves nothing (the caller then tries another point, or decides exactly).
//!
//! **Used for**: the rank of α and δ = det[Z; α] ≠ 0 in derivations too large for exact
//! elimination (square-root kernels: the bicycle's front contact).

use std::ops::{Add, Div, Mul, Neg, Sub};

use hamel_expr::Expr;
use hamel_runtime::{RationalParts, Scalar};
use indexmap::IndexMap;

/// A closed interval [lo, hi] of reals, with arithmetic rounded outwards.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Interval {
    /// Lower end.
    pub lo: f64,
    /// Upper end.
    pub hi: f64,
}

/// Error of the library's sin, cos, exp and ln in units of the result's magnitude: a
/// generous bound on their (sub-ulp) errors.
const LIBM: f64 = 4.0 * f64::EPSILON;

impl Interval {
    /// The interval [lo, hi] widened by one rounding step on each side.
    fn outward(lo: f64, hi: f64) -> Interval {
        Interval {
            lo: lo.next_down(),
            hi: hi.next_up(),
        }
    }

    /// The point v, exactly.
    pub fn point(v: f64) -> Interval {
        Interval { lo: v, hi: v }
    }

    fn whole() -> Interval {
        Interval {
            lo: f64::NEG_INFINITY,
            hi: f64::INFINITY,
        }
    }

    /// Whether zero lies outside the interval (or the interval is not finite).
    pub fn excludes_zero(&self) -> bool {
        self.lo.is_finite() && self.hi.is_finite() && (self.lo > 0.0 || self.hi < 0.0)
    }

    /// The smallest absolute value in the interval.
    pub fn mag_min(&self) -> f64 {
        if self.excludes_zero() {
            self.lo.abs().min(self.hi.abs())
        } else {
            0.0
        }
    }

    /// v ± (the library's error), for a function value v of magnitude about |v|.
    fn libm(v: f64, lo: f64, hi: f64) -> Interval {
        let e = LIBM * v.abs().max(f64::MIN_POSITIVE);
        Interval::outward(lo - e, hi + e)
    }

    /// A function with |f'| ≤ 1 (sin, cos) over the interval, from its value at the midpoint.
    fn lipschitz(self, f: fn(f64) -> f64) -> Interval {
        if !(self.lo.is_finite() && self.hi.is_finite()) {
            return Interval { lo: -1.0, hi: 1.0 };
        }
        let m = 0.5 * self.lo + 0.5 * self.hi;
        let r = (m - self.lo).max(self.hi - m).next_up();
        let v = f(m);
        let out = Interval::libm(1.0, v - r, v + r);
        Interval {
            lo: out.lo.max(-1.0),
            hi: out.hi.min(1.0),
        }
    }
}

impl Add for Interval {
    type Output = Interval;
    fn add(self, o: Interval) -> Interval {
        Interval::outward(self.lo + o.lo, self.hi + o.hi)
    }
}

impl Sub for Interval {
    type Output = Interval;
    fn sub(self, o: Interval) -> Interval {
        Interval::outward(self.lo - o.hi, self.hi - o.lo)
    }
}

impl Neg for Interval {
    type Output = Interval;
    fn neg(self) -> Interval {
        Interval {
            lo: -self.hi,
            hi: -self.lo,
        }
    }
}

impl Mul for Interval {
    type Output = Interval;
    fn mul(self, o: Interval) -> Interval {
        let p = [
            self.lo * o.lo,
            self.lo * o.hi,
            self.hi * o.lo,
            self.hi * o.hi,
        ];
        if p.iter().any(|v| v.is_nan()) {
            return Interval::whole();
        }
        let lo = p.iter().copied().fold(f64::INFINITY, f64::min);
        let hi = p.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        Interval::outward(lo, hi)
    }
}

impl Div for Interval {
    type Output = Interval;
    fn div(self, o: Interval) -> Interval {
        if !o.excludes_zero() {
            return Interval::whole();
        }
        let p = [
            self.lo / o.lo,
            self.lo / o.hi,
            self.hi / o.lo,
            self.hi / o.hi,
        ];
        if p.iter().any(|v| v.is_nan()) {
            return Interval::whole();
        }
        let lo = p.iter().copied().fold(f64::INFINITY, f64::min);
        let hi = p.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        Interval::outward(lo, hi)
    }
}

impl Scalar for Interval {
    hamel_runtime::plain_itself!();
    fn constant(v: f64) -> Self {
        Interval::point(v)
    }
    fn rational(r: &RationalParts) -> Self {
        Interval::outward(r.nearest, r.nearest)
    }
    /// The midpoint (not finite for an unbounded interval, which makes evaluation fail).
    fn value(&self) -> f64 {
        0.5 * self.lo + 0.5 * self.hi
    }
    fn sin(self) -> Self {
        self.lipschitz(f64::sin)
    }
    fn cos(self) -> Self {
        self.lipschitz(f64::cos)
    }
    fn sqrt(self) -> Self {
        if self.lo.is_nan() || self.lo < 0.0 {
            return Interval::whole();
        }
        Interval::outward(self.lo.sqrt(), self.hi.sqrt()).clamp_low(0.0)
    }
    fn exp(self) -> Self {
        let (lo, hi) = (self.lo.exp(), self.hi.exp());
        Interval::libm(hi, lo, hi).clamp_low(0.0)
    }
    fn ln(self) -> Self {
        if self.lo.is_nan() || self.lo <= 0.0 {
            return Interval::whole();
        }
        let (lo, hi) = (self.lo.ln(), self.hi.ln());
        Interval::libm(lo.abs().max(hi.abs()), lo, hi)
    }
    /// Increasing: the ends' arctangents, widened by libm's error.
    fn atan(self) -> Self {
        if self.lo.is_nan() || self.hi.is_nan() {
            return Interval::whole();
        }
        let (lo, hi) = (self.lo.atan(), self.hi.atan());
        Interval::libm(lo.abs().max(hi.abs()), lo, hi)
    }
    /// By repeated squaring (each product encloses, so the result does).
    fn powi(self, n: i32) -> Self {
        let (mut acc, mut base, mut k) = (Interval::point(1.0), self, n.unsigned_abs());
        while k > 0 {
            if k & 1 == 1 {
                acc = acc * base;
            }
            base = base * base;
            k >>= 1;
        }
        if n < 0 {
            Interval::point(1.0) / acc
        } else {
            acc
        }
    }
}

impl Interval {
    fn clamp_low(self, floor: f64) -> Interval {
        Interval {
            lo: self.lo.max(floor),
            hi: self.hi,
        }
    }
}

/// A point at which a matrix was certified nonsingular: the values used and the smallest
/// magnitude a pivot could have there.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Certificate {
    /// The value of every coordinate and parameter at the point.
    pub point: IndexMap<String, f64>,
    /// The least magnitude among the pivots' intervals (each excludes zero). Serialised with
    /// three significant digits, so that output does not depend on the last bits of the
    /// platform's sin and cos.
    #[serde(serialize_with = "three_digits")]
    pub smallest_pivot: f64,
}

fn three_digits<S: serde::Serializer>(v: &f64, s: S) -> Result<S::Ok, S::Error> {
    if s.is_human_readable() {
        s.serialize_str(&format!("{v:.2e}"))
    } else {
        s.serialize_f64(*v)
    }
}

/// Rank μ of a μ×n (μ ≤ n) interval matrix, certified: Gaussian elimination with complete
/// pivoting on the interval entries; the least pivot magnitude when all μ pivots exclude zero.
fn certified_full_rank(mut m: Vec<Vec<Interval>>) -> Option<f64> {
    let rows = m.len();
    let cols = m.first().map_or(0, Vec::len);
    if rows > cols {
        return None;
    }
    let mut smallest = f64::INFINITY;
    for k in 0..rows {
        let (pr, pc) = (k..rows)
            .flat_map(|r| (k..cols).map(move |c| (r, c)))
            .filter(|&(r, c)| m[r][c].excludes_zero())
            .max_by(|&(r1, c1), &(r2, c2)| m[r1][c1].mag_min().total_cmp(&m[r2][c2].mag_min()))?;
        m.swap(k, pr);
        for row in m.iter_mut() {
            row.swap(k, pc);
        }
        let pivot = m[k][k];
        smallest = smallest.min(pivot.mag_min());
        for r in k + 1..rows {
            let f = m[r][k] / pivot;
            for c in k..cols {
                m[r][c] = m[r][c] - f * m[k][c];
            }
        }
    }
    Some(smallest)
}

/// A deterministic value in (−1.2, 1.2) for attempt `a`, index `i`.
pub fn generic(a: usize, i: usize) -> f64 {
    // splitmix64 of (attempt, index)
    let mut x = ((a as u64) << 32 | i as u64).wrapping_add(0x9E37_79B9_7F4A_7C15);
    x = (x ^ (x >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    x = (x ^ (x >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    x ^= x >> 31;
    let unit = (x >> 11) as f64 / (1u64 << 53) as f64;
    2.4 * unit - 1.2
}

/// The points tried: coordinates at generic values with the parameters at their defaults,
/// then with the parameters perturbed (a default of zero replaced by a generic value). The same
/// attempt always gives the same point.
pub fn point(
    a: usize,
    coordinates: &[String],
    parameters: &IndexMap<String, f64>,
) -> IndexMap<String, f64> {
    let mut p = IndexMap::new();
    for (i, q) in coordinates.iter().enumerate() {
        p.insert(q.clone(), generic(a, i));
    }
    for (j, (name, &v)) in parameters.iter().enumerate() {
        let r = generic(a, coordinates.len() + j);
        let v = match a {
            0 => v,
            _ if v == 0.0 => r,
            _ => v * (1.0 + 0.2 * r),
        };
        p.insert(name.clone(), v);
    }
    p
}

/// How many points [`full_rank`] tries before it gives up.
pub const ATTEMPTS: usize = 8;

/// A certificate that the matrix `rows` (entries in the coordinates and parameters) has full
/// row rank as a function, or `None` when none of [`ATTEMPTS`] points certifies it (which
/// proves nothing: the rank may be deficient, or every point tried was near the singular set).
pub fn full_rank(
    rows: &[Vec<&Expr>],
    coordinates: &[String],
    parameters: &IndexMap<String, f64>,
) -> Option<Certificate> {
    (0..ATTEMPTS).find_map(|a| {
        let at = point(a, coordinates, parameters);
        let env = |n: &str| at.get(n).map(|&v| Interval::point(v));
        let m = rows
            .iter()
            .map(|r| {
                r.iter()
                    .map(|e| e.eval(&env).ok())
                    .collect::<Option<Vec<_>>>()
            })
            .collect::<Option<Vec<_>>>()?;
        let smallest_pivot = certified_full_rank(m)?;
        Some(Certificate {
            point: at,
            smallest_pivot,
        })
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rows(texts: &[&[&str]]) -> Vec<Vec<Expr>> {
        texts
            .iter()
            .map(|r| {
                r.iter()
                    .map(|t| hamel_expr::parse(t).unwrap().expr)
                    .collect()
            })
            .collect()
    }

    fn certify(texts: &[&[&str]]) -> Option<Certificate> {
        let m = rows(texts);
        let refs: Vec<Vec<&Expr>> = m.iter().map(|r| r.iter().collect()).collect();
        let coordinates = vec!["x".to_string(), "y".to_string()];
        let parameters = IndexMap::from([("a".to_string(), 2.0), ("b".to_string(), 0.0)]);
        full_rank(&refs, &coordinates, &parameters)
    }

    #[test]
    fn intervals_enclose_the_true_values() {
        let x = Interval::outward(0.1, 0.1);
        let third = Interval::point(1.0) / Interval::point(3.0);
        assert!(third.lo <= 1.0 / 3.0 && 1.0 / 3.0 <= third.hi && third.lo < third.hi);
        let s = x.sin() * x.sin() + x.cos() * x.cos() - Interval::point(1.0);
        assert!(s.lo <= 0.0 && 0.0 <= s.hi, "{s:?}");
        assert!(s.hi - s.lo < 1e-14);
        let q = Interval::point(2.0).sqrt();
        assert!(q.lo * q.lo <= 2.0 && q.hi * q.hi >= 2.0);
        let p = Interval::outward(1.1, 1.1).powi(13);
        assert!(p.lo <= 1.1f64.powi(13) && 1.1f64.powi(13) <= p.hi && p.hi - p.lo < 1e-13);
        let r = Interval::point(2.0).powi(-3);
        assert!(r.lo <= 0.125 && 0.125 <= r.hi);
        assert!(!(Interval::point(1.0) / Interval { lo: -1.0, hi: 1.0 }).excludes_zero());
    }

    #[test]
    fn a_nonsingular_matrix_is_certified_and_a_singular_one_is_not() {
        let c = certify(&[&["cos(x)", "sin(x)", "a"], &["-sin(x)", "cos(x)", "y"]]).unwrap();
        assert!(c.smallest_pivot > 0.1, "{c:?}");
        // Rows proportional for every x, y, a: never certified.
        assert!(certify(&[&["cos(x)", "sin(x)"], &["a*cos(x)", "a*sin(x)"]]).is_none());
        // Singular only because of a cancellation the intervals cannot see: not certified.
        assert!(certify(&[&["sin(x)^2 + cos(x)^2 - 1"]]).is_none());
        // Zero at the defaults (b = 0), nonzero elsewhere: certified at a perturbed point.
        let c = certify(&[&["b*x"]]).unwrap();
        assert_ne!(c.point["b"], 0.0);
    }
}
