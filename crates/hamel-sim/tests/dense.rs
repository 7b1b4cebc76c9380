//! Dense output: states at times between steps, forward and backward.

mod common;

use common::{Sample, distance, sample_exact};
use hamel_sim::{Method, Options, integrate};

/// Largest error over 200 output times that (with these few steps) fall between steps.
fn dense_error(method: Method, tol: f64) -> f64 {
    let outputs: Vec<f64> = (1..=200).map(|k| 0.0251 * f64::from(k)).collect();
    let options = Options {
        rtol: tol,
        atol: tol,
        ..Options::default()
    };
    let solution = integrate(&Sample, method, 0.0, &[1.0, 1.0], &outputs, &options).unwrap();
    assert_eq!(solution.t, outputs);
    assert!(
        solution.stats.steps < 100,
        "{method:?}: {} steps, outputs would not be off-step",
        solution.stats.steps
    );
    solution
        .t
        .iter()
        .zip(&solution.y)
        .map(|(&t, y)| distance(y, &sample_exact(t)))
        .fold(0.0, f64::max)
}

/// The continuous extensions are as accurate as the embedded error estimates that control
/// the steps (not as the propagated solution), so the dense error is a modest multiple of the
/// tolerance and shrinks in proportion to it.
fn check_dense(method: Method) {
    let loose = dense_error(method, 1e-8);
    let tight = dense_error(method, 1e-10);
    assert!(
        loose < 30.0 * 1e-8,
        "{method:?}: dense error {loose:e} at tol 1e-8"
    );
    assert!(
        tight < 30.0 * 1e-10,
        "{method:?}: dense error {tight:e} at tol 1e-10"
    );
    assert!(
        tight / loose < 0.05,
        "{method:?}: dense error {loose:e} → {tight:e} for tol 1e-8 → 1e-10"
    );
}

#[test]
fn dopri5_dense_output_tracks_the_tolerance() {
    // Observed: 2.2e-7 at tol 1e-8 (42 steps), 2.4e-9 at tol 1e-10 (97 steps).
    check_dense(Method::Dopri5);
}

#[test]
fn dop853_dense_output_tracks_the_tolerance() {
    // Observed: 5.7e-8 at tol 1e-8 (14 steps), 7.3e-10 at tol 1e-10 (23 steps).
    check_dense(Method::Dop853);
}

#[test]
fn vern9_dense_output_tracks_the_tolerance() {
    check_dense(Method::Vern9);
}

#[test]
fn integration_runs_backward_with_dense_output() {
    let y1 = sample_exact(1.0);
    let outputs = [0.9, 0.55, 0.3, 0.0];
    for method in [
        Method::Dopri5,
        Method::Dop853,
        Method::Vern9,
        Method::GaussLegendre {
            stages: 3,
            step: None,
        },
    ] {
        let options = Options {
            rtol: 1e-10,
            atol: 1e-10,
            ..Options::default()
        };
        let solution = integrate(&Sample, method, 1.0, &y1, &outputs, &options).unwrap();
        for (&t, y) in solution.t.iter().zip(&solution.y) {
            let error = distance(y, &sample_exact(t));
            assert!(error < 1e-8, "{method:?} at t = {t}: error {error:e}");
        }
    }
    let fixed = integrate(
        &Sample,
        Method::Rk4 { step: 0.01 },
        1.0,
        &y1,
        &outputs,
        &Options::default(),
    )
    .unwrap();
    assert!(distance(&fixed.y[3], &sample_exact(0.0)) < 1e-9);
}

#[test]
fn output_at_the_initial_time_is_the_initial_state() {
    let outputs = [0.0, 0.0, 0.5];
    for method in [Method::Dopri5, Method::Rk4 { step: 0.1 }] {
        let solution = integrate(
            &Sample,
            method,
            0.0,
            &[1.0, 1.0],
            &outputs,
            &Options::default(),
        )
        .unwrap();
        assert_eq!(solution.y[0], [1.0, 1.0]);
        assert_eq!(solution.y[1], [1.0, 1.0]);
        assert_eq!(solution.t, outputs);
    }
}
