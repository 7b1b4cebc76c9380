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

use common::{models, rel_error};

use hamel_derive::{Compiled, Form, FormRequest, SymbolicCompiled, derive, derive_with};
use hamel_expr::{DD, Dual, Expr, Scalar, parse};
use hamel_model::{Model, NumericModel};
use indexmap::IndexMap;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

const STATES: usize = 50;
const TOL: f64 = 1e-10;
/// Largest condition number of [Z; α] admitted for a sample state (very near the singular set
/// the comparison measures rounding, not the equations; the stability study covers it).
const MAX_CONDITION: f64 = 1e6;

/// Largest cond[Z; α] at which the f64 evaluation is compared (double-double is compared up to
/// [`MAX_CONDITION`]). Beyond it hamel's f64 error grows like cond·ε through Γ: 1.8e-10 at
/// cond 1.6e4 for the bicycle with its front wheel turned 90° (docs/derivation.md §5).
const F64_CONDITION: f64 = 1e4;

/// Concrete test functions for free functions: smooth, nonconstant, different for each name so
/// that nothing cancels by accident.
fn test_function(name: &str, args: &[String]) -> Expr {
    let k = name.bytes().map(|b| b as u32).sum::<u32>() % 7 + 2;
    let terms: Vec<String> = args
        .iter()
        .enumerate()
        .map(|(j, a)| {
            format!(
                "{}/10*sin({a}) + {}/10*cos({a})",
                k + j as u32,
                (k * 3 + j as u32) % 5 + 1
            )
        })
        .collect();
    parse(&format!("{}/5 + {}", k, terms.join(" + ")))
        .unwrap()
        .expr
}

fn test_functions(model: &Model, choice: &str) -> Vec<(String, Vec<String>, Expr)> {
    model
        .choice(Some(choice))
        .unwrap()
        .free_functions
        .iter()
        .map(|(n, a)| (n.clone(), a.clone(), test_function(n, a)))
        .collect()
}

fn with_test_functions(model: &Model, choice: &str) -> Model {
    let defs: Vec<(String, Expr)> = test_functions(model, choice)
        .into_iter()
        .map(|(n, _, e)| (n, e))
        .collect();
    model.with_free_functions(choice, &defs).unwrap()
}

/// Values at q of the inputs a symbolic tape asks for: free functions and first derivatives.
fn free_values(model: &Model, choice: &str, names: &[String], q: &[DD]) -> Vec<DD> {
    let mut known: IndexMap<String, DD> = IndexMap::new();
    for (name, args, body) in test_functions(model, choice) {
        for dir in 0..=args.len() {
            let mut orders = vec![0u32; args.len()];
            if dir > 0 {
                orders[dir - 1] = 1;
            }
            let env = |n: &str| {
                let i = model.coordinates.iter().position(|c| c == n)?;
                let d = if dir > 0 && args[dir - 1] == n {
                    1.0
                } else {
                    0.0
                };
                Some(Dual::new(q[i], DD::from_f64(d)))
            };
            let v: Dual<DD> = body.eval(&env).unwrap();
            let key = Expr::Free {
                name: name.clone(),
                args: args.clone(),
                orders,
            }
            .to_string();
            known.insert(key, if dir == 0 { v.v } else { v.d });
        }
    }
    names
        .iter()
        .map(|n| {
            *known
                .get(n)
                .unwrap_or_else(|| panic!("no test value for `{n}`"))
        })
        .collect()
}

/// q̈ = Γ̇η + Γη̇ for a given η̇, with Γ and Γ̇ (dual numbers along q̇ = Γη) from the structured
/// evaluation.
fn q_ddot<S: Scalar + Copy>(
    c: &Compiled,
    q: &[S],
    eta: &[S],
    eta_dot: &[S],
    q_dot: &[S],
    params: &IndexMap<String, f64>,
) -> Vec<S> {
    let qdual: Vec<Dual<S>> = q
        .iter()
        .zip(q_dot)
        .map(|(&v, &dv)| Dual::new(v, dv))
        .collect();
    let gamma = c.gamma::<Dual<S>>(&qdual, params).unwrap();
    (0..q.len())
        .map(|k| {
            (0..eta.len()).fold(S::constant(0.0), |acc, s| {
                acc + gamma[k][s].d * eta[s] + gamma[k][s].v * eta_dot[s]
            })
        })
        .collect()
}

fn dd(v: &[f64]) -> Vec<DD> {
    v.iter().map(|&x| DD::from_f64(x)).collect()
}

#[derive(Default)]
struct Worst {
    /// The derivation was structured (no expanded symbolic forms to compare).
    structured_form: bool,
    structured_f64: f64,
    structured_dd: f64,
    symbolic_dd: f64,
    paper_dd: f64,
    states: usize,
}

/// Compare hamel with the oracle at random admissible states.
fn compare(model: &Model, choice: &str, seed: u64) -> Worst {
    let concrete = with_test_functions(model, choice);
    let d =
        derive(&concrete, Some(choice)).unwrap_or_else(|e| panic!("{}/{choice}: {e}", model.name));
    if let Some(closed) = d.closed() {
        assert!(
            closed.checks.split_identity,
            "{}/{choice}: Q ≠ Q_paper + Q_correction",
            model.name
        );
        assert!(
            closed.checks.energy_conserved,
            "{}/{choice}: energy not conserved",
            model.name
        );
    }
    let c = d.compile().unwrap();
    // The symbolic equations as derived for the choice as written (free functions symbolic);
    // none for a structured derivation, which has only the ingredients.
    let sym: Option<SymbolicCompiled> = d.closed().map(|_| {
        derive(model, Some(choice))
            .unwrap()
            .compile_symbolic()
            .unwrap()
    });
    let nm = NumericModel::new(&concrete, &IndexMap::new()).unwrap();
    let params = d.parameters.clone();
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut w = Worst {
        structured_form: d.closed().is_none(),
        ..Worst::default()
    };
    let mut attempts = 0;
    while w.states < STATES {
        attempts += 1;
        assert!(
            attempts < 20 * STATES,
            "{}/{choice}: too many singular samples",
            model.name
        );
        let q: Vec<f64> = (0..d.ell).map(|_| rng.random_range(-3.0..3.0)).collect();
        let v: Vec<f64> = (0..d.ell).map(|_| rng.random_range(-2.0..2.0)).collect();
        if c.condition(&q, &params).unwrap() > MAX_CONDITION {
            continue;
        }
        let qd = hamel_oracle::project(&nm, &q, &v).unwrap();
        // η = Z q̇ from the model's own expressions (no derivation involved).
        let z = nm.quasi_velocity_matrix::<f64>(choice, &q).unwrap();
        let eta: Vec<f64> = z
            .iter()
            .map(|row| row.iter().zip(&qd).map(|(a, b)| a * b).sum())
            .collect();

        // Structured, f64.
        let oracle = hamel_oracle::accelerations::<f64>(&nm, &q, &qd).unwrap();
        let r = c.rhs::<f64>(&q, &eta, &params).unwrap();
        assert!(
            rel_error(&r.q_dot, &qd) <= TOL,
            "{}/{choice}: q̇ = Γη differs",
            model.name
        );
        let mine = q_ddot(&c, &q, &eta, &r.eta_dot, &r.q_dot, &params);
        if c.condition(&q, &params).unwrap() <= F64_CONDITION {
            w.structured_f64 = w.structured_f64.max(rel_error(&mine, &oracle.q_ddot));
        }

        // Structured and symbolic, double-double.
        // The state in double-double: q̇ = Γη computed in double-double lies on the constraint
        // manifold to that precision, and is what the oracle is given.
        let (qx, etax) = (dd(&q), dd(&eta));
        let r = c.rhs::<DD>(&qx, &etax, &params).unwrap();
        let oracle = hamel_oracle::accelerations::<DD>(&nm, &qx, &r.q_dot).unwrap();
        w.structured_dd = w.structured_dd.max(rel_error(
            &q_ddot(&c, &qx, &etax, &r.eta_dot, &r.q_dot, &params),
            &oracle.q_ddot,
        ));
        if let Some(sym) = &sym {
            let free = free_values(model, choice, sym.free_inputs(), &qx);
            let (sym_dot, paper_dot) = sym.eta_dot::<DD>(&qx, &etax, &params, &free).unwrap();
            w.symbolic_dd = w.symbolic_dd.max(rel_error(
                &q_ddot(&c, &qx, &etax, &sym_dot, &r.q_dot, &params),
                &oracle.q_ddot,
            ));
            w.paper_dd = w.paper_dd.max(rel_error(
                &q_ddot(&c, &qx, &etax, &paper_dot, &r.q_dot, &params),
                &oracle.q_ddot,
            ));
            // The structured paper's form agrees with the symbolic paper's form.
            assert!(
                rel_error(&r.eta_dot_paper, &paper_dot) <= TOL,
                "{}/{choice}: paper's forms differ",
                model.name
            );
        }
        w.states += 1;
    }
    w
}

#[test]
fn every_model_and_choice_matches_the_lagrange_multiplier_oracle() {
    let mut report = Vec::new();
    for (mi, model) in models().iter().enumerate() {
        for (ci, choice) in model.choices.iter().enumerate() {
            let w = compare(model, &choice.name, 1000 * mi as u64 + ci as u64);
            let symbolic = if w.structured_form {
                "symbolic: none (structured form)".to_string()
            } else {
                format!(
                    "symbolic dd {:.1e} (paper's form {:.1e})",
                    w.symbolic_dd, w.paper_dd
                )
            };
            report.push(format!(
                "{}/{}: {} states; max rel. error: structured f64 {:.1e}, structured dd {:.1e}, {symbolic}",
                model.name, choice.name, w.states, w.structured_f64, w.structured_dd
            ));
            let line = report.last().unwrap();
            assert!(
                w.structured_f64 <= TOL && w.symbolic_dd <= TOL && w.structured_dd <= 1e-20,
                "{line}"
            );
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
    let w = compare(sleigh, "paper_style", 7);
    assert!(w.symbolic_dd <= TOL);
    assert!(
        w.paper_dd > 1e-3,
        "the paper's form should be visibly wrong for the sleigh: {:.2e}",
        w.paper_dd
    );
    let knife = all.iter().find(|m| m.name == "knife").unwrap();
    let w = compare(knife, "paper", 8);
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
    let w = compare(&model, "paper", 7);
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
