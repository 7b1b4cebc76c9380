//! The generated numeric cores (`crates/hamel-models`, i.e. `generated/*`) against hamel's
//! structured evaluator and against the Lagrange-multiplier oracle, at random admissible
//! states: full right-hand side, reduced right-hand side, reconstruction, Jacobian, constraint
//! residual. The CAS runs in-process (for the structured evaluator's derivation) on its one
//! worker thread.

mod common;

use common::rel_error;

use hamel_derive::conditioning::{STATED_MULTIPLE, problem_condition};
use hamel_model::NumericModel;
use hamel_models::MODELS;
use hamel_models::runtime::DualN as Dual;
use hamel_models::runtime::EvalError;
use indexmap::IndexMap;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// Generated code against the structured evaluator (same algorithm, same precision).
const TOL_SAME: f64 = 1e-12;
/// Against the oracle in f64 (as tests/oracle.rs).
const TOL_ORACLE: f64 = 1e-10;
/// States where [Z; α] is worse conditioned are skipped: this test compares two evaluations of
/// the same equations, whose difference grows with the conditioning; digits lost to the
/// conditioning itself are tests/stability.rs's subject.
const MAX_CONDITION: f64 = 1e4;

#[test]
fn generated_cores_match_the_structured_evaluator_and_the_oracle() {
    let models = common::models();
    let mut rng = ChaCha8Rng::seed_from_u64(44);
    for core in MODELS {
        let model = &*common::model_of_core(&models, core.model, core.scene);
        let d = hamel_derive::derive(model, Some(core.eta)).unwrap();
        let c = d.compile().unwrap();
        let params: IndexMap<String, f64> = d.parameters.clone();
        let nm = NumericModel::new(model, &IndexMap::new()).unwrap();
        let (ell, sigma) = (core.dims.ell, core.dims.sigma);
        let (mut worst_same, mut worst_oracle, mut worst_reduced, mut worst_jac) =
            (0.0_f64, 0.0_f64, 0.0_f64, 0.0_f64);
        let mut states = 0;
        while states < 30 {
            let q: Vec<f64> = (0..ell).map(|_| rng.random_range(-3.0..3.0)).collect();
            let v: Vec<f64> = (0..ell).map(|_| rng.random_range(-2.0..2.0)).collect();
            if c.condition(&q, &params).unwrap() > MAX_CONDITION {
                continue;
            }
            let qd = hamel_oracle::project(&nm, &q, &v).unwrap();
            let z = nm.quasi_velocity_matrix::<f64>(core.eta, &q).unwrap();
            let eta: Vec<f64> = z
                .iter()
                .map(|row| row.iter().zip(&qd).map(|(a, b)| a * b).sum())
                .collect();
            states += 1;
            // Two f64 evaluations of the same equations differ by rounding, which the problem's
            // conditioning κ and the evaluation's own cancellations amplify: tolerances are
            // max(TOL, 32 (κ + 1) ε, 32 × the f64 error estimate of the structured evaluation)
            // (issue 14; the checked evaluation repeats in double-double above it).
            let kappa = problem_condition(&c, &q, &eta, &params).unwrap();
            let estimate = c.evaluate(&q, &eta, &params).unwrap().f64_error_estimate;
            let allow = (STATED_MULTIPLE * ((kappa + 1.0) * f64::EPSILON).max(estimate) / TOL_SAME)
                .max(1.0);

            // Full right-hand side: generated vs structured evaluator.
            let g = (core.full)(&q, &eta).unwrap();
            let s = c.rhs::<f64>(&q, &eta, &params).unwrap();
            for (a, b) in [
                (&g.eta_dot, &s.eta_dot),
                (&g.eta_dot_paper, &s.eta_dot_paper),
                (&g.q_dot, &s.q_dot),
            ] {
                worst_same = worst_same.max(rel_error(a, b) / allow);
            }
            worst_same = worst_same.max(rel_error(&[g.energy], &[s.energy]) / allow);
            // The energy by its own path (straight-line code of the closed form).
            let e = (core.energy)(&q, &eta).unwrap();
            worst_same = worst_same.max(rel_error(&[e], &[s.energy]) / allow);
            // The fast path (solved form or structured, as chosen at generation) agrees too.
            let y: Vec<f64> = q.iter().chain(&eta).copied().collect();
            let mut dy = vec![0.0; y.len()];
            (core.full_into)(&y, &mut dy).unwrap();
            worst_same = worst_same.max(rel_error(&dy[..ell], &g.q_dot) / allow);
            worst_same = worst_same.max(rel_error(&dy[ell..], &g.eta_dot) / allow);
            // The constraints hold along q̇ = Γη.
            let res = (core.constraint_residual)(&q, &g.q_dot);
            assert!(
                res.iter().all(|r| r.abs() < 1e-12),
                "{}: α q̇ = {res:?}",
                core.model
            );
            // The monitored residual α(q)Γ(q)η, by its own path: as small.
            let monitored = (core.residual)(&q, &eta).unwrap();
            assert!(monitored < 1e-12, "{}: ‖αΓη‖ = {monitored:e}", core.model);

            // Against the oracle: q̈ = Γ̇η + Γη̇, Γ̇η by dual numbers along q̇.
            let qdual: Vec<Dual<1>> = q
                .iter()
                .zip(&g.q_dot)
                .map(|(&x, &dx)| Dual { v: x, d: [dx] })
                .collect();
            let edual: Vec<Dual<1>> = eta.iter().map(|&x| Dual { v: x, d: [0.0] }).collect();
            let gd = (core.full_dual)(&qdual, &edual).unwrap();
            let g_eta_dot = (core.full)(&q, &g.eta_dot).unwrap();
            let q_ddot: Vec<f64> = (0..ell)
                .map(|k| gd.q_dot[k].d[0] + g_eta_dot.q_dot[k])
                .collect();
            let oracle = hamel_oracle::accelerations::<f64>(&nm, &q, &g.q_dot).unwrap();
            worst_oracle = worst_oracle.max(rel_error(&q_ddot, &oracle.q_ddot) / allow);

            // Reduced: the kept rates and η̇, with the eliminated coordinates dropped.
            let x: Vec<f64> = core
                .kept
                .iter()
                .map(|&k| q[k])
                .chain(eta.iter().copied())
                .collect();
            let r = (core.reduced)(&x).unwrap();
            let expect: Vec<f64> = core
                .kept
                .iter()
                .map(|&k| g.q_dot[k])
                .chain(g.eta_dot.iter().copied())
                .collect();
            worst_reduced = worst_reduced.max(rel_error(&r, &expect));
            let rec = (core.reconstruction)(&q, &eta).unwrap();
            let expect: Vec<f64> = core.eliminated.iter().map(|&k| g.q_dot[k]).collect();
            assert_eq!(rec, expect);

            // Jacobian against central differences.
            let jac = (core.jacobian)(&x).unwrap();
            for j in 0..x.len() {
                let h = 1e-6 * x[j].abs().max(1.0);
                let (mut xp, mut xm) = (x.clone(), x.clone());
                xp[j] += h;
                xm[j] -= h;
                let (fp, fm) = ((core.reduced)(&xp).unwrap(), (core.reduced)(&xm).unwrap());
                let col: Vec<f64> = (0..x.len()).map(|i| jac[i][j]).collect();
                let fd: Vec<f64> = fp
                    .iter()
                    .zip(&fm)
                    .map(|(a, b)| (a - b) / (2.0 * h))
                    .collect();
                worst_jac = worst_jac.max(rel_error(&col, &fd));
            }
        }
        eprintln!(
            "{}/{}: σ = {sigma}, {} eliminated; generated vs structured {worst_same:.1e}, vs oracle {worst_oracle:.1e} (relative errors over max(1, 32 max((κ + 1) ε, f64 estimate) / 1e-12)), reduced vs full {worst_reduced:.1e}, Jacobian vs differences {worst_jac:.1e}",
            core.model,
            core.eta,
            core.eliminated.len()
        );
        assert!(
            worst_same <= TOL_SAME,
            "{}/{}: {worst_same:e}",
            core.model,
            core.eta
        );
        assert!(
            worst_oracle <= TOL_ORACLE,
            "{}/{}: {worst_oracle:e}",
            core.model,
            core.eta
        );
        assert!(
            worst_reduced <= TOL_SAME,
            "{}/{}: {worst_reduced:e}",
            core.model,
            core.eta
        );
        assert!(
            worst_jac <= 1e-6,
            "{}/{}: {worst_jac:e}",
            core.model,
            core.eta
        );
    }
}

/// The solved form checks the pivots of A_Γ = L D Lᵀ: with a negative mass A_Γ is not positive
/// definite, and the generated code says so instead of returning accelerations.
/// `energies` and `residuals` (four states at a time where the core has a closed form, with
/// the lanes' own sine and cosine; one by one otherwise) agree with `energy` and `residual` at
/// each state, over a number of states that leaves a partial group.
#[test]
fn monitors_of_many_states_agree_with_one_at_a_time() {
    let mut rng = ChaCha8Rng::seed_from_u64(45);
    for core in MODELS {
        let (ell, sigma) = (core.dims.ell, core.dims.sigma);
        let n = 37;
        let rows: Vec<f64> = (0..n * (ell + sigma))
            .map(|i| {
                rng.random_range(if i % (ell + sigma) < ell {
                    -3.0..3.0
                } else {
                    -2.0..2.0
                })
            })
            .collect();
        let (mut energies, mut residuals) = (vec![None; n], vec![None; n]);
        (core.energies)(&rows, &mut energies);
        (core.residuals)(&rows, &mut residuals);
        for (j, y) in rows.chunks_exact(ell + sigma).enumerate() {
            let (q, eta) = y.split_at(ell);
            let one = (core.energy)(q, eta).ok();
            assert_eq!(
                energies[j].is_some(),
                one.is_some(),
                "{} state {j}",
                core.model
            );
            if let (Some(a), Some(b)) = (energies[j], one) {
                // A mix-up of lanes, rows or components would differ in the first digits; the
                // lanes' sine and cosine (within an ulp of libm's, hamel-runtime's tests) move
                // the value by rounding, which random states (some near a singularity)
                // amplify up to about 1e-12 here.
                let allow = 1e-10 * (1.0 + b.abs());
                assert!(
                    (a - b).abs() <= allow,
                    "{} E: {a} vs {b}, allowed {allow:e}",
                    core.model
                );
            }
            let one = (core.residual)(q, eta).ok();
            assert_eq!(
                residuals[j].is_some(),
                one.is_some(),
                "{} state {j}",
                core.model
            );
            // Both are rounding of the speeds q̇ = Γη (αΓ = 0 exactly).
            let speed = (core.full)(q, eta).map_or(f64::INFINITY, |r| {
                r.q_dot.iter().fold(1.0_f64, |m, v| m.max(v.abs()))
            });
            if let (Some(a), Some(b)) = (residuals[j], one) {
                let bound = 1e-13 * speed;
                assert!(
                    a <= bound && b <= bound,
                    "{} ‖αΓη‖: {a:e}, {b:e} (q̇ up to {speed:e})",
                    core.model
                );
            }
        }
    }
}

#[test]
fn the_solved_form_refuses_an_indefinite_a_gamma() {
    use hamel_models::{bar_blade__paper as bar, knife__paper as knife};
    const { assert!(knife::SOLVED && bar::SOLVED, "both use the solved form") };
    let p = knife::Parameters {
        m: -0.5,
        ..Default::default()
    };
    let e = knife::fast(&[0.1, 0.2, 0.3], &[1.0, 0.5], &p).unwrap_err();
    assert!(
        matches!(e, EvalError::Check(m) if m.contains("not positive definite")),
        "{e}"
    );
    assert!(knife::fast(&[0.1, 0.2, 0.3], &[1.0, 0.5], &Default::default()).is_ok());
    // The bar's A_Γ depends on φ; with m_f < 0 large enough its second pivot turns negative.
    let p = bar::Parameters {
        m_f: -10.0,
        ..Default::default()
    };
    let e = bar::fast(&[0.0, 0.0, 0.3, 0.4], &[1.0, 0.5], &p).unwrap_err();
    assert!(
        matches!(e, EvalError::Check(m) if m.contains("not positive definite")),
        "{e}"
    );
}

/// The parameter-only values prepared once (`Prepared`, what integrators use) change nothing:
/// `full_into` with them gives the same bits as computing them at each call, at random states of
/// every core, and the reduced right-hand side likewise.
#[test]
fn prepared_parameters_give_the_same_bits() {
    let mut rng = ChaCha8Rng::seed_from_u64(45);
    for core in MODELS {
        let n = core.dims.ell + core.dims.sigma;
        let nr = core.kept.len() + core.dims.sigma;
        let mut compared = 0;
        for _ in 0..50 {
            let y: Vec<f64> = (0..n).map(|_| rng.random_range(-2.0..2.0)).collect();
            let (mut a, mut b) = (vec![0.0; n], vec![0.0; n]);
            match (
                (core.full_into)(&y, &mut a),
                (core.full_into_per_call)(&y, &mut b),
            ) {
                (Ok(()), Ok(())) => assert_eq!(a, b, "{}/{} at {y:?}", core.model, core.eta),
                (Err(e), Err(f)) => assert_eq!(e, f),
                (x, z) => panic!("{}/{}: {x:?} vs {z:?}", core.model, core.eta),
            }
            let x: Vec<f64> = y[..nr].to_vec();
            let mut dx = vec![0.0; nr];
            match ((core.reduced_into)(&x, &mut dx), (core.reduced)(&x)) {
                (Ok(()), Ok(r)) => assert_eq!(dx, r, "{}/{} at {x:?}", core.model, core.eta),
                (Err(e), Err(f)) => assert_eq!(e, f),
                (x, z) => panic!("{}/{}: {x:?} vs {z:?}", core.model, core.eta),
            }
            compared += 1;
        }
        assert_eq!(compared, 50);
    }
}

/// Parameters for which A_Γ is indefinite at every state are refused when prepared, with the
/// reason; admissible ones are accepted.
#[test]
fn preparing_refuses_parameters_that_make_a_gamma_indefinite() {
    use hamel_models::knife__paper as knife;
    let p = knife::Parameters {
        m: -0.5,
        ..Default::default()
    };
    let e = knife::Prepared::new(&p).unwrap_err();
    assert!(
        matches!(e, EvalError::Check(m)
            if m.contains("not positive definite") && m.contains("for these parameters")),
        "{e}"
    );
    let prep = knife::Prepared::new(&Default::default()).unwrap();
    assert!(knife::fast_with(&[0.1, 0.2, 0.3], &[1.0, 0.5], &prep).is_ok());
}

/// The bicycle's core projects onto its front contact as the model's own completion does
/// (`Completion`, Newton on the expression from the bodies): the same pitch to 1e-14, the other
/// coordinates untouched, |h| at round-off after.
#[test]
fn the_bicycles_core_projects_onto_its_front_contact() {
    use hamel_models::whipple_bicycle__benchmark as core;
    let path = format!("{}/models/whipple_bicycle.toml", env!("CARGO_MANIFEST_DIR"));
    let model = hamel_model::Model::load(path).unwrap_or_else(|e| panic!("{e}"));
    let pitch = model.coordinates.iter().position(|c| c == "pitch").unwrap();
    assert_eq!((core::HOLONOMIC, core::DEPENDENT), (1, [pitch]));
    let p = core::Parameters::default();
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    for _ in 0..20 {
        let mut q: Vec<f64> = (0..model.ell())
            .map(|_| rng.random_range(-0.6..0.6))
            .collect();
        q[pitch] = rng.random_range(-0.05..0.05);
        let (mut mine, mut theirs) = (q.clone(), q.clone());
        let before = core::project(&mut mine, &p).unwrap();
        model
            .completion
            .complete(&mut theirs, &model.parameters)
            .unwrap();
        let h0 = model.completion.residual(&q, &model.parameters).unwrap();
        assert!(
            (before - h0).abs() <= 1e-15 * (1.0 + h0),
            "{before} vs {h0}"
        );
        assert!(
            (mine[pitch] - theirs[pitch]).abs() <= 1e-14,
            "{mine:?} vs {theirs:?}"
        );
        assert!((0..q.len()).all(|k| k == pitch || mine[k] == q[k]));
        assert!(model.completion.residual(&mine, &model.parameters).unwrap() <= 1e-15);
        assert!(core::project(&mut mine.clone(), &p).unwrap() <= 1e-15);
    }
}

/// The generated cores' constraint forces (issue 58: `constraint_forces`, straight-line code
/// of the map and the supports' equations over the runtime's structured evaluation) against
/// the interpreted evaluator's (`Compiled::constraint_forces_checked`) at random admissible
/// states: the same names in the same order, the same values to 1e-10 of the largest force.
#[test]
fn generated_cores_report_the_interpreted_constraint_forces() {
    let models = common::models();
    let mut rng = ChaCha8Rng::seed_from_u64(58);
    let mut checked = 0;
    for core in MODELS.iter().filter(|c| c.scene.is_empty()) {
        let model = common::model_of_core(&models, core.model, core.scene);
        let model = model.with_supports().unwrap();
        let d = hamel_derive::derive(&model, Some(core.eta)).unwrap();
        let c = d.compile_with_constraint_forces().unwrap();
        assert_eq!(
            c.constraint_force_names(),
            core.constraint_force_names,
            "{}",
            core.model
        );
        let params: IndexMap<String, f64> = d.parameters.clone();
        let nm = NumericModel::new(&model, &IndexMap::new()).unwrap();
        let ell = core.dims.ell;
        let mut states = 0;
        while states < 10 {
            let q: Vec<f64> = (0..ell).map(|_| rng.random_range(-3.0..3.0)).collect();
            let v: Vec<f64> = (0..ell).map(|_| rng.random_range(-2.0..2.0)).collect();
            if c.condition(&q, &params).unwrap() > MAX_CONDITION {
                continue;
            }
            let qd = hamel_oracle::project(&nm, &q, &v).unwrap();
            let z = nm.quasi_velocity_matrix::<f64>(core.eta, &q).unwrap();
            let eta: Vec<f64> = (z.iter())
                .map(|row| row.iter().zip(&qd).map(|(a, b)| a * b).sum())
                .collect();
            let Ok(expected) = c.constraint_forces_checked(&q, &eta, &params) else {
                continue;
            };
            states += 1;
            let got = (core.constraint_forces)(&q, &eta).unwrap();
            let scale = (expected.forces.iter()).fold(1.0_f64, |m, f| m.max(f.value.abs()));
            for (f, g) in expected.forces.iter().zip(&got) {
                assert!(
                    (f.value - g).abs() <= 1e-10 * scale,
                    "{} {}: {} generated, {} interpreted",
                    core.model,
                    f.name,
                    g,
                    f.value
                );
            }
        }
        checked += usize::from(!core.constraint_force_names.is_empty());
    }
    assert!(checked >= 15, "{checked} cores with constraint forces");
}

/// The Taylor method's recurrences compiled into the cores (`reduced_series`) against the
/// same recurrences interpreted over a trace of `reduced_with` (`runtime::taylor_by_trace`), at
/// random reduced states, order 20: the first five coefficients within 1e-11 of the largest of
/// their order (every recurrence enters by then: a wrong one shows), and the step the Taylor
/// method takes at 1e-14 — the series summed at the step its rule chooses — within 1e-13
/// (higher coefficients alone may differ more where they cancel: both sum the same terms in
/// another order, as do truncated power series). Every core with a closed form compiles its
/// series; the others (no closed form) trace.
#[test]
fn compiled_taylor_recurrences_match_the_traced_ones() {
    let mut rng = ChaCha8Rng::seed_from_u64(63);
    let (mut compiled, mut low, mut stepped) = (0, 0.0_f64, 0.0_f64);
    let order = 20;
    for core in MODELS {
        let n = core.kept.len() + core.dims.sigma;
        let (mut a, mut b) = (Vec::new(), Vec::new());
        let mut states = 0;
        for _ in 0..200 {
            let x: Vec<f64> = (0..n).map(|_| rng.random_range(-1.0..1.0)).collect();
            let mut dx = vec![0.0; n];
            if (core.reduced_into)(&x, &mut dx).is_err() {
                continue;
            }
            let Some(()) = (core.series)(&x, order, &mut a).unwrap() else {
                break;
            };
            (core.series_traced)(&x, order, &mut b).unwrap().unwrap();
            for k in 0..5 {
                let (ra, rb) = (&a[k * n..(k + 1) * n], &b[k * n..(k + 1) * n]);
                let scale = rb.iter().fold(f64::MIN_POSITIVE, |m, v| m.max(v.abs()));
                let e = (ra.iter().zip(rb)).fold(0.0_f64, |m, (u, v)| m.max((u - v).abs()));
                low = low.max(e / scale);
                assert!(
                    e / scale < 1e-11,
                    "{} {}: order {k}: {ra:?} against {rb:?}",
                    core.model,
                    core.eta
                );
            }
            let h = hamel_sim::taylor::step(&b, n, order, (1e-14, 1e-14), &x);
            let (mut ya, mut yb) = (vec![0.0; n], vec![0.0; n]);
            hamel_sim::taylor::sum(&a, n, h, &mut ya);
            hamel_sim::taylor::sum(&b, n, h, &mut yb);
            let e = (ya.iter().zip(&yb))
                .fold(0.0_f64, |m, (u, v)| m.max((u - v).abs() / v.abs().max(1.0)));
            stepped = stepped.max(e);
            assert!(
                e < 1e-13,
                "{} {}: a step of {h} differs by {e:e}",
                core.model,
                core.eta
            );
            states += 1;
            if states == 10 {
                break;
            }
        }
        if states > 0 {
            compiled += 1;
        }
        eprintln!("{} {}: {states} states compared", core.model, core.eta);
    }
    eprintln!(
        "{compiled} cores with compiled series: orders 0-4 within {low:.1e}, a step at 1e-14 within {stepped:.1e}"
    );
    assert!(compiled >= 15, "{compiled}");
}

/// A compiled series is written out whole for orders up to 20 (every coefficient's sums at
/// constant indices, hamel-codegen's `generate/recurrence.rs`) and as a loop over `runtime::recur`
/// beyond: the two give the same bits, and so does the loop alone compiled without FMA
/// (`reduced_series_looped`, what a CPU without it runs: its `mul_add`s the C library's). Coefficient k does not depend on the order asked for, so
/// the rows of an order-p run (written out, p ≤ 20) are the first rows of an order-23 run (the
/// loop), at every order 1 … 20 and random states of every core with a closed form.
#[test]
fn written_out_series_are_the_looped_ones_bit_for_bit() {
    let mut rng = ChaCha8Rng::seed_from_u64(6363);
    let mut cores = 0;
    for core in MODELS {
        let n = core.kept.len() + core.dims.sigma;
        let (mut a, mut b) = (Vec::new(), Vec::new());
        let mut states = 0;
        while states < 5 {
            let x: Vec<f64> = (0..n).map(|_| rng.random_range(-1.0..1.0)).collect();
            if (core.reduced_into)(&x, &mut vec![0.0; n]).is_err() {
                continue;
            }
            let Some(()) = (core.series)(&x, 23, &mut b).unwrap() else {
                break;
            };
            // what a CPU without FMA runs: the loop alone, compiled without it
            let mut l = Vec::new();
            (core.series_looped)(&x, 23, &mut l).unwrap().unwrap();
            assert!(
                l.iter().zip(&b).all(|(u, v)| u.to_bits() == v.to_bits()),
                "{} {}: the loop alone differs",
                core.model,
                core.eta
            );
            for order in 1..=20 {
                (core.series)(&x, order, &mut a).unwrap().unwrap();
                assert_eq!(a.len(), (order + 1) * n);
                let same = a.iter().zip(&b).all(|(u, v)| u.to_bits() == v.to_bits());
                assert!(
                    same,
                    "{} {} order {order}: {a:?} against {b:?}",
                    core.model, core.eta
                );
            }
            states += 1;
        }
        cores += usize::from(states > 0);
    }
    assert!(cores >= 15, "{cores}");
}

/// The compiled series checks at the state the closed form's definiteness tests that depend on
/// it (the scene core no longer evaluates the right-hand side before each series): where
/// `reduced_into` finds A_Γ not definite, the series fails with the same error before any
/// coefficient; where it passes, so does the series. At random states of every core with a
/// closed form, and at a state of NaNs, which fails every test (a core whose tests all depend
/// on the parameters alone passes it, and the driver then finds the series not finite).
#[test]
fn compiled_series_check_the_closed_forms_tests_at_the_state() {
    let mut rng = ChaCha8Rng::seed_from_u64(636);
    let (mut cores, mut failed) = (0, 0);
    for core in MODELS {
        let n = core.kept.len() + core.dims.sigma;
        let mut out = Vec::new();
        let states = (0..20)
            .map(|_| {
                (0..n)
                    .map(|_| rng.random_range(-4.0..4.0))
                    .collect::<Vec<f64>>()
            })
            .chain([vec![f64::NAN; n]]);
        for x in states {
            let Some(series) = (core.series)(&x, 5, &mut out).transpose() else {
                break;
            };
            match (core.reduced_into)(&x, &mut vec![0.0; n]) {
                Err(e) if e.to_string().contains("not positive definite") => {
                    let got = series.expect_err("the series passed a failed test");
                    assert_eq!(
                        got.to_string(),
                        e.to_string(),
                        "{} {}",
                        core.model,
                        core.eta
                    );
                    failed += 1;
                }
                Err(_) => {}
                Ok(()) => {
                    series.unwrap_or_else(|e| panic!("{} {}: {e}", core.model, core.eta));
                }
            }
        }
        cores += usize::from(!out.is_empty());
    }
    eprintln!("{cores} cores with compiled series, {failed} failed tests found alike");
    assert!(
        cores >= 15 && failed >= 5,
        "{cores} cores, {failed} failed tests"
    );
}

/// SymPy's count for the same bicycle: test_kane3's mass matrix and forcing after `cse`
/// (`python3 bench/sympy_bicycle.py --count`, SymPy 1.14; docs/models/whipple_bicycle.md).
const SYMPY_BICYCLE_OPERATIONS: usize = 2_513;

/// The bicycle's core writes Z, α and A once and takes their derivatives at run time by dual
/// numbers (`hamel_runtime::ingredients_by_partials`): every ingredient, the derivative blocks
/// included, against the derivation's own trees (∂A/∂q_k, ∂Z/∂q_k, ∂α/∂q_k taken symbolically,
/// `Expr::diff`) evaluated by the interpreter, at random configurations; and what it writes is
/// at most SymPy's operations.
#[test]
fn the_bicycles_derivatives_by_dual_numbers_are_its_trees_derivatives() {
    use hamel_models::whipple_bicycle__benchmark as core;
    let models = common::models();
    let model = &*common::model_of_core(&models, "whipple_bicycle", "");
    let d = hamel_derive::derive(model, Some("benchmark")).unwrap();
    let exprs = d.ingredient_exprs().unwrap();
    let inputs: Vec<String> = (d.coordinates.iter().chain(d.parameters.keys()))
        .cloned()
        .collect();
    let trees = hamel_expr::Tape::compile(&exprs, &inputs).unwrap();
    assert_eq!(exprs.len(), core::LEN);
    let p = core::Parameters::default();
    let mut rng = ChaCha8Rng::seed_from_u64(63);
    let mut worst = 0.0f64;
    for _ in 0..20 {
        let q: Vec<f64> = (0..d.ell).map(|_| rng.random_range(-1.5..1.5)).collect();
        let at: Vec<f64> = q
            .iter()
            .copied()
            .chain(d.parameters.values().copied())
            .collect();
        let expected = trees.eval(&at).unwrap();
        let mut got = [0.0; core::LEN];
        core::ingredients(&q, &p, &mut got);
        let scale = expected.iter().fold(1.0f64, |m, x| m.max(x.abs()));
        for (g, e) in got.iter().zip(&expected) {
            worst = worst.max((g - e).abs() / scale);
        }
    }
    println!(
        "bicycle: ingredients by dual numbers against the trees' derivatives {worst:.1e}; {} shared operations written (SymPy {SYMPY_BICYCLE_OPERATIONS})",
        core::OPERATIONS.1
    );
    assert!(worst <= 1e-13, "{worst:e}");
    assert!(core::OPERATIONS.1 <= SYMPY_BICYCLE_OPERATIONS);
}
