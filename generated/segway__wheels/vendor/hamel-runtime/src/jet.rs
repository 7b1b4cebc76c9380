//! Truncated Taylor series in time, [`Jet`], and the solution's series of an autonomous ODE
//! by evaluating its right-hand side over them ([`taylor_by_jets`]): what the Taylor method
//! (hamel_sim's `Method::Taylor`) asks of a system, for any right-hand side written generically
//! over [`Scalar`] (the generated cores, the interpreted structured evaluator, linear solves
//! included).
//!
//! Every operation is the automatic differentiation recurrence of its kind (Jorba & Zou 2005,
//! §3; Griewank & Walther, "Evaluating Derivatives", ch. 13): a product is the Cauchy product, a
//! quotient, a root, exp, ln, the pair sin/cos and atan follow from the linear differential
//! equation each satisfies. A jet holds `len` coefficients; a constant holds one, and a result
//! has the larger length of its operands (every non-constant value of one evaluation has the
//! same, the working order plus one).

use std::ops::{Add, Div, Mul, Neg, Sub};

use crate::scalar::{RationalParts, Scalar};

/// The most coefficients a [`Jet`] holds: orders 0 … 23 (the Taylor method's order at
/// rtol = ε is 20).
pub const JET_CAPACITY: usize = 24;

/// A truncated power series Σ_{k < len} c[k] τ^k.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Jet {
    /// The coefficients; those from `len` on are 0.
    pub c: [f64; JET_CAPACITY],
    /// How many coefficients are held (1 for a constant).
    pub len: usize,
}

impl Jet {
    /// The series with the given coefficients (at most [`JET_CAPACITY`]).
    pub fn from_coefficients(coefficients: &[f64]) -> Jet {
        let mut c = [0.0; JET_CAPACITY];
        c[..coefficients.len()].copy_from_slice(coefficients);
        Jet {
            c,
            len: coefficients.len().max(1),
        }
    }

    /// The coefficients held.
    pub fn coefficients(&self) -> &[f64] {
        &self.c[..self.len]
    }

    fn with_len(len: usize) -> Jet {
        Jet {
            c: [0.0; JET_CAPACITY],
            len,
        }
    }

    /// The series of the derivative, d/dτ, one coefficient shorter (a constant's is 0).
    fn derivative(&self) -> Jet {
        let mut d = Jet::with_len((self.len - 1).max(1));
        for k in 1..self.len {
            d.c[k - 1] = k as f64 * self.c[k];
        }
        d
    }

    /// The series t with t(0) = `t0` and t'·r = g (r[0] ≠ 0), to length `len`: the
    /// recurrence of atan and atan2, whose derivatives are quotients.
    fn integrate_quotient(t0: f64, g: &Jet, r: &Jet, len: usize) -> Jet {
        let mut t = Jet::with_len(len);
        t.c[0] = t0;
        for m in 0..len - 1 {
            // coefficient m of t'·r: Σ_{j ≤ m} (j + 1) t[j + 1] r[m − j] = g[m]
            let mut s = g.c[m];
            for j in 0..m {
                s -= (j + 1) as f64 * t.c[j + 1] * r.c[m - j];
            }
            t.c[m + 1] = s / ((m + 1) as f64 * r.c[0]);
        }
        t
    }
}

impl Add for Jet {
    type Output = Jet;
    fn add(mut self, o: Jet) -> Jet {
        self.len = self.len.max(o.len);
        for k in 0..o.len {
            self.c[k] += o.c[k];
        }
        self
    }
}
impl Sub for Jet {
    type Output = Jet;
    fn sub(mut self, o: Jet) -> Jet {
        self.len = self.len.max(o.len);
        for k in 0..o.len {
            self.c[k] -= o.c[k];
        }
        self
    }
}
impl Neg for Jet {
    type Output = Jet;
    fn neg(mut self) -> Jet {
        for k in 0..self.len {
            self.c[k] = -self.c[k];
        }
        self
    }
}
impl Mul for Jet {
    type Output = Jet;
    /// The Cauchy product, truncated to the longer operand's length.
    fn mul(self, o: Jet) -> Jet {
        let len = self.len.max(o.len);
        let mut p = Jet::with_len(len);
        for k in 0..len {
            let lo = (k + 1).saturating_sub(o.len);
            let hi = k.min(self.len - 1);
            let mut s = 0.0;
            for j in lo..=hi {
                s += self.c[j] * o.c[k - j];
            }
            p.c[k] = s;
        }
        p
    }
}
impl Div for Jet {
    type Output = Jet;
    /// q·b = a: q[k] = (a[k] − Σ_{j=1}^{k} b[j] q[k − j]) / b[0].
    fn div(self, b: Jet) -> Jet {
        let len = self.len.max(b.len);
        let mut q = Jet::with_len(len);
        for k in 0..len {
            let mut s = self.c[k];
            for j in 1..=k.min(b.len - 1) {
                s -= b.c[j] * q.c[k - j];
            }
            q.c[k] = s / b.c[0];
        }
        q
    }
}

impl Scalar for Jet {
    crate::plain_itself!();
    fn constant(v: f64) -> Self {
        let mut j = Jet::with_len(1);
        j.c[0] = v;
        j
    }
    fn rational(r: &RationalParts) -> Self {
        Jet::constant(r.nearest)
    }
    fn value(&self) -> f64 {
        self.c[0]
    }
    fn sin(self) -> Self {
        self.sin_cos().0
    }
    fn cos(self) -> Self {
        self.sin_cos().1
    }
    /// s' = a' c, c' = −a' s: s[k] = (1/k) Σ_{j=1}^{k} j a[j] c[k − j], and c[k] alike.
    fn sin_cos(self) -> (Self, Self) {
        let (mut s, mut c) = (Jet::with_len(self.len), Jet::with_len(self.len));
        (s.c[0], c.c[0]) = libm::sincos(self.c[0]);
        for k in 1..self.len {
            let (mut ss, mut cc) = (0.0, 0.0);
            for j in 1..=k {
                let ja = j as f64 * self.c[j];
                ss += ja * c.c[k - j];
                cc -= ja * s.c[k - j];
            }
            s.c[k] = ss / k as f64;
            c.c[k] = cc / k as f64;
        }
        (s, c)
    }
    /// r² = a: r[k] = (a[k] − Σ_{j=1}^{k−1} r[j] r[k − j]) / (2 r[0]).
    fn sqrt(self) -> Self {
        let mut r = Jet::with_len(self.len);
        r.c[0] = self.c[0].sqrt();
        for k in 1..self.len {
            let mut s = self.c[k];
            for j in 1..k {
                s -= r.c[j] * r.c[k - j];
            }
            r.c[k] = s / (2.0 * r.c[0]);
        }
        r
    }
    /// e' = a' e: e[k] = (1/k) Σ_{j=1}^{k} j a[j] e[k − j].
    fn exp(self) -> Self {
        let mut e = Jet::with_len(self.len);
        e.c[0] = self.c[0].exp();
        for k in 1..self.len {
            let mut s = 0.0;
            for j in 1..=k {
                s += j as f64 * self.c[j] * e.c[k - j];
            }
            e.c[k] = s / k as f64;
        }
        e
    }
    /// a l' = a': l[k] = (a[k] − (1/k) Σ_{j=1}^{k−1} j l[j] a[k − j]) / a[0].
    fn ln(self) -> Self {
        let mut l = Jet::with_len(self.len);
        l.c[0] = self.c[0].ln();
        for k in 1..self.len {
            let mut s = 0.0;
            for j in 1..k {
                s += j as f64 * l.c[j] * self.c[k - j];
            }
            l.c[k] = (self.c[k] - s / k as f64) / self.c[0];
        }
        l
    }
    /// t'·(1 + a²) = a'.
    fn atan(self) -> Self {
        let r = Jet::constant(1.0) + self * self;
        Jet::integrate_quotient(self.c[0].atan(), &self.derivative(), &r, self.len)
    }
    /// t'·(x² + y²) = x y' − y x'.
    fn atan2(self, x: Self) -> Self {
        let len = self.len.max(x.len);
        let r = x * x + self * self;
        let g = x * self.derivative() - self * x.derivative();
        Jet::integrate_quotient(self.c[0].atan2(x.c[0]), &g, &r, len)
    }
    /// By squaring (the base may vanish, where the power recurrence divides by it).
    fn powi(self, n: i32) -> Self {
        let mut result = Jet::constant(1.0);
        let mut base = self;
        let mut e = n.unsigned_abs();
        while e > 0 {
            if e & 1 == 1 {
                result = result * base;
            }
            e >>= 1;
            if e > 0 {
                base = base * base;
            }
        }
        if n < 0 {
            Jet::constant(1.0) / result
        } else {
            result
        }
    }
}

/// Why [`taylor_by_jets`] could not give the series.
#[derive(Debug)]
pub enum JetFailure<E> {
    /// The order asked for needs more coefficients than a [`Jet`] holds.
    Order(usize),
    /// The right-hand side failed.
    System(E),
}

/// The Taylor coefficients of the solution of the autonomous ODE y' = f(y) through `y`, to
/// `order`: `out` gets `order + 1` rows of `y.len()` values, row k holding y⁽ᵏ⁾/k!.
///
/// With y known to degree k, f(y) over jets is right to degree k, and y[k + 1] = f[k]/(k + 1):
/// `order` evaluations of `f` at growing lengths (O(p³) operations per operation of `f` in
/// all, where recurrences over a tape, `hamel_expr::taylor`, take O(p²)); what it buys is that
/// any `f` written over [`Scalar`] works, linear solves and all.
pub fn taylor_by_jets<E>(
    y: &[f64],
    order: usize,
    out: &mut Vec<f64>,
    mut f: impl FnMut(&[Jet], &mut [Jet]) -> Result<(), E>,
) -> Result<(), JetFailure<E>> {
    if order + 1 > JET_CAPACITY {
        return Err(JetFailure::Order(order));
    }
    let n = y.len();
    let mut x: Vec<Jet> = y.iter().map(|&v| Jet::constant(v)).collect();
    let mut dx = vec![Jet::constant(0.0); n];
    for k in 0..order {
        for xi in &mut x {
            xi.len = k + 1;
        }
        f(&x, &mut dx).map_err(JetFailure::System)?;
        for (xi, di) in x.iter_mut().zip(&dx) {
            // beyond its length a jet's coefficients are 0 (a constant's derivative)
            xi.c[k + 1] = di.c[k] / (k + 1) as f64;
        }
    }
    out.clear();
    out.resize((order + 1) * n, 0.0);
    for (i, xi) in x.iter().enumerate() {
        for k in 0..=order {
            out[k * n + i] = xi.c[k];
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn t(len: usize) -> Jet {
        // τ itself shifted: 0.3 + τ
        let mut c = vec![0.0; len];
        c[0] = 0.3;
        c[1] = 1.0;
        Jet::from_coefficients(&c)
    }

    /// Coefficients of f(0.3 + τ) by its derivatives f⁽ᵏ⁾(0.3)/k!, given in closed form.
    fn close(jet: Jet, expected: impl Fn(usize) -> f64) {
        for k in 0..jet.len {
            let e = expected(k);
            assert!(
                (jet.c[k] - e).abs() <= 1e-13 * e.abs().max(1.0),
                "coefficient {k}: {} against {e}",
                jet.c[k]
            );
        }
    }

    fn factorial(k: usize) -> f64 {
        (1..=k).map(|i| i as f64).product()
    }

    #[test]
    fn exp_sin_cos_and_ln_match_their_derivatives() {
        let x = 0.3_f64;
        close(t(12).exp(), |k| x.exp() / factorial(k));
        let (s, c) = t(12).sin_cos();
        let d = |k: usize, phase: f64| (x + phase + k as f64 * std::f64::consts::FRAC_PI_2).sin();
        close(s, |k| d(k, 0.0) / factorial(k));
        close(c, |k| d(k, std::f64::consts::FRAC_PI_2) / factorial(k));
        // ln(x + τ) = ln x + Σ (−1)^{k+1} τ^k / (k x^k)
        close(t(12).ln(), |k| {
            if k == 0 {
                x.ln()
            } else {
                -(-1.0_f64 / x).powi(k as i32) / k as f64
            }
        });
    }

    #[test]
    fn quotients_roots_and_powers_are_the_binomial_series() {
        let x = 0.3_f64;
        // (x + τ)^a = Σ binom(a, k) x^{a−k} τ^k
        let binom = |a: f64, k: usize| {
            (0..k)
                .map(|i| (a - i as f64) / (i + 1) as f64)
                .product::<f64>()
        };
        close(t(10).sqrt(), |k| binom(0.5, k) * x.powf(0.5 - k as f64));
        close(Jet::constant(1.0) / t(10), |k| {
            binom(-1.0, k) * x.powf(-1.0 - k as f64)
        });
        close(t(10).powi(5), |k| binom(5.0, k) * x.powf(5.0 - k as f64));
        close(t(10).powi(-3), |k| binom(-3.0, k) * x.powf(-3.0 - k as f64));
        close(t(10).powf(Jet::constant(2.5)), |k| {
            binom(2.5, k) * x.powf(2.5 - k as f64)
        });
        let q = (t(10) * t(10) + Jet::constant(1.0)) / t(10);
        close(q, |k| {
            binom(-1.0, k) * x.powf(-1.0 - k as f64) + [x, 1.0].get(k).copied().unwrap_or(0.0)
        });
    }

    #[test]
    fn atan_and_atan2_agree_with_the_series_of_the_tangent_inverse() {
        // atan2(sin(x + τ), cos(x + τ)) = x + τ, and atan(tan(x + τ)) too.
        let (s, c) = t(14).sin_cos();
        close(s.atan2(c), |k| [0.3, 1.0].get(k).copied().unwrap_or(0.0));
        close((s / c).atan(), |k| {
            [0.3, 1.0].get(k).copied().unwrap_or(0.0)
        });
        let scaled = (s * Jet::constant(2.0)).atan2(c * Jet::constant(2.0));
        close(scaled, |k| [0.3, 1.0].get(k).copied().unwrap_or(0.0));
    }

    #[test]
    fn the_series_of_an_ode_solution_is_its_taylor_expansion() {
        // y' = y² through y(0) = 0.5: y = 1/(2 − t) = Σ t^k / 2^{k+1}.
        let mut out = Vec::new();
        taylor_by_jets::<()>(&[0.5], 18, &mut out, |x, dx| {
            dx[0] = x[0] * x[0];
            Ok(())
        })
        .unwrap();
        for (k, c) in out.iter().enumerate() {
            let e = 0.5_f64.powi(k as i32 + 1);
            assert!((c - e).abs() <= 1e-15 * e, "{k}: {c} against {e}");
        }
        // the harmonic oscillator, a system: (x, v)' = (v, −x) through (1, 0) is (cos t, −sin t)
        taylor_by_jets::<()>(&[1.0, 0.0], 10, &mut out, |x, dx| {
            dx[0] = x[1];
            dx[1] = -x[0];
            Ok(())
        })
        .unwrap();
        for k in 0..=10 {
            let cos = [1.0, 0.0, -1.0, 0.0][k % 4] / factorial(k);
            let minus_sin = [0.0, -1.0, 0.0, 1.0][k % 4] / factorial(k);
            assert!((out[2 * k] - cos).abs() < 1e-16 && (out[2 * k + 1] - minus_sin).abs() < 1e-16);
        }
        let too_high = taylor_by_jets::<()>(&[1.0], JET_CAPACITY, &mut out, |_, _| Ok(()));
        assert!(matches!(too_high, Err(JetFailure::Order(_))));
    }
}
