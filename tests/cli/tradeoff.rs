//! `hamel tradeoff`: the work–precision table, its recommendation, the Python export.

#[allow(unused_imports)]
use super::*;

#[test]
fn tradeoff_measures_every_integrator_and_recommends_one_that_meets_the_target() {
    let dir = scratch("tradeoff");
    let json = dir.join("t.json");
    let svg = dir.join("t.svg");
    let o = hamel(
        &[
            "tradeoff",
            "scenes/knife.toml",
            "--format",
            "json",
            "--output",
            json.to_str().unwrap(),
            "--plot",
            svg.to_str().unwrap(),
        ],
        None,
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let t: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    assert!(
        t["reference_check"].as_f64().unwrap() < 1e-12,
        "{}",
        t["reference_check"]
    );
    let rows = t["rows"].as_array().unwrap();
    for m in ["dop853", "dopri5", "rk4", "gauss-legendre"] {
        assert!(rows.iter().any(|r| r["method"] == m), "{m} missing");
    }
    // DOP853's error falls as its tolerance tightens (1e-5 against 1e-12).
    let err = |tol: f64| {
        rows.iter()
            .find(|r| r["method"] == "dop853" && r["tol"].as_f64() == Some(tol))
            .unwrap()["error_span"]
            .as_f64()
            .unwrap()
    };
    assert!(
        err(1e-12) < 1e-3 * err(1e-5),
        "{} {}",
        err(1e-12),
        err(1e-5)
    );
    // The recommendation meets the target (the scene's 1e-10 / 1e-12) and is the fastest that does.
    let rec = &rows[t["recommended"].as_u64().unwrap() as usize];
    assert!(rec["target_ratio"].as_f64().unwrap() <= 1.0);
    let fastest = rows
        .iter()
        .filter(|r| r["complete"] == true && r["target_ratio"].as_f64().unwrap() <= 1.0)
        .map(|r| r["seconds"].as_f64().unwrap())
        .fold(f64::INFINITY, f64::min);
    assert_eq!(rec["seconds"].as_f64().unwrap(), fastest);
    assert_eq!(
        t["engine"], "compiled",
        "timed on the scene's core by default"
    );
    let text = std::fs::read_to_string(&svg).unwrap();
    assert!(text.contains("work–precision") && text.contains("dop853"));
}

#[test]
fn tradeoff_exports_the_planned_system_for_scipy_timed_on_the_compiled_core() {
    let dir = scratch("tradeoff_export");
    let json = dir.join("knife.json");
    let o = hamel(
        &[
            "tradeoff",
            "scenes/knife.toml",
            "--export-python",
            json.to_str().unwrap(),
            "--min-time",
            "0",
        ],
        None,
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    assert_eq!(v["engine"], "compiled", "timed on the scene's core");
    let times = v["times"].as_array().unwrap().len();
    assert_eq!(v["reference"].as_array().unwrap().len(), times);
    let rows = v["hamel"].as_array().unwrap();
    assert!(rows.iter().any(|r| r["method"] == "dop853"));
    assert!(rows.iter().any(|r| r["method"] == "taylor"));
    // a Taylor run counts its series, the others their right-hand sides
    let work = |r: &serde_json::Value| match r["method"].as_str() {
        Some("taylor") => r["series_evals"].as_u64().unwrap(),
        _ => r["rhs_evals"].as_u64().unwrap(),
    };
    assert!(
        rows.iter()
            .all(|r| r["seconds"].as_f64().unwrap() > 0.0 && work(r) > 0)
    );
    // The Python right-hand side is the knife's (x, y, θ, η₁, η₂)' = (η₁ cos θ, η₁ sin θ, η₂, 0, 0)
    // at the initial state; checked with python3 when it is installed.
    let script = format!(
        "from math import *\n{}\nimport json\nprint(json.dumps(rhs(0.0, {})))\n",
        v["python"].as_str().unwrap(),
        v["y0"]
    );
    match Command::new("python3").arg("-c").arg(&script).output() {
        Ok(p) if p.status.success() => {
            let f: Vec<f64> = serde_json::from_slice(&p.stdout).unwrap();
            let y0: Vec<f64> = serde_json::from_value(v["y0"].clone()).unwrap();
            let (th, e1, e2) = (y0[2], y0[3], y0[4]);
            let want = [e1 * th.cos(), e1 * th.sin(), e2, 0.0, 0.0];
            for (a, b) in f.iter().zip(want) {
                assert!((a - b).abs() <= 1e-15, "{f:?} against {want:?}");
            }
        }
        _ => eprintln!("python3 not available: the exported function is not evaluated"),
    }
}

#[test]
fn simulate_with_only_an_accuracy_target_uses_the_recommended_setting() {
    let dir = scratch("simulate_accuracy");
    let scene = knife_scene(&dir, "k.toml", "", "[accuracy]\nrtol = 1e-6\natol = 1e-8\n");
    let o = hamel(
        &["simulate", scene.to_str().unwrap(), "--format", "json"],
        None,
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let e = stderr(&o);
    assert!(
        e.contains("accuracy rtol = 1e-6, atol = 1e-8: using "),
        "{e}"
    );
    let v = json_on_stdout(&o);
    // The closed form, to the target.
    for (j, t) in v["t"].as_array().unwrap().iter().enumerate() {
        let th = 0.3 + 0.5 * t.as_f64().unwrap();
        let x = 2.0 * (th.sin() - 0.3f64.sin());
        assert!((v["q"]["x"][j].as_f64().unwrap() - x).abs() <= 1e-8 + 1e-6 * x.abs());
    }
    // A target below what f64 allows is refused clearly rather than attempted.
    let scene = knife_scene(&dir, "k.toml", "", "[accuracy]\nrtol = 0.0\natol = 1e-8\n");
    let o = hamel(&["simulate", scene.to_str().unwrap()], None);
    assert_eq!(o.status.code(), Some(1));
    assert!(
        stderr(&o).contains("rtol must be in (0, 1)"),
        "{}",
        stderr(&o)
    );
    // 1e-15 is below what f64 allows: a clear message, no output, no attempt.
    let scene = knife_scene(
        &dir,
        "k.toml",
        "",
        "[accuracy]\nrtol = 1e-15\natol = 1e-15\n",
    );
    let out = dir.join("out.csv");
    let o = hamel(
        &[
            "simulate",
            scene.to_str().unwrap(),
            "--output",
            out.to_str().unwrap(),
        ],
        None,
    );
    assert_eq!(o.status.code(), Some(1));
    assert!(
        stderr(&o).contains("below what f64 arithmetic can deliver"),
        "{}",
        stderr(&o)
    );
    assert!(!out.exists());
}

/// The bicycle's derivation is structured (no closed form): its export is the structured
/// right-hand side traced at the initial state into straight-line Python (issue 56). Both forms,
/// run by python3, agree with `hamel eval` (the structured evaluator) at random states to
/// 1e-12 relative.
#[test]
fn tradeoff_exports_the_structured_bicycle_as_python_that_agrees_with_the_evaluator() {
    use rand::{Rng, SeedableRng};
    let dir = scratch("tradeoff_export_bicycle");
    let bicycle = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/whipple_bicycle.toml");
    let scene = smoke::short_scene(&bicycle, &dir, 1.0);
    let json = dir.join("bicycle.json");
    let o = hamel(
        &[
            "tradeoff",
            scene.to_str().unwrap(),
            "--export-python",
            json.to_str().unwrap(),
            "--min-time",
            "0",
        ],
        None,
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    let names: Vec<String> = serde_json::from_value(v["state"].clone()).unwrap();
    let held = v["held"].as_object().unwrap().clone();
    // Random states: angles and rates well away from the upright start, wheel angles anywhere.
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(56);
    let ys: Vec<Vec<f64>> = (0..24)
        .map(|_| {
            (names.iter())
                .map(|n| match n.as_str() {
                    "roll" | "steer" | "pitch" => rng.random_range(-0.7..0.7),
                    "eta3" => rng.random_range(-25.0..25.0),
                    _ => rng.random_range(-3.0..3.0),
                })
                .collect()
        })
        .collect();
    let is_eta = |n: &String| n.starts_with("eta");
    let states: Vec<serde_json::Value> = (ys.iter())
        .map(|y| {
            let mut q: serde_json::Map<String, serde_json::Value> = (names.iter().zip(y))
                .filter(|(n, _)| !is_eta(n))
                .map(|(n, x)| (n.clone(), (*x).into()))
                .collect();
            q.extend(held.clone());
            let eta: Vec<f64> = (names.iter().zip(y))
                .filter(|(n, _)| is_eta(n))
                .map(|(_, x)| *x)
                .collect();
            serde_json::json!({ "q": q, "eta": eta })
        })
        .collect();
    let state_file = dir.join("states.json");
    std::fs::write(&state_file, serde_json::to_string(&states).unwrap()).unwrap();
    let evaluated = dir.join("evaluated.json");
    let o = hamel(
        &[
            "eval",
            "models/whipple_bicycle.toml",
            "--eta",
            "benchmark",
            "--state",
            state_file.to_str().unwrap(),
            "--output",
            evaluated.to_str().unwrap(),
        ],
        None,
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let ev: Vec<serde_json::Value> =
        serde_json::from_str(&std::fs::read_to_string(&evaluated).unwrap()).unwrap();
    let want: Vec<Vec<f64>> = (ev.iter())
        .map(|e| {
            (names.iter().filter(|n| !is_eta(n)))
                .map(|n| e["q_dot"][n].as_f64().unwrap())
                .chain(
                    e["eta_dot"]
                        .as_array()
                        .unwrap()
                        .iter()
                        .map(|x| x.as_f64().unwrap()),
                )
                .collect()
        })
        .collect();
    let script = format!(
        "from math import *\nimport json, sys\n{}\n{}\nys = json.load(sys.stdin)\n\
         out = []\nfor y in ys:\n    dy = [0.0] * len(y)\n    rhs_into(0.0, y, dy)\n    \
         out.append([rhs(0.0, y), dy])\nprint(json.dumps(out))\n",
        v["python"].as_str().unwrap(),
        v["python_into"].as_str().unwrap()
    );
    // As a file: the bicycle's two functions are longer than one argument may be.
    let script_file = dir.join("check.py");
    std::fs::write(&script_file, script).unwrap();
    let spawned = Command::new("python3")
        .arg(&script_file)
        .stdin(std::process::Stdio::piped())
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn();
    let mut child = match spawned {
        Ok(child) => child,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
            eprintln!("python3 not found: the exported functions are not evaluated");
            return;
        }
        Err(e) => panic!("python3 did not start: {e}"),
    };
    {
        use std::io::Write;
        let mut stdin = child.stdin.take().unwrap();
        let states = serde_json::to_string(&ys).unwrap();
        // A failure to write means python3 stopped: its stderr says why (asserted below).
        let _ = stdin.write_all(states.as_bytes());
    }
    let p = child.wait_with_output().unwrap();
    assert!(p.status.success(), "{}", String::from_utf8_lossy(&p.stderr));
    let got: Vec<[Vec<f64>; 2]> = serde_json::from_slice(&p.stdout).unwrap();
    let mut worst = 0.0_f64;
    for (pair, w) in got.iter().zip(&want) {
        let scale = w.iter().fold(1.0_f64, |m, x| m.max(x.abs()));
        for form in pair {
            assert_eq!(form.len(), w.len());
            let err = (form.iter().zip(w)).fold(0.0_f64, |m, (a, b)| m.max((a - b).abs()));
            worst = worst.max(err / scale);
        }
    }
    assert_eq!(got.len(), ys.len());
    assert!(worst <= 1e-12, "worst relative difference {worst:.2e}");
    eprintln!(
        "the exported bicycle against hamel eval at {} states: {worst:.1e}",
        ys.len()
    );
}
