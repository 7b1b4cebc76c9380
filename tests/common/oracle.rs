//! The comparison with the independent oracle (crate `hamel-oracle`, the Lagrange-multiplier
//! form solved numerically), shared by tests/oracle.rs (the bundled models) and
//! tests/random_models.rs (random ones).

use super::rel_error;
use hamel_derive::{Compiled, Derivation, Evaluation, SymbolicCompiled, derive};
use hamel_expr::{DD, Dual, Expr, Scalar, parse};
use hamel_model::{Model, NumericModel};
use indexmap::IndexMap;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

pub const TOL: f64 = 1e-10;
/// Largest condition number of [Z; α] admitted for a sample state (very near the singular set
/// the comparison measures rounding, not the equations; the stability study covers it).
pub const MAX_CONDITION: f64 = 1e6;

/// Largest cond[Z; α] at which the f64 evaluation is compared (double-double is compared up to
/// [`MAX_CONDITION`]). Beyond it hamel's f64 error grows like cond·ε through Γ: 1.8e-10 at
/// cond 1.6e4 for the bicycle with its front wheel turned 90° (docs/derivation.md §5).
pub const F64_CONDITION: f64 = 1e4;

/// The condition number of [Z; α] up to which f64 is expected to give 1e-12.
pub const WELL_CONDITIONED: f64 = 100.0;

/// Largest cond[Z; α]·cond(A_Γ) (see [`mass_condition`]) at which f64 is expected to give
/// 1e-12, and [`F64_PROBLEM`] 1e-10: the mass matrix is inverted too, by hamel and by the
/// oracle, and both lose about cond(A_Γ)·ε/10 (a random rider on a rolling disk reached
/// cond(A_Γ) = 5e4 and 1.1e-12 in both, with [Z; α] at 1.3).
pub const WELL_CONDITIONED_PROBLEM: f64 = 1e4;
/// See [`WELL_CONDITIONED_PROBLEM`].
pub const F64_PROBLEM: f64 = 1e6;

/// The condition number of A_Γ = ΓᵀAΓ (8), the matrix the equations are solved with, at `q`,
/// scaled to unit diagonal (so that it does not depend on the units of η; bar_wheels' A_Γ is
/// diagonal, 1 here, 1e3 to 6e4 unscaled).
pub fn mass_condition(
    nm: &NumericModel,
    c: &Compiled,
    q: &[f64],
    params: &IndexMap<String, f64>,
) -> f64 {
    let a = nm.mass_matrix::<f64>(q).unwrap();
    let gamma = c.gamma::<f64>(q, params).unwrap();
    let (ell, sigma) = (a.len(), gamma[0].len());
    let a = nalgebra::DMatrix::from_fn(ell, ell, |i, j| a[i][j]);
    let gamma = nalgebra::DMatrix::from_fn(ell, sigma, |k, s| gamma[k][s]);
    let a_gamma = gamma.transpose() * a * gamma;
    // Jacobi scaling: the condition number whatever units the quasi-velocities have.
    let scale = a_gamma.diagonal().map(|d| 1.0 / d.abs().sqrt());
    let a_gamma =
        nalgebra::DMatrix::from_fn(sigma, sigma, |r, s| a_gamma[(r, s)] * scale[r] * scale[s]);
    let eigen = a_gamma.symmetric_eigen().eigenvalues;
    let (small, large) = eigen.iter().fold((f64::INFINITY, 0.0_f64), |(s, l), e| {
        (s.min(e.abs()), l.max(e.abs()))
    });
    large / small
}

/// Concrete test functions for free functions: smooth, nonconstant, different for each name so
/// that nothing cancels by accident.
pub fn test_function(name: &str, args: &[String]) -> Expr {
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

pub fn test_functions(model: &Model, choice: &str) -> Vec<(String, Vec<String>, Expr)> {
    model
        .choice(Some(choice))
        .unwrap()
        .free_functions
        .iter()
        .map(|(n, a)| (n.clone(), a.clone(), test_function(n, a)))
        .collect()
}

pub fn with_test_functions(model: &Model, choice: &str) -> Model {
    let defs: Vec<(String, Expr)> = test_functions(model, choice)
        .into_iter()
        .map(|(n, _, e)| (n, e))
        .collect();
    model.with_free_functions(choice, &defs).unwrap()
}

/// Values at q of the inputs a symbolic tape asks for: free functions and first derivatives.
pub fn free_values(model: &Model, choice: &str, names: &[String], q: &[DD]) -> Vec<DD> {
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
pub fn q_ddot<S: Scalar + Copy>(
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

pub fn dd(v: &[f64]) -> Vec<DD> {
    v.iter().map(|&x| DD::from_f64(x)).collect()
}

#[derive(Default)]
pub struct Worst {
    /// The derivation was structured (no expanded symbolic forms to compare).
    pub structured_form: bool,
    /// At states where cond[Z; α] ≤ [`F64_CONDITION`] and cond[Z; α]·cond(A_Γ) ≤
    /// [`F64_PROBLEM`].
    pub structured_f64: f64,
    /// At states where cond[Z; α] ≤ [`WELL_CONDITIONED`] and cond[Z; α]·cond(A_Γ) ≤
    /// [`WELL_CONDITIONED_PROBLEM`].
    pub well_conditioned_f64: f64,
    /// The largest ratio of the f64 error of η̇ to the error estimate of the checked
    /// evaluation times ‖η̇‖∞ (at least ε·max(1, ‖η̇‖∞)), at every state.
    pub estimate_ratio: f64,
    /// The checked evaluation (`Compiled::evaluate`: f64, repeated in double-double where
    /// its error estimate says so), where `structured_f64` is measured.
    pub checked_f64: f64,
    pub structured_dd: f64,
    pub symbolic_dd: f64,
    pub paper_dd: f64,
    pub states: usize,
    /// States compared in f64 (cond[Z; α] ≤ [`F64_CONDITION`], the problem ≤ [`F64_PROBLEM`]).
    pub f64_states: usize,
    /// States at which f64 is held to 1e-12 ([`WELL_CONDITIONED`],
    /// [`WELL_CONDITIONED_PROBLEM`]).
    pub well_conditioned_states: usize,
}

/// The f64 error of η̇ (`approximate`) against `exact`, over the error estimate the checked
/// evaluation acts on. The estimate is relative to ‖η̇‖∞; where η̇ is near 0, an ulp of 1 is
/// the unit. None when the estimate is not finite.
fn estimate_ratio(approximate: &[f64], exact: &[DD], evaluated: &Evaluation) -> Option<f64> {
    let estimate = evaluated.f64_error_estimate;
    let size = exact.iter().fold(0.0_f64, |m, x| m.max(x.value().abs()));
    let error = approximate
        .iter()
        .zip(exact)
        .map(|(a, b)| (a - b.value()).abs())
        .fold(0.0, f64::max);
    let bound = (estimate * size).max(f64::EPSILON * size.max(1.0));
    estimate.is_finite().then_some(error / bound)
}

/// `q` completed onto the model's one holonomic constraint h = 0 (Newton in f64, the model's
/// completion), and that configuration refined in double-double by Newton steps on the
/// dependent coordinate (h and ∂h/∂q from the model's expressions): where rows depend on each
/// other only on h = 0, a state 1e-16 off it is not rank-deficient in double-double. `None`
/// where the completion fails.
pub fn completed_dd(
    model: &Model,
    nm: &NumericModel,
    q: &mut [f64],
    params: &IndexMap<String, f64>,
) -> Option<Vec<DD>> {
    let [h] = model.holonomic.as_slice() else {
        panic!("{}: one holonomic constraint", model.name)
    };
    model.completion.complete(q, params).ok()?;
    let j = model.coordinates.iter().position(|c| *c == h.dependent)?;
    let row = model.all_rows().iter().position(|(n, _, _)| *n == h.name)?;
    let mut qx = dd(q);
    for _ in 0..3 {
        let point = hamel_bodies::Point::at(&model.coordinates, &qx, params);
        let value: DD = h.h.eval(&point).ok()?;
        let slope = nm.all_constraint_rows::<DD>(&qx).ok()?[row][j];
        qx[j] = qx[j] - value / slope;
    }
    Some(qx)
}

/// Compare hamel with the oracle at random admissible states.
pub fn compare(model: &Model, choice: &str, seed: u64, states: usize) -> Worst {
    let concrete = with_test_functions(model, choice);
    let d =
        derive(&concrete, Some(choice)).unwrap_or_else(|e| panic!("{}/{choice}: {e}", model.name));
    compare_with(model, choice, &d, seed, states)
}

/// [`compare`] with the derivation `d` of the choice, its free functions (if any) replaced by
/// the test functions.
pub fn compare_with(
    model: &Model,
    choice: &str,
    d: &Derivation,
    seed: u64,
    states: usize,
) -> Worst {
    let concrete = with_test_functions(model, choice);
    if let Some(closed) = d.closed() {
        assert!(
            closed.checks.split_identity,
            "{}/{choice}: Q ≠ Q_paper + Q_correction",
            model.name
        );
        // Without forces E is conserved; with them dE/dt is their power, exactly.
        assert!(
            closed
                .checks
                .energy_balance
                .unwrap_or(closed.checks.energy_conserved),
            "{}/{choice}: the energy balance fails",
            model.name
        );
        assert_eq!(
            closed.checks.energy_conserved,
            closed.checks.working_forces.is_empty(),
            "{}/{choice}",
            model.name
        );
    }
    let c = d.compile().unwrap();
    // The symbolic equations as derived for the choice as written (free functions symbolic);
    // none for a structured derivation, which has only the ingredients.
    let sym: Option<SymbolicCompiled> = d.closed().map(|_| {
        if model
            .choice(Some(choice))
            .unwrap()
            .free_functions
            .is_empty()
        {
            d.compile_symbolic().unwrap()
        } else {
            let symbolic = derive(model, Some(choice)).unwrap();
            symbolic.compile_symbolic().unwrap()
        }
    });
    let nm = NumericModel::new(&concrete, &IndexMap::new()).unwrap();
    let params = d.parameters.clone();
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut w = Worst {
        structured_form: d.closed().is_none(),
        ..Worst::default()
    };
    // Where a dropped row depends on the kept ones only on h = 0, states are sampled there.
    let on_manifold = d.dependent_rows.iter().any(|r| r.on_manifold.is_some());
    let mut attempts = 0;
    while w.states < states {
        attempts += 1;
        assert!(
            attempts < 20 * states,
            "{}/{choice}: too many singular samples",
            model.name
        );
        let mut q: Vec<f64> = (0..d.ell).map(|_| rng.random_range(-3.0..3.0)).collect();
        let v: Vec<f64> = (0..d.ell).map(|_| rng.random_range(-2.0..2.0)).collect();
        let on = match on_manifold {
            true => match completed_dd(model, &nm, &mut q, &params) {
                Some(qx) => Some(qx),
                None => continue,
            },
            false => None,
        };
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

        // The reference: the state in double-double. q̇ = Γη computed in double-double lies on
        // the constraint manifold to that precision, and is what the oracle is given.
        let (qx, etax) = (on.unwrap_or_else(|| dd(&q)), dd(&eta));
        let r = c.rhs::<DD>(&qx, &etax, &params).unwrap();
        let oracle = hamel_oracle::accelerations::<DD>(&nm, &qx, &r.q_dot).unwrap();
        w.structured_dd = w.structured_dd.max(rel_error(
            &q_ddot(&c, &qx, &etax, &r.eta_dot, &r.q_dot, &params),
            &oracle.q_ddot,
        ));

        // Structured, f64: hamel's η̇ from the same f64 (q, η), taken to q̈ in double-double,
        // so that what is measured is the f64 evaluation, not the rounding of the state (the
        // accelerations of two states ε apart on the manifold can differ by 1e-9 where two
        // knife edges are nearly parallel) nor that of q̈ = Γ̇η + Γη̇.
        let f64_rhs = c.rhs::<f64>(&q, &eta, &params).unwrap();
        let condition = c.condition(&q, &params).unwrap();
        assert!(
            rel_error(&f64_rhs.q_dot, &qd) <= TOL,
            "{}/{choice}: q̇ = Γη differs: {:?} vs {:?} at q {:?}",
            model.name,
            f64_rhs.q_dot,
            qd,
            q
        );
        let in_dd = |eta_dot: &[f64]| q_ddot(&c, &qx, &etax, &dd(eta_dot), &r.q_dot, &params);
        let error = rel_error(&in_dd(&f64_rhs.eta_dot), &oracle.q_ddot);
        let evaluated = c.evaluate(&q, &eta, &params).unwrap();
        let checked = rel_error(&in_dd(&evaluated.eta_dot), &oracle.q_ddot);
        if let Some(ratio) = estimate_ratio(&f64_rhs.eta_dot, &r.eta_dot, &evaluated) {
            w.estimate_ratio = w.estimate_ratio.max(ratio);
        }
        let problem = condition * mass_condition(&nm, &c, &q, &params);
        if condition <= F64_CONDITION && problem <= F64_PROBLEM {
            w.structured_f64 = w.structured_f64.max(error);
            w.checked_f64 = w.checked_f64.max(checked);
            w.f64_states += 1;
        }
        if condition <= WELL_CONDITIONED && problem <= WELL_CONDITIONED_PROBLEM {
            w.well_conditioned_f64 = w.well_conditioned_f64.max(error);
            w.well_conditioned_states += 1;
        }

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
