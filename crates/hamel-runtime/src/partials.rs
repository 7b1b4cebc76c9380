//! The ingredients' derivatives ∂Z/∂q_k, ∂α/∂q_k, ∂A/∂q_k by forward-mode dual numbers at run
//! time ([`Partials`], [`ingredients_by_partials`]), for cores whose derivative trees would be
//! several times the code of Z, α and A themselves (the Whipple bicycle's: 3,498 operations of
//! derivatives against 1,062 of the geometry).
//!
//! Exact as the trees are: a dual number's partials obey the same differentiation rules, applied
//! at run time to the geometry's straight-line code instead of symbolically to its trees; only
//! the rounding differs. Coordinates the geometry's code does not mention have zero partials
//! exactly, so they are not carried ([`ingredients_by_partials`]'s `moving`).

use std::any::Any;
use std::ops::{Add, Div, Mul, Neg, Sub};

use crate::Cold;
use crate::scalar::{RationalParts, Scalar};
use crate::structured::{Dims, Layout};

/// A number with `K` partial derivatives, over any [`Scalar`] (so that the double-double
/// repeat and the Jacobian's dual numbers carry them too): `v + Σ d_j ε_j`, ε_i ε_j = 0.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Partials<T, const K: usize> {
    /// Value.
    pub v: T,
    /// ∂/∂x_j, j < K.
    pub d: [T; K],
}

impl<T: Scalar, const K: usize> Partials<T, K> {
    /// The variable number `j` at value `v` (partials e_j); `j ≥ K` gives a constant.
    pub fn variable(v: T, j: usize) -> Self {
        let mut d = [T::constant(0.0); K];
        if let Some(x) = d.get_mut(j) {
            *x = T::constant(1.0);
        }
        Partials { v, d }
    }

    /// f(self) given f's value `v` and derivative `dv` at self.v.
    #[inline(always)]
    fn chain(self, v: T, dv: T) -> Self {
        Partials {
            v,
            d: self.d.map(|x| x * dv),
        }
    }
}

impl<T: Scalar, const K: usize> Add for Partials<T, K> {
    type Output = Self;
    #[inline(always)]
    fn add(self, o: Self) -> Self {
        Partials {
            v: self.v + o.v,
            d: std::array::from_fn(|j| self.d[j] + o.d[j]),
        }
    }
}

impl<T: Scalar, const K: usize> Sub for Partials<T, K> {
    type Output = Self;
    #[inline(always)]
    fn sub(self, o: Self) -> Self {
        Partials {
            v: self.v - o.v,
            d: std::array::from_fn(|j| self.d[j] - o.d[j]),
        }
    }
}

impl<T: Scalar, const K: usize> Mul for Partials<T, K> {
    type Output = Self;
    #[inline(always)]
    #[allow(clippy::suspicious_arithmetic_impl)] // the product rule
    fn mul(self, o: Self) -> Self {
        Partials {
            v: self.v * o.v,
            d: std::array::from_fn(|j| self.d[j] * o.v + self.v * o.d[j]),
        }
    }
}

impl<T: Scalar, const K: usize> Div for Partials<T, K> {
    type Output = Self;
    #[inline(always)]
    #[allow(clippy::suspicious_arithmetic_impl)] // the quotient rule
    fn div(self, o: Self) -> Self {
        let v = self.v / o.v;
        Partials {
            v,
            d: std::array::from_fn(|j| (self.d[j] - v * o.d[j]) / o.v),
        }
    }
}

impl<T: Scalar, const K: usize> Neg for Partials<T, K> {
    type Output = Self;
    #[inline(always)]
    fn neg(self) -> Self {
        Partials {
            v: -self.v,
            d: self.d.map(|x| -x),
        }
    }
}

impl<T: Scalar, const K: usize> Scalar for Partials<T, K> {
    crate::plain_itself!();
    fn constant(v: f64) -> Self {
        Partials {
            v: T::constant(v),
            d: [T::constant(0.0); K],
        }
    }
    fn rational(r: &RationalParts) -> Self {
        Partials {
            v: T::rational(r),
            d: [T::constant(0.0); K],
        }
    }
    fn value(&self) -> f64 {
        self.v.value()
    }
    fn sin(self) -> Self {
        let (s, c) = self.v.sin_cos();
        self.chain(s, c)
    }
    fn cos(self) -> Self {
        let (s, c) = self.v.sin_cos();
        self.chain(c, -s)
    }
    fn sin_cos(self) -> (Self, Self) {
        let (s, c) = self.v.sin_cos();
        (self.chain(s, c), self.chain(c, -s))
    }
    fn sqrt(self) -> Self {
        let r = self.v.sqrt();
        self.chain(r, T::constant(0.5) / r)
    }
    fn exp(self) -> Self {
        let e = self.v.exp();
        self.chain(e, e)
    }
    fn ln(self) -> Self {
        self.chain(self.v.ln(), T::constant(1.0) / self.v)
    }
    fn atan(self) -> Self {
        let dv = T::constant(1.0) / (T::constant(1.0) + self.v * self.v);
        self.chain(self.v.atan(), dv)
    }
    fn atan2(self, x: Self) -> Self {
        // d atan2(y, x) = (x dy − y dx)/(x² + y²)
        let r2 = x.v * x.v + self.v * self.v;
        Partials {
            v: self.v.atan2(x.v),
            d: std::array::from_fn(|j| (x.v * self.d[j] - self.v * x.d[j]) / r2),
        }
    }
    fn powi(self, n: i32) -> Self {
        if n == 0 {
            return Self::constant(1.0);
        }
        self.chain(self.v.powi(n), T::constant(n as f64) * self.v.powi(n - 1))
    }
}

/// The ingredients at q in `layout`'s order, the derivative blocks from the geometry evaluated
/// over [`Partials`]: the geometry writes Z, α (with its dependent rows) and A (the layout's
/// entries before U) at the coordinates it is given, `moving[j]` carrying ∂/∂q_{moving[j]};
/// the blocks ∂A/∂q_k, ∂Z/∂q_k, ∂α/∂q_k are read off the partials, zero for a k not in
/// `moving` (the caller's proof: its code does not mention q_k). U and ∇U (the entries from
/// `layout.u` to `layout.da`) are left to the caller. `L` is ℓ, `G` is `layout.u`, `N` is
/// `layout.len`.
///
/// The geometry is given twice, as the same generic function: `hot` over `Partials<f64, K>`,
/// inlined, used when `S` is f64; `cold` over `Cold<Partials<S::Plain, K>>` for the wide types
/// (the double-double repeat, the Jacobian's duals; `Plain` unwraps a `Cold` they come in, so
/// that each operation is one call with the arithmetic inside it), so that the compiler is
/// not handed the geometry inlined once per wide type ([`Cold`]'s reason: the bicycle's core took
/// 3 min 53 s to build with it inlined, against 24 s before).
pub fn ingredients_by_partials<
    S: Scalar,
    const K: usize,
    const L: usize,
    const G: usize,
    const N: usize,
>(
    q: &[S],
    moving: &[usize; K],
    dims: Dims,
    out: &mut [S],
    hot: impl FnOnce(&[Partials<f64, K>], &mut [Partials<f64, K>]),
    cold: impl FnOnce(&[Cold<Partials<S::Plain, K>>], &mut [Cold<Partials<S::Plain, K>>]),
) {
    if let (Some(q), Some(out)) = (as_f64::<S, L>(q), as_f64_mut::<S, N>(out)) {
        return spread::<f64, Partials<f64, K>, K, L, G>(q, moving, dims, out, hot, |x| x, |x| x);
    }
    let wrap = |x: Partials<S, K>| {
        Cold(Partials {
            v: x.v.to_plain(),
            d: x.d.map(S::to_plain),
        })
    };
    let unwrap = |x: Cold<Partials<S::Plain, K>>| Partials {
        v: S::from_plain(x.0.v),
        d: x.0.d.map(S::from_plain),
    };
    spread::<S, Cold<Partials<S::Plain, K>>, K, L, G>(q, moving, dims, out, cold, wrap, unwrap);
}

/// `q` as f64 when `S` is f64 (and it has `L` entries).
fn as_f64<S: Scalar, const L: usize>(q: &[S]) -> Option<&[f64; L]> {
    let q: &[S; L] = q.get(..L)?.try_into().ok()?;
    (q as &dyn Any).downcast_ref()
}

/// `out` as f64 when `S` is f64 (and it has `N` entries).
fn as_f64_mut<S: Scalar, const N: usize>(out: &mut [S]) -> Option<&mut [f64; N]> {
    let out: &mut [S; N] = out.get_mut(..N)?.try_into().ok()?;
    (out as &mut dyn Any).downcast_mut()
}

/// [`ingredients_by_partials`] with the geometry evaluated in `E`, which `wrap` and `unwrap`
/// convert from and to `Partials<S, K>`.
fn spread<S: Scalar, E: Scalar, const K: usize, const L: usize, const G: usize>(
    q: &[S],
    moving: &[usize; K],
    dims: Dims,
    out: &mut [S],
    geometry: impl FnOnce(&[E], &mut [E]),
    wrap: impl Fn(Partials<S, K>) -> E,
    unwrap: impl Fn(E) -> Partials<S, K>,
) {
    let layout = Layout::new(dims);
    debug_assert_eq!((L, G), (dims.ell, layout.u));
    let qp: [E; L] = std::array::from_fn(|i| {
        let j = moving.iter().position(|&k| k == i).unwrap_or(K);
        wrap(Partials::variable(q[i], j))
    });
    let mut e = [E::constant(0.0); G];
    geometry(&qp, &mut e);
    let g: [Partials<S, K>; G] = e.map(unwrap);
    for (o, x) in out[..G].iter_mut().zip(&g) {
        *o = x.v;
    }
    let (l, s, rho) = (dims.ell, dims.sigma, dims.rho());
    // (where the block of q_k starts, the block's size, where its entries lie in `g`)
    let blocks = [
        (layout.da, l * l, layout.a),
        (layout.dz, s * l, layout.z),
        (layout.dalpha, rho * l, layout.alpha),
    ];
    for k in 0..l {
        let j = moving.iter().position(|&m| m == k);
        for &(start, size, from) in &blocks {
            let block = &mut out[start + k * size..start + (k + 1) * size];
            match j {
                Some(j) => {
                    for (o, x) in block.iter_mut().zip(&g[from..from + size]) {
                        *o = x.d[j];
                    }
                }
                None => block.fill(S::constant(0.0)),
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Dual;

    /// f(x, y) = atan2(y, x)·sqrt(x² + y²) + sin(x y)/exp(y) − ln(x)·y³, and its partials
    /// written out by hand.
    fn f<S: Scalar>(x: S, y: S) -> S {
        y.atan2(x) * (x * x + y * y).sqrt() + (x * y).sin() / y.exp() - x.ln() * y.powi(3)
    }

    fn grad(x: f64, y: f64) -> [f64; 2] {
        let (r2, r) = (x * x + y * y, (x * x + y * y).sqrt());
        let a = y.atan2(x);
        let (s, c) = (x * y).sin_cos();
        let e = (-y).exp();
        [
            -y / r2 * r + a * x / r + y * c * e - y.powi(3) / x,
            x / r2 * r + a * y / r + x * c * e - s * e - 3.0 * x.ln() * y * y,
        ]
    }

    #[test]
    fn partials_are_the_hand_derivatives() {
        for &(x, y) in &[(1.3, 0.4), (0.2, -2.0), (3.0, 1.0)] {
            let p = f(Partials::<f64, 2>::variable(x, 0), Partials::variable(y, 1));
            let g = grad(x, y);
            assert!((p.v - f(x, y)).abs() < 1e-15 * f(x, y).abs().max(1.0));
            for j in 0..2 {
                assert!(
                    (p.d[j] - g[j]).abs() < 1e-13 * g[j].abs().max(1.0),
                    "{j}: {} {}",
                    p.d[j],
                    g[j]
                );
            }
        }
    }

    #[test]
    fn partials_over_duals_give_second_derivatives() {
        // ∂/∂x of the partial ∂f/∂y, against central differences of the hand gradient.
        let (x, y) = (1.3, 0.4);
        let xp = Partials::<Dual, 1> {
            v: Dual::new(x, 1.0),
            d: [Dual::new(0.0, 0.0)],
        };
        let p = f(xp, Partials::variable(Dual::new(y, 0.0), 0));
        let h = 1e-6;
        let fd = (grad(x + h, y)[1] - grad(x - h, y)[1]) / (2.0 * h);
        assert!((p.d[0].d - fd).abs() < 1e-7, "{} {fd}", p.d[0].d);
    }

    #[test]
    fn the_blocks_land_where_the_layout_puts_them() {
        // ℓ = 2, μ = 1, σ = 1: Z = [1, q0], α = [q1², q0 q1], A = [[q0, 0], [0, sin q1]].
        const DIMS: Dims = Dims::new(2, 1, 1);
        const N: usize = Layout::new(DIMS).len;
        let (dims, layout) = (DIMS, Layout::new(DIMS));
        let mut out = [7.0; 64];
        let out = &mut out[..layout.len];
        fn geometry<S: Scalar>(q: &[S], g: &mut [S]) {
            let (one, zero) = (S::constant(1.0), S::constant(0.0));
            g.copy_from_slice(&[
                one,
                q[0],
                q[1] * q[1],
                q[0] * q[1],
                q[0],
                zero,
                zero,
                q[1].sin(),
            ]);
        }
        let q = [0.5, 0.3];
        let mut hot = false;
        let hot_geometry = |q: &[Partials<f64, 2>], g: &mut [Partials<f64, 2>]| {
            hot = true;
            geometry(q, g)
        };
        ingredients_by_partials::<f64, 2, 2, 8, N>(&q, &[0, 1], dims, out, hot_geometry, geometry);
        assert!(hot, "f64 takes the inlined path");
        // A coordinate not carried has its blocks zero, whatever the buffer held.
        let mut stale = [7.0; N];
        ingredients_by_partials::<f64, 1, 2, 8, N>(&q, &[1], dims, &mut stale, geometry, geometry);
        let (a, z, al) = (layout.da, layout.dz, layout.dalpha);
        assert!(
            [a..a + 4, z..z + 2, al..al + 2]
                .into_iter()
                .all(|r| stale[r].iter().all(|&x| x == 0.0))
        );
        assert_eq!(stale[a + 4 + 3], 0.3f64.cos());
        // The cold path (a wide type) gives the same numbers.
        let mut wide = [Dual::new(7.0, 0.0); 64];
        let wide = &mut wide[..layout.len];
        let qd = q.map(|v| Dual::new(v, 0.0));
        ingredients_by_partials::<Dual, 2, 2, 8, N>(&qd, &[0, 1], dims, wide, geometry, geometry);
        // … and so does a `Cold` one, computed in its plain type.
        let mut cold = [crate::Cold(Dual::new(7.0, 0.0)); 64];
        let cold = &mut cold[..layout.len];
        let qc = qd.map(crate::Cold);
        ingredients_by_partials::<crate::Cold<Dual>, 2, 2, 8, N>(
            &qc,
            &[0, 1],
            dims,
            cold,
            geometry,
            geometry,
        );
        assert!(wide.iter().zip(cold.iter()).all(|(w, c)| w.v == c.0.v));
        for (w, o) in wide
            .iter()
            .zip(out.iter())
            .take(layout.u)
            .chain(wide.iter().zip(out.iter()).skip(layout.da))
        {
            assert_eq!(w.v, *o);
        }
        assert_eq!(out[layout.alpha + 1], 0.15);
        assert_eq!(out[layout.da], 1.0); // ∂A00/∂q0
        assert_eq!(out[layout.da + 4 + 3], 0.3f64.cos()); // ∂A11/∂q1
        assert_eq!(out[layout.dz + 1], 1.0); // ∂Z01/∂q0
        assert_eq!(out[layout.dalpha + 2], 0.6); // ∂α00/∂q1
        assert_eq!(out[layout.dalpha + 1], 0.3); // ∂α01/∂q0
        assert_eq!(out[layout.u], 7.0, "U is left to the caller");
    }
}
