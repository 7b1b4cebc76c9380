//! Numeric benchmarks (criterion): `cargo bench --bench numeric`.
//!
//! * `rhs/<model>/<eta>/generated_reduced`: the reduced right-hand side (kept coordinates, η) at
//!   the same state, prepared parameters.
//! * `rhs/<model>/<eta>/{generated,interpreted}`: one evaluation of the right-hand side
//!   (q̇, η̇) at a fixed admissible state, by the generated code (`crates/hamel-models`,
//!   `full_into`: no allocation, the paper's form not computed, parameters prepared once) and
//!   by the structured evaluator
//!   it is generated from (`hamel_derive::Compiled::rhs`, a tape interpreter that also computes
//!   the paper's form and the energy); and, for the
//!   knife, the 3.2 bar and the unicycle with rider, by hand-written code (`hamel-handwritten`:
//!   η̇ and q̇ only, the practical limit), beside the generated `fast` called the same way
//!   (`generated_fast`: arrays in and out, no finite check, parameter-only values computed at
//!   each call) and `fast_with` with them prepared once (`generated_prepared`).
//! * `rhs/<model>/<eta>/symbolica`: Symbolica's own evaluator (its default optimisation: Horner
//!   scheme, common subexpressions) on the same solved form as the generated code, parameters
//!   as inputs, timed on the CAS worker thread (`hamel_cas::evaluator`, criterion's
//!   `iter_custom`).
//! * `checked/<model>/<eta>/<precision>/…`: the checked structured evaluation (error estimate,
//!   double-double repeat where it says so; `<precision>` is what it chose at the state) against
//!   the plain f64 one and double-double throughout, generated and interpreted.
//! * `simulate/<model>/{full,reduced}`: 100 s with DOP853 at rtol = atol = 1e-10, the full state
//!   (q, η) against the reduced one (kept q, η), both with the generated code;
//!   `simulate/<model>/gauss-legendre/{full,reduced}` the same with the implicit Gauss–Legendre
//!   method (step doubling, finite-difference Jacobians on both sides).
//!
//! The CAS runs only in the setup (one derivation per model, on its worker thread).

use criterion::{Criterion, criterion_group, criterion_main};
use hamel_models::MODELS;
use hamel_sim::{Method, OdeSystem, Options, SystemError};
use indexmap::IndexMap;
use std::hint::black_box;

fn models_dir() -> std::path::PathBuf {
    std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models")
}

/// A fixed admissible state: q = 0.3, 0.7, 1.1, …; η = 0.4, −0.3, 0.2, …
fn state(ell: usize, sigma: usize) -> (Vec<f64>, Vec<f64>) {
    let q = (0..ell).map(|i| 0.3 + 0.4 * i as f64).collect();
    let eta = (0..sigma)
        .map(|i| 0.4 * if i % 2 == 0 { 1.0 } else { -0.75 } / (1 + i / 2) as f64)
        .collect();
    (q, eta)
}

/// The reduced state of a core at (q, η): the kept coordinates, then η.
fn reduced_state(core: &hamel_models::Core, q: &[f64], eta: &[f64]) -> Vec<f64> {
    core.kept
        .iter()
        .map(|&k| q[k])
        .chain(eta.iter().copied())
        .collect()
}

fn rhs(c: &mut Criterion) {
    let mut group = c.benchmark_group("rhs");
    for core in MODELS {
        let model = hamel_model::Model::load(models_dir().join(format!("{}.toml", core.model)))
            .expect("bundled model");
        let d = hamel_derive::derive(&model, Some(core.eta)).expect("derivation");
        let compiled = d.compile().expect("compiles");
        let params: IndexMap<String, f64> = d.parameters.clone();
        let (q, eta) = state(core.dims.ell, core.dims.sigma);
        if (core.full)(&q, &eta).is_err() {
            continue;
        }
        let id = format!("{}/{}", core.model, core.eta);
        let y: Vec<f64> = q.iter().chain(&eta).copied().collect();
        let mut dy = vec![0.0; y.len()];
        group.bench_function(format!("{id}/generated"), |b| {
            b.iter(|| (core.full_into)(black_box(&y), &mut dy).unwrap())
        });
        // The reduced right-hand side (kept coordinates and η) at the same state.
        let x = reduced_state(core, &q, &eta);
        let mut dx = vec![0.0; x.len()];
        group.bench_function(format!("{id}/generated_reduced"), |b| {
            b.iter(|| (core.reduced_into)(black_box(&x), &mut dx).unwrap())
        });
        group.bench_function(format!("{id}/interpreted"), |b| {
            b.iter(|| {
                compiled
                    .rhs::<f64>(black_box(&q), black_box(&eta), &params)
                    .unwrap()
            })
        });
        // Symbolica's own evaluator (default optimisation) on the solved form the generator
        // wrote (parameters as inputs, like the generated code), timed on the CAS worker thread.
        let solved = hamel_derive::derive_for_code(&model, Some(core.eta))
            .map_err(|e| e.to_string())
            .and_then(|d| hamel_codegen::generate(&d, &[], "bench").map_err(|e| e.to_string()))
            .expect("generates")
            .solved;
        let at: Vec<f64> = q
            .iter()
            .chain(params.values())
            .chain(&eta)
            .copied()
            .collect();
        let reference = (core.full)(&q, &eta).unwrap();
        match hamel_cas::evaluator::SymbolicaEvaluator::build(solved.exprs, solved.inputs) {
            Ok(sym) => {
                let v = sym.evaluate(at.clone()).unwrap();
                let expect: Vec<f64> = reference
                    .eta_dot
                    .iter()
                    .chain(&reference.q_dot)
                    .copied()
                    .collect();
                let scale = expect.iter().fold(1.0_f64, |m, x| m.max(x.abs()));
                let err = v
                    .iter()
                    .zip(&expect)
                    .map(|(a, b)| (a - b).abs())
                    .fold(0.0, f64::max)
                    / scale;
                eprintln!(
                    "{id}: Symbolica's evaluator on `{}`{}: relative difference {err:.1e}",
                    solved.name,
                    if solved.used {
                        ""
                    } else {
                        " (not the generated fast path)"
                    }
                );
                assert!(err < 1e-9, "{id}: Symbolica's evaluator differs by {err:e}");
                group.bench_function(format!("{id}/symbolica"), |b| {
                    b.iter_custom(|iters| sym.time(at.clone(), iters).unwrap())
                });
            }
            Err(e) => eprintln!("{id}: Symbolica's evaluator not built: {e}"),
        }
        let (qa, ea) = (q.clone(), eta.clone());
        // The hand-written right-hand side of the same system, where there is one.
        // Beside it, the generated `fast` called the same way (arrays in and out, inlinable,
        // no finite check): the like-for-like comparison.
        macro_rules! handwritten {
            ($m:ident, $g:ident) => {{
                use hamel_handwritten::$m::{Params, rhs};
                let (q, e): ([f64; _], [f64; _]) = (qa.try_into().unwrap(), ea.try_into().unwrap());
                let p = Params::default();
                group.bench_function(format!("{id}/handwritten"), |b| {
                    b.iter(|| rhs(black_box(&q), black_box(&e), &p))
                });
                let p = hamel_models::$g::Parameters::default();
                group.bench_function(format!("{id}/generated_fast"), |b| {
                    b.iter(|| hamel_models::$g::fast(black_box(&q), black_box(&e), &p).unwrap())
                });
                let prep = hamel_models::$g::Prepared::new(&p).unwrap();
                group.bench_function(format!("{id}/generated_prepared"), |b| {
                    b.iter(|| {
                        hamel_models::$g::fast_with(black_box(&q), black_box(&e), &prep).unwrap()
                    })
                });
            }};
        }
        match (core.model, core.eta) {
            ("knife", "paper") => handwritten!(knife, knife__paper),
            ("bar_blade", "paper") => handwritten!(bar_blade, bar_blade__paper),
            ("unicycle_rider", "velocities") => {
                handwritten!(unicycle_rider, unicycle_rider__velocities)
            }
            _ => {}
        }
    }
    group.finish();
}

/// The price of the checked evaluation (docs/stability.md): the structured path with its error
/// estimate and double-double repeat against the plain f64 evaluation and against double-double
/// throughout, generated and interpreted, at the fixed state of `rhs/`.
fn checked(c: &mut Criterion) {
    let mut group = c.benchmark_group("checked");
    let picked = [
        ("knife", "paper"),
        ("rolling_disk", "velocities"),
        ("snakeboard", "velocities"),
        ("unicycle_rider", "momenta"),
    ];
    for core in MODELS.iter().filter(|k| picked.contains(&(k.model, k.eta))) {
        let model = hamel_model::Model::load(models_dir().join(format!("{}.toml", core.model)))
            .expect("bundled model");
        let d = hamel_derive::derive(&model, Some(core.eta)).expect("derivation");
        let compiled = d.compile().expect("compiles");
        let params: IndexMap<String, f64> = d.parameters.clone();
        let (q, eta) = state(core.dims.ell, core.dims.sigma);
        let Ok(r) = (core.full)(&q, &eta) else {
            continue;
        };
        let id = format!("{}/{}/{}", core.model, core.eta, r.precision.name());
        group.bench_function(format!("{id}/generated_unchecked"), |b| {
            b.iter(|| (core.full_unchecked)(black_box(&q), black_box(&eta)).unwrap())
        });
        group.bench_function(format!("{id}/generated_checked"), |b| {
            b.iter(|| (core.full)(black_box(&q), black_box(&eta)).unwrap())
        });
        group.bench_function(format!("{id}/interpreted_unchecked"), |b| {
            b.iter(|| {
                compiled
                    .rhs::<f64>(black_box(&q), black_box(&eta), &params)
                    .unwrap()
            })
        });
        group.bench_function(format!("{id}/interpreted_checked"), |b| {
            b.iter(|| {
                compiled
                    .evaluate(black_box(&q), black_box(&eta), &params)
                    .unwrap()
            })
        });
        let wide = |v: &[f64]| {
            v.iter()
                .map(|&x| hamel_expr::DD::from_f64(x))
                .collect::<Vec<_>>()
        };
        let (qd, ed) = (wide(&q), wide(&eta));
        group.bench_function(format!("{id}/interpreted_double_double"), |b| {
            b.iter(|| {
                compiled
                    .rhs::<hamel_expr::DD>(black_box(&qd), black_box(&ed), &params)
                    .unwrap()
            })
        });
    }
    group.finish();
}

struct Full(&'static hamel_models::Core);
struct Reduced(&'static hamel_models::Core);

impl OdeSystem for Full {
    fn dim(&self) -> usize {
        self.0.dims.ell + self.0.dims.sigma
    }
    fn rhs(&self, _t: f64, y: &[f64], dy: &mut [f64]) -> Result<(), SystemError> {
        (self.0.full_into)(y, dy).map_err(|e| SystemError::new(e.to_string()))
    }
}

impl OdeSystem for Reduced {
    fn dim(&self) -> usize {
        self.0.kept.len() + self.0.dims.sigma
    }
    fn rhs(&self, _t: f64, y: &[f64], dy: &mut [f64]) -> Result<(), SystemError> {
        (self.0.reduced_into)(y, dy).map_err(|e| SystemError::new(e.to_string()))
    }
}

fn simulate(c: &mut Criterion) {
    let mut group = c.benchmark_group("simulate");
    group.sample_size(10);
    let options = Options {
        rtol: 1e-10,
        atol: 1e-10,
        max_steps: 10_000_000,
        ..Options::default()
    };
    // The 3.3 cart (bar_wheels) and the unicycle with rider, 100 s.
    for (model, eta, q0, eta0) in [
        (
            "bar_wheels",
            "paper",
            vec![0.0, 0.0, 0.3, 0.0, 0.4],
            vec![1.0, 0.5],
        ),
        (
            "unicycle_rider",
            "velocities",
            // Rolling fast (ψ̇ = 40 rad/s, 10 m/s): gyroscopically stable, θ stays in
            // 0.005..0.11 over 100 s and full and reduced runs agree to 2e-7 (at ψ̇ = 4 the disk
            // falls over and the motion is chaotic: the runs diverge).
            vec![0.0, 0.0, 0.0, 0.0, 0.05, 0.02],
            vec![0.0, 40.0, 0.0, 0.0],
        ),
    ] {
        let core = MODELS
            .iter()
            .find(|c| c.model == model && c.eta == eta)
            .expect("generated core");
        let y_full: Vec<f64> = q0.iter().chain(&eta0).copied().collect();
        let y_red = reduced_state(core, &q0, &eta0);
        let times = [100.0];
        // DOP853, and Gauss–Legendre (3 stages, step doubling) with finite-difference
        // Jacobians for both systems (neither run gets the generated Jacobian: the same
        // machinery on both sides), whose Newton solves cost O(n³) in the state count.
        for (label, method) in [
            ("", Method::Dop853),
            (
                "gauss-legendre/",
                Method::GaussLegendre {
                    stages: 3,
                    step: None,
                },
            ),
        ] {
            // Both runs must reach t = 100 (a failure is not timed), and agree on η at the end.
            let full = hamel_sim::integrate(&Full(core), method, 0.0, &y_full, &times, &options)
                .unwrap_or_else(|e| panic!("{model}: full run failed: {e}"));
            let red = hamel_sim::integrate(&Reduced(core), method, 0.0, &y_red, &times, &options)
                .unwrap_or_else(|e| panic!("{model}: reduced run failed: {e}"));
            let (ef, er) = (&full.y[0][core.dims.ell..], &red.y[0][core.kept.len()..]);
            eprintln!(
                "{model} {label}: full {} RHS evaluations, reduced {}; η(100) differs by {:.1e}",
                full.stats.rhs_evals,
                red.stats.rhs_evals,
                ef.iter()
                    .zip(er)
                    .map(|(a, b)| (a - b).abs())
                    .fold(0.0, f64::max)
            );
            group.bench_function(format!("{model}/{label}full"), |b| {
                b.iter(|| {
                    hamel_sim::integrate(&Full(core), method, 0.0, &y_full, &times, &options)
                        .expect("checked above")
                        .stats
                        .rhs_evals
                })
            });
            group.bench_function(format!("{model}/{label}reduced"), |b| {
                b.iter(|| {
                    hamel_sim::integrate(&Reduced(core), method, 0.0, &y_red, &times, &options)
                        .expect("checked above")
                        .stats
                        .rhs_evals
                })
            });
        }
    }
    group.finish();
}

criterion_group! {
    name = benches;
    config = Criterion::default()
        .warm_up_time(std::time::Duration::from_millis(500))
        .measurement_time(std::time::Duration::from_secs(2));
    targets = rhs, checked, simulate
}
criterion_main!(benches);
