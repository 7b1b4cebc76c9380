//! `hamel codegen`: crates that build offline, evaluate as `hamel eval` does, and carry no injected code.

#[allow(unused_imports)]
use super::*;

#[test]
fn codegen_writes_a_crate_that_builds_offline_and_evaluates_like_hamel_eval() {
    let dir = scratch("codegen_knife");
    let out = dir.join("knife_core");
    let args = [
        "codegen",
        "models/knife.toml",
        "--eta",
        "paper",
        "--eliminate",
        "x,y",
        "--out",
        out.to_str().unwrap(),
    ];
    let o = hamel(&args, None);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stderr(&o).contains("operations as trees"), "{}", stderr(&o));
    let model_rs = std::fs::read_to_string(out.join("src/model.rs")).unwrap();
    assert!(model_rs.contains("pub const ELIMINATED: [usize; 2] = [0, 1];"));
    // A second run refuses to overwrite, --force overwrites.
    let o = hamel(&args, None);
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).contains("not empty"), "{}", stderr(&o));
    let mut forced = args.to_vec();
    forced.push("--force");
    assert!(hamel(&forced, None).status.success());

    // It builds offline and needs no computer algebra.
    build_generated(&out, &["eval"], &dir);

    let states = dir.join("states.json");
    std::fs::write(
        &states,
        r#"[{"q": {"x": 0.1, "y": 0.2, "theta": 0.3}, "eta": [1.0, 0.5]},
            {"q": {"x": -1, "y": 2, "theta": 2.2}, "eta": [-0.7, 1.5], "params": {"m": 2.5}}]"#,
    )
    .unwrap();
    let generated = Command::new(dir.join("eval"))
        .args(["--state", states.to_str().unwrap()])
        .output()
        .unwrap();
    assert!(generated.status.success(), "{}", stderr(&generated));
    let reference = hamel(
        &[
            "eval",
            "models/knife.toml",
            "--eta",
            "paper",
            "--state",
            states.to_str().unwrap(),
        ],
        None,
    );
    let (g, mut r) = (json_on_stdout(&generated), json_on_stdout(&reference));
    // A generated core's `eval` prints the constraint forces (issue 58), not λ by row (the
    // knife's one row is its own force: the same number, under `constraint_forces`).
    for state in r.as_array_mut().unwrap() {
        let state = state.as_object_mut().unwrap();
        let pushes = state.remove("constraint_multipliers");
        assert!(pushes.is_some_and(|m| m.as_object().unwrap().len() == 1));
        assert!(state["constraint_forces"]["no_slip"].is_number());
    }
    // Same shape and keys in the same order; values to 1e-12.
    fn close(a: &serde_json::Value, b: &serde_json::Value) -> bool {
        use serde_json::Value::*;
        match (a, b) {
            (Number(x), Number(y)) => {
                let (x, y) = (x.as_f64().unwrap(), y.as_f64().unwrap());
                (x - y).abs() <= 1e-12 * y.abs().max(1.0)
            }
            (Array(x), Array(y)) => x.len() == y.len() && x.iter().zip(y).all(|(a, b)| close(a, b)),
            (Object(x), Object(y)) => {
                x.keys().eq(y.keys()) && x.iter().zip(y).all(|((_, a), (_, b))| close(a, b))
            }
            _ => a == b,
        }
    }
    assert!(close(&g, &r), "generated {g}\nhamel eval {r}");

    // A bad state: an error naming the state, nothing on stdout.
    std::fs::write(&states, r#"{"q": {"x": 0, "y": 0}, "eta": [1, 2]}"#).unwrap();
    let bad = Command::new(dir.join("eval"))
        .args(["--state", states.to_str().unwrap()])
        .output()
        .unwrap();
    assert_eq!(bad.status.code(), Some(1));
    assert!(
        stderr(&bad).contains("state 1: missing coordinate `theta`"),
        "{}",
        stderr(&bad)
    );
    assert!(bad.stdout.is_empty());
}

#[test]
fn codegen_refuses_an_elimination_that_does_not_hold() {
    let dir = scratch("codegen_refuses");
    let out = dir.join("core");
    let o = hamel(
        &[
            "codegen",
            "models/vertical_knife.toml",
            "--eliminate",
            "theta",
            "--out",
            out.to_str().unwrap(),
        ],
        None,
    );
    assert_eq!(o.status.code(), Some(1));
    assert!(
        stderr(&o).contains("do not eliminate theta"),
        "{}",
        stderr(&o)
    );
    assert!(!out.exists(), "no partial output");
}

#[test]
fn codegen_with_simulator_integrates_the_knife_without_the_cas() {
    let dir = scratch("codegen_simulator");
    let out = dir.join("knife_sim");
    let o = hamel(
        &[
            "codegen",
            "models/knife.toml",
            "--eta",
            "paper",
            "--eliminate",
            "x,y",
            "--with-simulator",
            "--out",
            out.to_str().unwrap(),
        ],
        None,
    );
    assert!(o.status.success(), "{}", stderr(&o));
    build_generated(&out, &["simulate"], &dir);
    let state = dir.join("state.json");
    std::fs::write(
        &state,
        r#"{"q": {"x": 0, "y": 0, "theta": 0.3}, "eta": [1.0, 0.5]}"#,
    )
    .unwrap();
    let run = |extra: &[&str]| {
        let mut args = vec![
            "--state",
            state.to_str().unwrap(),
            "--t-end",
            "10",
            "--outputs",
            "11",
        ];
        args.extend(extra);
        let o = Command::new(dir.join("simulate"))
            .args(&args)
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", stderr(&o));
        json_on_stdout(&o)
    };
    // Full: θ = 0.3 + t/2, x = 2(sin θ − sin 0.3) at t = 10.
    let v = run(&[]);
    let th = 0.3 + 5.0_f64;
    assert!((v["q"]["theta"][10].as_f64().unwrap() - th).abs() < 1e-9);
    assert!((v["q"]["x"][10].as_f64().unwrap() - 2.0 * (th.sin() - 0.3f64.sin())).abs() < 1e-9);
    assert_eq!(v["complete"], true);
    // Reduced: only θ and η are integrated.
    let v = run(&["--reduced", "--method", "gauss-legendre"]);
    let q = v["q"].as_object().unwrap();
    assert_eq!(q.keys().collect::<Vec<_>>(), vec!["theta"]);
    assert!((v["q"]["theta"][10].as_f64().unwrap() - th).abs() < 1e-9);
}

#[test]
fn a_model_file_name_cannot_inject_code_into_a_generated_crate() {
    use std::os::unix::ffi::OsStrExt;
    let dir = scratch("hostile_name");
    let knife = std::fs::read_to_string("models/knife.toml").unwrap();
    // The reproduction of the issue, and a name that is not UTF-8 with a raw-string end.
    let names = [
        std::ffi::OsString::from(INJECTING_NAME),
        std::ffi::OsStr::from_bytes(b"k\xff\"#*\nfn injected_by_filename() {}\n.toml").to_owned(),
    ];
    for (i, name) in names.iter().enumerate() {
        let model = dir.join(name);
        std::fs::write(&model, &knife).unwrap();
        let out = dir.join(format!("out{i}"));
        let args: Vec<&std::ffi::OsStr> = vec![
            "codegen".as_ref(),
            model.as_os_str(),
            "--out".as_ref(),
            out.as_os_str(),
        ];
        let o = hamel_with_cache(&args, None, &code_cache());
        assert!(o.status.success(), "{}", stderr(&o));
        let fns = functions(&out.join("src/model.rs"));
        assert!(!fns.iter().any(|f| f == "injected_by_filename"), "{fns:?}");
        assert!(fns.iter().any(|f| f == "full_rhs"), "{fns:?}");
        let text = std::fs::read_to_string(out.join("src/model.rs")).unwrap();
        assert!(
            text.contains("\\nfn injected_by_filename() {}\\n"),
            "the name is shown, escaped"
        );
    }
    // A scene of that model: its cached core is generated with the model's path in it.
    let model = dir.join(INJECTING_NAME);
    let scene = dir.join("scene.toml");
    let text = knife_scene_text("").replace(
        &format!(
            "{:?}",
            Path::new(env!("CARGO_MANIFEST_DIR"))
                .join("models/knife.toml")
                .display()
                .to_string()
        ),
        &toml::Value::String(model.display().to_string()).to_string(),
    );
    std::fs::write(&scene, text).unwrap();
    let o = hamel(&["plan", scene.to_str().unwrap(), "--format", "json"], None);
    assert!(o.status.success(), "{}", stderr(&o));
    let code = PathBuf::from(json_on_stdout(&o)["code"].as_str().unwrap());
    let fns = functions(&code.join("src/model.rs"));
    assert!(!fns.iter().any(|f| f == "injected_by_filename"), "{fns:?}");
    let manifest: toml::Table = std::fs::read_to_string(code.join("Cargo.toml"))
        .unwrap()
        .parse()
        .unwrap();
    assert!(
        manifest["bin"][0]["name"]
            .as_str()
            .unwrap()
            .starts_with("scene-")
    );
}
