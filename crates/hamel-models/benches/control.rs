//! What a control law costs a generated core (issue 57): `cargo bench -p hamel-models --bench control`.
//!
//! The Segway's core with its motor torques as constant inputs (`generated/segway__body`, the
//! model file's equations, T_L and T_R parameters) against the core of its closed loop under
//! the LQR law of scenes/segway_lqr.toml (`generated/segway_lqr__body`: the law is straight-line
//! code of the state, its gains parameters), on the same 64 states:
//! * `control/segway/<constant|law>/reduced`: the reduced right-hand side a scene integrates
//!   (θ and η; x, y, ψ and the wheel angles eliminated), parameters prepared once;
//! * `control/segway/<constant|law>/full`: d(q, η)/dt of every coordinate.
//!
//! It prints law/constant for each, from criterion's estimates of this same run.

mod common;

use common::{estimate, uniform};
use criterion::{Criterion, criterion_group};
use hamel_models::{Core, MODELS};
use std::hint::black_box;

const STATES: usize = 64;

fn core(scene: &str) -> &'static Core {
    MODELS
        .iter()
        .find(|c| c.model == "segway" && c.eta == "body" && c.scene == scene)
        .expect("the Segway's cores are generated")
}

/// Deterministic states in [-1, 1).
fn states(n: usize) -> Vec<Vec<f64>> {
    let mut next = uniform();
    (0..STATES)
        .map(|_| (0..n).map(|_| next()).collect())
        .collect()
}

fn benches(c: &mut Criterion) {
    let cases = [
        ("constant", core("")),
        ("law", core("scenes/segway_lqr.toml")),
    ];
    for (name, k) in cases {
        let nr = k.kept.len() + k.dims.sigma;
        let xs = states(nr);
        let mut dx = vec![0.0; nr];
        c.bench_function(&format!("control/segway/{name}/reduced"), |b| {
            b.iter(|| {
                for x in &xs {
                    (k.reduced_into)(black_box(x), &mut dx).unwrap();
                }
                black_box(&dx);
            })
        });
        let n = k.dims.ell + k.dims.sigma;
        let ys = states(n);
        let mut dy = vec![0.0; n];
        c.bench_function(&format!("control/segway/{name}/full"), |b| {
            b.iter(|| {
                for y in &ys {
                    (k.full_into)(black_box(y), &mut dy).unwrap();
                }
                black_box(&dy);
            })
        });
    }
}

fn summary() {
    println!("\nThe LQR law against constant inputs (same states, this run)");
    for which in ["reduced", "full"] {
        let id = |name: &str| format!("control_segway_{name}_{which}");
        if let (Some(a), Some(b)) = (estimate(&id("law")), estimate(&id("constant"))) {
            println!(
                "  {which}: {:.1} ns vs {:.1} ns per evaluation, law/constant = {:.3}",
                a * 1e9 / STATES as f64,
                b * 1e9 / STATES as f64,
                a / b
            );
        }
    }
}

criterion_group!(group, benches);

fn main() {
    group();
    Criterion::default().configure_from_args().final_summary();
    summary();
}
