//! `hamel plan`: what a scene's requests need, for every bundled scene.

#[allow(unused_imports)]
use super::*;

#[test]
fn plan_integrates_only_what_the_scene_requests() {
    let dir = scratch("plan");
    let plan = |top: &str| {
        let scene = knife_scene(&dir, "k.toml", top, "");
        let o = hamel(&["plan", scene.to_str().unwrap(), "--format", "json"], None);
        assert!(o.status.success(), "{}", stderr(&o));
        json_on_stdout(&o)
    };
    let names = |v: &serde_json::Value| -> Vec<String> {
        v.as_array()
            .unwrap()
            .iter()
            .map(|s| s.as_str().unwrap().to_string())
            .collect()
    };
    // The knife's equations (η̇ = 0) contain no coordinate: only η is integrated.
    let p = plan("request = [\"theta\", \"eta\"]");
    assert_eq!(names(&p["integrated"]), ["eta1", "eta2"]);
    assert_eq!(names(&p["reconstructed"]), ["theta"]);
    assert_eq!(names(&p["dropped"]), ["x", "y"]);
    assert_eq!(p["eta"], "paper");
    assert!(p["ops"].as_u64().unwrap() < p["ops_full"].as_u64().unwrap());
    // x needs θ (ẋ = η1 cos θ): both are reconstructed, y is dropped.
    let p = plan("request = [\"x\"]");
    assert_eq!(names(&p["reconstructed"]), ["x", "theta"]);
    assert_eq!(names(&p["dropped"]), ["y"]);
    // Everything by default.
    let p = plan("");
    assert_eq!(names(&p["reconstructed"]), ["x", "y", "theta"]);
    assert!(names(&p["dropped"]).is_empty());
    // The unicycle's dynamics need θ and θ1; asking for θ alone drops the rolling coordinates.
    let scene = dir.join("u.toml");
    std::fs::write(
        &scene,
        std::fs::read_to_string("scenes/unicycle_rider.toml")
            .unwrap()
            .replace(
                "../models/",
                &format!("{}/models/", env!("CARGO_MANIFEST_DIR")),
            )
            .replace("[initial]", "request = [\"theta\"]\n[initial]"),
    )
    .unwrap();
    let o = hamel(&["plan", scene.to_str().unwrap(), "--format", "json"], None);
    assert!(o.status.success(), "{}", stderr(&o));
    let p = json_on_stdout(&o);
    assert_eq!(
        names(&p["integrated"]),
        ["theta", "theta1", "eta1", "eta2", "eta3", "eta4"]
    );
    assert!(names(&p["reconstructed"]).is_empty());
    assert_eq!(names(&p["dropped"]), ["xC", "yC", "phi", "psi"]);
}

/// `[expressions]`: named outputs of the coordinates, parameters and η. Requested, they are
/// evaluated at the output times with the scene's parameter values, and the coordinates they
/// need are kept in the state (reconstructed) while the others are dropped; bad ones are
/// refused with the key and the reason.
#[test]
fn scene_expressions_are_outputs_and_plan_what_they_need() {
    let dir = scratch("expressions");
    let tables = "[parameters]\nm = 3.0\n[expressions]\nahead = \"x + m*cos(theta)/10\"\nspeed2 = \"eta1^2\"\nside = \"y\"\n";
    let scene = knife_scene(&dir, "k.toml", "request = [\"ahead\", \"speed2\"]", tables);
    let o = hamel(&["plan", scene.to_str().unwrap(), "--format", "json"], None);
    assert!(o.status.success(), "{}", stderr(&o));
    let p = json_on_stdout(&o);
    // x and θ are needed by `ahead` (reconstructed); y by nothing requested (dropped).
    assert_eq!(p["reconstructed"], serde_json::json!(["x", "theta"]));
    assert_eq!(p["dropped"], serde_json::json!(["y"]));
    assert_eq!(p["expressions"]["ahead"], serde_json::json!(["x", "theta"]));
    assert!(p["expressions"].get("side").is_none(), "not requested");
    let o = hamel(
        &["simulate", scene.to_str().unwrap(), "--format", "json"],
        None,
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let v = json_on_stdout(&o);
    assert!(
        v["q"].as_object().unwrap().is_empty(),
        "no coordinate requested"
    );
    let ahead = v["expressions"]["ahead"].as_array().unwrap();
    let speed2 = v["expressions"]["speed2"].as_array().unwrap();
    assert!(v["expressions"].get("side").is_none());
    for (j, t) in v["t"].as_array().unwrap().iter().enumerate() {
        let th = 0.3 + 0.5 * t.as_f64().unwrap();
        let want = 2.0 * (th.sin() - 0.3f64.sin()) + 3.0 * th.cos() / 10.0;
        assert!((ahead[j].as_f64().unwrap() - want).abs() < 1e-9, "t = {t}");
        assert!((speed2[j].as_f64().unwrap() - 1.0).abs() < 1e-12);
    }
    // CSV columns.
    let o = hamel(&["simulate", scene.to_str().unwrap()], None);
    assert!(String::from_utf8_lossy(&o.stdout).contains("t,ahead,speed2\n"));
    // Bad expressions: the scene file, the key and the reason; nothing written.
    for (table, key, reason) in [
        ("bad = \"x + zz\"", "expressions.bad", "unknown name `zz`"),
        ("theta = \"x\"", "expressions.theta", "already a coordinate"),
        ("v = \"der(x)\"", "expressions.v", "`der(x)`"),
        ("w = \"x +\"", "expressions.w", "cannot parse"),
    ] {
        let scene = knife_scene(&dir, "bad.toml", "", &format!("[expressions]\n{table}\n"));
        let out = dir.join("bad.csv");
        let o = hamel(
            &[
                "simulate",
                scene.to_str().unwrap(),
                "--output",
                out.to_str().unwrap(),
            ],
            None,
        );
        assert_eq!(o.status.code(), Some(1), "{table}");
        let e = stderr(&o);
        assert!(
            e.contains("bad.toml") && e.contains(key) && e.contains(reason),
            "{table}: {e}"
        );
        assert!(!out.exists());
    }
    let scene = knife_scene(&dir, "bad.toml", "request = [\"nope\"]", tables);
    let o = hamel(&["plan", scene.to_str().unwrap()], None);
    assert_eq!(o.status.code(), Some(1));
    assert!(
        stderr(&o).contains("or an expression (ahead, speed2, side)"),
        "{}",
        stderr(&o)
    );
}

/// Every bundled scene is valid: it plans, and its plan integrates η.
#[test]
fn every_bundled_scene_plans() {
    let mut n = 0;
    for entry in std::fs::read_dir("scenes").unwrap() {
        let path = entry.unwrap().path();
        if path.extension().and_then(|e| e.to_str()) != Some("toml") {
            continue;
        }
        let o = hamel(&["plan", path.to_str().unwrap(), "--format", "json"], None);
        assert!(o.status.success(), "{}: {}", path.display(), stderr(&o));
        let p = json_on_stdout(&o);
        assert!(
            p["integrated"]
                .as_array()
                .unwrap()
                .iter()
                .any(|s| s == "eta1")
        );
        n += 1;
    }
    assert!(n >= 8, "a scene per bundled model");
}

#[test]
fn plan_measure_compares_the_plan_with_the_full_system() {
    let o = hamel(
        &[
            "plan",
            "scenes/bar_wheels.toml",
            "--format",
            "json",
            "--measure",
        ],
        None,
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let v = json_on_stdout(&o);
    let m = &v["measured"];
    // φ, η1, η2 against x, y, θ, ψ1, φ, η1, η2.
    assert_eq!(m["states"], serde_json::json!([3, 7]));
    assert!(m["ops"][0].as_u64().unwrap() < m["ops"][1].as_u64().unwrap());
    assert!(m["max_difference"].as_f64().unwrap() < 1e-8, "{m}");
    for i in 0..2 {
        assert!(m["seconds"][i].as_f64().unwrap() > 0.0, "{m}");
        assert!(m["rhs_evals"][i].as_u64().unwrap() > 0, "{m}");
    }
}
