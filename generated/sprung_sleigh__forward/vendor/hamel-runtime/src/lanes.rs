//! [`Lanes`]: four f64 values evaluated together, the scalar type of the generated cores'
//! monitors (energy, constraint residual) over many outputs at once.
//!
//! Every operation is lane by lane and IEEE-exact per lane (no fused multiply-add, no
//! reassociation), so a lane's value is the same bits whatever the vector width the compiler
//! chooses, and the same on every x86-64 or AArch64 machine. Sine and cosine are
//! branch-free in the lanes ([`sin_cos`]): Cody–Waite reduction by π/2 in three parts, then
//! fdlibm's kernel polynomials (the ones musl and the `libm` crate use), within an ulp of
//! `libm::sincos` for |x| ≤ 2²⁰·π/2; larger or non-finite arguments are passed to
//! `libm::sincos` lane by lane.

// The constants are fdlibm's, as musl and the `libm` crate print them: more digits than a
// double holds, each naming one double exactly.
#![allow(clippy::excessive_precision)]

use std::ops::{Add, Div, Mul, Neg, Sub};

use crate::error::EvalError;
use crate::scalar::Scalar;

/// The number of values evaluated together.
pub const LANES: usize = 4;

/// [`LANES`] f64 values, each evaluated on its own.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Lanes(pub [f64; LANES]);

impl Lanes {
    /// Each lane `f` of the lanes of `self`.
    #[inline(always)]
    pub fn map(self, f: impl Fn(f64) -> f64) -> Self {
        Lanes(self.0.map(f))
    }

    /// Lane by lane `f(self, other)`.
    #[inline(always)]
    pub fn zip(self, other: Self, f: impl Fn(f64, f64) -> f64) -> Self {
        Lanes(std::array::from_fn(|i| f(self.0[i], other.0[i])))
    }
}

macro_rules! lane_op {
    ($trait:ident, $method:ident, $op:tt) => {
        impl $trait for Lanes {
            type Output = Lanes;
            #[inline(always)]
            fn $method(self, other: Lanes) -> Lanes {
                self.zip(other, |a, b| a $op b)
            }
        }
    };
}

lane_op!(Add, add, +);
lane_op!(Sub, sub, -);
lane_op!(Mul, mul, *);
lane_op!(Div, div, /);

impl Neg for Lanes {
    type Output = Lanes;
    #[inline(always)]
    fn neg(self) -> Lanes {
        self.map(|a| -a)
    }
}

impl Scalar for Lanes {
    crate::plain_itself!();
    #[inline(always)]
    fn constant(v: f64) -> Self {
        Lanes([v; LANES])
    }
    /// The first lane (pivoting and domain checks read one value: generated code evaluates
    /// lanes only where it makes neither, the closed forms).
    fn value(&self) -> f64 {
        self.0[0]
    }
    #[inline(always)]
    fn sin(self) -> Self {
        sin_cos(self).0
    }
    #[inline(always)]
    fn cos(self) -> Self {
        sin_cos(self).1
    }
    #[inline(always)]
    fn sin_cos(self) -> (Self, Self) {
        sin_cos(self)
    }
    fn tan(self) -> Self {
        self.map(f64::tan)
    }
    #[inline(always)]
    fn sqrt(self) -> Self {
        self.map(f64::sqrt)
    }
    fn exp(self) -> Self {
        self.map(f64::exp)
    }
    fn ln(self) -> Self {
        self.map(f64::ln)
    }
    fn atan(self) -> Self {
        self.map(f64::atan)
    }
    fn atan2(self, x: Self) -> Self {
        self.zip(x, f64::atan2)
    }
    #[inline(always)]
    fn powi(self, n: i32) -> Self {
        self.map(|a| a.powi(n))
    }
    fn powf(self, e: Self) -> Self {
        self.zip(e, f64::powf)
    }
}

/// A function of a state, evaluated [`LANES`] states at a time by [`over_rows`].
pub trait LaneFn {
    /// The values at the states whose components are `x` (`x[i]` holds component i of each
    /// state, one per lane).
    fn at(&self, x: &[Lanes]) -> Result<Lanes, EvalError>;
    /// The value at one state `y`, where the lanes failed (None: not defined there).
    fn one(&self, y: &[f64]) -> Option<f64>;
}

/// `f` at every row of `rows` (states of `W` components one after another) into `out` (one
/// entry a row), None where it fails or is not finite. [`LANES`] rows at a time, the last
/// group filled up with its last row; where the CPU has AVX2 by a copy compiled for it, which
/// gives the same bits (lane by lane IEEE arithmetic either way).
pub fn over_rows<const W: usize, F: LaneFn>(f: &F, rows: &[f64], out: &mut [Option<f64>]) {
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx2") {
        // SAFETY: the CPU has AVX2, the one feature `over_rows_avx2` is compiled for.
        unsafe { over_rows_avx2::<W, F>(f, rows, out) };
        return;
    }
    over_rows_in::<W, F>(f, rows, out);
}

/// [`over_rows_in`] compiled for AVX2 (four f64 lanes in one register).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn over_rows_avx2<const W: usize, F: LaneFn>(f: &F, rows: &[f64], out: &mut [Option<f64>]) {
    over_rows_in::<W, F>(f, rows, out);
}

/// The body of [`over_rows`]: whole groups of [`LANES`] rows, then the rest padded with its
/// last row.
#[inline(always)]
fn over_rows_in<const W: usize, F: LaneFn>(f: &F, rows: &[f64], out: &mut [Option<f64>]) {
    assert_eq!(rows.len(), W * out.len(), "one output a row of {W}");
    let groups = rows.chunks_exact(LANES * W);
    let rest = groups.remainder();
    let mut outs = out.chunks_exact_mut(LANES);
    for (group, values) in groups.zip(&mut outs) {
        let x: [Lanes; W] =
            std::array::from_fn(|i| Lanes(std::array::from_fn(|l| group[l * W + i])));
        lanes_into(f, &x, group, values);
    }
    let values = outs.into_remainder();
    if let Some(last) = rest.len().checked_sub(W) {
        let mut padded = [[0.0; W]; LANES];
        for (l, state) in padded.iter_mut().enumerate() {
            let row = (l * W).min(last);
            state.copy_from_slice(&rest[row..row + W]);
        }
        let x: [Lanes; W] = std::array::from_fn(|i| Lanes(padded.map(|state| state[i])));
        lanes_into(f, &x, rest, values);
    }
}

/// `f` at the lanes `x` of the rows `rows` into `values` (one a row, at most [`LANES`]); row
/// by row where the lanes fail.
#[inline(always)]
fn lanes_into<const W: usize, F: LaneFn>(
    f: &F,
    x: &[Lanes; W],
    rows: &[f64],
    values: &mut [Option<f64>],
) {
    match f.at(x) {
        Ok(v) => {
            for (o, v) in values.iter_mut().zip(v.0) {
                *o = Some(v).filter(|v| v.is_finite());
            }
        }
        Err(_) => {
            for (o, y) in values.iter_mut().zip(rows.chunks_exact(W)) {
                *o = f.one(y).filter(|v| v.is_finite());
            }
        }
    }
}

/// max |x_i| over `xs`, lane by lane ([`max_abs`] from 0).
#[inline(always)]
pub fn abs_max(xs: &[Lanes]) -> Lanes {
    xs.iter()
        .fold(Lanes::constant(0.0), |m, x| m.zip(*x, max_abs))
}

/// The larger of m and |x|; NaN when either is (where `f64::max` would drop a NaN, and a
/// residual that is not a number would pass for a finite one).
#[inline(always)]
pub fn max_abs(m: f64, x: f64) -> f64 {
    if x.abs() > m || x.is_nan() {
        x.abs()
    } else {
        m
    }
}

/// Above this |x| (2²⁰·π/2) the reduction's three parts of π/2 no longer give every bit.
const REDUCED_UP_TO: f64 = 1_647_099.0;

/// sin x and cos x in every lane: lanes with |x| ≤ [`REDUCED_UP_TO`] by [`reduce`] and the
/// kernels, the others (large or not finite) by `libm::sincos`.
#[inline(always)]
pub fn sin_cos(x: Lanes) -> (Lanes, Lanes) {
    if every(x.map(|v| v.abs() - REDUCED_UP_TO), |d| d <= 0.0) {
        return sin_cos_reduced(x);
    }
    let both = x.0.map(libm::sincos);
    (Lanes(both.map(|b| b.0)), Lanes(both.map(|b| b.1)))
}

/// Whether `test` holds in every lane, tested in all of them (no early exit, so that the
/// compiler compares the lanes at once).
#[inline(always)]
fn every(x: Lanes, test: impl Fn(f64) -> bool) -> bool {
    x.0.iter().fold(true, |all, &v| all & test(v))
}

/// [`sin_cos`] for |x| ≤ [`REDUCED_UP_TO`] in every lane, written lane by lane over arrays
/// (and bit operations for the quadrant) so that the compiler keeps the lanes in vector
/// registers.
#[inline(always)]
fn sin_cos_reduced(x: Lanes) -> (Lanes, Lanes) {
    let (k, y0, y1) = reduce(x);
    let s = kernel_sin(y0, y1);
    let c = kernel_cos(y0, y1);
    // The quadrant k = n mod 4 picks (sin, cos) from (s, c): (s, c), (c, −s), (−s, −c), (−c, s).
    let mut sin = [0.0; LANES];
    let mut cos = [0.0; LANES];
    for i in 0..LANES {
        let swap = (k[i] & 1).wrapping_neg();
        let (s, c) = (s.0[i].to_bits(), c.0[i].to_bits());
        sin[i] = f64::from_bits(((s & !swap) | (c & swap)) ^ ((k[i] & 2) << 62));
        cos[i] = f64::from_bits(((c & !swap) | (s & swap)) ^ (((k[i] + 1) & 2) << 62));
        // sin(±0) = ±0 (the reduction's sums lose the sign of a zero).
        if x.0[i] == 0.0 {
            sin[i] = x.0[i];
        }
    }
    (Lanes(sin), Lanes(cos))
}

/// x = n·π/2 + (y0 + y1) with |y0 + y1| ≤ π/4 (a little more at the rounding of n), for
/// |x| ≤ [`REDUCED_UP_TO`], and k = n mod 4. Cody–Waite as musl's `__rem_pio2` for medium
/// arguments: π/2 in parts of 33 bits, n times each exact. One part and its tail (85 bits)
/// unless some lane lost more than 16 bits to cancellation (x near a multiple of π/2); then
/// all three, each subtraction's rounding error kept exactly ([`two_diff`]).
#[inline(always)]
fn reduce(x: Lanes) -> ([u64; LANES], Lanes, Lanes) {
    const TO_INT: f64 = 1.5 / f64::EPSILON;
    const PIO2_1: f64 = 1.570_796_326_734_125_614_17;
    const PIO2_1T: f64 = 6.077_100_506_506_192_249_32e-11;
    const PIO2_2: f64 = 6.077_100_506_303_965_976_6e-11;
    const PIO2_3: f64 = 2.022_266_248_711_166_455_8e-21;
    const PIO2_3T: f64 = 8.478_427_660_368_899_569_97e-32;
    let c = Lanes::constant;
    // 1.5·2⁵² + n: n in the low bits of the mantissa (two's complement).
    let shifted = x * c(std::f64::consts::FRAC_2_PI) + c(TO_INT);
    let k = shifted.0.map(|v| v.to_bits() & 3);
    let n = shifted - c(TO_INT);
    // Exact: n·PIO2_1 has at most 54 − 33 bits to spare, and it is within a factor 2 of x.
    let r1 = x - n * c(PIO2_1);
    let w = n * c(PIO2_1T);
    let y0 = r1 - w;
    let kept = y0.zip(x, |y0, x| y0.abs() - x.abs() * (1.0 / 65_536.0));
    if every(kept, |d| d >= 0.0) {
        return (k, y0, (r1 - y0) - w);
    }
    let (r2, e2) = two_diff(r1, n * c(PIO2_2));
    let (r3, e3) = two_diff(r2, n * c(PIO2_3));
    let tail = (e2 + e3) - n * c(PIO2_3T);
    let y0 = r3 + tail;
    let y1 = tail - (y0 - r3);
    (k, y0, y1)
}

/// a − b = d + e exactly, d the rounded difference (Knuth's TwoSum).
#[inline(always)]
fn two_diff(a: Lanes, b: Lanes) -> (Lanes, Lanes) {
    let d = a - b;
    let bb = a - d;
    (d, (a - (d + bb)) + (bb - b))
}

/// sin(x + y) for |x| ≤ π/4, y the tail of x: fdlibm's `__kernel_sin`.
#[inline(always)]
fn kernel_sin(x: Lanes, y: Lanes) -> Lanes {
    const S: [f64; 6] = [
        -1.666_666_666_666_663_243_48e-1,
        8.333_333_333_322_489_461_24e-3,
        -1.984_126_982_985_794_931_34e-4,
        2.755_731_370_707_006_767_89e-6,
        -2.505_076_025_340_686_341_95e-8,
        1.589_690_995_211_550_102_21e-10,
    ];
    let c = Lanes::constant;
    let z = x * x;
    let w = z * z;
    let r = c(S[1]) + z * (c(S[2]) + z * c(S[3])) + z * w * (c(S[4]) + z * c(S[5]));
    let v = z * x;
    x - ((z * (c(0.5) * y - v * r) - y) - v * c(S[0]))
}

/// cos(x + y) for |x| ≤ π/4, y the tail of x: fdlibm's `__kernel_cos`.
#[inline(always)]
fn kernel_cos(x: Lanes, y: Lanes) -> Lanes {
    const C: [f64; 6] = [
        4.166_666_666_666_660_190_37e-2,
        -1.388_888_888_887_410_957_49e-3,
        2.480_158_728_947_672_941_78e-5,
        -2.755_731_435_139_066_330_35e-7,
        2.087_572_321_298_174_827_9e-9,
        -1.135_964_755_778_819_482_65e-11,
    ];
    let c = Lanes::constant;
    let z = x * x;
    let w = z * z;
    let r = z * (c(C[0]) + z * (c(C[1]) + z * c(C[2])))
        + w * w * (c(C[3]) + z * (c(C[4]) + z * c(C[5])));
    let hz = c(0.5) * z;
    let w = c(1.0) - hz;
    w + (((c(1.0) - w) - hz) + (z * r - x * y))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Distance in units of the last place between a and b (same sign assumed near).
    fn ulps(a: f64, b: f64) -> f64 {
        let scale = b.abs().max(f64::MIN_POSITIVE);
        (a - b).abs() / (scale * f64::EPSILON)
    }

    /// Within one ulp of libm on a grid of [−10⁶, 10⁶], with extra points at the multiples of
    /// π/2 and π/4 (cancellation in the reduction, quadrant edges).
    #[test]
    fn sin_cos_is_within_an_ulp_of_libm() {
        let mut xs: Vec<f64> = (-200_000..=200_000).map(|k| k as f64 * 5.000_3).collect();
        for k in -4000..=4000 {
            let x = k as f64 * std::f64::consts::FRAC_PI_4;
            xs.extend([x, f64::from_bits(x.to_bits() + 1), x.next_down()]);
        }
        xs.extend([
            0.0,
            -0.0,
            1e-300,
            -1e-300,
            1e-8,
            REDUCED_UP_TO,
            -REDUCED_UP_TO,
        ]);
        let mut worst = 0.0_f64;
        for chunk in xs.chunks(LANES) {
            let mut lanes = [chunk[0]; LANES];
            lanes[..chunk.len()].copy_from_slice(chunk);
            let (s, c) = sin_cos(Lanes(lanes));
            for (i, &x) in lanes.iter().enumerate() {
                let (ls, lc) = libm::sincos(x);
                worst = worst.max(ulps(s.0[i], ls)).max(ulps(c.0[i], lc));
                assert!(ulps(s.0[i], ls) <= 1.0, "sin {x}: {} vs {ls}", s.0[i]);
                assert!(ulps(c.0[i], lc) <= 1.0, "cos {x}: {} vs {lc}", c.0[i]);
            }
        }
        assert!(worst > 0.0, "compared against itself?");
    }

    /// Arguments beyond the reduction, infinite or NaN go to libm unchanged.
    #[test]
    fn large_and_non_finite_arguments_are_libms() {
        let x = Lanes([1e7, f64::INFINITY, f64::NAN, 0.5]);
        let (s, c) = sin_cos(x);
        for i in 0..LANES {
            let (ls, lc) = libm::sincos(x.0[i]);
            assert_eq!(s.0[i].to_bits(), ls.to_bits());
            assert_eq!(c.0[i].to_bits(), lc.to_bits());
        }
    }

    /// The signs of zero: sin(−0) = −0.
    #[test]
    fn sin_keeps_the_sign_of_zero() {
        let (s, c) = sin_cos(Lanes([-0.0, 0.0, 0.0, 0.0]));
        assert!(s.0[0] == 0.0 && s.0[0].is_sign_negative());
        assert_eq!(c.0[0], 1.0);
    }
}
