//! Dependent constraints (issue 57): the robots of models/ whose two wheels on one axle give
//! four no-slip rows of rank 3.
//!
//! * the dropped row is exactly the printed combination of the kept rows, checked here
//!   numerically from the model file's own rows at random configurations (independently of
//!   the computer algebra that found the coefficients);
//! * the equations hold where the kept rows lose rank (cos ψ = 0): the evaluation there
//!   agrees with the Lagrange-multiplier oracle on every row, and is continuous across it;
//! * the position, the heading and the wheel angles drop out (ground truth, exact).
//!
//! The CAS runs in-process on its one worker thread.

mod common;

use common::oracle::q_ddot;
use common::rel_error;
use hamel_derive::{Derivation, derive};
use hamel_expr::{DD, Scalar};
use hamel_model::{Model, NumericModel};
use indexmap::IndexMap;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// A model of the test suite, by its path in the repository.
fn test_model(path: &str) -> Model {
    Model::load(format!("{}/{path}", env!("CARGO_MANIFEST_DIR"))).unwrap_or_else(|e| panic!("{e}"))
}

/// The oracle comparison (tests/common/oracle.rs) at `states` random states: f64 to 1e-12,
/// double-double and the symbolic equations to 1e-20.
fn agrees_with_the_oracle(
    m: &Model,
    choice: &str,
    seed: u64,
    states: usize,
) -> common::oracle::Worst {
    let w = common::oracle::compare(m, choice, seed, states);
    assert!(
        w.structured_f64 <= 1e-12 && w.structured_dd <= 1e-20 && w.symbolic_dd <= 1e-20,
        "{}/{choice}: f64 {:.1e}, dd {:.1e}, symbolic {:.1e}",
        m.name,
        w.structured_f64,
        w.structured_dd,
        w.symbolic_dd
    );
    w
}

fn bundled(name: &str) -> Model {
    Model::load(format!("{}/models/{name}.toml", env!("CARGO_MANIFEST_DIR")))
        .unwrap_or_else(|e| panic!("{e}"))
}

/// Σ_j c_j(q) α_j(q) − d(q) over every dropped row d, at q, with the coefficients evaluated
/// from the derivation's printed entries and the rows from the model's expressions.
fn remainder(m: &Model, d: &Derivation, q: &[f64]) -> f64 {
    let nm = NumericModel::new(m, &IndexMap::new()).unwrap();
    let rows = nm.all_constraint_rows::<f64>(q).unwrap();
    let names: Vec<&str> = m.all_rows().iter().map(|(n, _, _)| *n).collect();
    let row = |name: &str| &rows[names.iter().position(|n| *n == name).unwrap()];
    let point = hamel_bodies::Point::at(&m.coordinates, q, &m.parameters);
    let mut worst = 0.0_f64;
    for dep in &d.dependent_rows {
        let mut sum = row(&dep.name).iter().map(|x| -x).collect::<Vec<f64>>();
        for t in &dep.combination {
            let c = point.value(&t.coefficient.expr).unwrap();
            for (s, a) in sum.iter_mut().zip(row(&t.row)) {
                *s += c * a;
            }
        }
        worst = sum.iter().fold(worst, |w, x| w.max(x.abs()));
    }
    worst
}

#[test]
fn each_dropped_row_is_the_printed_combination_of_the_kept_ones() {
    let mut rng = ChaCha8Rng::seed_from_u64(57);
    for (name, choice, dropped) in [
        ("diff_drive", "wheels", "right_no_slip_y"),
        ("segway", "body", "right_no_slip_y"),
    ] {
        let m = bundled(name);
        assert_eq!(m.dependent.len(), 1, "{name}");
        assert_eq!(m.dependent[0].name, dropped, "{name}");
        let d = derive(&m, Some(choice)).unwrap();
        assert_eq!(d.mu + d.dependent_rows.len(), m.all_rows().len());
        let dep = &d.dependent_rows[0];
        assert_eq!(dep.combination.len(), 3, "{name}: {:?}", dep.combination);
        // The kept rows lose rank where cos(psi) = 0, and δ carries that factor once.
        let loss: Vec<&str> = dep.singular.iter().map(|e| e.text.as_str()).collect();
        assert_eq!(loss, ["cos(psi)"], "{name}");
        assert_eq!(d.kept_rank_loss.len(), 1, "{name}");
        assert_eq!(d.kept_rank_loss[0].power, 1, "{name}");
        for _ in 0..20 {
            let q: Vec<f64> = (0..m.ell()).map(|_| rng.random_range(-3.0..3.0)).collect();
            let r = remainder(&m, &d, &q);
            assert!(r < 1e-12, "{name}: remainder {r:e} at {q:?}");
        }
    }
}

/// At ψ = π/2 (to the nearest double) the kept rows of the diff-drive robot are parallel
/// (rank 2 of 3); the evaluation uses other rows there, and agrees with the oracle on all six
/// rows, in f64 and in double-double, and with the evaluation a millionth of a radian away.
#[test]
fn the_equations_hold_where_the_kept_rows_lose_rank() {
    let m = bundled("diff_drive");
    let d = derive(&m, Some("wheels")).unwrap();
    let c = d.compile().unwrap();
    let nm = NumericModel::new(&m, &IndexMap::new()).unwrap();
    let params = d.parameters.clone();
    let psi = m.coordinates.iter().position(|q| q == "psi").unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(2);
    for turn in [-1.0, 1.0, 3.0] {
        let mut q: Vec<f64> = (0..m.ell()).map(|_| rng.random_range(-1.0..1.0)).collect();
        q[psi] = turn * std::f64::consts::FRAC_PI_2;
        let eta = [rng.random_range(-2.0..2.0), rng.random_range(-2.0..2.0)];
        let e = c.evaluate(&q, &eta, &params).unwrap();
        let (qx, etax) = (common::oracle::dd(&q), common::oracle::dd(&eta));
        let r = c.rhs::<DD>(&qx, &etax, &params).unwrap();
        let oracle = hamel_oracle::accelerations::<DD>(&nm, &qx, &r.q_dot).unwrap();
        let ours = q_ddot(&c, &qx, &etax, &r.eta_dot, &r.q_dot, &params);
        let error = rel_error(&ours, &oracle.q_ddot);
        assert!(
            error < 1e-25,
            "ψ = {turn}π/2: q̈ off the oracle by {error:e}"
        );
        let f64_error = rel_error(
            &e.eta_dot,
            &r.eta_dot.iter().map(|x| x.value()).collect::<Vec<_>>(),
        );
        assert!(
            f64_error < 1e-12,
            "ψ = {turn}π/2: f64 η̇ off by {f64_error:e}"
        );
        let mut near = q.clone();
        near[psi] += 1e-6;
        let beside = c.evaluate(&near, &eta, &params).unwrap();
        let jump = rel_error(&beside.eta_dot, &e.eta_dot);
        assert!(
            jump < 1e-9,
            "ψ = {turn}π/2: η̇ jumps by {jump:e} within 1e-6 rad"
        );
        // δ over its kept-rank factor keeps its sign across cos ψ = 0.
        let mut before = q.clone();
        before[psi] -= 1e-3;
        let mut after = q.clone();
        after[psi] += 1e-3;
        let (a, b) = (
            c.delta(&before, &params).unwrap(),
            c.delta(&after, &params).unwrap(),
        );
        assert!(a * b > 0.0, "δ changes sign across cos ψ = 0: {a:e}, {b:e}");
    }
}

#[test]
fn the_robots_drop_their_position_heading_and_wheel_angles() {
    for (name, choice) in [("diff_drive", "wheels"), ("segway", "body")] {
        let m = bundled(name);
        let asked = common::eliminate(&m);
        let r = hamel_reduce::reduce(&m, Some(choice), &asked).unwrap();
        assert!(
            r.ground_truth.present.is_empty(),
            "{name}: present {:?}",
            r.ground_truth.present
        );
        assert_eq!(r.ground_truth.absent.len(), asked.len(), "{name}");
        assert!(r.reduced_system.is_some(), "{name}");
    }
}

/// A car with Ackermann steering written from bodies (tests/models/ackermann_car.toml): the
/// right front knuckle turns by atan(L sin δ/(L cos δ + 2b sin δ)), so that the four axles
/// meet at one point. The eight no-slip rows have rank 6 identically: the exact algebra sees
/// the atan's cosine and sine as 1/√(1 + u²) and u/√(1 + u²) and finds the front right wheel's
/// lateral row a combination of the others. σ = 2; the dropped rows are the printed
/// combinations; the equations agree with the oracle; the position, the heading and the
/// wheel angles drop out (the steering angle does not).
#[test]
fn the_ackermann_car_has_rank_six_through_its_arctangent() {
    let m = test_model("tests/models/ackermann_car.toml");
    assert_eq!(m.all_rows().len(), 8);
    let d = derive(&m, Some("drive")).unwrap();
    assert_eq!((d.mu, d.eta.len()), (6, 2));
    let dropped: Vec<&str> = d.dependent_rows.iter().map(|r| r.name.as_str()).collect();
    assert_eq!(dropped, ["rear_right_no_slip_y", "front_right_no_slip_y"]);
    let mut rng = ChaCha8Rng::seed_from_u64(58);
    for _ in 0..20 {
        let q: Vec<f64> = (0..m.ell()).map(|_| rng.random_range(-1.2..1.2)).collect();
        let r = remainder(&m, &d, &q);
        assert!(r < 1e-12, "remainder {r:e} at {q:?}");
    }
    agrees_with_the_oracle(&m, "drive", 59, 30);
    let asked: Vec<String> = ["x", "y", "psi", "phiRL", "phiRR", "phiFL", "phiFR"]
        .map(String::from)
        .into();
    let r = hamel_reduce::reduce(&m, Some("drive"), &asked).unwrap();
    assert!(
        r.ground_truth.present.is_empty(),
        "{:?}",
        r.ground_truth.present
    );
    let r = hamel_reduce::reduce(&m, Some("drive"), &["delta".into()]).unwrap();
    assert_eq!(r.ground_truth.present, ["delta"]);
}

/// Bare arctangents (tests/models/atan_knife.toml: atan(θ) in the inertia, atan(xy − 1) in U)
/// are kernels of the exact algebra with the derivative u'/(1 + u²): the closed form agrees
/// with the oracle.
#[test]
fn bare_arctangents_derive_exactly() {
    let m = test_model("tests/models/atan_knife.toml");
    let w = agrees_with_the_oracle(&m, "paper", 60, 30);
    assert!(!w.structured_form);
}

/// A holonomic constraint implied by the ones before it (tests/filetests/holonomic_implied.toml:
/// c − a − x = (b − a − x) + (c − b)): it is not solved for its coordinate (Newton would meet a
/// singular Jacobian), its row is dropped as the exact sum of the other two, σ = 4 − 2 = 2,
/// and the equations agree with the oracle.
#[test]
fn an_implied_holonomic_constraint_is_dropped() {
    let m = test_model("tests/filetests/holonomic_implied.toml");
    let names: Vec<&str> = m.holonomic.iter().map(|h| h.name.as_str()).collect();
    assert_eq!(names, ["ab", "bc"]);
    let d = derive(&m, Some("free")).unwrap();
    assert_eq!((d.mu, d.sigma), (2, 2));
    let dep = &d.dependent_rows[0];
    assert_eq!(dep.name, "ca");
    let rows: Vec<(&str, &str)> = (dep.combination.iter())
        .map(|t| (t.row.as_str(), t.coefficient.text.as_str()))
        .collect();
    assert_eq!(rows, [("ab", "1"), ("bc", "1")]);
    let w = common::oracle::compare(&m, "free", 61, 20);
    assert!(w.structured_f64 <= 1e-12, "{:.1e}", w.structured_f64);
}

/// The Ackermann car written with two steer angles tied by the holonomic constraint
/// L sin(dL − dR) = 2b sin dL sin dR (tests/models/ackermann_two_angles.toml): its nine rows
/// have rank 8 at configurations off h = 0 and 7 on it. The front right wheel's lateral row is
/// dropped as a combination of the kept rows that holds on h = 0 only (decided exactly on the
/// manifold: the remainders vanish modulo the constraint's prime, δ does not), so σ = 9 − 7 = 2,
/// not the 1 that counting rows or sampling off h = 0 would give. The combination holds at
/// completed configurations and fails off them; the equations agree with the oracle there.
#[test]
fn the_two_angle_ackermann_car_has_rank_seven_on_its_constraint_manifold() {
    let m = test_model("tests/models/ackermann_two_angles.toml");
    assert_eq!((m.ell(), m.all_rows().len()), (9, 9));
    let d = derive(&m, Some("drive")).unwrap();
    assert_eq!((d.mu, d.sigma), (7, 2));
    let on: Vec<(&str, Option<&str>)> = (d.dependent_rows.iter())
        .map(|r| (r.name.as_str(), r.on_manifold.as_deref()))
        .collect();
    assert_eq!(
        on,
        [
            ("rear_right_no_slip_y", None),
            ("front_right_no_slip_y", Some("ackermann"))
        ]
    );
    let params = d.parameters.clone();
    let mut rng = ChaCha8Rng::seed_from_u64(62);
    let (mut on_worst, mut off_least) = (0.0_f64, f64::INFINITY);
    for _ in 0..20 {
        let mut q: Vec<f64> = (0..m.ell()).map(|_| rng.random_range(-0.6..0.6)).collect();
        off_least = off_least.min(remainder(&m, &d, &q));
        m.completion.complete(&mut q, &params).unwrap();
        on_worst = on_worst.max(remainder(&m, &d, &q));
    }
    assert!(on_worst < 1e-12, "remainder on h = 0: {on_worst:e}");
    assert!(off_least > 1e-6, "remainder off h = 0: {off_least:e}");
    agrees_with_the_oracle(&m, "drive", 63, 30);
}

/// Two-argument arctangents (tests/models/atan2_knife.toml: bare atan2 kernels in U, a blade
/// turned by θ + atan2(x, 3)) derive exactly (the kernel's derivative (x dy − y dx)/(x² + y²),
/// the blade's sine and cosine algebraic) and agree with the oracle at states in every
/// quadrant of each atan2.
#[test]
fn two_argument_arctangents_derive_exactly() {
    let m = test_model("tests/models/atan2_knife.toml");
    let w = agrees_with_the_oracle(&m, "paper", 64, 40);
    assert!(!w.structured_form);
}

/// The Ackermann car with its right knuckle turned by atan2(L sin δ, L cos δ + 2b sin δ)
/// (tests/models/ackermann_atan2.toml): rank 6 of 8 as with atan, and the equations agree with
/// the oracle at steer angles on both sides of L cos δ + 2b sin δ = 0 (δ ≈ 2.11), where atan
/// of the quotient would take the other branch.
#[test]
fn the_ackermann_car_written_with_atan2_has_rank_six() {
    let m = test_model("tests/models/ackermann_atan2.toml");
    let d = derive(&m, Some("drive")).unwrap();
    assert_eq!((d.mu, d.eta.len()), (6, 2));
    let mut rng = ChaCha8Rng::seed_from_u64(65);
    let delta = m.coordinates.iter().position(|c| c == "delta").unwrap();
    for k in 0..20 {
        let mut q: Vec<f64> = (0..m.ell()).map(|_| rng.random_range(-1.2..1.2)).collect();
        q[delta] = if k % 2 == 0 { 2.6 } else { -2.6 } + 0.1 * q[delta];
        let r = remainder(&m, &d, &q);
        assert!(r < 1e-12, "remainder {r:e} at {q:?}");
    }
    agrees_with_the_oracle(&m, "drive", 66, 30);
}
