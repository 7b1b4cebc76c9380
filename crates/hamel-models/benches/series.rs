//! The Taylor method's series by the compiled recurrences against the traced ones (issue 63):
//! `cargo bench -p hamel-models --bench series`.
//!
//! For the knife, the rolling disk, bar_wheels and the unicycle (the closed forms of the
//! scenes compared with heyoka), the coefficients to order 20 (what a step at rtol ≈ 1e-16
//! computes; order 13 at 1e-10) at 16 admissible states:
//! * `series/<model>/compiled/<p>`: `reduced_series`, the recurrences written out per
//!   operation in the generated code;
//! * `series/<model>/traced/<p>`: `reduced_with` traced once and the recurrences interpreted
//!   over the trace (`runtime::taylor_by_trace`), what a core without a closed form runs.
//!
//! It prints traced/compiled for each, from criterion's estimates of this same run.

mod common;

use common::{estimate, uniform};
use criterion::{Criterion, criterion_group};
use hamel_models::{Core, MODELS};
use std::hint::black_box;

const STATES: usize = 16;

fn core(model: &str, eta: &str) -> &'static Core {
    MODELS
        .iter()
        .find(|c| c.model == model && c.eta == eta && c.scene.is_empty())
        .expect("the core is generated")
}

/// Admissible reduced states in [-1, 1).
fn states(core: &Core) -> Vec<Vec<f64>> {
    let n = core.kept.len() + core.dims.sigma;
    let mut next = uniform();
    let mut out = Vec::new();
    while out.len() < STATES {
        let x: Vec<f64> = (0..n).map(|_| next()).collect();
        let mut dx = vec![0.0; n];
        if (core.reduced_into)(&x, &mut dx).is_ok() {
            out.push(x);
        }
    }
    out
}

const CASES: [(&str, &str); 4] = [
    ("knife", "paper"),
    ("rolling_disk", "velocities"),
    ("bar_wheels", "paper"),
    ("unicycle_rider", "velocities"),
];

fn benches(c: &mut Criterion) {
    for (model, eta) in CASES {
        let core = core(model, eta);
        let xs = states(core);
        for order in [13, 20] {
            for (how, f) in [("compiled", core.series), ("traced", core.series_traced)] {
                let mut out = Vec::new();
                c.bench_function(&format!("series/{model}/{how}/{order}"), |b| {
                    b.iter(|| {
                        for x in &xs {
                            black_box(f(black_box(x), order, &mut out).unwrap());
                        }
                    })
                });
            }
        }
    }
}

fn summary() {
    println!("\nThe compiled recurrences against the traced ones (same states, this run)");
    for (model, _) in CASES {
        for order in [13, 20] {
            let id = |how: &str| format!("series_{model}_{how}_{order}");
            if let (Some(c), Some(t)) = (estimate(&id("compiled")), estimate(&id("traced"))) {
                println!(
                    "  {model}, order {order}: {:.2} µs vs {:.2} µs a series, traced/compiled = {:.2}",
                    c * 1e6 / STATES as f64,
                    t * 1e6 / STATES as f64,
                    t / c
                );
            }
        }
    }
}

criterion_group!(group, benches);

fn main() {
    group();
    Criterion::default().configure_from_args().final_summary();
    summary();
}
