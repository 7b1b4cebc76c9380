//! [`Cold`]: a scalar whose arithmetic is never inlined.

use std::ops::{Add, Div, Mul, Neg, Sub};

use crate::scalar::{RationalParts, Scalar};

/// `T` with every operation behind a call that is never inlined.
///
/// The straight-line code of a large model (the bicycle's ingredients: 4,700 shared
/// operations with their derivatives written as trees; its geometry, 1,060, evaluated over
/// [`Partials`](crate::Partials) now) is one function per scalar type. Inlined, each double-double or N-direction
/// dual operation becomes tens of instructions, and the compiler spends minutes on the
/// resulting function (the bicycle's core: 4 min 8 s with `DD` and `DualN` inlined, 20 s
/// behind `Cold`, release build on this machine). The generated code wraps the wide types
/// (the double-double repeat, the Jacobian's duals) in `Cold` above a size
/// (`hamel_codegen::COLD_ABOVE`); f64, the hot path, stays inlined.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Cold<T>(pub T);

impl<T> From<T> for Cold<T> {
    fn from(t: T) -> Cold<T> {
        Cold(t)
    }
}

impl<T> AsRef<T> for Cold<T> {
    fn as_ref(&self) -> &T {
        &self.0
    }
}

macro_rules! binary {
    ($tr:ident, $f:ident) => {
        impl<T: Scalar> $tr for Cold<T> {
            type Output = Cold<T>;
            #[inline(never)]
            fn $f(self, o: Cold<T>) -> Cold<T> {
                Cold(self.0.$f(o.0))
            }
        }
    };
}
binary!(Add, add);
binary!(Sub, sub);
binary!(Mul, mul);
binary!(Div, div);

impl<T: Scalar> Neg for Cold<T> {
    type Output = Cold<T>;
    #[inline(never)]
    fn neg(self) -> Cold<T> {
        Cold(-self.0)
    }
}

macro_rules! unary {
    ($($f:ident),*) => {$(
        #[inline(never)]
        fn $f(self) -> Self {
            Cold(self.0.$f())
        }
    )*};
}

impl<T: Scalar> Scalar for Cold<T> {
    type Plain = T;
    fn to_plain(self) -> T {
        self.0
    }
    fn from_plain(p: T) -> Self {
        Cold(p)
    }
    const CHECKED: bool = T::CHECKED;
    fn constant(v: f64) -> Self {
        Cold(T::constant(v))
    }
    fn rational(r: &RationalParts) -> Self {
        Cold(T::rational(r))
    }
    fn value(&self) -> f64 {
        self.0.value()
    }
    unary!(sin, cos, tan, sqrt, exp, ln, atan);
    #[inline(never)]
    fn sin_cos(self) -> (Self, Self) {
        let (s, c) = self.0.sin_cos();
        (Cold(s), Cold(c))
    }
    #[inline(never)]
    fn powi(self, n: i32) -> Self {
        Cold(self.0.powi(n))
    }
    #[inline(never)]
    fn powf(self, e: Self) -> Self {
        Cold(self.0.powf(e.0))
    }
}

#[cfg(test)]
mod tests {
    use super::Cold;
    use crate::{DD, DualN, Scalar};

    /// The same arithmetic as the wrapped type, bit for bit.
    #[test]
    fn cold_computes_what_it_wraps() {
        fn f<S: Scalar>(x: S, y: S) -> S {
            (x * y - x.sin_cos().1 / (y + S::constant(2.0))).powi(3) + x.sqrt().exp().ln()
                - (-y).tan()
        }
        let (x, y) = (DD::from_f64(0.7), DD::from_f64(-0.3));
        let (hot, cold) = (f(x, y), f(Cold(x), Cold(y)).0);
        assert_eq!((hot.hi, hot.lo), (cold.hi, cold.lo));
        let (x, y) = (DualN::<2>::variable(0.7, 0), DualN::<2>::variable(-0.3, 1));
        let (hot, cold) = (f(x, y), f(Cold(x), Cold(y)));
        assert_eq!(hot, *cold.as_ref());
    }
}
