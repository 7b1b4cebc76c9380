//! Failures: singular systems, blow-up, non-finite values, impossible tolerances, bad input,
//! step limits. Each returns the outputs reached, finite, with `complete == false`.

mod common;

use common::{BlowUp, Sample, SilentNan, Wall};
use hamel_sim::{ErrorKind, IntegrationError, Method, Options, integrate};

fn all_methods() -> [Method; 6] {
    [
        Method::Rk4 { step: 0.01 },
        Method::Dopri5,
        Method::Dop853,
        Method::GaussLegendre {
            stages: 2,
            step: Some(0.01),
        },
        Method::GaussLegendre {
            stages: 2,
            step: None,
        },
        Method::GaussLegendre {
            stages: 3,
            step: None,
        },
    ]
}

fn assert_partial_is_clean(error: &IntegrationError) {
    let partial = &error.partial;
    assert!(!partial.complete);
    assert_eq!(partial.t.len(), partial.y.len());
    assert!(
        partial
            .y
            .iter()
            .flatten()
            .chain(&error.state)
            .all(|v| v.is_finite())
    );
}

#[test]
fn system_error_at_half_stops_there_with_the_outputs_before_it() {
    let outputs: Vec<f64> = (1..=10).map(|k| 0.1 * f64::from(k)).collect();
    for method in all_methods() {
        let error = integrate(
            &Wall { wall: 0.5 },
            method,
            0.0,
            &[1.0],
            &outputs,
            &Options::default(),
        )
        .expect_err("the wall cannot be crossed");
        assert_eq!(error.kind, ErrorKind::System, "{method:?}: {error}");
        assert!(
            error.message.contains("wall at 0.5"),
            "{method:?}: {}",
            error.message
        );
        assert_partial_is_clean(&error);
        let fixed = matches!(
            method,
            Method::Rk4 { .. } | Method::GaussLegendre { step: Some(_), .. }
        );
        if matches!(method, Method::GaussLegendre { .. }) {
            // Gauss nodes lie inside the step: the wall is reached, only f at the wall fails.
            assert_eq!(error.partial.t, outputs[..5], "{method:?}");
            assert_eq!(error.time, 0.5, "{method:?}");
        } else {
            // Explicit methods evaluate at the end of the step: output 0.5 is out of reach.
            // Fixed steps stop at the last grid point before the wall; adaptive steps shrink
            // until they underflow against it.
            assert_eq!(error.partial.t, outputs[..4], "{method:?}");
            let reach = if fixed { 0.01 + 1e-12 } else { 1e-9 };
            assert!(
                error.time < 0.5 && 0.5 - error.time <= reach,
                "{method:?}: stopped at {}",
                error.time
            );
        }
        for (t, y) in error.partial.t.iter().zip(&error.partial.y) {
            assert!(
                (y[0] - (-t).exp()).abs() < 1e-5,
                "{method:?} at t = {t}: {}",
                y[0]
            );
        }
        assert!((error.state[0] - (-error.time).exp()).abs() < 1e-5);
    }
}

#[test]
fn blow_up_ends_in_underflow_near_the_singularity() {
    for method in [
        Method::Dopri5,
        Method::Dop853,
        Method::GaussLegendre {
            stages: 2,
            step: None,
        },
    ] {
        let error = integrate(
            &BlowUp,
            method,
            0.0,
            &[1.0],
            &[0.5, 2.0],
            &Options::default(),
        )
        .expect_err("y = 1/(1 − t) cannot be continued past t = 1");
        // Explicit methods see the steps collapse; the implicit one's Newton iteration stops
        // converging first.
        let expected = match method {
            Method::GaussLegendre { .. } => matches!(error.kind, ErrorKind::NewtonFailure),
            _ => matches!(
                error.kind,
                ErrorKind::StepSizeUnderflow | ErrorKind::NonFiniteState
            ),
        };
        assert!(expected, "{method:?}: {error}");
        assert!(
            (error.time - 1.0).abs() < 1e-3,
            "{method:?}: stopped at {}",
            error.time
        );
        assert_partial_is_clean(&error);
        assert_eq!(error.partial.t, [0.5]);
        assert!(
            (error.partial.y[0][0] - 2.0).abs() < 1e-4,
            "{method:?}: {:?}",
            error.partial.y
        );
    }
}

#[test]
fn silent_nan_is_reported_as_a_non_finite_state() {
    for method in all_methods() {
        let error = integrate(
            &SilentNan,
            method,
            0.0,
            &[1.0],
            &[0.2, 0.4, 0.6],
            &Options::default(),
        )
        .expect_err("NaN after t = 0.3");
        assert_eq!(error.kind, ErrorKind::NonFiniteState, "{method:?}: {error}");
        assert_partial_is_clean(&error);
        assert_eq!(error.partial.t, [0.2], "{method:?}");
        assert!(
            error.time <= 0.3 + 1e-12 && error.time > 0.28,
            "{method:?}: stopped at {}",
            error.time
        );
    }
}

#[test]
fn tolerance_below_f64_resolution_is_refused_up_front() {
    let options = Options {
        rtol: 1e-16,
        ..Options::default()
    };
    for method in [
        Method::Dopri5,
        Method::Dop853,
        Method::GaussLegendre {
            stages: 3,
            step: None,
        },
    ] {
        let error = integrate(&Sample, method, 0.0, &[1.0, 1.0], &[1.0], &options).unwrap_err();
        assert_eq!(error.kind, ErrorKind::ToleranceTooSmall);
        assert!(error.message.contains("rtol = 1e-16"), "{}", error.message);
        assert_eq!(error.partial.stats.rhs_evals, 0, "nothing is evaluated");
        assert!(error.partial.t.is_empty() && !error.partial.complete);
        assert_eq!(
            (error.time, error.state.as_slice()),
            (0.0, [1.0, 1.0].as_slice())
        );
    }
}

#[test]
fn very_loose_tolerance_still_gives_a_result() {
    let options = Options {
        rtol: 1e-1,
        atol: 1e-1,
        ..Options::default()
    };
    let outputs = [0.5, 1.0, 3.0];
    for method in [
        Method::Dopri5,
        Method::Dop853,
        Method::GaussLegendre {
            stages: 2,
            step: None,
        },
    ] {
        let solution = integrate(&Sample, method, 0.0, &[1.0, 1.0], &outputs, &options).unwrap();
        assert!(solution.complete);
        for (&t, y) in solution.t.iter().zip(&solution.y) {
            let error = common::distance(y, &common::sample_exact(t));
            assert!(error < 0.1, "{method:?} at t = {t}: error {error}");
        }
    }
}

#[test]
fn max_steps_stops_the_integration() {
    let options = Options {
        max_steps: 20,
        ..Options::default()
    };
    for method in [Method::Rk4 { step: 0.01 }, Method::Dopri5] {
        let error =
            integrate(&Sample, method, 0.0, &[1.0, 1.0], &[0.1, 1000.0], &options).unwrap_err();
        assert_eq!(error.kind, ErrorKind::MaxStepsExceeded);
        let stats = &error.partial.stats;
        assert_eq!(stats.steps + stats.rejected, 20);
        assert_eq!(error.partial.t, [0.1]);
        assert_partial_is_clean(&error);
    }
}

#[test]
fn newton_failure_with_a_fixed_step_is_an_error() {
    // A step of 50 on y' = −y² from y = 1 is far outside the iteration's convergence region.
    let method = Method::GaussLegendre {
        stages: 2,
        step: Some(50.0),
    };
    let outputs = [50.0, 100.0];
    let result = integrate(
        &Sample,
        method,
        0.0,
        &[1.0, 1.0],
        &outputs,
        &Options::default(),
    );
    let error = result.unwrap_err();
    assert_eq!(error.kind, ErrorKind::NewtonFailure, "{error}");
    assert_eq!(error.partial.stats.newton_failures, 1);
    assert_partial_is_clean(&error);
}

#[test]
fn invalid_input_is_refused_before_any_evaluation() {
    let options = Options::default();
    let cases: [(&str, Result<_, IntegrationError>); 8] = [
        (
            "dimension",
            integrate(&Sample, Method::Dopri5, 0.0, &[1.0], &[1.0], &options),
        ),
        (
            "non-finite y0",
            integrate(
                &Sample,
                Method::Dopri5,
                0.0,
                &[1.0, f64::NAN],
                &[1.0],
                &options,
            ),
        ),
        (
            "order",
            integrate(
                &Sample,
                Method::Dopri5,
                0.0,
                &[1.0, 1.0],
                &[1.0, 0.5],
                &options,
            ),
        ),
        (
            "both sides",
            integrate(
                &Sample,
                Method::Dopri5,
                0.0,
                &[1.0, 1.0],
                &[-1.0, 1.0],
                &options,
            ),
        ),
        (
            "infinite output",
            integrate(
                &Sample,
                Method::Dopri5,
                0.0,
                &[1.0, 1.0],
                &[f64::INFINITY],
                &options,
            ),
        ),
        (
            "stages",
            integrate(
                &Sample,
                Method::GaussLegendre {
                    stages: 4,
                    step: None,
                },
                0.0,
                &[1.0, 1.0],
                &[1.0],
                &options,
            ),
        ),
        (
            "step",
            integrate(
                &Sample,
                Method::Rk4 { step: 0.0 },
                0.0,
                &[1.0, 1.0],
                &[1.0],
                &options,
            ),
        ),
        (
            "atol",
            integrate(
                &Sample,
                Method::Dopri5,
                0.0,
                &[1.0, 1.0],
                &[1.0],
                &Options {
                    atol: 0.0,
                    ..options
                },
            ),
        ),
    ];
    for (case, result) in cases {
        let error = result.expect_err(case);
        assert_eq!(error.kind, ErrorKind::InvalidInput, "{case}: {error}");
        assert_eq!(error.partial.stats.rhs_evals, 0, "{case}");
    }
}
