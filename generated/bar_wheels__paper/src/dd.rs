//! Double-double arithmetic: about 32 significant digits from a pair of f64 (hi + lo, |lo| ≤
//! ulp(hi)/2), with error-free transformations (Knuth's two-sum, FMA two-product) and
//! transcendental functions by argument reduction and Taylor series.
//!
//! This file depends on `std` alone: it is the one double-double of the project, compiled into
//! `hamel-expr` (references, stability studies, [`crate::DD`]) and written as `src/dd.rs` into
//! every generated numeric core, whose evaluators repeat an ill-conditioned f64 evaluation in
//! it (docs/stability.md).

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

#[inline]
fn two_prod(a: f64, b: f64) -> (f64, f64) {
    let p = a * b;
    (p, a.mul_add(b, -p))
}

/// π in double-double.
const PI: DD = DD {
    hi: std::f64::consts::PI,
    lo: 1.224_646_799_147_353_2e-16,
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

    /// Taylor series of sin and cos for |t| ≤ π/4.
    fn sin_cos_small(t: DD) -> (DD, DD) {
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

    /// sin and cos together (reduced modulo 2π, then to a quarter period).
    pub fn sin_cos(self) -> (DD, DD) {
        let n = (self / TWO_PI).round();
        let r = self - TWO_PI.mul_f64(n);
        let j = (r / HALF_PI).round();
        let t = r - HALF_PI.mul_f64(j);
        let (s, c) = DD::sin_cos_small(t);
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
