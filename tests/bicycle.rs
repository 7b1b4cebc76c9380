//! The Whipple bicycle from its bodies: the nonlinear benchmark of Basu-Mandal, Chatterjee &
//! Papadopoulos (2007, Table 1), a state with large lean and steer and its accelerations,
//! reproduced to 1e-10 from `models/whipple_bicycle.toml` with the benchmark parameters:
//! by the Lagrange-multiplier oracle straight from the T, U and α hamel derives from the bodies,
//! and by the Boltzmann–Hamel equations. Then simulations: started on the capsize mode of the
//! benchmark's published linear equations (Meijaard et al. 2007), the bicycle follows it; the
//! bundled scene at 5 m/s stays upright, on its front contact at round-off.
//!
//! Basu-Mandal's coordinates are converted to the model's (Moore's, with the pitch measured from
//! upright) by the exact formulas of Moore's DynamicistToolKit (`basu_to_moore_input`): roll =
//! π/2 − ψ, pitch = π − φ, steer = −ψ_f, yaw = −θ, wheel angles −β, and their rates and
//! accelerations likewise (docs/design/whipple-bicycle-research.md §2). The CAS runs in-process on
//! its one worker thread.

use hamel_derive::derive;
use hamel_expr::{Dual, Scalar};
use hamel_model::{Model, NumericModel};

fn bicycle() -> Model {
    Model::load(format!(
        "{}/models/whipple_bicycle.toml",
        env!("CARGO_MANIFEST_DIR")
    ))
    .unwrap_or_else(|e| panic!("{e}"))
}

/// Basu-Mandal Table 1: (q, q̇, q̈) of ψ (lean from the horizontal), φ (rear frame pitch), ψ_f
/// (steer), θ (yaw), β_r, β_f (wheel rotations).
struct Basu {
    psi: [f64; 3],
    phi: [f64; 3],
    psi_f: [f64; 3],
    theta: [f64; 3],
    beta_r: [f64; 3],
    beta_f: [f64; 3],
}

const BASU: Basu = Basu {
    psi: [0.9501292851472, 0.6068425835418, -7.8555281128244],
    phi: [3.1257073014894, -0.0119185528069, 0.1205543897884],
    psi_f: [0.2311385135743, 0.4859824687093, -4.6198904039403],
    theta: [0.0, 0.7830033527065, 0.8353281706379],
    beta_r: [0.0, 8.9129896614890, 1.8472554144217],
    beta_f: [0.0, 8.0133620584155, 2.4548072904550],
};

/// In the model's order (x, y, yaw, roll, pitch, steer, rear_wheel, front_wheel), Basu's
/// values of one order of derivative; x and y (the rear contact) are filled in by the caller.
fn moore(order: usize) -> [f64; 8] {
    let b = &BASU;
    let (roll, pitch) = if order == 0 {
        (
            std::f64::consts::FRAC_PI_2 - b.psi[0],
            std::f64::consts::PI - b.phi[0],
        )
    } else {
        (-b.psi[order], -b.phi[order])
    };
    [
        0.0,
        0.0,
        -b.theta[order],
        roll,
        pitch,
        -b.psi_f[order],
        -b.beta_r[order],
        -b.beta_f[order],
    ]
}

/// |got − want| / max(|want|, 1) ≤ tol; prints it (`--nocapture` shows the table).
fn close(what: &str, got: f64, want: f64, tol: f64) {
    let error = (got - want).abs() / want.abs().max(1.0);
    eprintln!("{what:>28}: {got:>22.15e}  relative difference {error:.1e}");
    assert!(
        error <= tol,
        "{what}: hamel {got:.15e}, Basu-Mandal {want:.15e}"
    );
}

/// The configuration: Basu's, the rear contact from his rear-wheel centre, the pitch completed
/// from the front contact (checked against his to 1e-12).
fn configuration(model: &Model) -> [f64; 8] {
    let params = &model.parameters;
    let mut q = moore(0);
    q[1] = -params["rR"] * BASU.psi[0].cos();
    let tabulated_pitch = q[4];
    model.completion.complete(&mut q, params).unwrap();
    close("pitch", q[4], tabulated_pitch, 1e-12);
    q
}

/// Basu's ẍ, ÿ of the rear wheel centre from the rear contact's (Moore's `moore_to_basu`).
fn check_centre_acceleration(q: &[f64], q_dot: &[f64], q_ddot: &[f64], rr: f64) {
    let (s3, c3, s4, c4) = (q[2].sin(), q[2].cos(), q[3].sin(), q[3].cos());
    let (u3, u4, u3p, u4p) = (q_dot[2], q_dot[3], q_ddot[2], q_ddot[3]);
    let x_ddot = rr
        * (-s3 * s4 * u3 * u3 + 2.0 * c3 * c4 * u3 * u4 + c3 * s4 * u3p - s3 * s4 * u4 * u4
            + s3 * c4 * u4p)
        - q_ddot[0];
    let y_ddot = q_ddot[1]
        - rr * (c3 * s4 * u3 * u3 + 2.0 * s3 * c4 * u3 * u4 + s3 * s4 * u3p + c3 * s4 * u4 * u4
            - c3 * c4 * u4p);
    close("x acceleration", x_ddot, -0.5041626315047, 1e-10);
    close("y acceleration", y_ddot, -0.3449706619454, 1e-10);
}

/// The rates of x, y, yaw, pitch and the front wheel from α q̇ = 0, given the benchmark's
/// independent ones (roll, steer, rear wheel).
fn velocities(nm: &NumericModel, q: &[f64]) -> Vec<f64> {
    let alpha = nm.constraint_matrix::<f64>(q).unwrap();
    let given = moore(1);
    let (independent, dependent) = ([3, 5, 6], [0, 1, 2, 4, 7]);
    let a: Vec<Vec<f64>> = alpha
        .iter()
        .map(|row| dependent.iter().map(|&j| row[j]).collect())
        .collect();
    let b: Vec<f64> = alpha
        .iter()
        .map(|row| -independent.iter().map(|&j| row[j] * given[j]).sum::<f64>())
        .collect();
    let solved = hamel_expr::solve(a, b).expect("the constraints determine the dependent rates");
    let mut q_dot = given.to_vec();
    for (k, v) in dependent.iter().zip(solved) {
        q_dot[*k] = v;
    }
    q_dot
}

/// The oracle, from the bodies' T, U and α alone: Basu-Mandal's rates and accelerations.
#[test]
fn basu_mandal_table_one_by_the_oracle() {
    let model = bicycle();
    let nm = NumericModel::new(&model, &Default::default()).unwrap();
    let q = configuration(&model);
    let q_dot = velocities(&nm, &q);
    let rates = moore(1);
    for (k, name) in [(2, "yaw rate"), (4, "pitch rate"), (7, "front wheel rate")] {
        close(name, q_dot[k], rates[k], 1e-10);
    }
    let q_ddot = hamel_oracle::accelerations::<f64>(&nm, &q, &q_dot)
        .unwrap()
        .q_ddot;
    let acc = moore(2);
    for k in 2..8 {
        close(
            &format!("{} acceleration", model.coordinates[k]),
            q_ddot[k],
            acc[k],
            1e-10,
        );
    }
    check_centre_acceleration(&q, &q_dot, &q_ddot, model.parameters["rR"]);
}

/// The same from hamel's Boltzmann–Hamel equations in the benchmark's quasi-velocities.
#[test]
fn basu_mandal_table_one() {
    let model = bicycle();
    let params = model.parameters.clone();
    let rr = params["rR"];
    let d = derive(&model, Some("benchmark")).unwrap_or_else(|e| panic!("{e}"));
    let c = d.compile().unwrap_or_else(|e| panic!("{e}"));
    let q = configuration(&model);
    // η = (roll rate, steer rate, rear wheel rate)
    let rates = moore(1);
    let eta = [rates[3], rates[5], rates[6]];
    let ev = c
        .evaluate(&q, &eta, &params)
        .unwrap_or_else(|e| panic!("{e}"));
    // the velocities that follow from the constraints
    for (k, name) in [(2, "yaw rate"), (4, "pitch rate"), (7, "front wheel rate")] {
        close(name, ev.q_dot[k], rates[k], 1e-10);
    }
    // the accelerations: η̇ directly, the others from q̈ = Γη̇ + Γ̇η
    let acc = moore(2);
    for (s, k) in [(0, 3), (1, 5), (2, 6)] {
        close(
            &format!("{} acceleration", model.coordinates[k]),
            ev.eta_dot[s],
            acc[k],
            1e-10,
        );
    }
    let qdual: Vec<Dual<f64>> = q
        .iter()
        .zip(&ev.q_dot)
        .map(|(&v, &dv)| Dual::new(v, dv))
        .collect();
    let gamma = c.gamma::<Dual<f64>>(&qdual, &params).unwrap();
    let q_ddot: Vec<f64> = (0..8)
        .map(|k| {
            (0..3).fold(0.0, |a, s| {
                a + gamma[k][s].d * eta[s] + gamma[k][s].v.value() * ev.eta_dot[s]
            })
        })
        .collect();
    for (k, name) in [(2, "yaw"), (4, "pitch"), (7, "front wheel")] {
        close(&format!("{name} acceleration"), q_ddot[k], acc[k], 1e-10);
    }
    check_centre_acceleration(&q, &ev.q_dot, &q_ddot, rr);
}

/// The structured reduction: x, y and both wheel angles are of type (A) (31) and Z avoids
/// them, so they drop out exactly; the yaw drops out by the rotation about the vertical, checked
/// exactly; the roll is proved present by a certified derivative.
#[test]
fn the_bicycle_drops_its_position_heading_and_wheel_angles() {
    let model = bicycle();
    let names = |v: &[&str]| v.iter().map(|s| s.to_string()).collect::<Vec<_>>();
    let all = names(&["x", "y", "yaw", "rear_wheel", "front_wheel"]);
    let r = hamel_reduce::reduce(&model, Some("benchmark"), &all).unwrap_or_else(|e| panic!("{e}"));
    let gt = &r.ground_truth;
    assert_eq!(gt.absent, all);
    assert!(gt.present.is_empty() && gt.undecided.is_empty() && gt.kinematics_closed);
    assert!(
        r.findings
            .iter()
            .any(|f| f.contains("symmetry `vertical_rotation`") && f.ends_with("free of yaw")),
        "{:?}",
        r.findings
    );
    let reduced = r.reduced_system.expect("a reduced system");
    assert_eq!(
        reduced.state,
        names(&["eta1", "eta2", "eta3", "roll", "pitch", "steer"])
    );
    // Keeping x and y: the yaw is still absent from (11), but the rates of x and y, which the
    // rotation moves, contain it.
    let r = hamel_reduce::reduce(&model, Some("benchmark"), &names(&["yaw"])).unwrap();
    assert_eq!(r.ground_truth.absent, names(&["yaw"]));
    assert!(!r.ground_truth.kinematics_closed && r.reduced_system.is_none());
    // A claimed symmetry that is not one is rejected by the exact check, and proves nothing.
    let text = format!("{}\n[symmetries.bogus]\nroll = \"1\"\n", model.source);
    let mut bogus = Model::from_source(&model.file, &text).unwrap();
    bogus.symmetries.retain(|s| s.name == "bogus");
    let r = hamel_reduce::reduce(&bogus, Some("benchmark"), &names(&["yaw"])).unwrap();
    assert_eq!(r.ground_truth.undecided, names(&["yaw"]));
    assert!(
        r.findings
            .iter()
            .any(|f| f.contains("`bogus`") && f.contains("is not a symmetry")),
        "{:?}",
        r.findings
    );
    assert!(r.structure.is_none() && r.hypotheses.is_empty());
    let r = hamel_reduce::reduce(&model, Some("benchmark"), &names(&["roll"])).unwrap();
    assert_eq!(r.ground_truth.present, names(&["roll"]));
    let w = &r.ground_truth.occurrences[0];
    assert_eq!(w.object, "eta_dot");
    assert!(w.note.contains("certified nonzero"), "{}", w.note);
}

/// The benchmark's published linear equations about upright straight running (Meijaard et al.
/// 2007, eq. (5.4)), q = (roll, steer): M q̈ + v C1 q̇ + (g K0 + v² K2) q = 0. An independent
/// oracle for the nonlinear equations hamel derives from the bodies.
const M: [[f64; 2]; 2] = [
    [80.81722, 2.31941332208709],
    [2.31941332208709, 0.29784188199686],
];
const C1: [[f64; 2]; 2] = [
    [0.0, 33.86641391492494],
    [-0.85035641456978, 1.68540397397560],
];
const K0: [[f64; 2]; 2] = [
    [-80.95, -2.59951685249872],
    [-2.59951685249872, -0.80329488458618],
];
const K2: [[f64; 2]; 2] = [[0.0, 76.59734589573222], [0.0, 2.65431523794604]];

/// The capsize mode at speed v (its real eigenvalue, the largest real part): λ and the steer
/// per unit roll of its eigenvector.
fn capsize_mode(v: f64) -> (f64, f64) {
    let g = 9.81;
    let k = |i: usize, j: usize| g * K0[i][j] + v * v * K2[i][j];
    let minv = nalgebra::Matrix2::new(M[0][0], M[0][1], M[1][0], M[1][1])
        .try_inverse()
        .unwrap();
    let stiff = minv * nalgebra::Matrix2::new(k(0, 0), k(0, 1), k(1, 0), k(1, 1));
    let damp = minv * nalgebra::Matrix2::new(C1[0][0], C1[0][1], C1[1][0], C1[1][1]) * v;
    let mut a = nalgebra::Matrix4::zeros();
    a[(0, 2)] = 1.0;
    a[(1, 3)] = 1.0;
    for i in 0..2 {
        for j in 0..2 {
            a[(2 + i, j)] = -stiff[(i, j)];
            a[(2 + i, 2 + j)] = -damp[(i, j)];
        }
    }
    let lambda = a
        .complex_eigenvalues()
        .iter()
        .filter(|z| z.im.abs() < 1e-9)
        .map(|z| z.re)
        .fold(f64::NEG_INFINITY, f64::max);
    // (M λ² + v C1 λ + K) (1, s) = 0, first row.
    let p = |j: usize| M[0][j] * lambda * lambda + v * C1[0][j] * lambda + k(0, j);
    (lambda, -p(0) / p(1))
}

/// A scene of the bicycle at 5 m/s: the model by absolute path, the initial roll, steer and
/// their rates as given (pitch completed from the front contact), written to a temporary file.
fn scene(name: &str, roll: f64, steer: f64, rates: (f64, f64), t_end: f64) -> std::path::PathBuf {
    let dir = std::env::temp_dir().join(format!("hamel-bicycle-{}-{name}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("scene.toml");
    let text = format!(
        "model = \"{}/models/whipple_bicycle.toml\"\neta = \"benchmark\"\nt_end = {t_end}\noutputs = 101\n\
         request = [\"roll\", \"steer\", \"pitch\", \"energy\", \"constraint_residual\"]\n\
         [initial]\nq = {{ x = 0.0, y = 0.0, yaw = 0.0, roll = {roll:e}, steer = {steer:e}, rear_wheel = 0.0, front_wheel = 0.0 }}\n\
         eta = [{:e}, {:e}, {:e}]\n[integrator]\nmethod = \"dop853\"\nrtol = 1e-12\natol = 1e-14\n",
        env!("CARGO_MANIFEST_DIR"),
        rates.0,
        rates.1,
        -5.0 / 0.3
    );
    std::fs::write(&path, text).unwrap();
    path
}

fn run(path: &std::path::Path) -> hamel_run::Trajectory {
    let hamel_run::simulate::Simulated {
        trajectory: t,
        failure,
        ..
    } = hamel_run::simulate::run(path, hamel_run::Engine::Interpreted, false)
        .unwrap_or_else(|e| panic!("{e}"));
    assert!(failure.is_none() && t.complete, "{failure:?}");
    t
}

/// Started on the capsize eigenvector of the published linear equations at 5 m/s, with a roll
/// of 1e-4, the nonlinear bicycle follows roll(t) = 1e-4·e^{λt} and steer = s·roll, as the
/// linear theory says, over 5 s: roll to 1e-6 relative (2e-8 measured; the nonlinear terms
/// are cubic, the bicycle being mirror-symmetric), the steer ratio to 1e-5 (2.5e-6 at worst,
/// at outputs read from DOP853's continuous extension). The pitch is completed from the front contact, the state projected
/// back onto it after every step, and h, α q̇ and the energy are kept at round-off.
#[test]
fn the_bicycle_follows_the_benchmarks_linear_capsize_mode() {
    let (lambda, s) = capsize_mode(5.0);
    assert!(lambda < 0.0 && lambda > -1.0, "capsize eigenvalue {lambda}");
    let eps = 1e-4;
    let t = run(&scene(
        "capsize",
        eps,
        eps * s,
        (lambda * eps, lambda * eps * s),
        5.0,
    ));
    let (roll, steer) = (&t.q["roll"], &t.q["steer"]);
    for (i, &ti) in t.t.iter().enumerate() {
        let linear = eps * (lambda * ti).exp();
        let rel = (roll[i] / linear - 1.0).abs();
        assert!(
            rel <= 1e-6,
            "t = {ti}: roll {} vs linear {linear} ({rel:e})",
            roll[i]
        );
        let ratio = (steer[i] / roll[i] - s).abs() / s.abs();
        assert!(
            ratio <= 1e-5,
            "t = {ti}: steer/roll {} vs {s} ({ratio:e}), roll {rel:e}",
            steer[i] / roll[i]
        );
    }
    let completed = &t.initial_completion;
    assert_eq!(completed.len(), 1);
    assert_eq!(completed[0].coordinate, "pitch");
    assert!(completed[0].given.is_none() && completed[0].value != 0.0);
    let h = t.stats.holonomic.expect("projected onto the front contact");
    assert!(h.projections > 0 && h.at_outputs <= 1e-15, "{h:?}");
    assert!(
        t.stats.constraint_drift.unwrap() <= 1e-13,
        "{:?}",
        t.stats.constraint_drift
    );
    // The steer and pedal torques are forces (at zero here): the balance E − W is monitored.
    assert!(t.stats.energy_drift.is_none());
    assert!(
        t.stats.energy_balance_drift.unwrap() <= 1e-11,
        "{:?}",
        t.stats.energy_balance_drift
    );
}

/// scenes/whipple_bicycle.toml: at 5 m/s, inside the self-stable range, a lean of 0.05 rad dies
/// out and the bicycle stays upright; h and α q̇ stay at round-off.
#[test]
fn the_bundled_scene_stays_upright() {
    let t = run(std::path::Path::new(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/scenes/whipple_bicycle.toml"
    )));
    let roll = &t.q["roll"];
    let largest = roll.iter().fold(0.0_f64, |m, r| m.max(r.abs()));
    assert!(largest < 0.1, "the lean grows to {largest}");
    assert!(
        roll.last().unwrap().abs() < 0.1 * roll[0],
        "{:?}",
        roll.last()
    );
    let h = t.stats.holonomic.expect("projected onto the front contact");
    assert!(
        h.at_outputs <= 1e-15 && h.before_projection <= 1e-12,
        "{h:?}"
    );
    assert!(t.stats.constraint_drift.unwrap() <= 1e-13);
}
