//! The constraints' forces (issue 58, first step): the multipliers λ of every row of α and the
//! generalised force R = αᵀλ that hamel computes from its own equations
//! (`Compiled::constraint_force`: R = AΓη̇ + AΓ̇η − (∇U + F + ∇_qT − Ȧq̇), λ from [Z; α]ᵀy = R),
//! against the Lagrange-multiplier oracle's, which solves for q̈ and λ together from the model
//! file's expressions. The oracle writes A q̈ + αᵀλ_o = …, so λ = −λ_o. Random states, in
//! double-double (1e-20) and in f64 (1e-10).
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

/// η = Z q̇ of the velocities `v` projected onto the constraints at q (the oracle's projection).
fn allowed_eta(nm: &NumericModel, choice: &str, q: &[f64], v: &[f64]) -> Vec<f64> {
    let qd = hamel_oracle::project(nm, q, v).unwrap();
    let z = nm.quasi_velocity_matrix::<f64>(choice, q).unwrap();
    (z.iter())
        .map(|row| row.iter().zip(&qd).map(|(a, b)| a * b).sum())
        .collect()
}

/// The largest relative differences (λ, R in double-double; λ in f64) over `states` states.
fn worst(name: &str, choice: &str, seed: u64, states: usize) -> (f64, f64, f64) {
    let m = bundled(name);
    let d = derive(&m.with_supports().unwrap(), Some(choice)).unwrap();
    let c = d.compile_with_constraint_forces().unwrap();
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
        let eta = allowed_eta(&nm, choice, &q, &v);
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
            let f64 = c.constraint_force::<f64>(&q, &eta, &params).unwrap();
            let values: Vec<f64> = ours.multipliers.iter().map(|x| x.value()).collect();
            f64_lambda = f64_lambda.max(rel_error(&dd(&f64.multipliers), &dd(&values)));
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

/// The constraint forces of `c` at (q, η) by name, in double-double.
fn forces_dd(
    c: &hamel_derive::Compiled,
    q: &[f64],
    eta: &[f64],
    params: &IndexMap<String, f64>,
) -> IndexMap<String, f64> {
    (c.constraint_forces::<DD>(&dd(q), &dd(eta), params).unwrap())
        .into_iter()
        .map(|f| (f.name, f.value.value()))
        .collect()
}

/// The benchmark bicycle at rest, upright: the wheels carry the weight in the proportions its
/// centres of mass give (Meijaard et al. 2007, Table 1): front 309.3035294 N, rear
/// 612.8364706 N, nothing along the ground; the same at a steady upright 5 m/s.
#[test]
fn the_benchmark_bicycle_stands_on_its_wheels() {
    let m = bundled("whipple_bicycle");
    let d = derive(&m.with_supports().unwrap(), Some("benchmark")).unwrap();
    let c = d.compile_with_constraint_forces().unwrap();
    let params = d.parameters.clone();
    let mut q = vec![0.0; d.ell];
    m.completion.complete(&mut q, &params).unwrap();
    let r_rear = params["rR"];
    for v in [0.0, 5.0] {
        // roll, steer rates 0; the rear wheel turns at -v/rR (the benchmark's quasi-velocities)
        let eta: Vec<f64> = (m.choice(Some("benchmark")).unwrap().eta.iter())
            .map(|e| {
                if e.text.contains("rear") {
                    -v / r_rear
                } else {
                    0.0
                }
            })
            .collect();
        let f = forces_dd(&c, &q, &eta, &params);
        eprintln!("v = {v}: {f:?}");
        // the benchmark's figures (ten digits), and Table 1's moments about the rear contact
        assert!(
            (f["front.normal"] / 309.3035294 - 1.0).abs() <= 1e-9,
            "{f:?}"
        );
        assert!(
            (f["rear.normal"] / 612.8364706 - 1.0).abs() <= 1e-9,
            "{f:?}"
        );
        let p = |k: &str| params[k];
        let weight = (p("mR") + p("mB") + p("mH") + p("mF")) * p("g");
        let front = (p("mB") * p("xB") + p("mH") * p("xH") + p("mF") * p("w")) * p("g") / p("w");
        assert!((f["front.normal"] / front - 1.0).abs() <= 1e-13, "{f:?}");
        assert!(
            (f["rear.normal"] / (weight - front) - 1.0).abs() <= 1e-13,
            "{f:?}"
        );
        for k in [
            "front.lateral",
            "front.longitudinal",
            "rear.lateral",
            "rear.longitudinal",
        ] {
            assert!(f[k].abs() <= 1e-9, "{k}: {f:?}");
        }
    }
}

/// The centre of mass of the rolling disk, its centre a distance `e` (in the disk's plane, turning
/// with the spin ψ) from the geometric centre: C + Rz(φ) Rx(−θ) ([0, 0, R] + Ry(ψ) [e, 0, 0]).
const DISK_CENTRE_OF_MASS: [&str; 3] = [
    "xC + e*cos(psi)*cos(phi) - (R - e*sin(psi))*sin(theta)*sin(phi)",
    "yC + e*cos(psi)*sin(phi) + (R - e*sin(psi))*sin(theta)*cos(phi)",
    "(R - e*sin(psi))*cos(theta)",
];

/// Newton's law for the one body of a rolling disk: along an RK4 trajectory, the contact force
/// (longitudinal along the heading (cos φ, sin φ, 0), lateral along (−sin φ, cos φ, 0), normal
/// up) is m(a_G + g up), with a_G = J_G q̈ + q̇ᵀ∇²G q̇ from the evaluation's own q̈.
fn newton_along_a_trajectory(path: &str) -> f64 {
    let m = Model::load(format!("{}/{path}", env!("CARGO_MANIFEST_DIR"))).unwrap();
    let d = derive(&m.with_supports().unwrap(), Some("velocities")).unwrap();
    let c = d.compile_with_constraint_forces().unwrap();
    let mut params = d.parameters.clone();
    params.entry("e".into()).or_insert(0.0);
    let coords = d.coordinates.clone();
    let g: Vec<hamel_expr::Expr> = (DISK_CENTRE_OF_MASS.iter())
        .map(|t| hamel_expr::parse(t).unwrap().expr)
        .collect();
    let mut worst = 0.0_f64;
    let (mut q, mut eta) = (vec![0.3, -0.2, 0.4, 0.1, 0.35], vec![0.8, -12.0, 0.3]);
    let h = 0.005;
    for step in 0..200 {
        if step % 20 == 0 {
            worst = worst.max(newton_residual(&c, &g, &coords, &q, &eta, &params));
        }
        rk4(&c, &mut q, &mut eta, &params, h);
    }
    worst
}

/// |F_contact − m(a_G + g up)| / (m g) at one state.
fn newton_residual(
    c: &hamel_derive::Compiled,
    g: &[hamel_expr::Expr],
    coords: &[String],
    q: &[f64],
    eta: &[f64],
    params: &IndexMap<String, f64>,
) -> f64 {
    let (qx, etax) = (dd(q), dd(eta));
    let cf = c.constraint_force::<DD>(&qx, &etax, params).unwrap();
    let f = forces_dd(c, q, eta, params);
    let (qd, qdd): (Vec<f64>, Vec<f64>) = (
        cf.q_dot.iter().map(|x| x.value()).collect(),
        cf.q_ddot.iter().map(|x| x.value()).collect(),
    );
    let point = hamel_bodies::Point::at(coords, q, params);
    let value = |e: &hamel_expr::Expr| point.value(e).unwrap();
    let a_g: Vec<f64> = (g.iter())
        .map(|gi| {
            let mut a = 0.0;
            for (j, qj) in coords.iter().enumerate() {
                let dj = gi.diff(qj).unwrap();
                a += value(&dj) * qdd[j];
                for (k, qk) in coords.iter().enumerate() {
                    a += value(&dj.diff(qk).unwrap()) * qd[j] * qd[k];
                }
            }
            a
        })
        .collect();
    let phi = q[coords.iter().position(|x| x == "phi").unwrap()];
    let (long, lat, normal) = (f["disk.longitudinal"], f["disk.lateral"], f["disk.normal"]);
    let contact = [
        long * phi.cos() - lat * phi.sin(),
        long * phi.sin() + lat * phi.cos(),
        normal,
    ];
    let (mass, gravity) = (params["m_d"], params["g"]);
    let newton = [mass * a_g[0], mass * a_g[1], mass * (a_g[2] + gravity)];
    (0..3).fold(0.0_f64, |w, i| w.max((contact[i] - newton[i]).abs())) / (mass * gravity)
}

/// One classical Runge–Kutta step of (q̇, η̇) = (Γη, η̇) in f64.
fn rk4(
    c: &hamel_derive::Compiled,
    q: &mut [f64],
    eta: &mut [f64],
    p: &IndexMap<String, f64>,
    h: f64,
) {
    let f = |q: &[f64], eta: &[f64]| {
        let r = c.rhs::<f64>(q, eta, p).unwrap();
        (r.q_dot, r.eta_dot)
    };
    let shifted = |x: &[f64], k: &[f64], a: f64| -> Vec<f64> {
        x.iter().zip(k).map(|(x, k)| x + a * k).collect()
    };
    let (k1q, k1e) = f(q, eta);
    let (k2q, k2e) = f(&shifted(q, &k1q, h / 2.0), &shifted(eta, &k1e, h / 2.0));
    let (k3q, k3e) = f(&shifted(q, &k2q, h / 2.0), &shifted(eta, &k2e, h / 2.0));
    let (k4q, k4e) = f(&shifted(q, &k3q, h), &shifted(eta, &k3e, h));
    for i in 0..q.len() {
        q[i] += h / 6.0 * (k1q[i] + 2.0 * k2q[i] + 2.0 * k3q[i] + k4q[i]);
    }
    for i in 0..eta.len() {
        eta[i] += h / 6.0 * (k1e[i] + 2.0 * k2e[i] + 2.0 * k3e[i] + k4e[i]);
    }
}

#[test]
fn a_rolling_body_obeys_newton_with_its_contact_force() {
    for path in [
        "models/bodies/rolling_disk_bodies.toml",
        "tests/models/eccentric_disk.toml",
    ] {
        let worst = newton_along_a_trajectory(path);
        eprintln!("{path}: |F − m(a_G + g up)| / mg ≤ {worst:.1e}");
        assert!(worst <= 1e-9, "{path}: {worst:.1e}");
    }
}

/// The rolling disc's contact force against SymPy's tutorial "A rolling disc, with Kane's method
/// and constraint forces" (bench/sympy_rolling_disc_forces.py: auxiliary speeds at the contact,
/// KanesMethod's auxiliary equations solved for f1, f2, f3), at its random states: f1 along the
/// heading is `disk.longitudinal`, f2 across it `disk.lateral`, f3 up `disk.normal`. The
/// tutorial's lean q2 is about +x, the model's theta about −x. Skips, saying so, without SymPy.
#[test]
fn the_rolling_disc_agrees_with_sympys_auxiliary_equations() {
    let script = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/bench/sympy_rolling_disc_forces.py"
    );
    let out = std::process::Command::new("python3")
        .args([script, "20", "58"])
        .output();
    let out = match out {
        Ok(o) if o.status.success() => o,
        _ => {
            eprintln!("SKIPPED: python3 with sympy is needed (pip install sympy)");
            return;
        }
    };
    let m = Model::load(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/models/bodies/rolling_disk_bodies.toml"
    ))
    .unwrap();
    let d = derive(&m.with_supports().unwrap(), Some("velocities")).unwrap();
    let c = d.compile_with_constraint_forces().unwrap();
    let mut worst = 0.0_f64;
    let lines = String::from_utf8(out.stdout).unwrap();
    for line in lines.lines() {
        let s: serde_json::Value = serde_json::from_str(line).unwrap();
        let num = |v: &serde_json::Value| v.as_f64().unwrap();
        let (q, qd, p, f) = (&s["q"], &s["qdot"], &s["params"], &s["f"]);
        let state = [0.0, 0.0, num(&q[0]), num(&q[2]), -num(&q[1])];
        let eta = [num(&qd[0]), num(&qd[2]), -num(&qd[1])];
        let params = IndexMap::from([
            ("R".to_string(), num(&p["r"])),
            ("m_d".to_string(), num(&p["m"])),
            ("g".to_string(), num(&p["g"])),
        ]);
        let ours = forces_dd(&c, &state, &eta, &params);
        let theirs = [num(&f[0]), num(&f[1]), num(&f[2])];
        let scale = theirs.iter().fold(0.0_f64, |a, x| a.max(x.abs()));
        for (k, t) in ["disk.longitudinal", "disk.lateral", "disk.normal"]
            .iter()
            .zip(theirs)
        {
            worst = worst.max((ours[*k] - t).abs() / scale);
        }
    }
    eprintln!("rolling disc against SymPy, 20 states: {worst:.1e}");
    assert!(worst <= 1e-12, "{worst:.1e}");
}

/// Every reported force is a function of the motion, not of which multipliers solve the
/// Lagrange form: reported from the oracle's solution (its own q̈ and λ, which with dependent
/// rows differ from hamel's by null vectors of αᵀ), each value equals hamel's. For models with
/// dependent rows this checks the exact uniqueness decisions (crates/hamel-derive/src/
/// uniqueness.rs): a value wrongly claimed determined would differ. `expect`: names that must
/// be reported.
fn reported_as_the_oracle_would(path: &str, choice: &str, expect: &[&str]) -> f64 {
    let m = Model::load(format!("{}/{path}", env!("CARGO_MANIFEST_DIR"))).unwrap();
    let d = derive(&m.with_supports().unwrap(), Some(choice)).unwrap();
    let c = d.compile_with_constraint_forces().unwrap();
    let names = c.constraint_force_names();
    for e in expect {
        assert!(names.iter().any(|n| n == e), "{path}: no {e} in {names:?}");
    }
    let nm = NumericModel::new(&m, &IndexMap::new()).unwrap();
    let params = d.parameters.clone();
    let rows: Vec<&str> = d.row_names();
    let order: Vec<usize> = (m.all_rows().iter())
        .map(|(n, _, _)| rows.iter().position(|r| r == n).unwrap())
        .collect();
    let mut rng = ChaCha8Rng::seed_from_u64(60);
    let (mut worst, mut done) = (0.0_f64, 0);
    while done < 12 {
        let mut q: Vec<f64> = (0..d.ell).map(|_| rng.random_range(-1.0..1.0)).collect();
        if m.completion.complete(&mut q, &params).is_err()
            || c.condition(&q, &params).unwrap() > 1e4
        {
            continue;
        }
        let v: Vec<f64> = (0..d.ell).map(|_| rng.random_range(-2.0..2.0)).collect();
        let eta = allowed_eta(&nm, choice, &q, &v);
        let (qx, etax) = (dd(&q), dd(&eta));
        let ours = c.constraint_forces::<DD>(&qx, &etax, &params).unwrap();
        let own = c.constraint_force::<DD>(&qx, &etax, &params).unwrap();
        let oracle = hamel_oracle::accelerations::<DD>(&nm, &qx, &own.q_dot).unwrap();
        let mut lambda = vec![DD::from_f64(0.0); rows.len()];
        for (i, &k) in order.iter().enumerate() {
            lambda[k] = -oracle.lambda[i];
        }
        let theirs = hamel_derive::ConstraintForce {
            generalised: own.generalised.clone(),
            multipliers: lambda,
            q_dot: own.q_dot.clone(),
            q_ddot: oracle.q_ddot.clone(),
        };
        let theirs = c.constraint_forces_from(&qx, &params, &theirs).unwrap();
        let scale = ours
            .iter()
            .fold(1.0_f64, |a, f| a.max(f.value.value().abs()));
        for (a, b) in ours.iter().zip(&theirs) {
            worst = worst.max((a.value - b.value).value().abs() / scale);
        }
        done += 1;
    }
    worst
}

#[test]
fn every_reported_force_is_the_oracles() {
    for (path, choice, expect) in [
        (
            "models/whipple_bicycle.toml",
            "benchmark",
            &["rear.normal", "front.normal"][..],
        ),
        (
            "models/bodies/unicycle_rider_bodies.toml",
            "velocities",
            &["disk.normal"][..],
        ),
        (
            "models/bodies/chaplygin_sleigh_bodies.toml",
            "paper_style",
            &["runner.lateral"][..],
        ),
        (
            "models/sprung_sleigh.toml",
            "forward",
            &["runner.lateral"][..],
        ),
        (
            "models/diff_drive.toml",
            "wheels",
            &[
                "left.longitudinal",
                "right.longitudinal",
                "left+right.lateral",
                "castor.normal",
            ][..],
        ),
        (
            "models/segway.toml",
            "body",
            &["left+right.lateral", "left.normal"][..],
        ),
        ("tests/models/ackermann_car.toml", "drive", &[][..]),
    ] {
        let worst = reported_as_the_oracle_would(path, choice, expect);
        eprintln!("{path}: hamel's forces against the oracle's solution: {worst:.1e}");
        assert!(worst <= 1e-20, "{path}: {worst:.1e}");
    }
}
