//! The Taylor method (`Method::Taylor`) on systems given as expressions, their series from
//! `hamel_expr::taylor::Series`: Kepler's problem at eccentricity 0.5 against its exact
//! solution (Kepler's equation solved by Newton), at tolerances 1e-6 to 1e-15:
//! * the error at the outputs follows the tolerance (tolerance proportionality) and reaches
//!   1e-13 at the tightest, where DOP853 at its tightest stops short;
//! * the dense output (the series between steps) is as accurate as the steps;
//! * a system without a series is refused with a clear error;
//! * events: the orbit's crossings of the x axis (t = kπ) and of the y axis (Kepler's equation
//!   at Ê = π/3) located on the series to 1e-12, a terminal one ending the run, the crossing's
//!   direction respected; DOP853 to its tolerance; methods without dense output refused.

use std::cell::RefCell;

use hamel_expr::taylor::{Role, Series};
use hamel_expr::{Tape, parse};
use hamel_sim::{
    Crossing, Event, Method, OdeSystem, Options, SystemError, integrate, integrate_with_events,
};

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

/// Kepler's orbit over 5 orbits watching `events`, at tolerance `tol`.
fn with_events(method: Method, tol: f64, events: &[Event]) -> hamel_sim::Solution {
    let options = Options {
        rtol: tol,
        atol: tol,
        max_steps: 10_000_000,
        ..Options::default()
    };
    let outputs: Vec<f64> = (1..=100)
        .map(|k| k as f64 * 0.1 * std::f64::consts::PI)
        .collect();
    integrate_with_events(
        &kepler(),
        method,
        0.0,
        &exact(0.0),
        &outputs,
        &options,
        events,
    )
    .unwrap()
}

/// y = 0: the periapsis (rising, t = 2kπ) and the apoapsis (falling, t = (2k + 1)π).
fn axis(crossing: Crossing) -> Event<'static> {
    Event {
        condition: Box::new(|_t, y| y[1]),
        crossing,
        terminal: false,
    }
}

#[test]
fn events_are_located_on_the_series_to_1e_12() {
    let pi = std::f64::consts::PI;
    for (method, tol, within) in [
        (Method::Taylor, 1e-15, 1e-12),
        (Method::Dop853, 1e-12, 1e-9),
    ] {
        let s = with_events(method, tol, &[axis(Crossing::Either)]);
        assert!(s.complete);
        let times: Vec<f64> = s.events.iter().map(|e| e.t).collect();
        // t = 0 is the start, not a crossing; the last, t = 10π, the end of the run
        assert_eq!(times.len(), 10, "{method:?}: {times:?}");
        let worst = (times.iter().enumerate())
            .map(|(k, t)| (t - (k + 1) as f64 * pi).abs())
            .fold(0.0, f64::max);
        let state = (s.events.iter())
            .map(|e| {
                (0..4)
                    .map(|i| (e.y[i] - exact(e.t)[i]).abs())
                    .fold(0.0, f64::max)
            })
            .fold(0.0, f64::max);
        eprintln!(
            "kepler events, {} at tol {tol:.0e}: 10 crossings of y = 0 within {worst:.1e} of kπ, states within {state:.1e}",
            method.name()
        );
        assert!(worst <= within, "{method:?}: {worst:e}");
        assert!(state <= 10.0 * within, "{method:?}: {state:e}");
    }
}

#[test]
fn an_event_counts_only_its_direction_and_a_terminal_one_ends_the_run() {
    let pi = std::f64::consts::PI;
    let s = with_events(Method::Taylor, 1e-14, &[axis(Crossing::Falling)]);
    let times: Vec<f64> = s.events.iter().map(|e| e.t).collect();
    assert_eq!(times.len(), 5, "{times:?}");
    for (k, t) in times.iter().enumerate() {
        assert!((t - (2 * k + 1) as f64 * pi).abs() < 1e-12, "{times:?}");
    }
    // x = 0, falling: cos Ê = e, Ê = π/3, t = π/3 − e sin(π/3)
    let stop = Event {
        condition: Box::new(|_t, y| y[0]),
        crossing: Crossing::Falling,
        terminal: true,
    };
    let s = with_events(Method::Taylor, 1e-15, &[axis(Crossing::Either), stop]);
    let want = pi / 3.0 - E * (pi / 3.0).sin();
    let hit = s.events.last().unwrap();
    assert!((hit.event, hit.terminal) == (1, true) && s.events.len() == 1);
    assert!((hit.t - want).abs() < 1e-12, "{} against {want}", hit.t);
    assert!(hit.y[0].abs() < 1e-12, "{:?}", hit.y);
    assert!(!s.complete);
    assert_eq!(s.t, [0.1 * pi], "the outputs before the event, none after");
}

#[test]
fn events_without_a_continuous_extension_are_refused() {
    let options = Options::default();
    let e = integrate_with_events(
        &kepler(),
        Method::Rk4 { step: 0.01 },
        0.0,
        &exact(0.0),
        &[1.0],
        &options,
        &[axis(Crossing::Either)],
    )
    .unwrap_err();
    assert!(e.to_string().contains("continuous extension"), "{e}");
}

/// Kepler's orbit over one period in `steps` equal steps of the truncated series of order `p`
/// (the system's coefficients summed by `hamel_sim::taylor::sum`): the error at the end.
fn fixed_order_error(p: usize, steps: usize) -> f64 {
    let system = kepler();
    let period = 2.0 * std::f64::consts::PI;
    let h = period / steps as f64;
    let (mut y, mut series) = (exact(0.0).to_vec(), Vec::new());
    for k in 0..steps {
        system
            .taylor_coefficients(k as f64 * h, &y, p, &mut series)
            .unwrap()
            .unwrap();
        hamel_sim::taylor::sum(&series, 4, h, &mut y);
    }
    let want = exact(period);
    (0..4).map(|i| (y[i] - want[i]).abs()).fold(0.0, f64::max)
}

/// The series truncated at order p makes a local error O(h^{p+1}), so a global one O(h^p): the
/// observed order when the step halves (steps chosen so that the errors stay well above
/// round-off and in the asymptotic range).
#[test]
fn the_truncated_series_has_the_order_of_its_truncation() {
    for (p, steps) in [(2, 4000), (4, 400), (6, 200), (8, 120), (10, 120)] {
        let (e1, e2) = (fixed_order_error(p, steps), fixed_order_error(p, 2 * steps));
        let observed = (e1 / e2).log2();
        eprintln!(
            "kepler, taylor order {p}: {steps} steps {e1:.2e}, {} steps {e2:.2e}: observed order {observed:.2}",
            2 * steps
        );
        assert!(
            (observed - p as f64).abs() < 0.3,
            "order {p}: observed {observed}"
        );
    }
}
