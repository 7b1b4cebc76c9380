//! The double-double scalar ([`DD`], defined in `dd_core.rs`) as a [`Scalar`] of the
//! evaluators. Used where an f64 answer must itself be checked (the oracle comparison and the
//! stability study evaluate in double-double, so that rounding of the reference is far below
//! what is being measured), and where an f64 evaluation is too ill-conditioned to be trusted
//! (`hamel_derive::Compiled::evaluate` repeats it in double-double).

use num_traits::ToPrimitive;

use crate::ast::Rational;
pub use crate::dd_core::DD;
use crate::eval::Scalar;

impl Scalar for DD {
    fn constant(v: f64) -> Self {
        DD::from_f64(v)
    }

    fn rational(r: &Rational) -> Self {
        let split = |n: &num_bigint::BigInt| -> DD {
            let hi = n.to_f64().unwrap_or(f64::INFINITY);
            if !hi.is_finite() {
                return DD::from_f64(hi);
            }
            let rest = n - num_bigint::BigInt::from(hi as i128);
            DD {
                hi,
                lo: rest.to_f64().unwrap_or(0.0),
            } + DD::default()
        };
        split(r.numer()) / split(r.denom())
    }

    fn value(&self) -> f64 {
        self.to_f64()
    }

    fn sin(&self) -> Self {
        self.sin_cos().0
    }

    fn cos(&self) -> Self {
        self.sin_cos().1
    }

    fn sqrt(&self) -> Self {
        DD::sqrt(*self)
    }

    fn exp(&self) -> Self {
        DD::exp(*self)
    }

    fn ln(&self) -> Self {
        DD::ln(*self)
    }

    fn powi(&self, n: i32) -> Self {
        DD::powi(*self, n)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: DD, b: DD, tol: f64) -> bool {
        let d = (a - b).to_f64().abs();
        d <= tol * b.to_f64().abs().max(1e-300)
    }

    #[test]
    fn arithmetic_carries_about_32_digits() {
        let third = DD::from_f64(1.0) / DD::from_f64(3.0);
        let one = third * DD::from_f64(3.0);
        assert!((one - DD::from_f64(1.0)).to_f64().abs() < 1e-31);
        let r = DD::rational(&Rational::new(1.into(), 10.into()));
        assert!((r * DD::from_f64(10.0) - DD::from_f64(1.0)).to_f64().abs() < 1e-31);
        let x = DD::from_f64(2.0).sqrt();
        assert!((x * x - DD::from_f64(2.0)).to_f64().abs() < 1e-31);
    }

    #[test]
    fn transcendental_identities_hold_to_30_digits() {
        for &v in &[0.1, 0.7, 1.3, 2.9, -2.2, 5.5, 11.0, -40.0] {
            let x = DD::from_f64(v) + DD::from_f64(v * 1e-17);
            let (s, c) = (x.sin(), x.cos());
            assert!(
                (s * s + c * c - DD::from_f64(1.0)).to_f64().abs() < 1e-30,
                "{v}"
            );
            // the leading parts agree with f64
            assert!((s.to_f64() - (v + v * 1e-17).sin()).abs() < 1e-15);
            let e = x.exp();
            let back = e.ln();
            assert!(
                close(back, x, 1e-30),
                "{v}: ln(exp(x)) - x = {:e}",
                (back - x).to_f64()
            );
            assert!((e.to_f64() / (v + v * 1e-17).exp() - 1.0).abs() < 1e-15);
        }
        // sin(π/6) = 1/2 exactly
        let s = (DD::PI / DD::from_f64(6.0)).sin();
        assert!((s - DD::from_f64(0.5)).to_f64().abs() < 1e-31);
    }
}
