//! `hamel reduce`: each hypothesis where it holds and where it fails (with its witness), the
//! ground truth against the paper's claims, and the reduced system checked numerically
//! against the full true equations.
//!
//! The CAS runs in-process on its one worker thread (`hamel_reduce::reduce` sends it a job).

use hamel_derive::derive;
use hamel_expr::{DD, Env, Expr};
use hamel_model::Model;
use hamel_reduce::hypotheses::{H0, H1, H2, H3, H4, H5, H6, Id};
use hamel_reduce::{PropertyId, Reduction, reduce};
use indexmap::IndexMap;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

fn bundled(name: &str) -> Model {
    Model::load(format!("{}/models/{name}.toml", env!("CARGO_MANIFEST_DIR")))
        .unwrap_or_else(|e| panic!("{e}"))
}

fn inline(name: &str, text: &str) -> Model {
    Model::from_source(&format!("{name}.toml"), text).unwrap_or_else(|e| panic!("{e}"))
}

fn run(model: &Model, eta: &str, eliminate: &str) -> Reduction {
    let names: Vec<String> = eliminate.split(',').map(str::to_string).collect();
    reduce(model, Some(eta), &names).unwrap_or_else(|e| panic!("{e}"))
}

fn holds(r: &Reduction, h: Id) -> bool {
    r.hypotheses[&h].holds
}

/// The witness of a failed hypothesis: (object, coordinate).
fn witness(r: &Reduction, h: Id) -> (String, Option<String>, String) {
    let w = r.hypotheses[&h]
        .witness
        .as_ref()
        .unwrap_or_else(|| panic!("{h} has no witness"));
    (w.object.clone(), w.coordinate.clone(), w.expression.clone())
}

/// A knife edge whose first quasi-velocity is der(x) + der(y): b₁₁ of (22) = m/(sin θ + cos θ)²
/// contains θ.
const KNIFE_CARTESIAN: &str = r#"
name = "knife_cartesian"
title = "test model"
coordinates = ["x", "y", "theta"]
[parameters]
m = 1.0
J = 0.1
[lagrangian]
kinetic = "m/2*(der(x)^2 + der(y)^2) + J/2*der(theta)^2"
[constraints]
no_slip = "sin(theta)*der(x) - cos(theta)*der(y)"
[quasi_velocities.cartesian]
eta = ["der(x) + der(y)", "der(theta)"]
"#;

/// A knife edge whose moment of inertia about the contact point grows with x: A⁽²'²⁾ = J + m x².
const KNIFE_GROWING: &str = r#"
name = "knife_growing"
title = "test model"
coordinates = ["x", "y", "theta"]
[parameters]
m = 1.0
J = 0.1
[lagrangian]
kinetic = "m/2*(der(x)^2 + der(y)^2) + (J + m*x^2)/2*der(theta)^2"
[constraints]
no_slip = "sin(theta)*der(x) - cos(theta)*der(y)"
[quasi_velocities.paper]
eta = ["cos(theta)*der(x) + sin(theta)*der(y)", "der(theta)"]
"#;

/// The Chaplygin sleigh with the Cartesian velocity of the contact point as η₁: the correction
/// term of the true equations contains θ.
const SLEIGH_CARTESIAN: &str = r#"
name = "sleigh_cartesian"
title = "test model"
coordinates = ["x", "y", "theta"]
[parameters]
m = 2.0
I = 0.05
a = 0.2
[lagrangian]
kinetic = "m/2*((der(x) - a*sin(theta)*der(theta))^2 + (der(y) + a*cos(theta)*der(theta))^2) + I/2*der(theta)^2"
[constraints]
no_slip = "sin(theta)*der(x) - cos(theta)*der(y)"
[quasi_velocities.cartesian]
eta = ["der(x)", "der(theta)"]
"#;

#[test]
fn the_knife_meets_every_hypothesis_and_loses_every_coordinate() {
    let r = run(&bundled("knife"), "paper", "x,y,theta");
    for h in Id::ALL {
        assert!(holds(&r, h), "{h}: {:?}", r.hypotheses[&h].witness);
        assert!(r.hypotheses[&h].witness.is_none());
    }
    assert_eq!(r.proposition_2_1, Some(true));
    assert_eq!(r.ground_truth.absent, ["x", "y", "theta"]);
    assert!(r.ground_truth.present.is_empty());
    assert_eq!(r.structure.as_ref().unwrap().v, 1);
    assert_eq!(r.structure.as_ref().unwrap().block2, ["theta"]);
    let kinds: Vec<_> = r
        .classification
        .iter()
        .map(|c| format!("{:?}", c.kind))
        .collect();
    assert_eq!(kinds, ["A", "A", "B"]);
    let reduced = r.reduced_system.as_ref().expect("reduced system");
    assert_eq!(reduced.state, ["eta1", "eta2"]);
    assert_eq!(reduced.reconstruction.len(), 3);
}

#[test]
fn h0_fails_for_the_vertical_knife_on_theta_and_for_remark_2_2() {
    // Gravity along y: Γᵀ∇U = (−m g sin θ, 0) contains θ (Remark 3.1) but not y.
    let vk = bundled("vertical_knife");
    let r = run(&vk, "paper", "x,y");
    assert!(holds(&r, H0));
    assert_eq!(r.ground_truth.absent, ["x", "y"]);
    let r = run(&vk, "paper", "x,y,theta");
    assert!(!holds(&r, H0));
    let (object, coordinate, expression) = witness(&r, H0);
    assert_eq!(object, "Gamma^T grad U");
    assert_eq!(coordinate.as_deref(), Some("theta"));
    assert!(expression.contains("sin(theta)"), "{expression}");
    assert_eq!(r.ground_truth.present, ["theta"]);
    assert!(r.reduced_system.is_none());

    // (33): the kept coordinate q2 has a row of Γ containing q1.
    let r = run(&bundled("remark22"), "paper", "q1");
    assert!(!holds(&r, H0));
    let (object, coordinate, _) = witness(&r, H0);
    assert_eq!(object, "Gamma");
    assert_eq!(coordinate.as_deref(), Some("q1"));
}

#[test]
fn h1_holds_for_the_momenta_and_fails_for_the_velocities_of_the_rolling_disk() {
    let disk = bundled("rolling_disk");
    let r = run(&disk, "momenta", "xC,yC,phi,psi");
    assert!(holds(&r, H1));
    assert!(r.properties[&PropertyId::P2_1].holds);
    let r = run(&disk, "velocities", "xC,yC,phi,psi");
    assert!(!holds(&r, H1));
    let (object, coordinate, _) = witness(&r, H1);
    assert_eq!(object, "alpha2");
    assert_eq!(coordinate, None);
    // Property 2.1: Γ₂ ≠ 0 exactly when (Z₂; α₂) ≠ 0.
    assert!(!r.properties[&PropertyId::P2_1].holds);
    // The hypotheses are only sufficient: φ drops out all the same.
    assert_eq!(r.ground_truth.absent, ["xC", "yC", "phi", "psi"]);
    assert!(
        r.findings
            .iter()
            .any(|f| f.starts_with("eliminated although H1"))
    );
}

#[test]
fn h2_fails_for_the_bar_with_a_blade_where_sin_phi_is_not_zero() {
    // The paper says (H2) holds for φ ≠ π/2; with the blade's inertia it holds only where
    // sin φ = 0. The witness is the entry of Γ₁ᵀA⁽¹'²⁾ (Property 2.2).
    let r = run(&bundled("bar_blade"), "paper", "x,y,theta");
    assert!(!holds(&r, H2));
    let (object, _, expression) = witness(&r, H2);
    assert_eq!(object, "Gamma1^T A12");
    assert!(expression.contains("sin(phi)"), "{expression}");
    assert!(!r.properties[&PropertyId::P2_2].holds);
    assert_eq!(r.proposition_2_1, Some(false));
    assert_eq!(r.ground_truth.absent, ["x", "y", "theta"]);
    assert!(
        r.findings
            .iter()
            .any(|f| f.starts_with("eliminated although H2"))
    );
    // Where it holds: the knife (no block-2 coupling in A).
    assert!(holds(&run(&bundled("knife"), "paper", "theta"), H2));
}

#[test]
fn h3_fails_when_the_first_quasi_velocity_is_not_the_forward_speed() {
    let r = run(
        &inline("knife_cartesian", KNIFE_CARTESIAN),
        "cartesian",
        "theta",
    );
    assert!(!holds(&r, H3));
    let (object, coordinate, expression) = witness(&r, H3);
    assert_eq!(object, "b");
    assert_eq!(coordinate.as_deref(), Some("theta"));
    assert!(expression.contains("cos(theta)"), "{expression}");
    assert_eq!(r.ground_truth.present, ["theta"]);
    assert!(holds(&run(&bundled("knife"), "paper", "theta"), H3));
}

#[test]
fn h4_fails_when_the_block_2_inertia_contains_the_coordinate() {
    let r = run(&inline("knife_growing", KNIFE_GROWING), "paper", "x");
    assert!(!holds(&r, H4));
    let (object, coordinate, expression) = witness(&r, H4);
    assert_eq!(object, "A22");
    assert_eq!(coordinate.as_deref(), Some("x"));
    assert!(expression.contains("x^2"), "{expression}");
    assert_eq!(r.ground_truth.present, ["x"]);
    assert!(holds(&run(&bundled("knife"), "paper", "x"), H4));
}

#[test]
fn h5_fails_for_remark_2_2_where_a_gamma_is_free_of_q1_and_the_equations_are_not() {
    let r = run(&bundled("remark22"), "paper", "q1");
    assert!(!holds(&r, H5));
    let (object, coordinate, _) = witness(&r, H5);
    assert!(object.starts_with("(35)"), "{object}");
    assert_eq!(coordinate.as_deref(), Some("q1"));
    assert_eq!(r.ground_truth.present, ["q1"]);
    // The first occurrence is in a Q coefficient: A_Γ itself is free of q1 (Remark 2.2).
    let w = &r.ground_truth.occurrences[0];
    assert!(w.object.starts_with("Q("), "{}", w.object);
    assert!(holds(&run(&bundled("knife"), "paper", "theta"), H5));
}

#[test]
fn h6_fails_for_the_sleigh_with_a_cartesian_quasi_velocity() {
    let r = run(
        &inline("sleigh_cartesian", SLEIGH_CARTESIAN),
        "cartesian",
        "theta",
    );
    assert!(!holds(&r, H6));
    let (object, coordinate, _) = witness(&r, H6);
    assert!(object.starts_with("Q_correction("), "{object}");
    assert_eq!(coordinate.as_deref(), Some("theta"));
    // With η₁ the forward speed the correction is free of θ.
    let r = run(&bundled("chaplygin_sleigh"), "paper_style", "x,y,theta");
    assert!(holds(&r, H6));
    assert_eq!(r.ground_truth.absent, ["x", "y", "theta"]);
}

/// The names a reduced equation may use: parameters, the needed coordinates, η, η̇.
struct ReducedEnv<'a> {
    values: &'a IndexMap<String, DD>,
}

impl Env<DD> for ReducedEnv<'_> {
    fn symbol(&self, name: &str) -> Option<DD> {
        self.values.get(name).copied()
    }
}

/// η̇ from the reduced equations (linear in η̇: M η̇ + c = 0), in double-double; coordinates
/// outside the reduced state are unbound, so an equation that needs one fails to evaluate.
fn reduced_eta_dot(equations: &[Expr], values: &IndexMap<String, DD>) -> Vec<DD> {
    let sigma = equations.len();
    let eval = |dot: &[DD]| -> Vec<DD> {
        let mut v = values.clone();
        for (i, d) in dot.iter().enumerate() {
            v.insert(format!("eta{}_dot", i + 1), *d);
        }
        let env = ReducedEnv { values: &v };
        equations
            .iter()
            .map(|e| e.eval(&env).unwrap_or_else(|err| panic!("{err}")))
            .collect()
    };
    let zero = vec![DD::from_f64(0.0); sigma];
    let c = eval(&zero);
    let mut m = vec![vec![DD::from_f64(0.0); sigma]; sigma];
    for j in 0..sigma {
        let mut e = zero.clone();
        e[j] = DD::from_f64(1.0);
        let col = eval(&e);
        for i in 0..sigma {
            m[i][j] = col[i] - c[i];
        }
    }
    let rhs: Vec<DD> = c.iter().map(|x| -*x).collect();
    hamel_expr::solve(m, rhs).expect("A_Γ is invertible")
}

#[test]
fn reduced_systems_agree_with_the_full_true_equations() {
    let cases = [
        ("knife", "paper", "x,y,theta"),
        ("vertical_knife", "paper", "x,y"),
        ("chaplygin_sleigh", "paper_style", "x,y,theta"),
        ("bar_blade", "paper", "x,y,theta"),
        ("bar_wheels", "paper", "x,y,theta,psi1"),
        ("rolling_disk", "momenta", "xC,yC,phi,psi"),
        ("rolling_disk", "velocities", "xC,yC,phi,psi"),
        ("unicycle_rider", "velocities", "xC,yC,phi,psi"),
        ("unicycle_rider", "momenta", "xC,yC,phi,psi"),
    ];
    let mut rng = ChaCha8Rng::seed_from_u64(22);
    for (name, eta, eliminate) in cases {
        let model = bundled(name);
        let r = run(&model, eta, eliminate);
        let reduced = r
            .reduced_system
            .as_ref()
            .unwrap_or_else(|| panic!("{name}/{eta}: no reduced system: {:?}", r.findings));
        let compiled = derive(&model, Some(eta)).unwrap().compile().unwrap();
        let equations: Vec<Expr> = reduced.equations.iter().map(|e| e.expr.clone()).collect();
        let params = model.parameters.clone();
        let mut worst = 0.0f64;
        let mut states = 0;
        while states < 20 {
            let q: Vec<f64> = (0..model.ell())
                .map(|_| rng.random_range(-1.5..1.5))
                .collect();
            let eta_v: Vec<f64> = (0..model.sigma())
                .map(|_| rng.random_range(-2.0..2.0))
                .collect();
            let Ok(full) = compiled.evaluate(&q, &eta_v, &params) else {
                continue;
            };
            if full.condition > 1e6 {
                continue;
            }
            states += 1;
            let mut values: IndexMap<String, DD> = params
                .iter()
                .map(|(k, v)| (k.clone(), DD::from_f64(*v)))
                .collect();
            for (i, e) in eta_v.iter().enumerate() {
                values.insert(format!("eta{}", i + 1), DD::from_f64(*e));
            }
            for k in &reduced.kinematics {
                let i = model
                    .coordinates
                    .iter()
                    .position(|c| c == &k.coordinate)
                    .unwrap();
                values.insert(k.coordinate.clone(), DD::from_f64(q[i]));
            }
            let dot = reduced_eta_dot(&equations, &values);
            let scale = full.eta_dot.iter().fold(1.0f64, |m, x| m.max(x.abs()));
            for (a, b) in dot.iter().zip(&full.eta_dot) {
                worst = worst.max((a.to_f64() - b).abs() / scale);
            }
            // The kept kinematic equations give the same rates as the full ones.
            let env = ReducedEnv { values: &values };
            for k in &reduced.kinematics {
                let i = model
                    .coordinates
                    .iter()
                    .position(|c| c == &k.coordinate)
                    .unwrap();
                let rate = k.rate.expr.eval(&env).unwrap_or_else(|e| panic!("{e}"));
                worst = worst.max((rate.to_f64() - full.q_dot[i]).abs() / scale);
            }
        }
        assert!(
            worst < 1e-10,
            "{name}/{eta}: reduced vs full η̇ differ by {worst:e}"
        );
    }
}

/// A bundled model's text without its `[quasi_velocities]`: L and α alone.
fn stripped_text(name: &str) -> String {
    let path = format!("{}/models/{name}.toml", env!("CARGO_MANIFEST_DIR"));
    let mut table: toml::Table = std::fs::read_to_string(path).unwrap().parse().unwrap();
    table.remove("quasi_velocities");
    toml::to_string(&table).unwrap()
}

/// [`stripped_text`] as a model: hamel adds its default choice.
fn stripped(name: &str) -> Model {
    inline(name, &stripped_text(name))
}

/// Search a bundled model stripped of its quasi-velocities: the search starts from L and α.
fn search(model: &str, eliminate: &str) -> hamel_reduce::SearchReport {
    search_in(&stripped(model), eliminate)
}

fn search_in(model: &Model, eliminate: &str) -> hamel_reduce::SearchReport {
    let names: Vec<String> = eliminate.split(',').map(str::to_string).collect();
    let options = hamel_reduce::SearchOptions {
        budget: std::time::Duration::from_secs(60),
        max_candidates: 12,
    };
    hamel_reduce::search(model, &names, options, Box::new(|_| {})).unwrap_or_else(|e| panic!("{e}"))
}

#[test]
fn a_model_is_l_and_alpha_its_default_choice_derives_and_search_candidates_paste_back() {
    let eliminate: std::collections::HashMap<&str, &str> = [
        ("bar_blade", "x,y,theta"),
        ("bar_wheels", "x,y,theta,psi1"),
        ("chaplygin_sleigh", "x,y,theta"),
        ("diff_drive", "x,y,psi,phiL,phiR,phiC"),
        ("knife", "x,y,theta"),
        ("rolling_disk", "xC,yC,phi"),
        ("segway", "x,y,psi,phiL,phiR"),
        ("unicycle_rider", "xC,yC,phi,psi"),
        ("vertical_knife", "x,y"),
        ("snakeboard", "x,y,theta"),
        ("sprung_sleigh", "x,y,psi"),
        ("whipple_bicycle", "x,y,yaw,rear_wheel,front_wheel"),
    ]
    .into();
    for model in bundled_names() {
        let m = stripped(&model);
        // The default: σ independent velocities, named and described.
        let choice = m.choice(None).unwrap();
        assert_eq!(choice.origin, hamel_model::ChoiceOrigin::Independent);
        assert_eq!(choice.eta.len(), m.sigma());
        assert!(
            m.default_choice_note(choice)
                .unwrap()
                .contains("eta = [\"der(")
        );
        let d = derive(&m, None).unwrap_or_else(|e| panic!("{model}: {e}"));
        // The bicycle derives in structured form: no closed-form checks to read.
        if let Some(closed) = d.closed() {
            // With forces (the robots' motor torques) dE/dt is their power, exactly.
            let balance = closed.checks.energy_balance;
            assert!(
                closed.checks.split_identity && balance.unwrap_or(closed.checks.energy_conserved),
                "{model}"
            );
        }
        // The first candidate of the search, pasted back, is confirmed by `reduce` (Remark 2.2
        // is the paper's example where nothing is eliminated).
        let Some(eliminate) = eliminate.get(model.as_str()) else {
            assert_eq!(model, "remark22");
            continue;
        };
        let r = search_in(&m, eliminate);
        let first = r
            .candidates
            .first()
            .unwrap_or_else(|| panic!("{model}: no candidate"));
        let pasted = inline(
            &model,
            &format!("{}\n{}", stripped_text(&model), first.toml),
        );
        assert_eq!(pasted.choice(None).unwrap().name, first.name);
        let red = run(&pasted, &first.name, eliminate);
        assert!(
            red.ground_truth.present.is_empty()
                && red.ground_truth.undecided.is_empty()
                && red.ground_truth.kinematics_closed,
            "{model}: {:?}",
            red.ground_truth.present
        );
    }
}

fn bundled_names() -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(format!("{}/models", env!("CARGO_MANIFEST_DIR")))
        .unwrap()
        .filter_map(|e| {
            let p = e.unwrap().path();
            (p.extension()? == "toml").then(|| p.file_stem().unwrap().to_string_lossy().into())
        })
        .collect();
    v.sort();
    v
}

#[test]
fn search_rediscovers_the_papers_choices() {
    // 3.1: z11 = cos θ, z12 = sin θ.
    let r = search("knife", "x,y,theta");
    assert!(r.candidates.iter().any(|c| {
        c.eta
            .contains(&"cos(theta)*der(x) + sin(theta)*der(y)".to_string())
    }));
    // 3.2 and 3.3: θ removed (on the true equations: every candidate is decided on them).
    for (m, p) in [("bar_blade", "x,y,theta"), ("bar_wheels", "x,y,theta,psi1")] {
        let r = search(m, p);
        assert!(r.candidates.iter().any(|c| {
            c.eta
                .contains(&"cos(theta)*der(x) + sin(theta)*der(y)".to_string())
        }));
    }
    // 3.4: the family (39)–(40), whose basis contains the rolling direction, φ̇ and ψ̇, so that
    // the conjugate momenta of Remark 3.2 are members.
    let r = search("unicycle_rider", "xC,yC,phi,psi");
    let family = r
        .candidates
        .iter()
        .find(|c| c.family == "functions")
        .expect("a family with unknown functions");
    assert_eq!(family.free_functions.len(), 6);
    for part in [
        "der(phi)",
        "der(psi)",
        "cos(phi)*der(xC) + sin(phi)*der(yC)",
    ] {
        assert!(family.eta[0].contains(part), "{}", family.eta[0]);
    }
    assert_eq!(family.reduced_state.len(), 6);
    // Remark 3.1: y is removed, θ is not within the basis.
    assert!(!search("vertical_knife", "x,y").candidates.is_empty());
    let r = search("vertical_knife", "x,y,theta");
    assert!(r.candidates.is_empty());
    assert!(r.none_found.as_deref().unwrap().contains("theta"));
    // Remark 2.2: A_Γ is free of q1 while the equations are not (the explanation is given
    // under the model's first choice: the paper's).
    assert!(search("remark22", "q1").candidates.is_empty());
    let r = search_in(&bundled("remark22"), "q1");
    assert!(r.candidates.is_empty());
    let why = r.none_found.unwrap();
    assert!(why.contains("A_Γ and Γᵀ∇U are free of it"), "{why}");
}

#[test]
fn family_a_solves_its_conditions_on_the_unknown_functions() {
    // 3.2: the ansatz z11(φ)·θ̇ + z12(φ)·(cos θ ẋ + sin θ ẏ) + z13(φ)·ẋ does not remove θ; the
    // conditions (coefficients of the θ-dependence of the true equations) have the factor
    // z13(φ), solved by z13 = 0, which leaves the paper's family with z13(φ) (here z11, z12).
    let r = search("bar_blade", "x,y,theta");
    assert!(
        r.families["functions"].exact_checks >= 2,
        "{:?}",
        r.families["functions"]
    );
    let family = r
        .candidates
        .iter()
        .find(|c| c.family == "functions")
        .expect("a solved family");
    assert_eq!(family.free_functions, vec!["z11(phi)", "z12(phi)"]);
    assert!(!family.eta[0].contains("z13"), "{}", family.eta[0]);
    assert!(
        family.eta[0].contains("cos(theta)*der(x) + sin(theta)*der(y)"),
        "{}",
        family.eta[0]
    );
}

#[test]
fn reduced_systems_of_search_candidates_agree_with_the_full_equations() {
    let mut rng = ChaCha8Rng::seed_from_u64(23);
    let mut checked = 0;
    for (name, eliminate) in [
        ("knife", "x,y,theta"),
        ("chaplygin_sleigh", "x,y,theta"),
        ("bar_blade", "x,y,theta"),
        ("rolling_disk", "xC,yC,phi,psi"),
        ("unicycle_rider", "xC,yC,phi,psi"),
    ] {
        let base = bundled(name);
        for c in search(name, eliminate).candidates {
            if !c.free_functions.is_empty() {
                continue;
            }
            let text = format!("{}\n{}", base.source, c.toml);
            let model = inline(name, &text);
            let r = run(&model, &c.name, eliminate);
            let reduced = r.reduced_system.expect("a reducing candidate reduces");
            let compiled = derive(&model, Some(&c.name)).unwrap().compile().unwrap();
            let equations: Vec<Expr> = reduced.equations.iter().map(|e| e.expr.clone()).collect();
            let mut states = 0;
            let mut tries = 0;
            while states < 5 && tries < 200 {
                tries += 1;
                let q: Vec<f64> = (0..model.ell())
                    .map(|_| rng.random_range(-1.5..1.5))
                    .collect();
                let eta: Vec<f64> = (0..model.sigma())
                    .map(|_| rng.random_range(-2.0..2.0))
                    .collect();
                let Ok(full) = compiled.evaluate(&q, &eta, &model.parameters) else {
                    continue;
                };
                if full.condition > 1e6 {
                    continue;
                }
                states += 1;
                let mut values: IndexMap<String, DD> = model
                    .parameters
                    .iter()
                    .map(|(k, v)| (k.clone(), DD::from_f64(*v)))
                    .collect();
                for (i, e) in eta.iter().enumerate() {
                    values.insert(format!("eta{}", i + 1), DD::from_f64(*e));
                }
                for k in &reduced.kinematics {
                    let i = model
                        .coordinates
                        .iter()
                        .position(|x| x == &k.coordinate)
                        .unwrap();
                    values.insert(k.coordinate.clone(), DD::from_f64(q[i]));
                }
                let dot = reduced_eta_dot(&equations, &values);
                let scale = full.eta_dot.iter().fold(1.0f64, |m, x| m.max(x.abs()));
                for (a, b) in dot.iter().zip(&full.eta_dot) {
                    let d = (a.to_f64() - b).abs() / scale;
                    assert!(d < 1e-9, "{name}/{}: {d:e}", c.name);
                }
            }
            assert!(states > 0, "{name}/{}: no regular state", c.name);
            checked += 1;
        }
    }
    assert!(checked >= 10, "only {checked} candidates checked");
}
