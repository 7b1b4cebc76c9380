//! Dual numbers, forward-mode differentiation: [`Dual`] (one direction, over any scalar, so
//! that duals of duals give second derivatives) and [`DualN`] (N directions over f64, for
//! Jacobians in one pass).

use std::ops::{Add, Div, Mul, Neg, Sub};

use crate::scalar::{RationalParts, Scalar};

/// A first-order dual number `v + d ε` with ε² = 0: evaluating `f(x + ε ẋ)` gives `f(x)` and the
/// exact directional derivative `f'(x) ẋ` (forward-mode automatic differentiation), over any
/// [`Scalar`] (f64 by default).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Dual<T = f64> {
    /// Value.
    pub v: T,
    /// Derivative part.
    pub d: T,
}

impl<T> Dual<T> {
    /// `v + d ε`.
    pub fn new(v: T, d: T) -> Dual<T> {
        Dual { v, d }
    }
}

impl<T: Scalar> Add for Dual<T> {
    type Output = Dual<T>;
    fn add(self, o: Dual<T>) -> Dual<T> {
        Dual::new(self.v + o.v, self.d + o.d)
    }
}
impl<T: Scalar> Sub for Dual<T> {
    type Output = Dual<T>;
    fn sub(self, o: Dual<T>) -> Dual<T> {
        Dual::new(self.v - o.v, self.d - o.d)
    }
}
impl<T: Scalar> Mul for Dual<T> {
    type Output = Dual<T>;
    fn mul(self, o: Dual<T>) -> Dual<T> {
        Dual::new(self.v * o.v, self.d * o.v + self.v * o.d)
    }
}
impl<T: Scalar> Div for Dual<T> {
    type Output = Dual<T>;
    fn div(self, o: Dual<T>) -> Dual<T> {
        let q = self.v / o.v;
        Dual::new(q, (self.d - q * o.d) / o.v)
    }
}
impl<T: Scalar> Neg for Dual<T> {
    type Output = Dual<T>;
    fn neg(self) -> Dual<T> {
        Dual::new(-self.v, -self.d)
    }
}

impl<T: Scalar> Scalar for Dual<T> {
    crate::plain_itself!();
    fn constant(v: f64) -> Self {
        Dual::new(T::constant(v), T::constant(0.0))
    }
    fn rational(r: &RationalParts) -> Self {
        Dual::new(T::rational(r), T::constant(0.0))
    }
    fn value(&self) -> f64 {
        self.v.value()
    }
    fn sin(self) -> Self {
        Dual::new(self.v.sin(), self.d * self.v.cos())
    }
    fn cos(self) -> Self {
        Dual::new(self.v.cos(), -(self.d * self.v.sin()))
    }
    fn sqrt(self) -> Self {
        let s = self.v.sqrt();
        Dual::new(s, self.d / (s + s))
    }
    fn exp(self) -> Self {
        let e = self.v.exp();
        Dual::new(e, self.d * e)
    }
    fn ln(self) -> Self {
        Dual::new(self.v.ln(), self.d / self.v)
    }
    fn atan(self) -> Self {
        Dual::new(self.v.atan(), self.d / (T::constant(1.0) + self.v * self.v))
    }
    fn powi(self, n: i32) -> Self {
        if n == 0 {
            return Dual::constant(1.0);
        }
        Dual::new(
            self.v.powi(n),
            self.d * T::constant(n as f64) * self.v.powi(n - 1),
        )
    }
}

/// A dual number with `N` directional derivatives (forward-mode differentiation).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DualN<const N: usize> {
    /// Value.
    pub v: f64,
    /// Derivatives.
    pub d: [f64; N],
}

/// The identity, so that code generic over [`Cold`](crate::Cold)`<DualN<N>>` and `DualN<N>`
/// reads the derivatives the same way.
impl<const N: usize> AsRef<DualN<N>> for DualN<N> {
    fn as_ref(&self) -> &DualN<N> {
        self
    }
}

impl<const N: usize> DualN<N> {
    /// The variable number `i` at value `v` (derivative e_i).
    pub fn variable(v: f64, i: usize) -> Self {
        let mut d = [0.0; N];
        d[i] = 1.0;
        DualN { v, d }
    }
    fn chain(self, v: f64, dv: f64) -> Self {
        let mut d = self.d;
        for x in &mut d {
            *x *= dv;
        }
        DualN { v, d }
    }
}

impl<const N: usize> Add for DualN<N> {
    type Output = Self;
    fn add(mut self, o: Self) -> Self {
        self.v += o.v;
        for i in 0..N {
            self.d[i] += o.d[i];
        }
        self
    }
}

impl<const N: usize> Sub for DualN<N> {
    type Output = Self;
    fn sub(mut self, o: Self) -> Self {
        self.v -= o.v;
        for i in 0..N {
            self.d[i] -= o.d[i];
        }
        self
    }
}

impl<const N: usize> Mul for DualN<N> {
    type Output = Self;
    fn mul(self, o: Self) -> Self {
        let mut d = [0.0; N];
        for (i, x) in d.iter_mut().enumerate() {
            *x = self.d[i] * o.v + self.v * o.d[i];
        }
        DualN { v: self.v * o.v, d }
    }
}

impl<const N: usize> Div for DualN<N> {
    type Output = Self;
    fn div(self, o: Self) -> Self {
        let v = self.v / o.v;
        let mut d = [0.0; N];
        for (i, x) in d.iter_mut().enumerate() {
            *x = (self.d[i] - v * o.d[i]) / o.v;
        }
        DualN { v, d }
    }
}

impl<const N: usize> Neg for DualN<N> {
    type Output = Self;
    fn neg(self) -> Self {
        self.chain(-self.v, -1.0)
    }
}

impl<const N: usize> Scalar for DualN<N> {
    crate::plain_itself!();
    fn constant(v: f64) -> Self {
        DualN { v, d: [0.0; N] }
    }
    fn value(&self) -> f64 {
        self.v
    }
    fn sin(self) -> Self {
        self.chain(self.v.sin(), self.v.cos())
    }
    fn cos(self) -> Self {
        self.chain(self.v.cos(), -self.v.sin())
    }
    fn sin_cos(self) -> (Self, Self) {
        let (s, c) = self.v.sin_cos();
        (self.chain(s, c), self.chain(c, -s))
    }
    fn sqrt(self) -> Self {
        let r = self.v.sqrt();
        self.chain(r, 0.5 / r)
    }
    fn exp(self) -> Self {
        let e = self.v.exp();
        self.chain(e, e)
    }
    fn ln(self) -> Self {
        self.chain(self.v.ln(), 1.0 / self.v)
    }
    fn atan(self) -> Self {
        self.chain(self.v.atan(), 1.0 / (1.0 + self.v * self.v))
    }
    fn powi(self, n: i32) -> Self {
        if n == 0 {
            return DualN::constant(1.0);
        }
        self.chain(self.v.powi(n), n as f64 * self.v.powi(n - 1))
    }
}
