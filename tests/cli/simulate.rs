//! `hamel simulate` on single scenes: closed forms, requests, initial velocities, inputs, friction.

#[allow(unused_imports)]
use super::*;

#[test]
fn simulate_the_knife_follows_its_closed_form_solution() {
    let dir = scratch("simulate_knife");
    let file = dir.join("knife.json");
    let o = hamel(
        &[
            "simulate",
            "scenes/knife.toml",
            "--format",
            "json",
            "--output",
            file.to_str().unwrap(),
        ],
        None,
    );
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("RHS evaluations, energy drift"),
        "{}",
        stderr(&o)
    );
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&file).unwrap()).unwrap();
    assert_eq!(v["complete"], true);
    let t = v["t"].as_array().unwrap();
    assert_eq!(t.len(), 101);
    // With η = (1, 0.5) constant: θ = 0.3 + t/2, x = 2(sin θ − sin 0.3), y = −2(cos θ − cos 0.3).
    for (j, tj) in t.iter().enumerate() {
        let tj = tj.as_f64().unwrap();
        let th = 0.3 + 0.5 * tj;
        let at = |c: &str| v["q"][c][j].as_f64().unwrap();
        assert!((at("theta") - th).abs() < 1e-9);
        assert!((at("x") - 2.0 * (th.sin() - 0.3f64.sin())).abs() < 1e-9);
        assert!((at("y") + 2.0 * (th.cos() - 0.3f64.cos())).abs() < 1e-9);
    }
    let stats = &v["stats"];
    assert!(stats["steps"].as_u64().unwrap() > 0);
    // --plot: an SVG with both panels and the coordinate names; a bad extension is refused.
    let svg = dir.join("knife.svg");
    let o = hamel(
        &[
            "simulate",
            "scenes/knife.toml",
            "--output",
            dir.join("k.csv").to_str().unwrap(),
            "--plot",
            svg.to_str().unwrap(),
        ],
        None,
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let text = std::fs::read_to_string(&svg).unwrap();
    assert!(text.starts_with("<svg"));
    for label in ["quasi-velocities", "theta", "eta2"] {
        assert!(text.contains(label), "{label} missing from the plot");
    }
    let o = hamel(
        &["simulate", "scenes/knife.toml", "--plot", "/tmp/x.pdf"],
        None,
    );
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).contains(".svg or .png"), "{}", stderr(&o));
    assert!(stats["energy_drift"].as_f64().unwrap() < 1e-12);
    // Not requested: α(q)Γ(q)η is identically zero, computed only when named.
    assert!(stats["constraint_drift"].is_null(), "{stats}");
}

#[test]
fn simulate_stops_at_the_singular_set_and_keeps_what_it_computed() {
    let dir = scratch("simulate_singular");
    let scene = dir.join("bar.toml");
    std::fs::write(
        &scene,
        format!(
            "model = {:?}\neta = \"paper\"\nt_end = 2.0\noutputs = 21\n\
             [initial]\nq = {{ x = 0.0, y = 0.0, theta = 0.0, phi = 1.3 }}\neta = [0.5, 1.0]\n",
            Path::new(env!("CARGO_MANIFEST_DIR"))
                .join("models/bar_blade.toml")
                .display()
                .to_string()
        ),
    )
    .unwrap();
    let csv = dir.join("bar.csv");
    let o = hamel(
        &[
            "simulate",
            scene.to_str().unwrap(),
            "--output",
            csv.to_str().unwrap(),
        ],
        None,
    );
    assert_eq!(o.status.code(), Some(1));
    let e = stderr(&o);
    assert!(e.contains("singular"), "{e}");
    assert!(e.contains("phi = 1.570796"), "{e}");
    // On the way it warns how close the path came: the condition number of [Z; α].
    assert!(
        e.contains("warning: the path comes near the singular set")
            && e.contains("condition number of [Z; α] reaches"),
        "{e}"
    );
    assert!(e.contains("INCOMPLETE"), "{e}");
    let text = std::fs::read_to_string(&csv).unwrap();
    assert!(text.starts_with("# incomplete:"), "{text}");
    // Rows up to the singularity (φ reaches π/2 near t = 0.3): t = 0, 0.1, 0.2.
    assert_eq!(text.lines().count(), 5, "{text}");
}

#[test]
fn simulate_rejects_a_bad_scene_with_the_place_and_reason() {
    let dir = scratch("simulate_bad");
    let scene = dir.join("bad.toml");
    let csv = dir.join("out.csv");
    for (body, expect) in [
        (
            "model = \"../../../../models/knife.toml\"\nt_end = 1\noutputs = 3\n[initial]\nq = { x = 0, y = 0 }\neta = [1, 0]\n",
            "missing coordinate `theta`",
        ),
        (
            "model = \"../../../../models/knife.toml\"\nt_end = 1\noutputs = 3\n[initial]\nq = { x = 0, y = 0, theta = 0 }\neta = [1, 0]\n[integrator]\nmethod = \"euler\"\n",
            "unknown variant `euler`, expected one of `rk4`, `dopri5`, `dop853`, `vern9`, `gauss-legendre`",
        ),
        (
            "model = \"../../../../models/knife.toml\"\nt_end = 1\noutputs = 3\nspeed = 2\n",
            "unknown field `speed`",
        ),
    ] {
        std::fs::write(&scene, body).unwrap();
        let o = hamel(
            &[
                "simulate",
                scene.to_str().unwrap(),
                "--output",
                csv.to_str().unwrap(),
            ],
            None,
        );
        assert_eq!(o.status.code(), Some(1), "{body}");
        assert!(stderr(&o).contains(expect), "{body}: {}", stderr(&o));
        assert!(stderr(&o).contains("bad.toml"), "{}", stderr(&o));
        assert!(!csv.exists(), "no output for a bad scene");
    }
}

#[test]
fn simulate_with_a_request_writes_only_that_and_agrees_with_the_closed_form() {
    let dir = scratch("simulate_request");
    let scene = knife_scene(
        &dir,
        "k.toml",
        "request = [\"theta\"]",
        "[accuracy]\nrtol = 1e-11\natol = 1e-12\n",
    );
    let file = dir.join("k.json");
    let o = hamel(
        &[
            "simulate",
            scene.to_str().unwrap(),
            "--format",
            "json",
            "--output",
            file.to_str().unwrap(),
        ],
        None,
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&file).unwrap()).unwrap();
    let q = v["q"].as_object().unwrap();
    assert_eq!(q.keys().collect::<Vec<_>>(), ["theta"]);
    assert!(v.get("eta").is_none() && v.get("energy").is_none(), "{v}");
    for (j, t) in v["t"].as_array().unwrap().iter().enumerate() {
        let th = 0.3 + 0.5 * t.as_f64().unwrap();
        assert!((v["q"]["theta"][j].as_f64().unwrap() - th).abs() < 1e-9);
    }
    // CSV: the header names only what was requested.
    let o = hamel(&["simulate", scene.to_str().unwrap()], None);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        String::from_utf8_lossy(&o.stdout)
            .lines()
            .any(|l| l == "t,theta"),
        "{}",
        String::from_utf8_lossy(&o.stdout)
    );
}

/// A requested constraint residual is a column at every output (JSON and CSV), rounding only
/// (αΓ = 0), and its largest value is the reported drift.
#[test]
fn simulate_writes_a_requested_constraint_residual_at_every_output() {
    let dir = scratch("simulate_residual");
    let scene = knife_scene(
        &dir,
        "k.toml",
        "request = [\"theta\", \"constraint_residual\"]",
        "",
    );
    let file = dir.join("k.json");
    let args = [
        "simulate",
        scene.to_str().unwrap(),
        "--format",
        "json",
        "--output",
    ];
    let o = hamel(&[&args[..], &[file.to_str().unwrap()]].concat(), None);
    assert!(o.status.success(), "{}", stderr(&o));
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&file).unwrap()).unwrap();
    let residual: Vec<f64> = v["constraint_residual"]
        .as_array()
        .unwrap_or_else(|| panic!("no constraint_residual in {v}"))
        .iter()
        .map(|r| r.as_f64().unwrap())
        .collect();
    assert_eq!(residual.len(), v["t"].as_array().unwrap().len());
    assert!(
        residual.iter().all(|r| (0.0..1e-15).contains(r)),
        "{residual:?}"
    );
    let largest = residual.iter().copied().fold(0.0, f64::max);
    assert_eq!(v["stats"]["constraint_drift"].as_f64(), Some(largest));
    let o = hamel(&["simulate", scene.to_str().unwrap()], None);
    assert!(o.status.success(), "{}", stderr(&o));
    let csv = String::from_utf8_lossy(&o.stdout);
    assert!(
        csv.lines().any(|l| l == "t,theta,constraint_residual"),
        "{csv}"
    );
}

#[test]
fn a_bad_request_or_accuracy_is_an_error_naming_the_scene() {
    let dir = scratch("simulate_bad_request");
    let out = dir.join("out.csv");
    for (top, tables, expect) in [
        (
            "request = [\"speed\"]",
            "",
            "`speed` is not an output of this scene",
        ),
        (
            "",
            "[accuracy]\nrtol = 1e-8\natol = 1e-10\n[integrator]\nmethod = \"rk4\"\nstep = 0.1\n",
            "not both",
        ),
    ] {
        let scene = knife_scene(&dir, "bad.toml", top, tables);
        for cmd in ["plan", "simulate"] {
            let o = hamel(
                &[
                    cmd,
                    scene.to_str().unwrap(),
                    "--output",
                    out.to_str().unwrap(),
                ],
                None,
            );
            assert_eq!(o.status.code(), Some(1), "{cmd} {top} {tables}");
            assert!(stderr(&o).contains(expect), "{}", stderr(&o));
            assert!(stderr(&o).contains("bad.toml"), "{}", stderr(&o));
            assert!(!out.exists(), "no output for a bad scene");
        }
    }
}

/// Initial velocities given as q̇ are projected onto the constraints in the kinetic metric (for
/// the knife: the sideways component of the velocity of the contact point is removed, θ̇ is
/// kept), the correction is reported, and the run starts from η = Z q̇.
#[test]
fn simulate_projects_initial_velocities_given_as_q_dot() {
    let dir = scratch("simulate_q_dot");
    let scene = dir.join("k.toml");
    std::fs::write(
        &scene,
        knife_scene_text("request = [\"x\", \"y\", \"theta\"]").replace(
            "eta = [1.0, 0.5]",
            "q_dot = { x = 1.0, y = 0.5, theta = 0.5 }",
        ),
    )
    .unwrap();
    let file = dir.join("k.json");
    let o = hamel(
        &[
            "simulate",
            scene.to_str().unwrap(),
            "--format",
            "json",
            "--output",
            file.to_str().unwrap(),
        ],
        None,
    );
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("projected onto the constraints"),
        "{}",
        stderr(&o)
    );
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&file).unwrap()).unwrap();
    let p = &v["initial_projection"];
    let (s, c) = 0.3f64.sin_cos();
    let side = s * 1.0 - c * 0.5; // n·v with n = (sin θ, −cos θ)
    let expect = [1.0 - side * s, 0.5 + side * c, 0.5];
    for (k, name) in ["x", "y", "theta"].iter().enumerate() {
        assert!(
            (p["q_dot"][name].as_f64().unwrap() - expect[k]).abs() < 1e-12,
            "{p}"
        );
    }
    assert!(
        (p["correction"].as_f64().unwrap() - side.abs() * c).abs() < 1e-12,
        "{p}"
    );
    assert!(p["kinetic_after"].as_f64().unwrap() < p["kinetic_before"].as_f64().unwrap());
    // The forward speed is the tangential one: x = u (sin θ − sin 0.3)/θ̇ …
    let u = c * 1.0 + s * 0.5;
    for (j, t) in v["t"].as_array().unwrap().iter().enumerate() {
        let th = 0.3 + 0.5 * t.as_f64().unwrap();
        let at = |n: &str| v["q"][n][j].as_f64().unwrap();
        assert!((at("theta") - th).abs() < 1e-9);
        assert!((at("x") - 2.0 * u * (th.sin() - s)).abs() < 1e-8);
        assert!((at("y") + 2.0 * u * (th.cos() - c)).abs() < 1e-8);
    }
    // Both, or neither, is an error.
    for (body, expect) in [
        (
            knife_scene_text("").replace(
                "eta = [1.0, 0.5]",
                "eta = [1.0, 0.5]\nq_dot = { x = 1.0, y = 0.0, theta = 0.0 }",
            ),
            "not both",
        ),
        (
            knife_scene_text("").replace("eta = [1.0, 0.5]", "q_dot = { x = 1.0, theta = 0.0 }"),
            "missing the velocity of `y`",
        ),
    ] {
        std::fs::write(&scene, body).unwrap();
        let o = hamel(&["simulate", scene.to_str().unwrap()], None);
        assert_eq!(o.status.code(), Some(1));
        assert!(stderr(&o).contains(expect), "{}", stderr(&o));
    }
}

/// A loose tolerance still returns the trajectory, with its global error estimated by a check
/// run (and said on stderr); `--estimate-error` does the same for any setting. The estimate is
/// compared with the knife's true error (closed form: θ = θ₀ + η₂t, x = (η₁/η₂)(sin θ − sin θ₀),
/// y = −(η₁/η₂)(cos θ − cos θ₀)).
#[test]
fn loose_tolerances_return_a_result_with_its_error_estimate() {
    let dir = scratch("loose");
    let true_error = |v: &serde_json::Value| {
        let mut e = 0.0_f64;
        for (j, t) in v["t"].as_array().unwrap().iter().enumerate() {
            let th = 0.3 + 0.5 * t.as_f64().unwrap();
            let exact = [
                ("x", 2.0 * (th.sin() - 0.3f64.sin())),
                ("y", -2.0 * (th.cos() - 0.3f64.cos())),
                ("theta", th),
            ];
            for (name, x) in exact {
                let got = v["q"][name][j].as_f64().unwrap();
                e = e.max((got - x).abs() / x.abs().max(1.0));
            }
        }
        e
    };
    for (integrator, flag, loose) in [
        ("method = \"dop853\"\nrtol = 0.1\natol = 0.1\n", None, true),
        (
            "method = \"dopri5\"\nrtol = 1e-2\natol = 1e-2\n",
            None,
            true,
        ),
        (
            "method = \"rk4\"\nstep = 0.25\n",
            Some("--estimate-error"),
            false,
        ),
    ] {
        let scene = knife_scene(&dir, "k.toml", "", &format!("[integrator]\n{integrator}"));
        let mut args = vec!["simulate", scene.to_str().unwrap(), "--format", "json"];
        args.extend(flag);
        let o = hamel(&args, None);
        assert!(o.status.success(), "{}", stderr(&o));
        assert_eq!(stderr(&o).contains("is loose"), loose, "{}", stderr(&o));
        let v = json_on_stdout(&o);
        assert_eq!(v["complete"], true);
        let estimate = v["stats"]["error_estimate"].as_f64().expect("an estimate");
        let truth = true_error(&v);
        assert!(
            truth > 1e-9,
            "{integrator}: the run is not loose ({truth:e})"
        );
        assert!(
            (0.5 * truth..=2.0 * truth).contains(&estimate),
            "{integrator}: estimate {estimate:e}, true error {truth:e}"
        );
    }
    // Without the flag, a tight run is not checked twice.
    let scene = knife_scene(&dir, "k.toml", "", "");
    let o = hamel(
        &["simulate", scene.to_str().unwrap(), "--format", "json"],
        None,
    );
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(json_on_stdout(&o)["stats"].get("error_estimate").is_none());
}

#[test]
fn eta_auto_takes_a_regular_reducing_choice_from_the_search() {
    let dir = scratch("eta_auto");
    let model = Path::new(env!("CARGO_MANIFEST_DIR")).join("models/knife.toml");
    let scene = |name: &str, initial: &str| {
        let path = dir.join(name);
        std::fs::write(
            &path,
            format!(
                "model = {:?}\neta = \"auto\"\nrequest = [\"theta\", \"eta\"]\nt_end = 10.0\noutputs = 11\n\
                 [initial]\nq = {{ x = 0.0, y = 0.0, theta = 0.3 }}\n{initial}\n",
                model.display().to_string()
            ),
        )
        .unwrap();
        path
    };
    let good = scene("auto.toml", "q_dot = { x = 0.95, y = 0.3, theta = 0.5 }");
    let o = hamel(&["plan", good.to_str().unwrap(), "--format", "json"], None);
    assert!(o.status.success(), "{}", stderr(&o));
    let e = stderr(&o);
    assert!(
        e.contains("eta = auto: using") && e.contains("regular everywhere"),
        "{e}"
    );
    let plan = json_on_stdout(&o);
    assert_eq!(plan["dropped"], serde_json::json!(["x", "y"]));
    assert_ne!(plan["eta"], "paper");
    let out = dir.join("auto.json");
    let o = hamel(
        &[
            "simulate",
            good.to_str().unwrap(),
            "--format",
            "json",
            "--output",
            out.to_str().unwrap(),
        ],
        None,
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&out).unwrap()).unwrap();
    // The sideways velocity is removed by the projection; θ̇ = 0.5 stays: θ(10) = 5.3.
    let theta = v["q"]["theta"]
        .as_array()
        .unwrap()
        .last()
        .unwrap()
        .as_f64()
        .unwrap();
    assert!((theta - 5.3).abs() < 1e-9, "{theta}");
    // η of a choice not yet made cannot be given.
    let bad = scene("bad.toml", "eta = [1.0, 0.5]");
    let o = hamel(&["plan", bad.to_str().unwrap()], None);
    assert_eq!(o.status.code(), Some(1));
    let e = stderr(&o);
    assert!(
        e.contains("bad.toml") && e.contains("initial.eta") && e.contains("q_dot"),
        "{e}"
    );
}

/// `--set NAME=VALUE` on `simulate`: the same trajectory as the scene with that value in its
/// `[parameters]`, and another than without it; a derived parameter, an unknown name and a
/// malformed pair are errors that write nothing.
#[test]
fn simulate_sets_parameters_from_the_command_line() {
    let root = env!("CARGO_MANIFEST_DIR");
    let scene = format!("{root}/scenes/unicycle_rider.toml");
    let dir = scratch("set");
    let text = std::fs::read_to_string(&scene)
        .unwrap()
        .replace(
            "model = \"../models/unicycle_rider.toml\"",
            &format!("model = \"{root}/models/unicycle_rider.toml\""),
        )
        .replace("[initial]", "[parameters]\nm_f = 2.25\n\n[initial]");
    let written = dir.join("scene.toml");
    std::fs::write(&written, text).unwrap();
    let run = |path: &str, extra: &[&str]| {
        let mut args = vec![
            "simulate",
            path,
            "--engine",
            "interpreted",
            "--format",
            "json",
        ];
        args.extend(extra);
        let o = hamel(&args, None);
        assert!(o.status.success(), "{}", stderr(&o));
        json_on_stdout(&o)["q"].clone()
    };
    let by_flag = run(&scene, &["--set", "m_f=2.25"]);
    assert_eq!(by_flag, run(written.to_str().unwrap(), &[]));
    assert_ne!(by_flag, run(&scene, &[]));
    let bicycle = format!("{root}/scenes/whipple_bicycle.toml");
    let out = dir.join("never.csv");
    for (set, says) in [
        ("d1=1.0", "`d1` is derived from other parameters"),
        (
            "wheelbase=1.0",
            "`wheelbase` is not a parameter or input of the model",
        ),
        ("w", "write NAME=VALUE"),
    ] {
        let o = hamel(
            &[
                "simulate",
                &bicycle,
                "--set",
                set,
                "--output",
                out.to_str().unwrap(),
            ],
            None,
        );
        assert!(
            !o.status.success() && stderr(&o).contains(says),
            "{set}: {}",
            stderr(&o)
        );
        assert!(!out.exists());
    }
}

/// A scene whose inputs follow a law of the time and a table (the Segway pushed by
/// T_L = A sin(w t) and T_R from a table): the compiled core, which sets the live parameters
/// (t, the tabled input) at every evaluation, integrates what the interpreted evaluator does;
/// a table that does not increase is refused with exit 1, its key named, and no output written,
/// as is the Python export of a table (which it cannot write).
#[test]
fn simulate_drives_inputs_by_laws_and_tables_on_both_engines() {
    let dir = scratch("driven");
    let model = Path::new(env!("CARGO_MANIFEST_DIR")).join("models/segway.toml");
    let scene = |table: &str| {
        format!(
            "model = {model:?}\neta = \"body\"\nt_end = 2.0\noutputs = 21\nrequest = [\"theta\", \"x\", \"psi\"]\n\
             [gains]\nA = 0.2\nw = 3.0\n[inputs]\nT_L = \"A*sin(w*t)\"\nT_R = {{ times = {table}, values = [0.0, 0.1, -0.1, 0.05], interpolation = \"cubic\" }}\n\
             [initial]\nq = {{ x = 0.0, y = 0.0, psi = 0.0, theta = 0.05, phiL = 0.0, phiR = 0.0 }}\neta = [0.0, 0.0, 0.0]\n\
             [integrator]\nmethod = \"dop853\"\nrtol = 1e-10\natol = 1e-12\n"
        )
    };
    let good = dir.join("good.toml");
    std::fs::write(&good, scene("[0.0, 0.7, 1.4, 2.0]")).unwrap();
    let (c, i) = compiled_and_interpreted(&good, &dir);
    for k in ["theta", "x", "psi"] {
        let scale = series(&i, k).iter().fold(0.0_f64, |m, x| m.max(x.abs()));
        assert!(scale > 1e-3, "{k} moves: {scale}");
        let worst = largest_difference(&c, &i, k);
        assert!(
            worst <= 1e-8 * scale,
            "{k}: compiled vs interpreted {worst:.1e}"
        );
    }
    // The Python export cannot read a table: refused, naming the input, writing nothing.
    let export = dir.join("export.json");
    let o = hamel(
        &[
            "tradeoff",
            good.to_str().unwrap(),
            "--export-python",
            export.to_str().unwrap(),
        ],
        None,
    );
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(stderr(&o).contains("inputs.T_R"), "{}", stderr(&o));
    assert!(!export.exists());
    let bad = dir.join("bad.toml");
    std::fs::write(&bad, scene("[0.0, 0.7, 0.7, 2.0]")).unwrap();
    let out = dir.join("bad.csv");
    let o = hamel(
        &[
            "simulate",
            bad.to_str().unwrap(),
            "--output",
            out.to_str().unwrap(),
        ],
        None,
    );
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(stderr(&o).contains("inputs.T_R"), "{}", stderr(&o));
    assert!(!out.exists(), "no partial output");
}

/// The Ackermann car (tests/models/ackermann_car.toml: the right front knuckle turned by an
/// arctangent of the left's angle; ackermann_atan2.toml: by atan2), driven and steered by a
/// law: its compiled core, with the arctangent's sine and cosine as straight-line code,
/// integrates what the interpreted evaluator does, and the work of the torques balances the
/// energy.
#[test]
fn the_ackermann_car_runs_compiled_with_its_arctangent() {
    for name in ["ackermann_car", "ackermann_atan2"] {
        ackermann_runs_compiled(name);
    }
}

fn ackermann_runs_compiled(name: &str) {
    let dir = scratch(name);
    let model = Path::new(env!("CARGO_MANIFEST_DIR")).join(format!("tests/models/{name}.toml"));
    let scene = dir.join("car.toml");
    std::fs::write(
        &scene,
        format!(
            "model = {model:?}\neta = \"drive\"\nt_end = 8.0\noutputs = 81\nrequest = [\"x\", \"y\", \"psi\", \"delta\", \"energy\"]\n\
             [inputs]\nT_drive = 20.0\nT_steer = \"-200*(delta - 0.3*sin(t)) - 50*eta2\"\n\
             [initial]\nq = {{ x = 0.0, y = 0.0, psi = 0.0, delta = 0.0, phiRL = 0.0, phiRR = 0.0, phiFL = 0.0, phiFR = 0.0 }}\neta = [2.0, 0.0]\n\
             [integrator]\nmethod = \"dop853\"\nrtol = 1e-10\natol = 1e-12\n"
        ),
    )
    .unwrap();
    let (c, i) = compiled_and_interpreted(&scene, &dir);
    for k in ["x", "y", "psi", "delta"] {
        let worst = largest_difference(&c, &i, k);
        assert!(worst <= 1e-9, "{k}: compiled vs interpreted {worst:.1e}");
    }
    let turned = c["q"]["psi"]
        .as_array()
        .unwrap()
        .last()
        .unwrap()
        .as_f64()
        .unwrap();
    assert!(turned.abs() > 0.05, "{name}: the car turns: ψ = {turned}");
    assert!(c["stats"]["energy_balance_drift"].as_f64().unwrap() <= 1e-9);
}

/// A bare atan2 in U (tests/models/atan2_knife.toml) becomes `atan2` in the compiled core: the
/// trajectory and the energy it reports are the interpreted evaluator's, and the energy is
/// conserved.
#[test]
fn a_bare_atan2_runs_compiled() {
    let dir = scratch("atan2");
    let model = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/models/atan2_knife.toml");
    let scene = dir.join("knife.toml");
    std::fs::write(
        &scene,
        format!(
            "model = {model:?}\neta = \"paper\"\nt_end = 6.0\noutputs = 61\nrequest = [\"x\", \"y\", \"energy\"]\n\
             [initial]\nq = {{ x = 0.5, y = 0.8, theta = 0.3 }}\neta = [1.5, 1.0]\n\
             [integrator]\nmethod = \"dop853\"\nrtol = 1e-11\natol = 1e-13\n"
        ),
    )
    .unwrap();
    let (c, i) = compiled_and_interpreted(&scene, &dir);
    for k in ["x", "y"] {
        let worst = largest_difference(&c, &i, k);
        assert!(worst <= 1e-9, "{k}: compiled vs interpreted {worst:.1e}");
    }
    assert!(
        c["stats"]["energy_drift"].as_f64().unwrap() <= 1e-9,
        "{}",
        c["stats"]
    );
}

/// The skidding disk (issue 58): the friction monitor stops the compiled run at μ = 0.2 between
/// the output times where the friction ratio the disk needs crosses μ, with the violation in
/// the report and a non-zero exit; the compiled core's forces are the interpreted
/// evaluator's; at μ = 1 the same scene runs through, keeping the largest ratio and the
/// smallest normal force.
#[test]
fn the_friction_monitor_stops_a_skidding_disk() {
    let dir = scratch("skid");
    let scene = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/rolling_disk_skid.toml");
    let run = |scene: &Path, engine: &str| -> (Output, serde_json::Value) {
        let out = dir.join(format!("{engine}.json"));
        let args = [
            "simulate",
            scene.to_str().unwrap(),
            "--format",
            "json",
            "--engine",
            engine,
            "--output",
            out.to_str().unwrap(),
        ];
        let o = hamel(&args, None);
        let report = serde_json::from_str(&std::fs::read_to_string(out).unwrap()).unwrap();
        (o, report)
    };
    let (o, c) = run(&scene, "compiled");
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("wheel `disk` would slip"),
        "{}",
        stderr(&o)
    );
    assert_eq!(c["engine"], "compiled");
    let v = &c["friction"]["violation"];
    assert_eq!(
        (v["kind"].as_str(), v["t_before"].as_f64(), v["t"].as_f64()),
        (Some("slip"), Some(0.16), Some(0.17))
    );
    assert!(v["ratio"].as_f64().unwrap() > 0.2);
    assert_eq!(
        c["t"].as_array().unwrap().len(),
        18,
        "the outputs up to the violation"
    );
    let (_, i) = run(&scene, "interpreted");
    for k in ["longitudinal", "lateral", "normal"] {
        let key = format!("force.disk.{k}");
        let (a, b) = (
            c["forces"][&key].as_array().unwrap(),
            i["forces"][&key].as_array().unwrap(),
        );
        assert_eq!(a.len(), b.len());
        for (x, y) in a.iter().zip(b) {
            let (x, y) = (x.as_f64().unwrap(), y.as_f64().unwrap());
            assert!(
                (x - y).abs() <= 1e-10 * y.abs().max(1.0),
                "{key}: compiled {x}, interpreted {y}"
            );
        }
    }
    let grippy = dir.join("grippy.toml");
    let text = std::fs::read_to_string(&scene).unwrap();
    let text = text.replace("mu = 0.2", "mu = 1.0").replace(
        "\"../models",
        &format!("\"{}/models", env!("CARGO_MANIFEST_DIR")),
    );
    std::fs::write(&grippy, text).unwrap();
    let (o, g) = run(&grippy, "compiled");
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(g["t"].as_array().unwrap().len(), 201);
    let disk = &g["friction"]["contacts"]["disk"];
    let ratio = disk["largest_friction_ratio"].as_f64().unwrap();
    assert!((0.2..1.0).contains(&ratio), "{disk}");
    assert!(disk["smallest_normal"].as_f64().unwrap() > 0.0, "{disk}");
    assert!(g["friction"]["violation"].is_null());
}
