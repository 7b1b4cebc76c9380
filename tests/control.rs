//! Inputs driven by a scene (issue 57, part 3): control laws closed into the forces, laws of
//! the time, and inputs read from tables.
//! * the closed loops (an LQR law of the Segway, a path follower of the differential-drive
//!   robot, a law of the time) against the independent Lagrange-multiplier oracle, which reads
//!   the law through the forces F(q, q̇) of the closed-loop model;
//! * the bundled scenes do what their laws are for: the Segway and the bicycle are balanced,
//!   the robot settles onto its circle; the motors' work keeps E − W at E(0);
//! * a law of the time and a dense table of the same function give the same motion;
//! * the gains are parameters: an ensemble over a gain changes the motion.

mod common;

use std::path::{Path, PathBuf};

use common::oracle::compare;
use hamel_model::{Control, Law, Model};
use hamel_run::{Engine, Trajectory};
use indexmap::IndexMap;

fn root() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

fn load(path: &str) -> Model {
    Model::load(root().join(path)).unwrap_or_else(|e| panic!("{e}"))
}

fn law(input: &str, text: &str) -> Law {
    Law {
        input: input.into(),
        text: text.into(),
    }
}

fn control(gains: &[(&str, f64)], laws: Vec<Law>) -> Control {
    Control {
        gains: gains.iter().map(|(k, v)| (k.to_string(), *v)).collect(),
        laws,
        tabled: Vec::new(),
    }
}

/// Run a scene on the interpreted evaluator; it must complete.
fn run(scene: &Path) -> Trajectory {
    let hamel_run::simulate::Simulated {
        trajectory: t,
        failure,
        ..
    } = hamel_run::simulate::run(scene, Engine::Interpreted, false)
        .unwrap_or_else(|e| panic!("{e}"));
    assert!(failure.is_none() && t.complete, "{}", scene.display());
    t
}

/// max |v(t)| over the output times t ≥ `from`.
fn max_after(t: &Trajectory, v: &[f64], from: f64) -> f64 {
    t.t.iter()
        .zip(v)
        .filter(|(t, _)| **t >= from)
        .map(|(_, v)| v.abs())
        .fold(0.0, f64::max)
}

/// max |E − W − E(0)| / |E(0)| along the trajectory (E − W is conserved).
fn balance(t: &Trajectory) -> f64 {
    let energy: Vec<f64> = t
        .energy
        .as_ref()
        .unwrap()
        .iter()
        .map(|e| e.unwrap())
        .collect();
    let work = t.work.as_ref().expect("the motors' work is reported");
    let e0 = energy[0];
    energy
        .iter()
        .zip(work)
        .map(|(e, w)| (e - w - e0).abs() / e0.abs().max(1e-300))
        .fold(0.0, f64::max)
}

fn scratch_dir() -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("control");
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// A scene file written to the test's scratch directory (its model named by absolute path).
fn scratch_scene(name: &str, text: &str) -> PathBuf {
    let path = scratch_dir().join(format!("{name}.toml"));
    std::fs::write(&path, text).unwrap();
    path
}

/// The closed loops are models like any other: η̇ agrees with the oracle to 1e-12 (f64) and
/// 1e-20 (double-double) at random states, for laws of the state (the Segway's LQR, with its
/// η read back through Z(q)q̇), of the position (the robot's path follower, nonlinear in x, y,
/// ψ) and of the time (`t` a live parameter, set by the oracle's sampler like any other).
#[test]
fn closed_loops_match_the_oracle() {
    let segway = load("models/segway.toml");
    let lqr = control(
        &[("k_th", -53.4), ("k_v", -7.1), ("k_w", 0.7), ("k_d", -11.0)],
        vec![
            law("T_L", "-(k_th*theta + k_d*eta1 + k_v*eta2 - k_w*eta3)"),
            law("T_R", "-(k_th*theta + k_d*eta1 + k_v*eta2 + k_w*eta3)"),
        ],
    );
    let robot = load("models/diff_drive.toml");
    let follow = control(
        &[("V", 0.5), ("R", 2.0), ("k", 0.5), ("c", 0.1)],
        vec![
            law(
                "T_L",
                "k*(V - eta1) - c*(V/R + (x*cos(psi) + y*sin(psi))/sqrt(x^2 + y^2) - eta2)",
            ),
            law("T_R", "k*(V - eta1) + c*(V/R + sqrt(x^2 + y^2) - R - eta2)"),
        ],
    );
    let timed = control(
        &[("A", 0.3), ("w", 2.0)],
        vec![law("T_L", "A*sin(w*t)"), law("T_R", "A*cos(w*t)*theta")],
    );
    for (model, choice, c, of_velocities) in [
        (&segway, "body", &lqr, true),
        (&robot, "body", &follow, true),
        (&segway, "body", &timed, false),
    ] {
        let closed = model
            .controlled(c, model.choice(Some(choice)).unwrap())
            .unwrap();
        assert!(
            closed.inputs.is_empty(),
            "{}: the laws drive every input",
            model.name
        );
        assert_eq!(
            closed.has_velocity_forces(),
            of_velocities,
            "{}",
            model.name
        );
        let w = compare(&closed, choice, 57, 30);
        assert!(
            w.structured_f64 <= 1e-12 && w.structured_dd <= 1e-20,
            "{}: f64 {:.1e}, dd {:.1e}",
            model.name,
            w.structured_f64,
            w.structured_dd
        );
    }
    assert_eq!(
        segway
            .controlled(&timed, segway.choice(Some("body")).unwrap())
            .unwrap()
            .live,
        ["t"]
    );
}

/// The bundled control scenes: the Segway's LQR law brings a lean of 0.1 rad back to upright
/// and rest, the bicycle's steer-torque law holds it up below its weave speed, the robot
/// settles onto its circle; along each, E − W stays at E(0) (the motors' work is integrated).
#[test]
fn the_control_scenes_do_what_their_laws_are_for() {
    let segway = run(&root().join("scenes/segway_lqr.toml"));
    let lean = max_after(&segway, &segway.q["theta"], 5.0);
    assert!(lean <= 1e-3, "the Segway leans {lean:.1e} rad after 5 s");
    let speed: Vec<f64> = segway.eta.iter().map(|e| e[1]).collect();
    assert!(
        max_after(&segway, &speed, 5.0) <= 1e-3,
        "the Segway comes to rest"
    );
    assert!(balance(&segway) <= 1e-9, "{:.1e}", balance(&segway));

    let bicycle = run(&root().join("scenes/whipple_bicycle_steer.toml"));
    let roll = max_after(&bicycle, &bicycle.q["roll"], 5.0);
    assert!(roll <= 1e-3, "the bicycle leans {roll:.1e} rad after 5 s");
    assert!(balance(&bicycle) <= 1e-9, "{:.1e}", balance(&bicycle));

    let robot = run(&root().join("scenes/diff_drive_circle.toml"));
    let off: Vec<f64> = robot.expressions["rho"]
        .iter()
        .map(|r| r.unwrap() - 2.0)
        .collect();
    assert!(off[0] > 0.29, "released outside the circle: {}", off[0]);
    let late = max_after(&robot, &off, 10.0);
    assert!(
        late <= 1e-2,
        "the robot is {late:.1e} m off its circle after 10 s"
    );
    let speed: Vec<f64> = robot.eta.iter().map(|e| e[0] - 0.5).collect();
    assert!(max_after(&robot, &speed, 10.0) <= 1e-2);
}

/// The Segway driven open loop by T_L = A sin(w t) (a law of the time) and by a dense cubic
/// table of the same function (T_R = 0 in both): the motions agree to the table's
/// interpolation error, far below the motion itself.
#[test]
fn a_law_of_the_time_and_its_table_give_one_motion() {
    let model = root().join("models/segway.toml");
    let head = format!(
        "model = {model:?}\neta = \"body\"\nt_end = 3.0\noutputs = 31\nrequest = [\"theta\", \"x\"]\n\
         [initial]\nq = {{ x = 0.0, y = 0.0, psi = 0.0, theta = 0.0, phiL = 0.0, phiR = 0.0 }}\n\
         eta = [0.0, 0.0, 0.0]\n[integrator]\nmethod = \"dop853\"\nrtol = 1e-11\natol = 1e-13\n"
    );
    let law = scratch_scene(
        "law",
        &format!("{head}[gains]\nA = 0.2\nw = 3.0\n[inputs]\nT_L = \"A*sin(w*t)\"\nT_R = 0.0\n"),
    );
    let times: Vec<f64> = (0..=600).map(|i| i as f64 * 0.005).collect();
    let values: Vec<f64> = times.iter().map(|t| 0.2 * (3.0 * t).sin()).collect();
    let table = scratch_scene(
        "table",
        &format!(
            "{head}[inputs]\nT_R = 0.0\nT_L = {{ times = {times:?}, values = {values:?}, interpolation = \"cubic\" }}\n"
        ),
    );
    // The same samples from a CSV file beside the scene (the column named as the input).
    let csv: String = std::iter::once("# T_L = 0.2 sin(3 t)\ntime, T_L\n".to_string())
        .chain(
            times
                .iter()
                .zip(&values)
                .map(|(t, v)| format!("{t:?}, {v:?}\n")),
        )
        .collect();
    std::fs::write(scratch_dir().join("torque.csv"), csv).unwrap();
    let file = scratch_scene(
        "file",
        &format!(
            "{head}[inputs]\nT_R = 0.0\nT_L = {{ file = \"torque.csv\", time = \"time\", interpolation = \"cubic\" }}\n"
        ),
    );
    let (a, b) = (run(&law), run(&table));
    assert_eq!(
        run(&file).q["x"],
        b.q["x"],
        "the file's table is the inline one"
    );
    let moved = max_after(&a, &a.q["x"], 0.0);
    assert!(moved > 1e-2, "the torque moves the robot: {moved}");
    for k in ["theta", "x"] {
        let worst = (a.q[k].iter().zip(&b.q[k]))
            .map(|(u, v)| (u - v).abs())
            .fold(0.0, f64::max);
        assert!(worst <= 1e-6 * moved, "{k}: law vs table {worst:.1e}");
    }
}

/// The gains are parameters of the closed loop: `--set` of a gain changes the motion (a weaker
/// speed gain) without changing the scene.
#[test]
fn a_gain_is_a_parameter() {
    let scene = root().join("scenes/segway_lqr.toml");
    let base = run(&scene);
    let weak = IndexMap::from([
        ("K_T_L_eta2".to_string(), -2.0),
        ("K_T_R_eta2".to_string(), -2.0),
    ]);
    let hamel_run::simulate::Simulated {
        trajectory: t,
        failure,
        ..
    } = hamel_run::simulate::run_with(&scene, &weak, Engine::Interpreted, false).unwrap();
    assert!(failure.is_none());
    let lean = max_after(&base, &base.q["theta"], 0.0);
    let apart = (base.q["theta"].iter().zip(&t.q["theta"]))
        .map(|(u, v)| (u - v).abs())
        .fold(0.0, f64::max);
    assert!(
        apart > 1e-3 * lean,
        "the pitch moves by {apart:.1e} of {lean:.1e}"
    );
}
