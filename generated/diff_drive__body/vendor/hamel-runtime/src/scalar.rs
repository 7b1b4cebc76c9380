//! The number types equations are evaluated in: [`Scalar`], for f64 and [`DD`].

use std::ops::{Add, Div, Mul, Neg, Sub};

use crate::dd::DD;

/// An exact rational n/d as the evaluators receive it: numerator and denominator each as an
/// unevaluated sum of two doubles (exact for integers below 2¹⁰⁶), and the f64 nearest n/d.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RationalParts {
    /// n = numer.0 + numer.1
    pub numer: (f64, f64),
    /// d = denom.0 + denom.1
    pub denom: (f64, f64),
    /// The f64 nearest n/d.
    pub nearest: f64,
}

/// The [`Scalar::Plain`] items of a type that computes in itself (every scalar type but
/// [`Cold`](crate::Cold)): write `plain_itself!();` in its `impl Scalar`.
#[macro_export]
macro_rules! plain_itself {
    () => {
        type Plain = Self;
        fn to_plain(self) -> Self {
            self
        }
        fn from_plain(p: Self) -> Self {
            p
        }
    };
}

/// The number types the equations are evaluated in: f64, dual numbers ([`crate::Dual`],
/// [`crate::DualN`]) for exact derivatives, and double-double ([`DD`]).
pub trait Scalar:
    Copy
    + 'static
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<Output = Self>
    + Div<Output = Self>
    + Neg<Output = Self>
{
    /// What this type computes in behind its calls: itself, except [`Cold`](crate::Cold)`<T>`,
    /// which is `T` behind calls that are never inlined. Code that puts a composite of scalars
    /// behind `Cold` itself ([`crate::ingredients_by_partials`]) builds it of the plain type, so
    /// as not to call out of line from inside a call out of line. Types other than `Cold`
    /// write [`plain_itself!`](crate::plain_itself) in their impl.
    type Plain: Scalar;
    /// This as [`Scalar::Plain`].
    fn to_plain(self) -> Self::Plain;
    /// Back from [`Scalar::Plain`].
    fn from_plain(p: Self::Plain) -> Self;
    /// A constant.
    fn constant(v: f64) -> Self;
    /// An exact rational literal, as accurately as the type allows.
    fn rational(r: &RationalParts) -> Self {
        Self::constant(r.nearest)
    }
    /// The value part (for pivoting and domain checks).
    fn value(&self) -> f64;
    /// sine
    fn sin(self) -> Self;
    /// cosine
    fn cos(self) -> Self;
    /// sine and cosine together
    fn sin_cos(self) -> (Self, Self) {
        (self.sin(), self.cos())
    }
    /// tangent
    fn tan(self) -> Self {
        self.sin() / self.cos()
    }
    /// square root
    fn sqrt(self) -> Self;
    /// exponential
    fn exp(self) -> Self;
    /// natural logarithm
    fn ln(self) -> Self;
    /// arctangent, in (−π/2, π/2). The default: f64's atan as a first value a, corrected in
    /// this type by one Newton step on tan, a + (x cos a − sin a)/(cos a + x sin a): the
    /// correction is of the order of f64's rounding, so its own error (its cube) is far
    /// below double-double's, and over dual numbers it carries the derivative 1/(1 + x²).
    fn atan(self) -> Self {
        let a = Self::constant(self.value().atan());
        let (s, c) = a.sin_cos();
        a + (self * c - s) / (c + self * s)
    }
    /// The angle of the point (x, self) in (−π, π]: atan2(self, x), the two-argument
    /// arctangent. The default, as [`Scalar::atan`]: f64's atan2 as a first value a, corrected
    /// by one Newton step, a + (y cos a − x sin a)/(x cos a + y sin a) (the denominator is
    /// √(x² + y²) > 0 near a); over dual numbers it carries (x dy − y dx)/(x² + y²).
    fn atan2(self, x: Self) -> Self {
        let a = Self::constant(self.value().atan2(x.value()));
        let (s, c) = a.sin_cos();
        a + (self * c - x * s) / (x * c + self * s)
    }
    /// integer power
    fn powi(self, n: i32) -> Self;
    /// real power of a positive base
    fn powf(self, e: Self) -> Self {
        (self.ln() * e).exp()
    }
    /// Whether an ill-conditioned evaluation in this type is repeated in double-double (f64
    /// only: dual numbers carry derivatives, double-double is the repeat).
    const CHECKED: bool = false;
    /// Whether this type records the decisions a computation takes by value (a tracer such as
    /// `hamel_expr::Traced`, whose straight-line record of the path taken holds only where
    /// those decisions would be taken alike): then [`Scalar::decided`] and
    /// [`Scalar::undecidable`] are called where they are taken (pivots).
    const RECORDS_DECISIONS: bool = false;
    /// A decision by value that the path taken stays valid (and as stable) wherever
    /// |`chosen`| > `factor` · max |`others`| (the max of none is 0): a pivot against the
    /// other candidates of its column, or against the matrix's entries for the floor below
    /// which it counts as zero. Called only where [`Scalar::RECORDS_DECISIONS`].
    fn decided(chosen: Self, factor: f64, others: &[Self]) {
        let _ = (chosen, factor, others);
    }
    /// A decision by value was taken that no condition of [`Scalar::decided`]'s form states
    /// (a fallback after a failed attempt): a tracer's record holds at its tracing point only.
    /// Called only where [`Scalar::RECORDS_DECISIONS`].
    fn undecidable() {}
}

impl Scalar for f64 {
    crate::plain_itself!();
    const CHECKED: bool = true;
    fn constant(v: f64) -> Self {
        v
    }
    fn value(&self) -> f64 {
        *self
    }
    fn sin(self) -> Self {
        f64::sin(self)
    }
    fn cos(self) -> Self {
        f64::cos(self)
    }
    /// libm's `sincos` (musl's, < 1 ulp): inlined into the generated code, where the system
    /// library's is a call (a fifth less latency on the right-hand sides that need one).
    fn sin_cos(self) -> (Self, Self) {
        libm::sincos(self)
    }
    fn tan(self) -> Self {
        f64::tan(self)
    }
    fn sqrt(self) -> Self {
        f64::sqrt(self)
    }
    fn exp(self) -> Self {
        f64::exp(self)
    }
    fn ln(self) -> Self {
        f64::ln(self)
    }
    fn powi(self, n: i32) -> Self {
        f64::powi(self, n)
    }
    fn powf(self, e: Self) -> Self {
        f64::powf(self, e)
    }
    fn atan(self) -> Self {
        f64::atan(self)
    }
    fn atan2(self, x: Self) -> Self {
        f64::atan2(self, x)
    }
}

impl Scalar for DD {
    crate::plain_itself!();
    fn constant(v: f64) -> Self {
        DD::from_f64(v)
    }
    fn rational(r: &RationalParts) -> Self {
        let exact = |(hi, lo): (f64, f64)| DD { hi, lo } + DD::default();
        exact(r.numer) / exact(r.denom)
    }
    fn value(&self) -> f64 {
        self.to_f64()
    }
    fn sin(self) -> Self {
        DD::sin_cos(self).0
    }
    fn cos(self) -> Self {
        DD::sin_cos(self).1
    }
    fn sin_cos(self) -> (Self, Self) {
        DD::sin_cos(self)
    }
    fn sqrt(self) -> Self {
        DD::sqrt(self)
    }
    fn exp(self) -> Self {
        DD::exp(self)
    }
    fn ln(self) -> Self {
        DD::ln(self)
    }
    fn powi(self, n: i32) -> Self {
        DD::powi(self, n)
    }
}

/// The values of `v` as exact values of another scalar type.
pub fn widen<S: Scalar, T: Scalar, const N: usize>(v: &[S]) -> [T; N] {
    std::array::from_fn(|i| T::constant(v[i].value()))
}

/// a^e for e ≥ 1 by squaring, `mul` making each product: the order of products every trace and
/// series program of hamel uses for an integer power (so that they agree to the bit). None for
/// e = 0.
pub fn power_by_squaring<T: Copy>(a: T, e: u32, mut mul: impl FnMut(T, T) -> T) -> Option<T> {
    let (mut result, mut base, mut rest) = (None, a, e);
    while rest > 0 {
        if rest & 1 == 1 {
            result = Some(match result {
                None => base,
                Some(r) => mul(r, base),
            });
        }
        rest >>= 1;
        if rest > 0 {
            base = mul(base, base);
        }
    }
    result
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Distance in units in the last place (same sign assumed, as here).
    fn ulps(a: f64, b: f64) -> u64 {
        (a.to_bits() as i64 - b.to_bits() as i64).unsigned_abs()
    }

    /// The generated code's sine and cosine (libm's `sincos`) agree with the system
    /// library's to within one ulp, near zero, across many turns and where the reduction
    /// modulo π/2 cancels most (near multiples of π/2).
    #[test]
    fn f64_sin_cos_agrees_with_the_system_library_to_one_ulp() {
        let near_quadrants = (1..2000).flat_map(|k| {
            let x = f64::from(k) * std::f64::consts::FRAC_PI_2;
            [x, x.next_up(), x.next_down()]
        });
        let sweep = (-200_000..200_000).map(|i| f64::from(i) * 1.37e-3);
        let tiny = (1..200).map(|k| 1e-300 * 1.5f64.powi(k));
        let far = (0..1000).map(|k| 1e6 + f64::from(k) * 12.345);
        for x in sweep.chain(near_quadrants).chain(tiny).chain(far) {
            let (s, c) = Scalar::sin_cos(x);
            let (s0, c0) = (x.sin(), x.cos());
            let ok = |a: f64, b: f64| a == b || (a.signum() == b.signum() && ulps(a, b) <= 1);
            assert!(
                ok(s, s0) && ok(c, c0),
                "x = {x:e}: ({s:e}, {c:e}) vs ({s0:e}, {c0:e})"
            );
        }
        let (s, c) = Scalar::sin_cos(f64::NAN);
        assert!(s.is_nan() && c.is_nan());
        assert!(Scalar::sin_cos(f64::INFINITY).0.is_nan());
    }

    fn close(a: DD, b: DD, tol: f64) -> bool {
        let d = (a - b).to_f64().abs();
        d <= tol * b.to_f64().abs().max(1e-300)
    }

    /// atan in double-double to about 32 digits (tan(atan x) = x, and atan 1 = π/4 with π's
    /// double-double value), over dual numbers with the derivative 1/(1 + x²).
    #[test]
    fn atan_carries_double_double_and_derivatives() {
        let pi_4 = DD {
            hi: std::f64::consts::FRAC_PI_4,
            lo: 3.061616997868383e-17,
        };
        assert!(close(Scalar::atan(DD::from_f64(1.0)), pi_4, 1e-31));
        for x in [-40.0, -1.5, -0.3, 1e-8, 0.7, 3.0, 1e6] {
            let xd = DD::from_f64(x);
            let (s, c) = Scalar::atan(xd).sin_cos();
            assert!(close(s / c, xd, 1e-30 * (1.0 + x.abs())), "tan(atan {x})");
            let d = crate::Dual::new(x, 1.0).atan();
            assert!((d.d - 1.0 / (1.0 + x * x)).abs() <= 1e-15 / (1.0 + x * x));
            let dd = crate::Dual::new(xd, DD::from_f64(1.0)).atan();
            assert!((dd.v - Scalar::atan(xd)).to_f64().abs() <= 1e-31 * (1.0 + x.abs()));
        }
    }

    /// atan2 in double-double in all four quadrants (its sine and cosine are y/r and x/r; the
    /// angle of (−1, 0) is π), over dual numbers with the derivative (x dy − y dx)/(x² + y²).
    #[test]
    fn atan2_carries_double_double_and_derivatives_in_every_quadrant() {
        let pi = DD {
            hi: std::f64::consts::PI,
            lo: 1.2246467991473532e-16,
        };
        assert!(close(
            Scalar::atan2(DD::from_f64(0.0), DD::from_f64(-1.0)),
            pi,
            1e-31
        ));
        for (y, x) in [
            (0.3, 2.0),
            (1.0, -1e-9),
            (-2.0, -0.5),
            (-1e-7, 3.0),
            (5.0, 0.0),
        ] {
            let (yd, xd) = (DD::from_f64(y), DD::from_f64(x));
            let a = Scalar::atan2(yd, xd);
            assert!((a.to_f64() - f64::atan2(y, x)).abs() <= 4.0 * f64::EPSILON);
            let r = (yd * yd + xd * xd).sqrt();
            let (s, c) = a.sin_cos();
            let off = ((s - yd / r).to_f64().abs()).max((c - xd / r).to_f64().abs());
            assert!(off <= 1e-30, "({y}, {x}): {off:e}");
            let d = crate::Dual::new(y, 1.0).atan2(crate::Dual::new(x, 2.0));
            let exact = (x - 2.0 * y) / (x * x + y * y);
            assert!(
                (d.d - exact).abs() <= 1e-14 * exact.abs().max(1.0),
                "({y}, {x})"
            );
        }
    }

    #[test]
    fn arithmetic_carries_about_32_digits() {
        let third = DD::from_f64(1.0) / DD::from_f64(3.0);
        let one = third * DD::from_f64(3.0);
        assert!((one - DD::from_f64(1.0)).to_f64().abs() < 1e-31);
        let r = DD::rational(&RationalParts {
            numer: (1.0, 0.0),
            denom: (10.0, 0.0),
            nearest: 0.1,
        });
        assert!((r * DD::from_f64(10.0) - DD::from_f64(1.0)).to_f64().abs() < 1e-31);
        let x = DD::from_f64(2.0).sqrt();
        assert!((x * x - DD::from_f64(2.0)).to_f64().abs() < 1e-31);
    }

    #[test]
    fn transcendental_identities_hold_to_30_digits() {
        for &v in &[0.1, 0.7, 1.3, 2.9, -2.2, 5.5, 11.0, -40.0] {
            let x = DD::from_f64(v) + DD::from_f64(v * 1e-17);
            let (s, c) = (Scalar::sin(x), Scalar::cos(x));
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
        let s = Scalar::sin(DD::PI / DD::from_f64(6.0));
        assert!((s - DD::from_f64(0.5)).to_f64().abs() < 1e-31);
    }
}
