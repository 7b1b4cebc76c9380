//! The automatic differentiation recurrences of the Taylor method (Jorba & Zou 2005, §3), one
//! coefficient at a time: coefficient k ≥ 1 of an operation's result from its operands' series
//! to k and its own to k − 1. Normalised coefficients, x(t₀ + τ) = Σ_j x[j] τ^j. What the
//! interpreter of traced programs ([`crate::taylor_by_trace`]) and the generated cores'
//! compiled recurrences (`reduced_series`) both call, so that the two compute alike.
//!
//! Slices: `a`, `b`, … an operand's coefficients 0..=k (at least), `own` the result's 0..k.
//!
//! Every multiply–add of the sums the series written out repeats ([`convolve`], [`weighted`],
//! [`product`], [`square`], [`quotient`]) is a fused one, `f64::mul_add`: rounded once, so the
//! same bits on every machine, and one instruction where the CPU has FMA. Callers inline these
//! into a copy of their loop compiled for FMA (`#[target_feature(enable = "fma")]`), taken
//! where the CPU has it (the trace interpreter's `run`, the generated `reduced_series`);
//! elsewhere `mul_add` is the C library's correctly rounded `fma`, slower and the same bits.

/// Σ_i a[i]·b[len − 1 − i] over slices of one length: a Cauchy product's coefficient. Four
/// partial sums, so that the additions do not wait on one another.
#[inline(always)]
pub fn convolve(a: &[f64], b: &[f64]) -> f64 {
    let len = a.len().min(b.len());
    let (a, b) = (&a[..len], &b[..len]);
    let mut acc = [0.0_f64; 4];
    let (chunks, tail) = (len / 4, len % 4);
    for c in 0..chunks {
        for (l, s) in acc.iter_mut().enumerate() {
            let i = 4 * c + l;
            *s = a[i].mul_add(b[len - 1 - i], *s);
        }
    }
    for i in 4 * chunks..4 * chunks + tail {
        acc[0] = a[i].mul_add(b[len - 1 - i], acc[0]);
    }
    (acc[0] + acc[1]) + (acc[2] + acc[3])
}

/// Σ_{j=1}^{k} j·a[j]·b[k − j], `a` and `b` to coefficient k (b's own coefficient k unused):
/// one running sum from 0, term j as (j·a[j])·b[k − j] fused into it.
#[inline(always)]
pub fn weighted(a: &[f64], b: &[f64], k: usize) -> f64 {
    let terms = a[1..=k].iter().zip(b[..k].iter().rev());
    (terms.enumerate()).fold(0.0, |s, (j, (x, y))| ((j + 1) as f64 * x).mul_add(*y, s))
}

/// (a·b)[k]: the terms of coefficients below k first, then a[0]·b[k] and a[k]·b[0], the two
/// that wait on coefficient k of the operands. In a chain of operations each coefficient k then
/// waits on its operands' by one multiplication and two additions, not by a whole sum: the
/// latency the compiled series (`reduced_series`, written out) is bound by.
#[inline(always)]
pub fn product(a: &[f64], b: &[f64], k: usize) -> f64 {
    if k == 0 {
        return a[0] * b[0];
    }
    a[k].mul_add(b[0], a[0].mul_add(b[k], convolve(&a[1..k], &b[1..k])))
}

/// (a²)[k]: the product's symmetric terms once, doubled: 2·Σ_{0<i<k/2} a[i] a[k − i] (one
/// running sum), a[k/2]² for even k, then 2a[0]·a[k] last (as in [`product`]). Half the
/// product's multiplications.
#[inline(always)]
pub fn square(a: &[f64], k: usize) -> f64 {
    if k == 0 {
        return a[0] * a[0];
    }
    let mut s = 0.0_f64;
    for i in 1..k.div_ceil(2) {
        s = a[i].mul_add(a[k - i], s);
    }
    let base = if k.is_multiple_of(2) {
        a[k / 2].mul_add(a[k / 2], 2.0 * s)
    } else {
        2.0 * s
    };
    (2.0 * a[0]).mul_add(a[k], base)
}

// Every division below is a multiplication by a reciprocal: 1/b[0], 1/(2r[0]) and 1/k do not
// wait on coefficient k, so the chain from one coefficient to the next carries multiplications
// (4 cycles) where it carried divisions (13–15); the written-out series computes the same
// reciprocals once (`reduced_series`), the same bits.

/// 1/k, the factor of the recurrences that divide by the coefficient's index.
#[inline(always)]
pub fn inverse(k: usize) -> f64 {
    1.0 / k as f64
}

/// (a/b)[k] = (a[k] − Σ_{j=1}^{k} b[j] q[k − j]) · (1/b[0]), the term of b[k] added last (as in
/// [`product`]).
#[inline(always)]
pub fn quotient(a_k: f64, b: &[f64], own: &[f64], k: usize) -> f64 {
    (a_k - b[k].mul_add(own[0], convolve(&b[1..k], &own[1..k]))) * (1.0 / b[0])
}

/// √a[k] = (a[k] − Σ_{j=1}^{k−1} r[j] r[k − j]) · (1/(2 r[0])).
#[inline(always)]
pub fn sqrt(a_k: f64, own: &[f64], k: usize) -> f64 {
    (a_k - convolve(&own[1..k], &own[1..k])) * (1.0 / (2.0 * own[0]))
}

/// (sin a)[k] from a and cos a: s' = a' c.
#[inline(always)]
pub fn sin(a: &[f64], cos: &[f64], k: usize) -> f64 {
    weighted(a, cos, k) * inverse(k)
}

/// (cos a)[k] from a and sin a: c' = −a' s.
#[inline(always)]
pub fn cos(a: &[f64], sin: &[f64], k: usize) -> f64 {
    -weighted(a, sin, k) * inverse(k)
}

/// (exp a)[k]: e' = a' e.
#[inline(always)]
pub fn exp(a: &[f64], own: &[f64], k: usize) -> f64 {
    weighted(a, own, k) * inverse(k)
}

/// (ln a)[k] = (a[k] − (1/k) Σ_{j=1}^{k−1} j l[j] a[k − j]) / a[0]: a l' = a'.
#[inline(always)]
pub fn ln(a: &[f64], own: &[f64], k: usize) -> f64 {
    let terms = own[1..k].iter().zip(a[1..k].iter().rev());
    let sum: f64 = terms
        .enumerate()
        .map(|(j, (l, x))| (j + 1) as f64 * l * x)
        .sum();
    (a[k] - sum / k as f64) / a[0]
}

/// (a^r)[k] for a constant real r: a·p' = r·a'·p, p[k] = Σ_{j=0}^{k−1} (r(k − j) − j) a[k − j]
/// p[j] / (k a[0]).
#[inline(always)]
pub fn power(a: &[f64], own: &[f64], r: f64, k: usize) -> f64 {
    let mut s = 0.0;
    for (j, p) in own[..k].iter().enumerate() {
        s += (r * (k - j) as f64 - j as f64) * a[k - j] * p;
    }
    s / (k as f64 * a[0])
}

/// (atan a)[k] with r = 1 + a²: t'·r = a'.
#[inline(always)]
pub fn atan(a: &[f64], r: &[f64], own: &[f64], k: usize) -> f64 {
    let kf = k as f64;
    (kf * a[k] - quotient_sum(own, r, k)) / (kf * r[0])
}

/// atan2(y, x)[k] with r = x² + y²: t'·r = x y' − y x'.
#[inline(always)]
pub fn atan2(y: &[f64], x: &[f64], r: &[f64], own: &[f64], k: usize) -> f64 {
    let mut g = 0.0;
    for i in 0..k {
        let d = (k - i) as f64;
        g += d * (x[i] * y[k - i] - y[i] * x[k - i]);
    }
    (g - quotient_sum(own, r, k)) / (k as f64 * r[0])
}

/// Σ_{j=0}^{k−2} (j + 1) t[j + 1] r[k − 1 − j]: the known part of coefficient k − 1 of t'·r.
#[inline(always)]
fn quotient_sum(t: &[f64], r: &[f64], k: usize) -> f64 {
    let mut s = 0.0;
    for j in 0..k.saturating_sub(1) {
        s += (j + 1) as f64 * t[j + 1] * r[k - 1 - j];
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The sums the series written out repeats, once compiled for FMA (one instruction each
    /// `mul_add`) and once not (the C library's `fma`): the same bits, what makes a series the
    /// same on every machine.
    #[test]
    #[cfg(target_arch = "x86_64")]
    fn fused_sums_give_the_same_bits_with_and_without_the_fma_unit() {
        #[target_feature(enable = "fma")]
        fn with_unit(a: &[f64], b: &[f64], k: usize) -> [f64; 4] {
            without(a, b, k)
        }
        #[inline(always)]
        fn without(a: &[f64], b: &[f64], k: usize) -> [f64; 4] {
            [
                product(a, b, k),
                square(a, k),
                quotient(a[k], b, a, k),
                sin(a, b, k),
            ]
        }
        if !std::arch::is_x86_feature_detected!("fma") {
            return;
        }
        let a: Vec<f64> = (0..21)
            .map(|i| ((i * 7 % 11) as f64 - 5.3) / (i + 1) as f64)
            .collect();
        let b: Vec<f64> = (0..21)
            .map(|i| ((i * 5 % 13) as f64 + 0.7) / (i + 2) as f64)
            .collect();
        for k in 1..=20 {
            // SAFETY: the CPU has FMA (tested above).
            let fused = unsafe { with_unit(&a, &b, k) };
            let called = std::hint::black_box(without)(&a, &b, k);
            assert_eq!(fused.map(f64::to_bits), called.map(f64::to_bits), "k = {k}");
        }
    }

    /// The square's recurrence is the product's with the operand twice, to rounding.
    #[test]
    fn square_is_the_product_of_a_series_with_itself() {
        let a: Vec<f64> = (0..21)
            .map(|i| ((i * 7 % 11) as f64 - 5.0) / (i + 1) as f64)
            .collect();
        for k in 0..=20 {
            let (s, p) = (square(&a, k), product(&a, &a, k));
            let scale: f64 = (0..=k).map(|i| (a[i] * a[k - i]).abs()).sum();
            assert!(
                (s - p).abs() <= 4.0 * f64::EPSILON * scale,
                "k = {k}: {s} against {p}"
            );
        }
    }
}
