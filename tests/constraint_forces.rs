//! The constraints' forces (issue 58, first step): the multipliers λ of every row of α and the
//! generalised force R = αᵀλ that hamel computes from its own equations
//! (`Compiled::constraint_force`: R = AΓη̇ + AΓ̇η − (∇U + F + ∇_qT − Ȧq̇), λ from [Z; α]ᵀy = R),
//! against the Lagrange-multiplier oracle's, which solves for q̈ and λ together from the model
//! file's expressions. The oracle writes A q̈ + αᵀλ_o = …, so λ = −λ_o. Random states, in
//! double-double (1e-20) and through `evaluate` in f64 (1e-10).
//!
//! The CAS runs in-process on its one worker thread.

mod common;

use common::oracle::dd;
use common::rel_error;
use hamel_derive::derive;
use hamel_expr::{DD, Scalar};
use hamel_model::{Model, NumericModel};
use indexmap::IndexMap;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

fn bundled(name: &str) -> Model {
    Model::load(format!("{}/models/{name}.toml", env!("CARGO_MANIFEST_DIR")))
        .unwrap_or_else(|e| panic!("{e}"))
}

/// The largest relative differences (λ, R in double-double; λ in f64) over `states` states.
fn worst(name: &str, choice: &str, seed: u64, states: usize) -> (f64, f64, f64) {
    let m = bundled(name);
    let d = derive(&m, Some(choice)).unwrap();
    let c = d.compile().unwrap();
    let nm = NumericModel::new(&m, &IndexMap::new()).unwrap();
    let params = d.parameters.clone();
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let (mut lambda, mut force, mut f64_lambda) = (0.0_f64, 0.0_f64, 0.0_f64);
    let mut done = 0;
    while done < states {
        let q: Vec<f64> = (0..d.ell).map(|_| rng.random_range(-3.0..3.0)).collect();
        let v: Vec<f64> = (0..d.ell).map(|_| rng.random_range(-2.0..2.0)).collect();
        if c.condition(&q, &params).unwrap() > 1e4 {
            continue;
        }
        let qd = hamel_oracle::project(&nm, &q, &v).unwrap();
        let z = nm.quasi_velocity_matrix::<f64>(choice, &q).unwrap();
        let eta: Vec<f64> = (z.iter())
            .map(|row| row.iter().zip(&qd).map(|(a, b)| a * b).sum())
            .collect();
        let (qx, etax) = (dd(&q), dd(&eta));
        let r = c.rhs::<DD>(&qx, &etax, &params).unwrap();
        let oracle = hamel_oracle::accelerations::<DD>(&nm, &qx, &r.q_dot).unwrap();
        let ours = c.constraint_force::<DD>(&qx, &etax, &params).unwrap();
        // R = −αᵀλ_o from every row of the model (the dropped ones included)
        let rows = nm.all_constraint_rows::<DD>(&qx).unwrap();
        let expected: Vec<DD> = (0..d.ell)
            .map(|k| {
                (rows.iter().zip(&oracle.lambda))
                    .fold(DD::from_f64(0.0), |acc, (row, l)| acc - row[k] * *l)
            })
            .collect();
        force = force.max(rel_error(&ours.generalised, &expected));
        if m.dependent.is_empty() {
            let minus: Vec<DD> = oracle.lambda.iter().map(|&l| -l).collect();
            lambda = lambda.max(rel_error(&ours.multipliers, &minus));
            let e = c.evaluate(&q, &eta, &params).unwrap();
            let values: Vec<f64> = ours.multipliers.iter().map(|x| x.value()).collect();
            f64_lambda = f64_lambda.max(rel_error(&dd(&e.multipliers), &dd(&values)));
        }
        done += 1;
    }
    (lambda, force, f64_lambda)
}

#[test]
fn multipliers_agree_with_the_oracle() {
    for (name, choice) in [
        ("knife", "paper"),
        ("rolling_disk", "velocities"),
        ("bar_wheels", "paper"),
        ("unicycle_rider", "velocities"),
    ] {
        let (lambda, force, f64_lambda) = worst(name, choice, 58, 20);
        eprintln!("{name}/{choice}: λ {lambda:.1e}, R {force:.1e}, f64 λ {f64_lambda:.1e}");
        assert!(
            lambda <= 1e-20 && force <= 1e-20 && f64_lambda <= 1e-10,
            "{name}/{choice}: λ {lambda:.1e}, R {force:.1e}, f64 λ {f64_lambda:.1e}"
        );
    }
}

/// With dependent rows (two wheels on one axle) λ is not unique, but R = αᵀλ is.
#[test]
fn the_generalised_constraint_force_is_unique_with_dependent_rows() {
    for (name, choice) in [("diff_drive", "wheels"), ("segway", "body")] {
        let (_, force, _) = worst(name, choice, 59, 20);
        eprintln!("{name}/{choice}: R {force:.1e}");
        assert!(force <= 1e-20, "{name}/{choice}: R {force:.1e}");
    }
}
