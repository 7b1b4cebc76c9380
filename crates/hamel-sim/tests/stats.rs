//! Statistics: evaluation counts follow from the step counts as each method's structure says.

mod common;

use common::{Kepler, Sample};
use hamel_sim::{Method, Options, integrate};

#[test]
fn rk4_takes_four_evaluations_per_step_and_lands_on_outputs() {
    let outputs = [0.25, 0.5, 1.0];
    let solution = integrate(
        &Sample,
        Method::Rk4 { step: 0.1 },
        0.0,
        &[1.0, 1.0],
        &outputs,
        &Options::default(),
    )
    .unwrap();
    let stats = &solution.stats;
    // 0 → 0.25: 0.1, 0.1, 0.05; 0.25 → 0.5: the same; 0.5 → 1.0: five full steps.
    assert_eq!(stats.steps, 11);
    assert_eq!(stats.rhs_evals, 4 * stats.steps);
    assert_eq!(
        (
            stats.rejected,
            stats.jacobian_evals,
            stats.newton_iterations
        ),
        (0, 0, 0)
    );
    assert_eq!(solution.t, outputs);
}

#[test]
fn dopri5_takes_six_evaluations_per_attempt() {
    // A far too large first step forces rejections.
    for h0 in [None, Some(1.0)] {
        let options = Options {
            rtol: 1e-10,
            atol: 1e-10,
            h0,
            ..Options::default()
        };
        let solution =
            integrate(&Sample, Method::Dopri5, 0.0, &[1.0, 1.0], &[3.0], &options).unwrap();
        let stats = &solution.stats;
        let attempts = stats.steps + stats.rejected;
        // f(t0, y0), the initial-step probe (unless h0 is given), six per attempt.
        let setup = if h0.is_some() { 1 } else { 2 };
        assert_eq!(stats.rhs_evals, 6 * attempts + setup, "{stats:?}");
        if h0.is_some() {
            assert!(stats.rejected > 0, "{stats:?}");
        }
    }
}

#[test]
fn dop853_takes_eleven_evaluations_per_attempt_plus_one_per_step() {
    let options = Options {
        rtol: 1e-10,
        atol: 1e-10,
        h0: Some(1.0),
        ..Options::default()
    };
    let solution = integrate(&Sample, Method::Dop853, 0.0, &[1.0, 1.0], &[3.0], &options).unwrap();
    let stats = &solution.stats;
    assert!(stats.rejected > 0);
    assert_eq!(
        stats.rhs_evals,
        11 * (stats.steps + stats.rejected) + stats.steps + 1,
        "{stats:?}"
    );

    // Dense output costs three more evaluations in each step that has outputs inside it.
    let outputs: Vec<f64> = (1..=30).map(|k| 0.1 * f64::from(k)).collect();
    let dense = integrate(
        &Sample,
        Method::Dop853,
        0.0,
        &[1.0, 1.0],
        &outputs,
        &options,
    )
    .unwrap()
    .stats;
    let extra = dense.rhs_evals - (11 * (dense.steps + dense.rejected) + dense.steps + 1);
    assert!(
        extra.is_multiple_of(3) && extra > 0 && extra <= 3 * dense.steps,
        "{dense:?}"
    );
}

#[test]
fn vern9_takes_fifteen_evaluations_per_attempt_plus_one_per_step_and_four_per_output_step() {
    let options = Options {
        rtol: 1e-10,
        atol: 1e-10,
        h0: Some(1.0),
        ..Options::default()
    };
    let run = |outputs: &[f64]| {
        integrate(&Sample, Method::Vern9, 0.0, &[1.0, 1.0], outputs, &options)
            .unwrap()
            .stats
    };
    let plain = run(&[3.0]);
    assert!(plain.rejected > 0);
    let base = |s: &hamel_sim::Stats| 15 * (s.steps + s.rejected) + s.steps + 1;
    assert_eq!(plain.rhs_evals, base(&plain), "{plain:?}");
    // The lazy extension: four more evaluations in each step with outputs inside it, none
    // in a step without.
    let outputs: Vec<f64> = (1..=30).map(|k| 0.1 * f64::from(k)).collect();
    let dense = run(&outputs);
    let extra = dense.rhs_evals - base(&dense);
    assert!(
        extra.is_multiple_of(4) && extra > 0 && extra <= 4 * dense.steps,
        "{dense:?}"
    );
}

#[test]
fn fixed_step_gauss_counts_newton_iterations_and_jacobians() {
    let method = Method::GaussLegendre {
        stages: 3,
        step: Some(0.1),
    };
    // Analytic Jacobian: one f(t, y) and one Jacobian per step, s evaluations per iteration.
    let (kepler, y0) = Kepler::new(0.5, true);
    let stats = integrate(&kepler, method, 0.0, &y0, &[1.0, 2.0], &Options::default())
        .unwrap()
        .stats;
    assert_eq!(stats.steps, 20);
    assert_eq!(stats.jacobian_evals, stats.steps);
    assert_eq!(stats.rhs_evals, stats.steps + 3 * stats.newton_iterations);
    assert!(
        stats.newton_iterations >= 2 * stats.steps && stats.newton_iterations <= 10 * stats.steps,
        "{stats:?}"
    );
    // Finite differences add one evaluation per state component per Jacobian.
    let (kepler, y0) = Kepler::new(0.5, false);
    let stats = integrate(&kepler, method, 0.0, &y0, &[1.0, 2.0], &Options::default())
        .unwrap()
        .stats;
    assert_eq!(
        stats.rhs_evals,
        stats.steps + 3 * stats.newton_iterations + 4 * stats.jacobian_evals
    );
    assert_eq!(stats.newton_failures, 0);
}

#[test]
fn adaptive_gauss_reuses_the_jacobian_across_rejections() {
    let options = Options {
        rtol: 1e-9,
        atol: 1e-9,
        h0: Some(0.2),
        ..Options::default()
    };
    let (kepler, y0) = Kepler::new(0.5, true);
    let method = Method::GaussLegendre {
        stages: 2,
        step: None,
    };
    let stats = integrate(&kepler, method, 0.0, &y0, &[2.0, 4.0], &options)
        .unwrap()
        .stats;
    // Rejections by the error test only (a Newton failure would end an attempt early).
    assert!(
        stats.rejected > 0 && stats.newton_failures == 0,
        "{stats:?}"
    );
    // One Jacobian and one f(t, y) per point a step starts from (f(t0, y0) is the driver's),
    // one evaluation at the midpoint per attempt, s per Newton iteration.
    assert_eq!(stats.jacobian_evals, stats.steps);
    let attempts = stats.steps + stats.rejected;
    assert_eq!(
        stats.rhs_evals,
        stats.steps + attempts + 2 * stats.newton_iterations,
        "{stats:?}"
    );
}

#[test]
fn invariants_are_monitored_and_stats_serialise() {
    let (kepler, y0) = Kepler::new(0.5, true);
    let method = Method::GaussLegendre {
        stages: 2,
        step: Some(0.01),
    };
    let solution = integrate(
        &kepler,
        method,
        0.0,
        &y0,
        &[1.0, 2.0, 3.0],
        &Options::default(),
    )
    .unwrap();
    assert!(solution.energy.iter().all(Option::is_some));
    let drift = solution.stats.energy_drift.unwrap();
    assert!(drift > 0.0 && drift < 1e-8, "{drift:e}");
    assert!(solution.stats.constraint_drift.unwrap() < 1e-13);

    let plain = integrate(
        &Sample,
        Method::Dopri5,
        0.0,
        &[1.0, 1.0],
        &[1.0],
        &Options::default(),
    )
    .unwrap();
    assert_eq!(
        (plain.stats.energy_drift, plain.stats.constraint_drift),
        (None, None)
    );
    assert_eq!(plain.energy, [None]);

    let json = serde_json::to_value(&solution).unwrap();
    assert_eq!(json["stats"]["steps"], 300);
    assert_eq!(json["complete"], true);
    assert_eq!(json["y"].as_array().unwrap().len(), 3);
}
