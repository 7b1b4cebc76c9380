//! Double-double arithmetic: about 32 significant digits from a pair of f64 (hi + lo, |lo| ≤
//! ulp(hi)/2), with error-free transformations (Knuth's two-sum, FMA two-product) and
//! transcendental functions by argument reduction and Taylor series.
//!
//! The one double-double of the project: references and stability studies evaluate in it, and
//! the structured evaluation repeats an ill-conditioned f64 evaluation in it (docs/stability.md).

use std::ops::{Add, Div, Mul, Neg, Sub};

/// A double-double number hi + lo.
#[derive(Clone, Copy, Debug, PartialEq, PartialOrd, Default)]
pub struct DD {
    /// Leading part.
    pub hi: f64,
    /// Trailing part.
    pub lo: f64,
}

#[inline]
fn two_sum(a: f64, b: f64) -> (f64, f64) {
    let s = a + b;
    let bb = s - a;
    (s, (a - (s - bb)) + (b - bb))
}

#[inline]
fn quick_two_sum(a: f64, b: f64) -> (f64, f64) {
    let s = a + b;
    (s, b - (s - a))
}

/// a·b = p + e exactly: with a fused multiply-add where the target has one, else by Dekker's
/// splitting (a software `mul_add` is ten times slower; the split overflows above ~1e300).
#[inline]
fn two_prod(a: f64, b: f64) -> (f64, f64) {
    let p = a * b;
    #[cfg(target_feature = "fma")]
    {
        (p, a.mul_add(b, -p))
    }
    #[cfg(not(target_feature = "fma"))]
    {
        let (ah, al) = split(a);
        let (bh, bl) = split(b);
        (p, ((ah * bh - p) + ah * bl + al * bh) + al * bl)
    }
}

/// a = hi + lo with hi holding the upper 26 bits (Veltkamp).
#[cfg(not(target_feature = "fma"))]
#[inline]
fn split(a: f64) -> (f64, f64) {
    let t = 134_217_729.0 * a; // 2^27 + 1
    let hi = t - (t - a);
    (hi, a - hi)
}

/// 1/n! for n < 20, and sin, cos of kπ/16 for k = 0…4, computed once.
struct Tables {
    inverse_factorial: [DD; 20],
    sin_cos_sixteenths: [(DD, DD); 5],
}

fn tables() -> &'static Tables {
    static TABLES: std::sync::OnceLock<Tables> = std::sync::OnceLock::new();
    TABLES.get_or_init(|| {
        let mut inverse_factorial = [DD::from_f64(1.0); 20];
        for n in 1..20 {
            inverse_factorial[n] = inverse_factorial[n - 1] / DD::from_f64(n as f64);
        }
        let sin_cos_sixteenths =
            std::array::from_fn(|k| DD::sin_cos_series(PI_SIXTEENTH.mul_f64(k as f64)));
        Tables {
            inverse_factorial,
            sin_cos_sixteenths,
        }
    })
}

/// π in double-double.
const PI: DD = DD {
    hi: std::f64::consts::PI,
    lo: 1.224_646_799_147_353_2e-16,
};
/// π/16 (exact scaling of [`PI`]).
const PI_SIXTEENTH: DD = DD {
    hi: std::f64::consts::PI / 16.0,
    lo: 1.224_646_799_147_353_2e-16 / 16.0,
};
const HALF_PI: DD = DD {
    hi: std::f64::consts::FRAC_PI_2,
    lo: 6.123_233_995_736_766e-17,
};
const TWO_PI: DD = DD {
    hi: 2.0 * std::f64::consts::PI,
    lo: 2.449_293_598_294_706_4e-16,
};
const LN2: DD = DD {
    hi: std::f64::consts::LN_2,
    lo: 2.319_046_813_846_299_6e-17,
};

impl DD {
    /// π.
    pub const PI: DD = PI;

    /// An exact f64.
    pub const fn from_f64(x: f64) -> DD {
        DD { hi: x, lo: 0.0 }
    }

    /// Nearest f64.
    pub fn to_f64(self) -> f64 {
        self.hi + self.lo
    }

    /// Times an f64.
    pub fn mul_f64(self, b: f64) -> DD {
        let (p, e) = two_prod(self.hi, b);
        let (s, e) = quick_two_sum(p, e + self.lo * b);
        DD { hi: s, lo: e }
    }

    fn ldexp(self, k: i32) -> DD {
        let f = 2f64.powi(k);
        DD {
            hi: self.hi * f,
            lo: self.lo * f,
        }
    }

    fn round(self) -> f64 {
        let r = self.hi.round();
        if r == self.hi {
            // hi is an integer: the fraction is in lo
            r + self.lo.round()
        } else if (r - self.hi).abs() == 0.5 {
            // tie in hi: lo decides
            if self.lo > 0.0 {
                self.hi.ceil()
            } else {
                self.hi.floor()
            }
        } else {
            r
        }
    }

    /// Taylor series of sin and cos for |t| ≤ π/4, term by term (slow: builds the tables).
    fn sin_cos_series(t: DD) -> (DD, DD) {
        let t2 = t * t;
        let mut term = t;
        let mut sin = t;
        let mut k = 1.0;
        while k < 60.0 {
            term = term * t2 / DD::from_f64((k + 1.0) * (k + 2.0));
            term = -term;
            sin = sin + term;
            k += 2.0;
            if term.hi.abs() < 1e-34 {
                break;
            }
        }
        let mut term = DD::from_f64(1.0);
        let mut cos = term;
        let mut k = 0.0;
        while k < 60.0 {
            term = term * t2 / DD::from_f64((k + 1.0) * (k + 2.0));
            term = -term;
            cos = cos + term;
            k += 2.0;
            if term.hi.abs() < 1e-34 {
                break;
            }
        }
        (sin, cos)
    }

    /// sin and cos for |t| ≤ π/4: t = kπ/16 + u with |u| ≤ π/32, sin u by its Taylor series
    /// (nine terms at most), cos u = √(1 − sin²u), then the addition theorems with the tables.
    fn sin_cos_quarter(t: DD) -> (DD, DD) {
        let tables = tables();
        let k = (t.hi / PI_SIXTEENTH.hi).round();
        let u = t - PI_SIXTEENTH.mul_f64(k);
        let u2 = u * u;
        let mut power = u;
        let mut sin_u = u;
        for n in (3..20).step_by(2) {
            power = -(power * u2);
            let term = power * tables.inverse_factorial[n];
            sin_u = sin_u + term;
            if term.hi.abs() <= 1e-33 * u.hi.abs() {
                break;
            }
        }
        let cos_u = (DD::from_f64(1.0) - sin_u * sin_u).sqrt();
        let (sk, ck) = tables.sin_cos_sixteenths[k.abs() as usize];
        let sk = if k < 0.0 { -sk } else { sk };
        (sk * cos_u + ck * sin_u, ck * cos_u - sk * sin_u)
    }

    /// sin and cos together (reduced modulo 2π, then to a quarter period). Beyond |t| = 1e15
    /// the quotient by 2π is no longer an exact f64 integer and the reduction keeps no digit:
    /// there (and for a non-finite angle, whose sine is NaN) the f64 sine and cosine of the
    /// leading part, as f64 evaluation would give them, rather than a remainder outside the
    /// tables' range (a state that large is a diverged one, which the caller reports).
    pub fn sin_cos(self) -> (DD, DD) {
        if self.hi.is_nan() || self.hi.abs() >= 1e15 {
            let (s, c) = self.hi.sin_cos();
            return (DD::from_f64(s), DD::from_f64(c));
        }
        // The quotients in f64 suffice: a misrounded one leaves a remainder just past the
        // boundary, which the series and the tables cover.
        let n = (self.hi / TWO_PI.hi).round();
        let r = self - TWO_PI.mul_f64(n);
        let j = (r.hi / HALF_PI.hi).round();
        let t = r - HALF_PI.mul_f64(j);
        let (s, c) = DD::sin_cos_quarter(t);
        match (j as i64).rem_euclid(4) {
            0 => (s, c),
            1 => (c, -s),
            2 => (-s, -c),
            _ => (-c, s),
        }
    }

    /// Square root (one Newton step from the f64 root).
    pub fn sqrt(self) -> DD {
        if self.hi <= 0.0 {
            return DD::from_f64(self.hi.sqrt());
        }
        let x = DD::from_f64(self.hi.sqrt());
        x + (self - x * x) / x.mul_f64(2.0)
    }

    /// Exponential.
    pub fn exp(self) -> DD {
        if self.hi > 709.0 {
            return DD::from_f64(f64::INFINITY);
        }
        if self.hi < -745.0 {
            return DD::default();
        }
        let k = (self / LN2).round();
        let r = (self - LN2.mul_f64(k)).ldexp(-10);
        // exp(r) - 1 by Taylor series, then squared 10 times.
        let mut term = r;
        let mut sum = r;
        let mut n = 2.0;
        while n < 40.0 {
            term = term * r / DD::from_f64(n);
            sum = sum + term;
            n += 1.0;
            if term.hi.abs() < 1e-36 {
                break;
            }
        }
        // (1 + s)² − 1 = s (2 + s): squaring in this form keeps the relative accuracy of s.
        let mut s = sum;
        for _ in 0..10 {
            s = s * (s + DD::from_f64(2.0));
        }
        (s + DD::from_f64(1.0)).ldexp(k as i32)
    }

    /// Natural logarithm (Newton on exp).
    pub fn ln(self) -> DD {
        if self.hi <= 0.0 {
            return DD::from_f64(self.hi.ln());
        }
        // Newton on exp: x ← x + a·e^{−x} − 1, twice from the f64 logarithm.
        let mut x = DD::from_f64(self.hi.ln());
        for _ in 0..2 {
            x = x + self * (-x).exp() - DD::from_f64(1.0);
        }
        x
    }

    /// Integer power by squaring.
    pub fn powi(self, n: i32) -> DD {
        let mut result = DD::from_f64(1.0);
        let mut base = self;
        let mut k = n.unsigned_abs();
        while k > 0 {
            if k & 1 == 1 {
                result = result * base;
            }
            base = base * base;
            k >>= 1;
        }
        if n < 0 {
            DD::from_f64(1.0) / result
        } else {
            result
        }
    }
}

impl Add for DD {
    type Output = DD;
    fn add(self, b: DD) -> DD {
        let (s, e) = two_sum(self.hi, b.hi);
        let (t, f) = two_sum(self.lo, b.lo);
        let (s, e) = quick_two_sum(s, e + t);
        let (hi, lo) = quick_two_sum(s, e + f);
        DD { hi, lo }
    }
}

impl Neg for DD {
    type Output = DD;
    fn neg(self) -> DD {
        DD {
            hi: -self.hi,
            lo: -self.lo,
        }
    }
}

impl Sub for DD {
    type Output = DD;
    fn sub(self, b: DD) -> DD {
        self + (-b)
    }
}

impl Mul for DD {
    type Output = DD;
    fn mul(self, b: DD) -> DD {
        let (p, e) = two_prod(self.hi, b.hi);
        let e = e + (self.hi * b.lo + self.lo * b.hi);
        let (hi, lo) = quick_two_sum(p, e);
        DD { hi, lo }
    }
}

impl Div for DD {
    type Output = DD;
    fn div(self, b: DD) -> DD {
        let q1 = self.hi / b.hi;
        let r = self - b.mul_f64(q1);
        let q2 = r.hi / b.hi;
        let r = r - b.mul_f64(q2);
        let q3 = r.hi / b.hi;
        let (hi, lo) = quick_two_sum(q1, q2);
        DD { hi, lo } + DD::from_f64(q3)
    }
}

#[cfg(test)]
mod tests {
    use super::DD;

    /// A diverged state's huge or non-finite angle gives f64's sine and cosine, not a panic
    /// (an RK4 step far too long for the rattleback sent 1e30 here).
    #[test]
    fn huge_and_non_finite_angles_do_not_leave_the_tables() {
        for x in [1e15, -3.5e20, 1e300, f64::MAX] {
            let (s, c) = DD::from_f64(x).sin_cos();
            assert_eq!((s.hi, c.hi), x.sin_cos(), "{x}");
        }
        for x in [f64::INFINITY, f64::NEG_INFINITY, f64::NAN] {
            let (s, c) = DD::from_f64(x).sin_cos();
            assert!(s.hi.is_nan() && c.hi.is_nan(), "{x}");
        }
        let (s, _) = DD::from_f64(9.9e14).sin_cos();
        assert!((s.hi - 9.9e14f64.sin()).abs() < 1e-3, "{}", s.hi);
    }

    #[test]
    fn the_table_driven_sin_cos_matches_the_plain_series_to_31_digits() {
        for i in -200..=200 {
            let t = DD::from_f64(f64::from(i) * std::f64::consts::FRAC_PI_4 / 200.0)
                + DD::from_f64(f64::from(i) * 1e-19);
            let (s, c) = DD::sin_cos_quarter(t);
            let (s0, c0) = DD::sin_cos_series(t);
            assert!((s - s0).to_f64().abs() < 1e-31, "sin at step {i}");
            assert!((c - c0).to_f64().abs() < 1e-31, "cos at step {i}");
        }
    }
}
