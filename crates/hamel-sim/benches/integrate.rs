//! The cost of `integrate` itself (issue 21): `cargo bench -p hamel-sim --bench integrate`.
//!
//! * `integrate/<scene>/dop853-<tol>/<n>-outputs`: the scene's model and initial state
//!   (scenes/knife.toml: the knife edge, paper's quasi-velocities, state (x, y, θ, η), 10 s,
//!   101 outputs; scenes/unicycle_rider.toml: six coordinates and four quasi-velocities, 2 s,
//!   41 outputs), DOP853, on the generated right-hand side (`crates/hamel-models`,
//!   `full_into`: the solved form, parameters prepared once), with every output and with only
//!   the last.
//! * `rhs/<scene>/dop853-<tol>`: the evaluations of that run alone, replayed: the same states,
//!   in the same order, through `OdeSystem::rhs`, each waiting for the result of the one
//!   before (as the stages of a step do).
//! * `monitors/<scene>/dop853-<tol>/<which>`: the run with every output and the monitors a
//!   scene may request — none, the energy, the constraint residual ‖α(q)Γ(q)η‖∞, both — each
//!   evaluated at every output by the core's own functions, as `hamel simulate` does.
//! * `monitors/<scene>/dop853-<tol>/<energy|residual>-alone`: those monitors alone over that
//!   run's outputs (`Core::energies`, `Core::residuals`, as the recorder calls them after a
//!   run), so that their share of a run is read without the noise of comparing two runs.
//! * `integrate/still/dop853/101-outputs`: ẏ = 0 in five dimensions, one step: the fixed cost
//!   of a run with 101 outputs.
//!
//! After the runs it prints the cost of a run besides its evaluations, T(run) − T(its
//! evaluations), per evaluation, and the cost per output, (T(all outputs) − T(1 output)) /
//! (outputs − 1) (the dense output prepared at every step, and interpolated), from criterion's
//! estimates of this same run.

use criterion::{Criterion, criterion_group};
use hamel_models::{Core, MODELS};
use hamel_sim::{Method, OdeSystem, Options, SystemError, integrate};
use std::cell::RefCell;
use std::hint::black_box;

/// The full state (q, η) of a core, as `hamel simulate` integrates a scene that requests
/// every coordinate.
struct Full(&'static Core);

impl OdeSystem for Full {
    fn dim(&self) -> usize {
        self.0.dims.ell + self.0.dims.sigma
    }
    fn rhs(&self, _t: f64, y: &[f64], dy: &mut [f64]) -> Result<(), SystemError> {
        (self.0.full_into)(y, dy).map_err(|e| SystemError::new(e.to_string()))
    }
}

/// The full state with the monitors a scene requested.
struct Monitored {
    full: Full,
    energy: bool,
    residual: bool,
}

impl OdeSystem for Monitored {
    fn dim(&self) -> usize {
        self.full.dim()
    }
    fn rhs(&self, t: f64, y: &[f64], dy: &mut [f64]) -> Result<(), SystemError> {
        self.full.rhs(t, y, dy)
    }
    fn energy(&self, _t: f64, y: &[f64]) -> Option<f64> {
        let ell = self.full.0.dims.ell;
        self.energy
            .then(|| (self.full.0.energy)(&y[..ell], &y[ell..]).ok())
            .flatten()
    }
    fn constraint_residual(&self, _t: f64, y: &[f64]) -> Option<f64> {
        let ell = self.full.0.dims.ell;
        self.residual
            .then(|| (self.full.0.residual)(&y[..ell], &y[ell..]).ok())
            .flatten()
    }
    /// As `hamel simulate`: all outputs at once after the run, four at a time.
    fn energies(&self, _t: &[f64], rows: &[f64], out: &mut [Option<f64>]) {
        if self.energy {
            (self.full.0.energies)(rows, out);
        }
    }
    fn constraint_residuals(&self, _t: &[f64], rows: &[f64], out: &mut [Option<f64>]) {
        if self.residual {
            (self.full.0.residuals)(rows, out);
        }
    }
}

/// The monitors compared: (name, energy, residual).
const MONITORS: [(&str, bool, bool); 4] = [
    ("none", false, false),
    ("energy", true, false),
    ("residual", false, true),
    ("both", true, true),
];

/// ẏ = 0 in five dimensions: with a first step over the whole interval, DOP853 takes one
/// step (its error estimate is zero), so a run is the fixed cost alone: set-up, one step, 101
/// outputs interpolated and recorded.
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

/// A scene: its model's core, initial state, duration and number of outputs (t0 = 0 among
/// them).
struct Case {
    name: &'static str,
    model: &'static str,
    eta: &'static str,
    y0: &'static [f64],
    t_end: f64,
    outputs: usize,
}

const CASES: [Case; 2] = [
    Case {
        name: "knife",
        model: "knife",
        eta: "paper",
        y0: &[0.0, 0.0, 0.3, 1.0, 0.5],
        t_end: 10.0,
        outputs: 101,
    },
    Case {
        name: "unicycle_rider",
        model: "unicycle_rider",
        eta: "velocities",
        y0: &[0.0, 0.0, 0.0, 0.0, 0.2, 0.1, 0.5, 3.0, 0.0, 0.0],
        t_end: 2.0,
        outputs: 41,
    },
];

const TOLERANCES: [f64; 3] = [1e-4, 1e-8, 1e-12];

impl Case {
    fn system(&self) -> Full {
        let core = MODELS
            .iter()
            .find(|c| c.model == self.model && c.eta == self.eta)
            .expect("the scene's core");
        Full(core)
    }

    /// `n` output times ending at `t_end`, evenly spaced from 0 (or the last alone).
    fn times(&self, n: usize) -> Vec<f64> {
        if n == 1 {
            return vec![self.t_end];
        }
        (0..n)
            .map(|k| self.t_end * k as f64 / (n - 1) as f64)
            .collect()
    }

    fn run(&self, tol: f64, n: usize) -> hamel_sim::Solution {
        let ts = self.times(n);
        integrate(
            &self.system(),
            Method::Dop853,
            0.0,
            self.y0,
            &ts,
            &options(tol),
        )
        .unwrap()
    }

    /// The states at which a run with every output evaluates the right-hand side.
    fn visited(&self, tol: f64) -> Vec<Vec<f64>> {
        struct Logged(Full, RefCell<Vec<Vec<f64>>>);
        impl OdeSystem for Logged {
            fn dim(&self) -> usize {
                self.0.dim()
            }
            fn rhs(&self, t: f64, y: &[f64], dy: &mut [f64]) -> Result<(), SystemError> {
                self.1.borrow_mut().push(y.to_vec());
                self.0.rhs(t, y, dy)
            }
        }
        let logged = Logged(self.system(), RefCell::default());
        let ts = self.times(self.outputs);
        integrate(&logged, Method::Dop853, 0.0, self.y0, &ts, &options(tol)).unwrap();
        logged.1.into_inner()
    }
}

fn options(tol: f64) -> Options {
    Options {
        rtol: tol,
        atol: tol,
        ..Options::default()
    }
}

fn benches(c: &mut Criterion) {
    for case in &CASES {
        let system = case.system();
        let mut group = c.benchmark_group(format!("integrate/{}", case.name));
        for tol in TOLERANCES {
            for n in [case.outputs, 1] {
                let ts = case.times(n);
                let o = options(tol);
                group.bench_function(format!("dop853-{tol:e}/{n}-outputs"), |b| {
                    b.iter(|| {
                        integrate(&system, Method::Dop853, 0.0, black_box(case.y0), &ts, &o)
                            .unwrap()
                    })
                });
            }
        }
        group.finish();
        let mut group = c.benchmark_group(format!("rhs/{}", case.name));
        for tol in TOLERANCES {
            let states = case.visited(tol);
            let mut dy = vec![0.0; case.y0.len()];
            let mut y = vec![0.0; case.y0.len()];
            group.bench_function(format!("dop853-{tol:e}"), |b| {
                b.iter(|| {
                    // Each evaluation waits for the one before, as the stages of a step do.
                    for x in &states {
                        y.copy_from_slice(x);
                        y[0] += 0.0 * dy[0];
                        system.rhs(0.0, black_box(&y), &mut dy).unwrap();
                    }
                })
            });
        }
        group.finish();
    }
    monitors(c);
    let ts: Vec<f64> = (0..101).map(|k| 0.1 * k as f64).collect();
    let o = still_options();
    c.bench_function("integrate/still/dop853/101-outputs", |b| {
        b.iter(|| integrate(&Still, Method::Dop853, 0.0, black_box(&[0.0; 5]), &ts, &o).unwrap())
    });
}

/// Every scene's run with every output, under each set of monitors.
fn monitors(c: &mut Criterion) {
    for case in &CASES {
        let mut group = c.benchmark_group(format!("monitors/{}", case.name));
        for tol in TOLERANCES {
            let ts = case.times(case.outputs);
            let o = options(tol);
            for (name, energy, residual) in MONITORS {
                let system = Monitored {
                    full: case.system(),
                    energy,
                    residual,
                };
                group.bench_function(format!("dop853-{tol:e}/{name}"), |b| {
                    b.iter(|| {
                        integrate(&system, Method::Dop853, 0.0, black_box(case.y0), &ts, &o)
                            .unwrap()
                    })
                });
            }
            // The monitors alone, as the recorder calls them after the run: over the run's own
            // outputs (what they add to a run, without the noise of two whole runs).
            let run = integrate(&case.system(), Method::Dop853, 0.0, case.y0, &ts, &o).unwrap();
            let rows = run.y.as_flat();
            let core = case.system().0;
            let mut out = vec![None; run.t.len()];
            for (name, batch) in [("energy", core.energies), ("residual", core.residuals)] {
                group.bench_function(format!("dop853-{tol:e}/{name}-alone"), |b| {
                    b.iter(|| batch(black_box(rows), &mut out))
                });
            }
        }
        group.finish();
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

/// Criterion's point estimate of the mean, in seconds, for a benchmark of this run.
fn estimate(id: &str) -> Option<f64> {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../target/criterion");
    let text = std::fs::read_to_string(dir.join(id).join("new/estimates.json")).ok()?;
    let v: serde_json::Value = serde_json::from_str(&text).ok()?;
    Some(v["mean"]["point_estimate"].as_f64()? * 1e-9)
}

fn summary() {
    if let Some(still) = estimate("integrate_still_dop853_101-outputs") {
        println!(
            "\nthe fixed cost of a run with 101 outputs (ẏ = 0, one step): {:.2} µs",
            still * 1e6
        );
    }
    println!("\nDOP853: the cost of a run besides its evaluations");
    println!(
        "| scene | tol | evaluations | run | the evaluations alone | the rest | the rest per evaluation | per output |"
    );
    println!("|---|---|---|---|---|---|---|---|");
    for case in &CASES {
        for tol in TOLERANCES {
            let id = |n: usize| format!("integrate_{}/dop853-{tol:e}_{n}-outputs", case.name);
            let rhs = estimate(&format!("rhs_{}/dop853-{tol:e}", case.name));
            let (Some(all), Some(last), Some(rhs)) =
                (estimate(&id(case.outputs)), estimate(&id(1)), rhs)
            else {
                continue;
            };
            let evals = case.run(tol, case.outputs).stats.rhs_evals;
            println!(
                "| {} | {tol:e} | {evals} | {:.2} µs | {:.2} µs | {:.2} µs | {:.1} ns | {:.1} ns |",
                case.name,
                all * 1e6,
                rhs * 1e6,
                (all - rhs) * 1e6,
                (all - rhs) / evals as f64 * 1e9,
                (all - last) / (case.outputs - 1) as f64 * 1e9
            );
        }
    }
}

/// What each monitor adds to a run, from this run's estimates.
fn monitors_summary() {
    println!("\nWhat a requested monitor costs (every output; run time, and over no monitor)");
    println!(
        "| scene | tol | none | energy | residual | both | energy alone, of none | residual alone, of none |"
    );
    println!("|---|---|---|---|---|---|---|---|");
    for case in &CASES {
        for tol in TOLERANCES {
            let id = |m: &str| estimate(&format!("monitors_{}/dop853-{tol:e}_{m}", case.name));
            let Some(none) = id("none") else { continue };
            let mut cells: Vec<String> = MONITORS[1..]
                .iter()
                .filter_map(|(m, _, _)| id(m))
                .map(|t| format!("{:.2} µs ({:+.1} %)", t * 1e6, (t / none - 1.0) * 100.0))
                .collect();
            for m in ["energy-alone", "residual-alone"] {
                let t = id(m).unwrap_or(f64::NAN);
                cells.push(format!("{:.2} µs ({:.1} %)", t * 1e6, t / none * 100.0));
            }
            println!(
                "| {} | {tol:e} | {:.2} µs | {} |",
                case.name,
                none * 1e6,
                cells.join(" | ")
            );
        }
    }
}

criterion_group!(group, benches);

fn main() {
    group();
    Criterion::default().configure_from_args().final_summary();
    summary();
    monitors_summary();
}
