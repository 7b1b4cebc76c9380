//! Velocity-dependent forces, springs and dampers (issue 57, part 2), against the independent
//! Lagrange-multiplier oracle, which reads F(q, q̇) from the model file:
//! * the sprung sleigh of models/ (a spring and dampers from bodies, drag as a load with
//!   der(q), a thrust input), closed and structured;
//! * a knife edge with quadratic drag typed by hand (tests/models/dragged_knife.toml): the
//!   velocities under a square root send the derivation to the structured form;
//! * the energy balance E(t) − E(0) = ∫ q̇ᵀF dt along the sleigh's scene, on both engines'
//!   path through the interpreted evaluator.

mod common;

use std::path::Path;

use common::oracle::{compare, q_ddot};
use common::rel_error;
use hamel_derive::{FormRequest, derive, derive_with};
use hamel_model::{Model, NumericModel};
use indexmap::IndexMap;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

fn load(path: &str) -> Model {
    Model::load(format!("{}/{path}", env!("CARGO_MANIFEST_DIR"))).unwrap_or_else(|e| panic!("{e}"))
}

/// η̇ against the oracle at 50 random states on the constraints, to 1e-12 relative, for the
/// closed and the structured form (the dragged knife has only the structured one).
#[test]
fn damped_driven_models_match_the_oracle() {
    for (path, choice, closed) in [
        ("models/sprung_sleigh.toml", "forward", true),
        ("tests/models/dragged_knife.toml", "paper", false),
    ] {
        let model = load(path);
        assert!(model.has_velocity_forces(), "{path}");
        let w = compare(&model, choice, 41, 50);
        assert_eq!(w.structured_form, !closed, "{path}");
        assert!(
            w.structured_f64 <= 1e-12 && w.structured_dd <= 1e-20,
            "{path}: f64 {:.1e}, dd {:.1e}",
            w.structured_f64,
            w.structured_dd
        );
        if closed {
            assert!(
                w.symbolic_dd <= 1e-20,
                "{path}: symbolic {:.1e}",
                w.symbolic_dd
            );
        }
    }
}

/// The sleigh with other inputs and dampings (the thrust reversed, the damper ten times
/// stiffer): structured and closed evaluations agree with the oracle, and the power each
/// reports is q̇ᵀF with F read from the file.
#[test]
fn inputs_and_dampings_move_the_forces() {
    let model = load("models/sprung_sleigh.toml");
    let closed = derive(&model, Some("forward")).unwrap();
    let structured = derive_with(&model, Some("forward"), FormRequest::Structured, false).unwrap();
    let (cc, cs) = (closed.compile().unwrap(), structured.compile().unwrap());
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    for (thrust, c) in [(-2.0, 15.0), (0.3, 0.1)] {
        let set = IndexMap::from([("F".to_string(), thrust), ("c".to_string(), c)]);
        let mut params = closed.parameters.clone();
        params.extend(set.clone());
        let nm = NumericModel::new(&model, &set).unwrap();
        for _ in 0..20 {
            let q: Vec<f64> = (0..4).map(|_| rng.random_range(-2.0..2.0)).collect();
            let eta: Vec<f64> = (0..3).map(|_| rng.random_range(-2.0..2.0)).collect();
            let rc = cc.evaluate(&q, &eta, &params).unwrap();
            let rs = cs.evaluate(&q, &eta, &params).unwrap();
            assert!(rel_error(&rs.eta_dot, &rc.eta_dot) <= 1e-13);
            let oracle = hamel_oracle::accelerations::<f64>(&nm, &q, &rs.q_dot).unwrap();
            let rhs = cs.rhs::<f64>(&q, &eta, &params).unwrap();
            let mine = q_ddot(&cs, &q, &eta, &rhs.eta_dot, &rhs.q_dot, &params);
            assert!(rel_error(&mine, &oracle.q_ddot) <= 1e-12);
            let f = nm.forces::<f64>(&q, &rs.q_dot).unwrap();
            let power: f64 = f.iter().zip(&rs.q_dot).map(|(f, v)| f * v).sum();
            for r in [&rc, &rs] {
                let p = r.power.expect("a model with forces reports their power");
                assert!((p - power).abs() <= 1e-13 * (1.0 + power.abs()));
            }
        }
    }
}

/// Along the sleigh's scene the forces change the energy by several times its start, and
/// E(t) − W(t) stays at E(0) to 1e-9 relative (W integrated beside the state from the power
/// q̇ᵀF); without a request of the energy no work is integrated.
#[test]
fn the_energy_balance_holds_along_a_simulation() {
    let scene = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/sprung_sleigh.toml");
    let engine = hamel_run::Engine::Interpreted;
    let hamel_run::simulate::Simulated {
        trajectory: t,
        failure,
        ..
    } = hamel_run::simulate::run(&scene, engine, false).unwrap();
    assert!(failure.is_none() && t.complete);
    let energy: Vec<f64> = t
        .energy
        .as_ref()
        .unwrap()
        .iter()
        .map(|e| e.unwrap())
        .collect();
    let work = t.work.as_ref().expect("the work is reported");
    let (e0, e_end) = (energy[0], *energy.last().unwrap());
    assert!(
        (e_end - e0).abs() > e0.abs(),
        "the forces change the energy: {e0} → {e_end}"
    );
    let worst = energy
        .iter()
        .zip(work)
        .map(|(e, w)| (e - w - e0).abs() / e0.abs())
        .fold(0.0, f64::max);
    assert!(worst <= 1e-9, "E − W − E(0) reaches {worst:.2e} of E(0)");
    let drift = t.stats.energy_balance_drift.unwrap();
    assert!(drift <= 1e-9 && t.stats.energy_drift.is_none());
    assert!(
        t.summary().contains("energy balance drift"),
        "{}",
        t.summary()
    );
}
