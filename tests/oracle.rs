//! hamel's Boltzmann–Hamel equations against the independent oracle.
//!
//! For every bundled model and every quasi-velocity choice, at ≥ 50 random states on the
//! constraint manifold, q̈ = Γ̇η + Γη̇ from hamel's equations must equal q̈ from the
//! Lagrange-multiplier form (crate `hamel-oracle`) to 1e-10 relative:
//! * the structured evaluation of (11) (what `hamel eval` and the numeric core use), in f64;
//! * the same in double-double, to 1e-20;
//! * the expanded symbolic equations (A_Γ, Γᵀ∇U, Q⁽ⁱ⁾ as printed by `hamel derive`), derived
//!   with free functions kept symbolic and evaluated in double-double with the free functions'
//!   values and first derivatives as inputs (in f64 their expanded forms cancel badly: see
//!   docs/derivation.md).
//!
//! Choices with free functions use concrete test functions. The CAS runs in-process, on its one
//! worker thread.

mod common;

use common::oracle::{F64_CONDITION, TOL, compare, q_ddot};
use common::{models, rel_error};

use hamel_derive::{Form, FormRequest, derive, derive_with};
use hamel_model::{Model, NumericModel};
use indexmap::IndexMap;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

const STATES: usize = 50;

#[test]
fn every_model_and_choice_matches_the_lagrange_multiplier_oracle() {
    let mut report = Vec::new();
    for (mi, model) in models().iter().enumerate() {
        for (ci, choice) in model.choices.iter().enumerate() {
            let w = compare(model, &choice.name, 1000 * mi as u64 + ci as u64, STATES);
            let symbolic = if w.structured_form {
                "symbolic: none (structured form)".to_string()
            } else {
                format!(
                    "symbolic dd {:.1e} (paper's form {:.1e})",
                    w.symbolic_dd, w.paper_dd
                )
            };
            report.push(format!(
                "{}/{}: {} states; max rel. error: structured f64 {:.1e} ({} states), structured dd {:.1e}, {symbolic}",
                model.name, choice.name, w.states, w.structured_f64, w.f64_states, w.structured_dd
            ));
            let line = report.last().unwrap();
            assert!(
                w.structured_f64 <= TOL && w.symbolic_dd <= TOL && w.structured_dd <= 1e-20,
                "{line}"
            );
            // The f64 comparison is not emptied by its conditioning gates.
            assert!(2 * w.f64_states >= w.states, "{line}");
        }
    }
    eprintln!("{}", report.join("\n"));
    assert!(
        report.len() >= 15,
        "expected every model and choice, got {}",
        report.len()
    );
    // The bicycle is among them, in structured form (its closed form is too large).
    assert!(
        report
            .iter()
            .any(|l| l.starts_with("whipple_bicycle/benchmark"))
    );
}

/// Every bundled model and choice (without free functions) derived in structured form: the
/// certificate holds, and the equations evaluated from its ingredients (derivatives taken on
/// the trees) equal those of the closed form's (derivatives taken canonically) at random states.
#[test]
fn the_structured_form_evaluates_as_the_closed_form() {
    let mut rng = ChaCha8Rng::seed_from_u64(23);
    let mut compared = 0;
    for model in models() {
        for choice in model.choices.iter().filter(|c| c.free_functions.is_empty()) {
            let name = format!("{}/{}", model.name, choice.name);
            let closed = derive(&model, Some(&choice.name)).unwrap();
            if closed.closed().is_none() {
                continue; // the bicycle: structured already
            }
            let structured =
                derive_with(&model, Some(&choice.name), FormRequest::Structured, false)
                    .unwrap_or_else(|e| panic!("{name}: {e}"));
            let Form::Structured(st) = &structured.form else {
                panic!("{name}: not structured");
            };
            assert!(st.certificate.smallest_pivot > 0.0, "{name}");
            let (c, s) = (closed.compile().unwrap(), structured.compile().unwrap());
            let params = closed.parameters.clone();
            for _ in 0..10 {
                let q: Vec<f64> = (0..closed.ell)
                    .map(|_| rng.random_range(-3.0..3.0))
                    .collect();
                let eta: Vec<f64> = (0..closed.sigma)
                    .map(|_| rng.random_range(-2.0..2.0))
                    .collect();
                let (Ok(a), Ok(b)) = (
                    c.rhs::<f64>(&q, &eta, &params),
                    s.rhs::<f64>(&q, &eta, &params),
                ) else {
                    continue;
                };
                assert!(rel_error(&a.eta_dot, &b.eta_dot) <= 1e-12, "{name}");
                assert!(rel_error(&a.q_dot, &b.q_dot) <= 1e-12, "{name}");
                compared += 1;
            }
        }
    }
    assert!(compared >= 100, "only {compared} states compared");
}

#[test]
fn the_papers_form_fails_for_the_chaplygin_sleigh_and_holds_for_the_knife() {
    let all = models();
    let sleigh = all.iter().find(|m| m.name == "chaplygin_sleigh").unwrap();
    let w = compare(sleigh, "paper_style", 7, STATES);
    assert!(w.symbolic_dd <= TOL);
    assert!(
        w.paper_dd > 1e-3,
        "the paper's form should be visibly wrong for the sleigh: {:.2e}",
        w.paper_dd
    );
    let knife = all.iter().find(|m| m.name == "knife").unwrap();
    let w = compare(knife, "paper", 8, STATES);
    assert!(
        w.symbolic_dd <= TOL && w.paper_dd <= TOL,
        "knife: {:.2e} / {:.2e}",
        w.symbolic_dd,
        w.paper_dd
    );
    assert!(
        derive(knife, Some("paper"))
            .unwrap()
            .closed()
            .unwrap()
            .checks
            .paper_is_exact
    );
    assert!(
        !derive(sleigh, Some("paper_style"))
            .unwrap()
            .closed()
            .unwrap()
            .checks
            .paper_is_exact
    );
}

#[test]
fn sleigh_equations_are_the_classical_ones() {
    // m v̇ = m a ω², (I + m a²) ω̇ = −m a v ω with v = η1, ω = η2.
    let all = models();
    let sleigh = all.iter().find(|m| m.name == "chaplygin_sleigh").unwrap();
    let d = derive(sleigh, Some("paper_style")).unwrap();
    let c = d.compile().unwrap();
    let p = d.parameters.clone();
    let (m, i, a) = (p["m"], p["I"], p["a"]);
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    for _ in 0..20 {
        let q: Vec<f64> = (0..3).map(|_| rng.random_range(-3.0..3.0)).collect();
        let eta = [rng.random_range(-2.0..2.0), rng.random_range(-2.0..2.0)];
        let ev = c.evaluate(&q, &eta, &p).unwrap();
        let (v, w) = (eta[0], eta[1]);
        assert!((ev.eta_dot[0] - a * w * w).abs() < 1e-12 * (1.0 + a * w * w));
        assert!((ev.eta_dot[1] + m * a * v * w / (i + m * a * a)).abs() < 1e-12);
    }
}

/// A model with generalised forces that no potential gives and named inputs
/// (tests/models/driven_knife.toml): the Boltzmann–Hamel equations, closed and structured,
/// against the Lagrange-multiplier oracle, which reads F from the file. Then with another
/// value of an input: the equations follow it (an input is a parameter of the derivation).
#[test]
fn forces_and_inputs_match_the_oracle() {
    let path = format!(
        "{}/tests/models/driven_knife.toml",
        env!("CARGO_MANIFEST_DIR")
    );
    let model = Model::load(&path).unwrap_or_else(|e| panic!("{e}"));
    assert!(model.has_forces());
    assert_eq!(model.inputs, ["thrust", "tau"]);
    let w = compare(&model, "paper", 7, STATES);
    assert!(!w.structured_form);
    assert!(w.structured_f64 <= TOL && w.symbolic_dd <= TOL && w.structured_dd <= 1e-20);
    let structured = hamel_derive::derive_with(
        &model,
        Some("paper"),
        hamel_derive::FormRequest::Structured,
        false,
    )
    .unwrap();
    assert!(structured.closed().is_none() && structured.forces.len() == 3);
    let closed = derive(&model, Some("paper")).unwrap();
    let (cs, cc) = (structured.compile().unwrap(), closed.compile().unwrap());
    let mut rng = ChaCha8Rng::seed_from_u64(11);
    for thrust in [0.7, -2.5] {
        let mut params = closed.parameters.clone();
        params["thrust"] = thrust;
        let nm =
            NumericModel::new(&model, &IndexMap::from([("thrust".to_string(), thrust)])).unwrap();
        for _ in 0..20 {
            let q: Vec<f64> = (0..3).map(|_| rng.random_range(-3.0..3.0)).collect();
            let eta: Vec<f64> = (0..2).map(|_| rng.random_range(-2.0..2.0)).collect();
            let (rs, rc) = (
                cs.rhs::<f64>(&q, &eta, &params).unwrap(),
                cc.rhs::<f64>(&q, &eta, &params).unwrap(),
            );
            assert!(rel_error(&rs.eta_dot, &rc.eta_dot) <= TOL);
            let oracle = hamel_oracle::accelerations::<f64>(&nm, &q, &rs.q_dot).unwrap();
            let mine = q_ddot(&cs, &q, &eta, &rs.eta_dot, &rs.q_dot, &params);
            assert!(rel_error(&mine, &oracle.q_ddot) <= TOL, "thrust {thrust}");
        }
    }
}

/// The bicycle's inputs (models/whipple_bicycle.toml: a steer torque between the fork and the
/// rear frame, a pedalling torque between the rear wheel and the rear frame, as loads on its
/// frames): with both nonzero, the structured equations against the oracle (which reads the
/// generalised forces hamel derived from the loads, T_steer along steer and −T_pedal along the
/// rear wheel), and the inputs change η̇.
#[test]
fn the_bicycles_steer_and_pedal_torques_match_the_oracle() {
    let path = format!("{}/models/whipple_bicycle.toml", env!("CARGO_MANIFEST_DIR"));
    let model = Model::load(&path).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(model.inputs, ["T_steer", "T_pedal"]);
    let d = derive(&model, Some("benchmark")).unwrap();
    let c = d.compile().unwrap();
    let inputs = IndexMap::from([("T_steer".to_string(), 1.3), ("T_pedal".to_string(), -0.7)]);
    let nm = NumericModel::new(&model, &inputs).unwrap();
    let mut params = d.parameters.clone();
    params.extend(inputs.clone());
    let mut rng = ChaCha8Rng::seed_from_u64(5);
    let mut checked = 0;
    while checked < 10 {
        let q: Vec<f64> = (0..d.ell).map(|_| rng.random_range(-0.5..0.5)).collect();
        let eta: Vec<f64> = (0..d.sigma).map(|_| rng.random_range(-2.0..2.0)).collect();
        if c.condition(&q, &params).unwrap() > F64_CONDITION {
            continue;
        }
        let r = c.rhs::<f64>(&q, &eta, &params).unwrap();
        let free = c.rhs::<f64>(&q, &eta, &d.parameters).unwrap();
        assert!(
            rel_error(&r.eta_dot, &free.eta_dot) > 1e-3,
            "the inputs change nothing"
        );
        let oracle = hamel_oracle::accelerations::<f64>(&nm, &q, &r.q_dot).unwrap();
        let mine = q_ddot(&c, &q, &eta, &r.eta_dot, &r.q_dot, &params);
        let e = rel_error(&mine, &oracle.q_ddot);
        assert!(e <= TOL, "bicycle with torques: {e:e}");
        checked += 1;
    }
}

/// The models of bodies under `models/bodies/` (the twins of hand-typed models, and the
/// rolling disc in SymPy's coordinates and speeds) against the oracle, every choice.
#[test]
fn the_models_of_bodies_match_the_lagrange_multiplier_oracle() {
    let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/models/bodies");
    let mut paths: Vec<_> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "toml"))
        .collect();
    paths.sort();
    assert!(paths.len() >= 4, "{paths:?}");
    for (mi, path) in paths.iter().enumerate() {
        let model = hamel_model::Model::load(path).unwrap_or_else(|e| panic!("{e}"));
        for (ci, choice) in model.choices.iter().enumerate() {
            let w = compare(
                &model,
                &choice.name,
                7000 + 10 * mi as u64 + ci as u64,
                STATES,
            );
            let line = format!(
                "{}/{}: structured f64 {:.1e} ({} of {} states), structured dd {:.1e}, symbolic dd {:.1e}",
                model.name,
                choice.name,
                w.structured_f64,
                w.f64_states,
                w.states,
                w.structured_dd,
                w.symbolic_dd
            );
            assert!(
                w.structured_f64 <= TOL && w.symbolic_dd <= TOL && w.structured_dd <= 1e-20,
                "{line}"
            );
            assert!(2 * w.f64_states >= w.states, "{line}");
            eprintln!("{line}");
        }
    }
}
