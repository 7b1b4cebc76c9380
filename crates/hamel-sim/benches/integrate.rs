//! The cost of `integrate` itself (issue 21): `cargo bench -p hamel-sim --bench integrate`.
//!
//! * `integrate/knife/dop853-<tol>/<n>-outputs`: scenes/knife.toml (the knife edge with the
//!   paper's quasi-velocities, state (x, y, θ, η), 10 s), DOP853, on the generated right-hand
//!   side (`crates/hamel-models`, `full_into`), with 101 outputs and with only the last.
//! * `rhs/knife/dop853-<tol>`: the evaluations of that run with 101 outputs alone, replayed:
//!   the same states, in the same order, through `OdeSystem::rhs`, each waiting for the result
//!   of the one before (as the stages of a step do).
//!
//! * `integrate/still/dop853/101-outputs`: ẏ = 0 in five dimensions, one step: the fixed cost
//!   of a run with 101 outputs.
//!
//! After the runs it prints the cost of a run besides its evaluations, T(run) − T(its
//! evaluations), and the cost per output, (T(101 outputs) − T(1 output)) / 100 (the dense
//! output prepared at every step, and interpolated), from criterion's estimates of this same
//! run.

use criterion::{Criterion, criterion_group};
use hamel_models::{Core, MODELS};
use hamel_sim::{Method, OdeSystem, Options, SystemError, integrate};
use std::hint::black_box;

/// The full state (q, η) of a core, as `hamel simulate` integrates the knife scene (every
/// coordinate requested).
struct Full(&'static Core);

impl OdeSystem for Full {
    fn dim(&self) -> usize {
        self.0.dims.ell + self.0.dims.sigma
    }
    fn rhs(&self, _t: f64, y: &[f64], dy: &mut [f64]) -> Result<(), SystemError> {
        (self.0.full_into)(y, dy).map_err(|e| SystemError::new(e.to_string()))
    }
}

/// ẏ = 0 in five dimensions: DOP853 takes one step over the whole interval (its error
/// estimate is zero), so a run is the fixed cost alone: set-up, the initial step heuristic, one
/// step, 101 outputs interpolated and recorded.
struct Still;

impl OdeSystem for Still {
    fn dim(&self) -> usize {
        5
    }
    fn rhs(&self, _t: f64, _y: &[f64], dy: &mut [f64]) -> Result<(), SystemError> {
        dy.fill(0.0);
        Ok(())
    }
}

/// The first step over the whole interval (the heuristic would start small and grow by at
/// most 6 per step).
fn still_options() -> Options {
    Options {
        h0: Some(10.0),
        ..options(1e-8)
    }
}

fn knife() -> &'static Core {
    MODELS
        .iter()
        .find(|c| c.model == "knife" && c.eta == "paper")
        .expect("the knife's core")
}

/// scenes/knife.toml's initial state: (x, y, θ) = (0, 0, 0.3), η = (1, 0.5).
const Y0: [f64; 5] = [0.0, 0.0, 0.3, 1.0, 0.5];
const TOLERANCES: [f64; 3] = [1e-4, 1e-8, 1e-12];

fn times(n: usize) -> Vec<f64> {
    (1..=n).map(|k| 10.0 * k as f64 / n as f64).collect()
}

fn options(tol: f64) -> Options {
    Options {
        rtol: tol,
        atol: tol,
        ..Options::default()
    }
}

fn benches(c: &mut Criterion) {
    let system = Full(knife());
    let mut group = c.benchmark_group("integrate/knife");
    for tol in TOLERANCES {
        for n in [101, 1] {
            let ts = times(n);
            let o = options(tol);
            group.bench_function(format!("dop853-{tol:e}/{n}-outputs"), |b| {
                b.iter(|| integrate(&system, Method::Dop853, 0.0, black_box(&Y0), &ts, &o).unwrap())
            });
        }
    }
    group.finish();
    let ts = times(101);
    let o = still_options();
    c.bench_function("integrate/still/dop853/101-outputs", |b| {
        b.iter(|| integrate(&Still, Method::Dop853, 0.0, black_box(&Y0), &ts, &o).unwrap())
    });
    // The evaluations of each run, replayed: the same states in the same order.
    let mut group = c.benchmark_group("rhs/knife");
    for tol in TOLERANCES {
        let states = visited(tol);
        let mut dy = [0.0; 5];
        group.bench_function(format!("dop853-{tol:e}"), |b| {
            b.iter(|| {
                // Each evaluation waits for the one before, as the stages of a step do.
                for y in &states {
                    let mut y = *y;
                    y[0] += 0.0 * dy[0];
                    system.rhs(0.0, black_box(&y), &mut dy).unwrap();
                }
            })
        });
    }
    group.finish();
}

/// The states at which a run with 101 outputs evaluates the right-hand side.
fn visited(tol: f64) -> Vec<[f64; 5]> {
    struct Logged(Full, std::cell::RefCell<Vec<[f64; 5]>>);
    impl OdeSystem for Logged {
        fn dim(&self) -> usize {
            self.0.dim()
        }
        fn rhs(&self, t: f64, y: &[f64], dy: &mut [f64]) -> Result<(), SystemError> {
            self.1
                .borrow_mut()
                .push(y.try_into().expect("five components"));
            self.0.rhs(t, y, dy)
        }
    }
    let logged = Logged(Full(knife()), Default::default());
    integrate(
        &logged,
        Method::Dop853,
        0.0,
        &Y0,
        &times(101),
        &options(tol),
    )
    .unwrap();
    logged.1.into_inner()
}

/// Criterion's point estimate of the mean, in seconds, for a benchmark of this run.
fn estimate(id: &str) -> Option<f64> {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../target/criterion");
    let text = std::fs::read_to_string(dir.join(id).join("new/estimates.json")).ok()?;
    let v: serde_json::Value = serde_json::from_str(&text).ok()?;
    Some(v["mean"]["point_estimate"].as_f64()? * 1e-9)
}

fn summary() {
    if let Some(still) = estimate("integrate_still_dop853_101-outputs") {
        let s = integrate(
            &Still,
            Method::Dop853,
            0.0,
            &Y0,
            &times(101),
            &still_options(),
        )
        .unwrap();
        println!(
            "\nthe fixed cost of a run with 101 outputs (ẏ = 0, {} step of 10 s, {} evaluations): {:.2} µs",
            s.stats.steps,
            s.stats.rhs_evals,
            still * 1e6
        );
    }
    println!("\nknife, DOP853, 10 s: the cost of a run besides its evaluations");
    println!(
        "| tol | evaluations | run, 101 outputs | the evaluations alone | the rest | per output |"
    );
    println!("|---|---|---|---|---|---|");
    for tol in TOLERANCES {
        let id = |n: usize| format!("integrate_knife/dop853-{tol:e}_{n}-outputs");
        let rhs = estimate(&format!("rhs_knife/dop853-{tol:e}"));
        let (Some(all), Some(last), Some(rhs)) = (estimate(&id(101)), estimate(&id(1)), rhs) else {
            continue;
        };
        println!(
            "| {tol:e} | {} | {:.2} µs | {:.2} µs | {:.2} µs | {:.1} ns |",
            visited(tol).len(),
            all * 1e6,
            rhs * 1e6,
            (all - rhs) * 1e6,
            (all - last) / 100.0 * 1e9
        );
    }
}

criterion_group!(group, benches);

fn main() {
    group();
    Criterion::default().configure_from_args().final_summary();
    summary();
}
