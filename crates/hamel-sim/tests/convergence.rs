//! Convergence: observed orders of the fixed-step methods, and error against tolerance for the
//! adaptive ones.

mod common;

use common::{Kepler, Sample, distance, sample_exact};
use hamel_sim::{Method, Options, Stats, integrate};

/// Error at `t_end` of the sample problem, with the statistics of the run.
fn sample_error(method: Method, tol: f64, t_end: f64) -> (f64, Stats) {
    let options = Options {
        rtol: tol,
        atol: tol,
        ..Options::default()
    };
    let solution = integrate(&Sample, method, 0.0, &[1.0, 1.0], &[t_end], &options).unwrap();
    assert!(solution.complete);
    assert_eq!(solution.t, [t_end]);
    (
        distance(&solution.y[0], &sample_exact(t_end)),
        solution.stats,
    )
}

fn observed_order(method: impl Fn(f64) -> Method, h: f64) -> f64 {
    let (e1, _) = sample_error(method(h), 1e-6, 1.0);
    let (e2, _) = sample_error(method(h / 2.0), 1e-6, 1.0);
    (e1 / e2).log2()
}

#[test]
fn rk4_has_order_four() {
    // Observed 4.01 (errors 9.7e-7 and 6.0e-8).
    let order = observed_order(|step| Method::Rk4 { step }, 0.1);
    assert!((order - 4.0).abs() < 0.2, "observed order {order}");
}

#[test]
fn gauss_legendre_two_stages_has_order_four() {
    // Observed 4.00 (errors 1.0e-7 and 6.5e-9).
    let order = observed_order(
        |h| Method::GaussLegendre {
            stages: 2,
            step: Some(h),
        },
        0.1,
    );
    assert!((order - 4.0).abs() < 0.2, "observed order {order}");
}

#[test]
fn gauss_legendre_three_stages_has_order_six() {
    // Observed 6.00 (errors 2.0e-9 and 3.1e-11).
    let order = observed_order(
        |h| Method::GaussLegendre {
            stages: 3,
            step: Some(h),
        },
        0.2,
    );
    assert!((order - 6.0).abs() < 0.2, "observed order {order}");
}

#[test]
fn analytic_and_finite_difference_jacobians_give_the_same_gauss_steps() {
    let (analytic, y0) = Kepler::new(0.5, true);
    let (numeric, _) = Kepler::new(0.5, false);
    let method = Method::GaussLegendre {
        stages: 3,
        step: Some(0.05),
    };
    let outputs = [1.0, 2.0, 3.0];
    let a = integrate(&analytic, method, 0.0, &y0, &outputs, &Options::default()).unwrap();
    let b = integrate(&numeric, method, 0.0, &y0, &outputs, &Options::default()).unwrap();
    // Both iterations converge to roundoff; only the number of iterations may differ.
    for (ya, yb) in a.y.iter().zip(&b.y) {
        assert!(distance(ya, yb) < 1e-13, "{ya:?} vs {yb:?}");
    }
    assert_eq!(a.stats.jacobian_evals, b.stats.jacobian_evals);
    assert!(
        b.stats.rhs_evals > a.stats.rhs_evals,
        "finite differences cost evaluations"
    );
}

/// Error at t = 5 for tolerances 1e-3, 1e-5, …, 1e-11: strictly decreasing, and within
/// `bound(tol, stats)`.
fn check_tolerance_sweep(method: Method, bound: impl Fn(f64, &Stats) -> f64) {
    let mut previous = f64::INFINITY;
    for k in [3, 5, 7, 9, 11] {
        let tol = 10f64.powi(-k);
        let (error, stats) = sample_error(method, tol, 5.0);
        assert!(
            error < previous,
            "{method:?}: error {error:e} at tol {tol:e} not below {previous:e}"
        );
        assert!(
            error <= bound(tol, &stats),
            "{method:?}: error {error:e} at tol {tol:e}, {stats:?}"
        );
        previous = error;
    }
}

#[test]
fn dopri5_error_decreases_with_tolerance_and_meets_it() {
    // Observed error/tol between 0.06 and 1.4.
    check_tolerance_sweep(Method::Dopri5, |tol, _| 5.0 * tol);
}

#[test]
fn dop853_error_decreases_with_tolerance_and_meets_it() {
    // Observed error/tol between 0.04 and 1.5.
    check_tolerance_sweep(Method::Dop853, |tol, _| 5.0 * tol);
}

#[test]
fn vern9_error_decreases_with_tolerance_and_meets_it() {
    check_tolerance_sweep(Method::Vern9, |tol, _| 5.0 * tol);
}

#[test]
fn adaptive_gauss_legendre_error_decreases_with_tolerance() {
    // Step doubling controls the error per step, and the un-extrapolated solution is
    // propagated: the global error stays below steps × tol (observed error/tol up to 10).
    for stages in [2, 3] {
        check_tolerance_sweep(
            Method::GaussLegendre { stages, step: None },
            |tol, stats| stats.steps as f64 * tol,
        );
    }
}
