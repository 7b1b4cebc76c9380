//! Long runs on the Kepler problem: Gauss–Legendre keeps the energy error bounded, RK4 drifts.

mod common;

use std::f64::consts::PI;

use common::Kepler;
use hamel_sim::{Method, OdeSystem, Options, Solution, integrate};

const STEPS_PER_PERIOD: usize = 100;
const PERIODS: usize = 10_000;
/// Outputs every 37 steps: on the step grid, and sampling every phase of the orbit.
const OUTPUT_EVERY: usize = 37;

/// Kepler with eccentricity 0.5 over 10⁴ periods with 100 fixed steps per period.
fn run(method: impl Fn(f64) -> Method) -> (Kepler, Vec<f64>, Solution) {
    let (kepler, y0) = Kepler::new(0.5, true);
    let h = 2.0 * PI / STEPS_PER_PERIOD as f64;
    let outputs: Vec<f64> = (1..=STEPS_PER_PERIOD * PERIODS / OUTPUT_EVERY)
        .map(|k| (k * OUTPUT_EVERY) as f64 * h)
        .collect();
    let options = Options {
        max_steps: 2_000_000,
        ..Options::default()
    };
    let solution = integrate(&kepler, method(h), 0.0, &y0, &outputs, &options).unwrap();
    assert_eq!(
        solution.stats.steps,
        outputs.len() * OUTPUT_EVERY,
        "outputs on the grid take no extra steps"
    );
    (kepler, y0, solution)
}

/// Largest energy error over the outputs in the periods `[from, to]`.
fn energy_error(kepler: &Kepler, y0: &[f64], solution: &Solution, from: f64, to: f64) -> f64 {
    let e0 = kepler.energy(0.0, y0).unwrap();
    solution
        .t
        .iter()
        .zip(&solution.energy)
        .filter(|(t, _)| (from * 2.0 * PI..=to * 2.0 * PI).contains(*t))
        .map(|(_, e)| (e.unwrap() - e0).abs())
        .fold(0.0, f64::max)
}

fn assert_bounded(stages: usize) {
    let (kepler, y0, solution) = run(|h| Method::GaussLegendre {
        stages,
        step: Some(h),
    });
    let first = energy_error(&kepler, &y0, &solution, 0.0, 1000.0);
    let last = energy_error(&kepler, &y0, &solution, 9000.0, 10_000.0);
    // Observed: 2.386e-6 in both windows (s = 2), 5.458e-9 and 5.459e-9 (s = 3).
    assert!(
        last <= 1.05 * first,
        "s = {stages}: energy error grew from {first:e} to {last:e}"
    );
    assert!(first < 1e-5, "s = {stages}: energy error {first:e}");
    // Quadratic invariants (the angular momentum) are conserved up to roundoff.
    let momentum = solution.stats.constraint_drift.unwrap();
    assert!(
        momentum < 1e-10,
        "s = {stages}: angular momentum drift {momentum:e}"
    );
    assert_eq!(solution.stats.newton_failures, 0);
}

#[test]
#[cfg_attr(debug_assertions, ignore = "10⁶ implicit steps: run with --release")]
fn gauss_legendre_two_stages_energy_error_stays_bounded() {
    assert_bounded(2);
}

#[test]
#[cfg_attr(debug_assertions, ignore = "10⁶ implicit steps: run with --release")]
fn gauss_legendre_three_stages_energy_error_stays_bounded() {
    assert_bounded(3);
}

#[test]
fn rk4_energy_error_drifts() {
    let (kepler, y0, solution) = run(|step| Method::Rk4 { step });
    let first = energy_error(&kepler, &y0, &solution, 0.0, 1000.0);
    let last = energy_error(&kepler, &y0, &solution, 9000.0, 10_000.0);
    // Observed: 1.5e-2 over the first thousand periods, 0.17 over the last (linear drift).
    assert!(last > 5.0 * first, "RK4 energy error {first:e} → {last:e}");
    let drift = solution.stats.energy_drift.unwrap();
    assert!(drift > 0.1, "relative energy drift {drift:e}");
}
