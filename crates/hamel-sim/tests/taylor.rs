//! The Taylor method (`Method::Taylor`) on systems given as expressions, their series from
//! `hamel_expr::taylor::Series`: Kepler's problem at eccentricity 0.5 against its exact
//! solution (Kepler's equation solved by Newton), at tolerances 1e-6 to 1e-15:
//! * the error at the outputs follows the tolerance (tolerance proportionality) and reaches
//!   1e-13 at the tightest, where DOP853 at its tightest stops short;
//! * the dense output (the series between steps) is as accurate as the steps;
//! * a system without a series is refused with a clear error.

use std::cell::RefCell;

use hamel_expr::taylor::{Role, Series};
use hamel_expr::{Tape, parse};
use hamel_sim::{Method, OdeSystem, Options, SystemError, integrate};

/// y' = f(t, y) from expressions in the state's names and t.
struct Expressions {
    tape: Tape,
    series: Series,
    work: RefCell<Vec<f64>>,
    dim: usize,
}

impl Expressions {
    fn new(f: &[&str], state: &[&str]) -> Self {
        let exprs: Vec<hamel_expr::Expr> = f.iter().map(|s| parse(s).unwrap().expr).collect();
        let mut inputs: Vec<String> = state.iter().map(|s| s.to_string()).collect();
        inputs.push("t".into());
        let tape = Tape::compile(&exprs.iter().collect::<Vec<_>>(), &inputs).unwrap();
        let mut roles: Vec<Role> = (0..state.len()).map(Role::State).collect();
        roles.push(Role::Time);
        let series = Series::new(&tape, &roles).unwrap();
        Expressions {
            tape,
            series,
            work: RefCell::new(Vec::new()),
            dim: state.len(),
        }
    }
}

impl OdeSystem for Expressions {
    fn dim(&self) -> usize {
        self.dim
    }
    fn rhs(&self, t: f64, y: &[f64], dy: &mut [f64]) -> Result<(), SystemError> {
        let mut inputs = y.to_vec();
        inputs.push(t);
        let out = self
            .tape
            .eval(&inputs)
            .map_err(|e| SystemError::new(e.to_string()))?;
        dy.copy_from_slice(&out);
        Ok(())
    }
    fn taylor_coefficients(
        &self,
        t: f64,
        y: &[f64],
        order: usize,
        out: &mut Vec<f64>,
    ) -> Option<Result<(), SystemError>> {
        let mut work = self.work.borrow_mut();
        Some(
            self.series
                .coefficients(t, y, order, out, &mut work)
                .map_err(|e| SystemError::new(e.to_string())),
        )
    }
}

fn kepler() -> Expressions {
    Expressions::new(
        &["u", "v", "-x/(x^2 + y^2)^(3/2)", "-y/(x^2 + y^2)^(3/2)"],
        &["x", "y", "u", "v"],
    )
}

const E: f64 = 0.5;

/// The orbit of a = 1, μ = 1, eccentricity E from periapsis: x = cos Ê − e, y = √(1 − e²) sin Ê
/// with Ê − e sin Ê = t.
fn exact(t: f64) -> [f64; 4] {
    let mut anomaly = t;
    for _ in 0..50 {
        anomaly -= (anomaly - E * anomaly.sin() - t) / (1.0 - E * anomaly.cos());
    }
    let (s, c) = anomaly.sin_cos();
    let rate = 1.0 / (1.0 - E * c);
    let b = (1.0 - E * E).sqrt();
    [c - E, b * s, -s * rate, b * c * rate]
}

/// The largest error at `outputs` over 5 orbits, with the steps taken.
fn run(method: Method, tol: f64, outputs: &[f64]) -> (f64, usize) {
    let options = Options {
        rtol: tol,
        atol: tol,
        max_steps: 10_000_000,
        ..Options::default()
    };
    let s = integrate(&kepler(), method, 0.0, &exact(0.0), outputs, &options).unwrap();
    let error = (s.t.iter().zip(s.y.iter()))
        .map(|(&t, y)| {
            let want = exact(t);
            (0..4).map(|i| (y[i] - want[i]).abs()).fold(0.0, f64::max)
        })
        .fold(0.0, f64::max);
    (error, s.stats.steps)
}

#[test]
fn the_error_follows_the_tolerance_down_to_1e_13() {
    let period = 2.0 * std::f64::consts::PI;
    let outputs: Vec<f64> = (1..=5).map(|k| k as f64 * period).collect();
    let mut previous: Option<(f64, f64)> = None;
    for tol in [1e-6, 1e-8, 1e-10, 1e-12, 1e-14, 1e-15] {
        let (error, steps) = run(Method::Taylor, tol, &outputs);
        let (dop, dop_steps) = run(Method::Dop853, tol.max(1e-14), &outputs);
        eprintln!(
            "kepler e = 0.5, 5 orbits, tol {tol:.0e}: taylor error {error:.1e} in {steps} steps (order {}), dop853 {dop:.1e} in {dop_steps}",
            hamel_sim::taylor::order(tol)
        );
        // Within a modest multiple of the tolerance times the number of orbits.
        assert!(
            error <= 1e3 * tol.max(1e-16) + 2e-13,
            "tol {tol:e}: {error:e}"
        );
        if let Some((t0, e0)) = previous {
            assert!(
                error < e0 || error < 1e-12,
                "{tol:e}: {error:e} after {e0:e} at {t0:e}"
            );
        }
        previous = Some((tol, error));
    }
}

#[test]
fn the_dense_output_is_as_accurate_as_the_steps() {
    let period = 2.0 * std::f64::consts::PI;
    let outputs: Vec<f64> = (1..=2000).map(|k| k as f64 * period / 1000.0).collect();
    for tol in [1e-9, 1e-13] {
        let (dense, steps) = run(Method::Taylor, tol, &outputs);
        let (ends, _) = run(Method::Taylor, tol, &[2.0 * period]);
        eprintln!(
            "kepler, 2 orbits, tol {tol:.0e}: 2000 dense outputs within {dense:.1e} ({steps} steps), the end {ends:.1e}"
        );
        assert!(dense <= 10.0 * ends.max(tol), "{dense:e} against {ends:e}");
    }
}

struct NoSeries;

impl OdeSystem for NoSeries {
    fn dim(&self) -> usize {
        1
    }
    fn rhs(&self, _t: f64, y: &[f64], dy: &mut [f64]) -> Result<(), SystemError> {
        dy[0] = -y[0];
        Ok(())
    }
}

#[test]
fn a_system_without_a_series_is_refused() {
    let e = integrate(
        &NoSeries,
        Method::Taylor,
        0.0,
        &[1.0],
        &[1.0],
        &Options::default(),
    )
    .unwrap_err();
    assert!(e.to_string().contains("no Taylor series"), "{e}");
}
