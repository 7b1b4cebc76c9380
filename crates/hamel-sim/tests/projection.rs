//! Projection after each accepted step (`OdeSystem::project`): the invariant is kept at
//! round-off, the solution stays as accurate as without it, and the FSAL derivative is renewed.

use hamel_sim::{Method, OdeSystem, Options, SystemError, integrate};

/// Rotation on the unit circle, y = (cos t, sin t): the exact solution keeps |y| = 1.
struct Circle {
    project: bool,
}

impl OdeSystem for Circle {
    fn dim(&self) -> usize {
        2
    }
    fn rhs(&self, _t: f64, y: &[f64], dy: &mut [f64]) -> Result<(), SystemError> {
        dy[0] = -y[1];
        dy[1] = y[0];
        Ok(())
    }
    fn project(&self, _t: f64, y: &mut [f64]) -> Option<Result<f64, SystemError>> {
        if !self.project {
            return None;
        }
        let r = y[0].hypot(y[1]);
        let residual = (r - 1.0).abs();
        if residual > 0.0 {
            y[0] /= r;
            y[1] /= r;
        }
        Some(Ok(residual))
    }
}

fn run(method: Method, project: bool) -> (f64, f64, hamel_sim::Stats) {
    let options = Options {
        rtol: 1e-5,
        atol: 1e-8,
        ..Options::default()
    };
    let times: Vec<f64> = (1..=40).map(|i| 0.5 * f64::from(i)).collect();
    let s = integrate(
        &Circle { project },
        method,
        0.0,
        &[1.0, 0.0],
        &times,
        &options,
    )
    .unwrap();
    let y = s.y.last().unwrap();
    let t = *times.last().unwrap();
    let radius = (y[0].hypot(y[1]) - 1.0).abs();
    let error = (y[0] - t.cos()).hypot(y[1] - t.sin());
    (radius, error, s.stats)
}

#[test]
fn projection_keeps_the_invariant_and_the_accuracy() {
    for method in [Method::Dopri5, Method::Dop853, Method::Rk4 { step: 0.05 }] {
        let (drift_free, error_free, stats_free) = run(method, false);
        let (drift, error, stats) = run(method, true);
        assert!(
            drift_free > 1e-12,
            "{method:?}: the free run drifts ({drift_free:e})"
        );
        assert!(
            drift <= 4.0 * f64::EPSILON,
            "{method:?}: |y| − 1 = {drift:e}"
        );
        assert!(
            stats.projections > 0 && stats.projections <= stats.steps,
            "{stats:?}"
        );
        let found = stats.projection_drift.unwrap();
        assert!(found > 0.0 && found < 1e-4, "{method:?}: {found:e}");
        assert_eq!(
            (stats_free.projections, stats_free.projection_drift),
            (0, None)
        );
        // The phase error is no worse than the free run's (a stale FSAL derivative would
        // show here as an error of the size of the projections).
        assert!(
            error <= 2.0 * error_free + 1e-12,
            "{method:?}: {error:e} vs {error_free:e}"
        );
    }
}

#[test]
fn adaptive_projection_renews_the_first_stage() {
    // DOP853 takes eleven evaluations per attempt, one per step (FSAL) and one at t0; a
    // projected step costs one more: f at the projected state.
    let options = Options {
        rtol: 1e-6,
        atol: 1e-9,
        h0: Some(0.1),
        ..Options::default()
    };
    let circle = Circle { project: true };
    let s = integrate(&circle, Method::Dop853, 0.0, &[1.0, 0.0], &[20.0], &options).unwrap();
    let st = &s.stats;
    assert!(st.projections > 0, "{st:?}");
    assert_eq!(
        st.rhs_evals,
        11 * (st.steps + st.rejected) + st.steps + 1 + st.projections,
        "{st:?}"
    );
}
