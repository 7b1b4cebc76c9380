//! The Taylor method's choices (Jorba & Zou 2005, "A software package for the numerical
//! integration of ODEs by means of high-order Taylor methods", Exp. Math. 14; the rules TIDES
//! and heyoka use): the order from the tolerance, the step from the last two coefficients, and
//! the series summed by Horner's rule (the dense output is the series itself).
//!
//! With ε = rtol and the scale s = max(atol/rtol, ‖y‖∞) (relative error where the state is
//! large, absolute where it is small), the order is p = ⌈−ln ε / 2 + 1⌉ and the step
//! h = ρ/e² · exp(−0.7/(p − 1)), ρ = min((s/‖y[p−1]‖∞)^{1/(p−1)}, (s/‖y[p]‖∞)^{1/p}): the
//! series' last terms then contribute about ε·s, and the method needs no error estimate or
//! rejected steps. The coefficients come from the system ([`crate::OdeSystem::taylor_coefficients`];
//! `hamel_expr::taylor::Series` computes them from a tape).

/// The order for the tolerances: ⌈−ln ε / 2 + 1⌉, ε = rtol, at least 2.
pub fn order(rtol: f64) -> usize {
    ((-rtol.ln() / 2.0 + 1.0).ceil() as usize).max(2)
}

/// The step (positive; +∞ where the series ends before order p − 1) from the coefficients
/// `series` (rows of `n`, orders 0..=p) at the state `y`.
pub fn step(series: &[f64], n: usize, order: usize, (rtol, atol): (f64, f64), y: &[f64]) -> f64 {
    let norm = |k: usize| {
        series[k * n..(k + 1) * n]
            .iter()
            .fold(0.0_f64, |m, x| m.max(x.abs()))
    };
    let size = y.iter().fold(0.0_f64, |m, x| m.max(x.abs()));
    let scale = (atol / rtol).max(size);
    // ln of (s/‖y[k]‖)^{1/k}: two logarithms and one exponential, where two powers cost more
    let log_radius = |k: usize| {
        let c = norm(k);
        if c == 0.0 {
            f64::INFINITY
        } else {
            (scale / c).ln() / k as f64
        }
    };
    let p = order as f64;
    let log_rho = log_radius(order - 1).min(log_radius(order));
    (log_rho - 2.0 - 0.7 / (p - 1.0)).exp()
}

/// y(t + τ) = Σ_k y[k] τ^k into `out`, by Horner's rule: one component at a time, its sum
/// held in a register (the components' chains overlap; row by row, every component went
/// through memory at every row), each step a fused multiply–add (`f64::mul_add`, rounded once:
/// the same bits on every machine; where the CPU has FMA by a copy compiled for it, one
/// instruction a step).
pub fn sum(series: &[f64], n: usize, tau: f64, out: &mut [f64]) {
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("fma") {
        // SAFETY: the CPU has FMA, the one feature `sum_fma` is compiled for.
        unsafe { sum_fma(series, n, tau, out) };
        return;
    }
    sum_in(series, n, tau, out);
}

/// [`sum_in`] compiled for FMA.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "fma")]
fn sum_fma(series: &[f64], n: usize, tau: f64, out: &mut [f64]) {
    sum_in(series, n, tau, out);
}

/// The body of [`sum`].
#[inline(always)]
fn sum_in(series: &[f64], n: usize, tau: f64, out: &mut [f64]) {
    let rows = series.len() / n;
    for (i, o) in out.iter_mut().enumerate().take(n) {
        let mut s = series[(rows - 1) * n + i];
        for k in (0..rows - 1).rev() {
            s = s.mul_add(tau, series[k * n + i]);
        }
        *o = s;
    }
}
