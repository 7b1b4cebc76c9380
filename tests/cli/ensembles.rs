//! `hamel simulate` on scenes with `[ensemble]`: members drawn or read from a file, run on the
//! compiled core's pool, checked against the knife's closed-form solution; failures kept per
//! member; export, shards run by the core alone, and merge.

use std::path::{Path, PathBuf};
use std::process::Command;

use super::{hamel, scratch, stderr};

/// A knife scene (paper's η, rtol 1e-10) with `ensemble` as its `[ensemble]` tables.
fn knife_ensemble(dir: &Path, ensemble: &str) -> PathBuf {
    let model = Path::new(env!("CARGO_MANIFEST_DIR")).join("models/knife.toml");
    let text = format!(
        "model = {model:?}\neta = \"paper\"\nt_end = 10.0\noutputs = 21\nrequest = [\"x\", \"y\", \"theta\", \"energy\"]\n\n[parameters]\nm = 2.0\n\n[initial]\nq = {{ x = 0.0, y = 0.0, theta = 0.3 }}\neta = [1.0, 0.5]\n\n[integrator]\nmethod = \"dop853\"\nrtol = 1e-10\natol = 1e-12\n\n{ensemble}"
    );
    let path = dir.join("scene.toml");
    std::fs::write(&path, text).unwrap();
    path
}

/// The knife with η constant (the paper's choice, section 3.1): θ = θ0 + η2 t and
/// (x, y) = (x0, y0) + η1 ∫ (cos θ, sin θ) dt, written without dividing by η2; E = ½ m η1²
/// + ½ (m l²/12) η2² with l = 0.3.
fn closed_form(theta0: f64, eta: [f64; 2], m: f64, t: f64) -> [f64; 4] {
    let u = eta[1] * t / 2.0;
    let sinc = if u == 0.0 { 1.0 } else { u.sin() / u };
    let mid = theta0 + u;
    [
        eta[0] * t * mid.cos() * sinc,
        eta[0] * t * mid.sin() * sinc,
        theta0 + eta[1] * t,
        0.5 * m * eta[0].powi(2) + 0.5 * m * 0.09 / 12.0 * eta[1].powi(2),
    ]
}

/// `hamel simulate SCENE --format json --output OUT` with `extra` arguments after it.
fn simulate_json(scene: &str, out: &Path, extra: &[&str]) -> std::process::Output {
    let mut args = vec!["simulate", scene, "--format", "json", "--output"];
    args.push(out.to_str().unwrap());
    args.extend_from_slice(extra);
    hamel(&args, None)
}

fn lines(path: &Path) -> Vec<serde_json::Value> {
    std::fs::read_to_string(path)
        .unwrap()
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect()
}

fn f(v: &serde_json::Value) -> f64 {
    v.as_f64().unwrap()
}

#[test]
fn drawn_members_follow_the_closed_form_on_one_and_two_threads() {
    let dir = scratch("ensemble_drawn");
    let scene = knife_ensemble(
        &dir,
        "[ensemble]\nmembers = 300\nseed = 11\nsave = \"outputs\"\n\n[ensemble.vary]\ntheta = { uniform = [0.0, 6.283185307179586] }\neta1 = { normal = [1.0, 0.2] }\neta2 = { uniform = [-1.0, 1.0] }\nm = { uniform = [1.0, 3.0] }\n",
    );
    let mut runs = Vec::new();
    for threads in ["1", "2"] {
        let out = dir.join(format!("result-{threads}.jsonl"));
        let o = simulate_json(scene.to_str().unwrap(), &out, &["--threads", threads]);
        assert!(o.status.success(), "{}", stderr(&o));
        assert!(stderr(&o).contains("300 members"), "{}", stderr(&o));
        runs.push(lines(&out));
    }
    let [one, two] = [&runs[0], &runs[1]];
    let header = &one[0];
    assert_eq!(header["members"], 300);
    assert_eq!(header["failed"], 0);
    assert_eq!(header["varying"], serde_json::json!(["m"]));
    assert_eq!(two[0]["threads"], 2);
    // The same members, bit for bit, whatever the threads.
    assert_eq!(one[1..], two[1..]);
    let mut worst = 0.0_f64;
    for m in &one[1..] {
        let g = &m["given"];
        let (theta0, eta, mass) = (f(&g["theta"]), [f(&g["eta1"]), f(&g["eta2"])], f(&g["m"]));
        let t = m["t"].as_array().unwrap();
        assert_eq!(t.len(), 21);
        for (j, tj) in t.iter().enumerate() {
            let want = closed_form(theta0, eta, mass, f(tj));
            for (k, name) in ["x", "y", "theta", "energy"].iter().enumerate() {
                let got = f(&m["values"][name][j]);
                worst = worst.max((got - want[k]).abs() / want[k].abs().max(1.0));
            }
        }
    }
    assert!(
        worst < 1e-8,
        "largest error against the closed form {worst:e}"
    );
}

#[test]
fn a_members_file_keeps_the_members_that_run_and_names_the_ones_that_fail() {
    let dir = scratch("ensemble_file");
    std::fs::write(
        dir.join("members.csv"),
        "# theta, eta, mass\ntheta,eta1,eta2,m\n0.1,1.0,0.25,2.0\n0.2,1.0,0.5,-1.0\n,0.5,-0.5,\n",
    )
    .unwrap();
    let scene = knife_ensemble(&dir, "[ensemble]\nfile = \"members.csv\"\n");
    let out = dir.join("result.csv");
    let o = hamel(
        &[
            "simulate",
            scene.to_str().unwrap(),
            "--output",
            out.to_str().unwrap(),
        ],
        None,
    );
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("1 failed; first: member 1"),
        "{}",
        stderr(&o)
    );
    let text = std::fs::read_to_string(&out).unwrap();
    let mut reader = csv_rows(&text);
    let header = reader.remove(0);
    let col = |name: &str| header.iter().position(|h| h == name).unwrap();
    assert_eq!(reader.len(), 3);
    // Member 1 (negative mass) fails with its reason; 0 and 2 run, 2 with the scene's θ and m.
    assert_eq!(reader[1][col("complete")], "false");
    assert!(
        reader[1][col("error")].contains("positive definite"),
        "{:?}",
        reader[1]
    );
    for (i, theta0, eta, m) in [(0, 0.1, [1.0, 0.25], 2.0), (2, 0.3, [0.5, -0.5], 2.0)] {
        let row = &reader[i];
        assert_eq!(row[col("complete")], "true");
        let want = closed_form(theta0, eta, m, 10.0);
        for (k, name) in ["x", "y", "theta", "energy"].iter().enumerate() {
            let got: f64 = row[col(name)].parse().unwrap();
            assert!(
                (got - want[k]).abs() < 1e-8 * want[k].abs().max(1.0),
                "{name}: {got} vs {}",
                want[k]
            );
        }
    }
    // A bad cell: located in the members file, non-zero exit, nothing written.
    std::fs::write(dir.join("members.csv"), "theta,m\n0.1,2\n0.2,heavy\n").unwrap();
    let bad = dir.join("bad.csv");
    let o = hamel(
        &[
            "simulate",
            scene.to_str().unwrap(),
            "--output",
            bad.to_str().unwrap(),
        ],
        None,
    );
    assert_eq!(o.status.code(), Some(1));
    let e = stderr(&o);
    assert!(
        e.contains("members.csv") && e.contains("line 3") && e.contains("`heavy`"),
        "{e}"
    );
    assert!(!bad.exists());
}

/// A CSV file's rows (no quoted commas in these).
fn csv_rows(text: &str) -> Vec<Vec<String>> {
    text.lines()
        .map(|l| l.split(',').map(str::to_string).collect())
        .collect()
}

#[test]
fn an_exported_ensemble_runs_in_shards_without_hamel_and_merges_to_the_same_result() {
    let dir = scratch("ensemble_export");
    let scene = knife_ensemble(
        &dir,
        "[ensemble]\nmembers = 500\nseed = 3\n\n[ensemble.vary]\neta2 = { normal = [0.0, 0.5] }\n",
    );
    let scene = scene.to_str().unwrap();
    let direct = dir.join("direct.jsonl");
    let o = simulate_json(scene, &direct, &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    let job = dir.join("job");
    let o = hamel(
        &[
            "simulate",
            scene,
            "--export-ensemble",
            job.to_str().unwrap(),
        ],
        None,
    );
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stderr(&o).contains("--shard K/N"), "{}", stderr(&o));
    // Three tasks of the core alone, as a job array would run them.
    let mut parts = Vec::new();
    for k in 0..3 {
        let part = job.join(format!("part-{k}.jsonl"));
        let o = Command::new(job.join("core"))
            .args(["--job", job.join("job.json").to_str().unwrap(), "--shard"])
            .arg(format!("{k}/3"))
            .args(["--threads", "1", "--output", part.to_str().unwrap()])
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", stderr(&o));
        parts.push(part.to_str().unwrap().to_string());
    }
    let merged = dir.join("merged.jsonl");
    let mut merge = vec!["--merge"];
    merge.extend(parts.iter().map(String::as_str));
    let o = simulate_json(scene, &merged, &merge);
    assert!(o.status.success(), "{}", stderr(&o));
    let (a, b) = (lines(&direct), lines(&merged));
    assert_eq!(a.len(), 501);
    assert_eq!(a[1..], b[1..]);
    // A missing part is an error naming where the gap is; nothing is written.
    let partial = dir.join("partial.jsonl");
    let o = hamel(
        &[
            "simulate",
            scene,
            "--output",
            partial.to_str().unwrap(),
            "--merge",
            &parts[0],
            &parts[2],
        ],
        None,
    );
    assert_eq!(o.status.code(), Some(1));
    assert!(
        stderr(&o).contains("leaves a gap before it"),
        "{}",
        stderr(&o)
    );
    assert!(!partial.exists());
    // Parts of another job (the same scene with another seed: as many members, other ones)
    // are refused, not merged.
    let text = std::fs::read_to_string(scene)
        .unwrap()
        .replace("seed = 3", "seed = 4");
    let other = dir.join("other.toml");
    std::fs::write(&other, text).unwrap();
    let mut args = vec!["simulate", other.to_str().unwrap(), "--output"];
    args.push(partial.to_str().unwrap());
    args.push("--merge");
    args.extend(parts.iter().map(String::as_str));
    let o = hamel(&args, None);
    assert_eq!(o.status.code(), Some(1));
    assert!(
        stderr(&o).contains("computed for another job"),
        "{}",
        stderr(&o)
    );
    assert!(!partial.exists());
    core_refusals(&job, scene, &parts, &partial);
}

/// The exported core refuses a job it cannot run with its typed error (a line for a person,
/// one of JSON for hamel), exit 2 and no part written; a part in an older format is refused
/// by hamel by name.
fn core_refusals(job: &Path, scene: &str, parts: &[String], partial: &Path) {
    let text = std::fs::read_to_string(job.join("job.json")).unwrap();
    let mut broken: serde_json::Value = serde_json::from_str(&text).unwrap();
    broken["members"][1]["y0"] = serde_json::json!([1.0]);
    let bad = job.join("bad.json");
    std::fs::write(&bad, broken.to_string()).unwrap();
    let out = job.join("bad-part.jsonl");
    let o = Command::new(job.join("core"))
        .args([
            "--job",
            bad.to_str().unwrap(),
            "--output",
            out.to_str().unwrap(),
        ])
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2));
    let err = stderr(&o);
    assert!(
        err.contains("error: bad job: member 1's y0 has 1 values"),
        "{err}"
    );
    let json = (err.lines())
        .find_map(|l| l.strip_prefix("hamel-core-error: "))
        .expect("the typed line");
    let typed: serde_json::Value = serde_json::from_str(json).unwrap();
    assert_eq!(typed["State"]["member"], 1, "{typed}");
    assert!(!out.exists());
    // A part written by an older core (format 1) is named and refused, not misread.
    let old = std::fs::read_to_string(&parts[0]).unwrap().replacen(
        "\"hamel_ensemble_part\":2",
        "\"hamel_ensemble_part\":1",
        1,
    );
    let old_part = job.join("old-part.jsonl");
    std::fs::write(&old_part, old).unwrap();
    let args = [
        "simulate",
        scene,
        "--output",
        partial.to_str().unwrap(),
        "--merge",
    ];
    let mut args = args.to_vec();
    args.extend([old_part.to_str().unwrap(), &parts[1], &parts[2]]);
    let o = hamel(&args, None);
    assert_eq!(o.status.code(), Some(1));
    assert!(
        stderr(&o).contains("old-part.jsonl") && stderr(&o).contains("format 1 of ensemble parts"),
        "{}",
        stderr(&o)
    );
    assert!(!partial.exists());
}

#[test]
fn expressions_of_a_parameter_the_members_vary_use_each_members_value() {
    let dir = scratch("ensemble_expression");
    let model = Path::new(env!("CARGO_MANIFEST_DIR")).join("models/knife.toml");
    // The knife's momentum along the blade, m η1: constant, with each member's own m.
    let text = format!(
        "model = {model:?}\neta = \"paper\"\nt_end = 2.0\noutputs = 5\nrequest = [\"theta\", \"momentum\"]\n\n[expressions]\nmomentum = \"m*eta1\"\n\n[initial]\nq = {{ x = 0.0, y = 0.0, theta = 0.3 }}\neta = [1.0, 0.5]\n\n[ensemble]\nmembers = 50\nseed = 5\n\n[ensemble.vary]\nm = {{ uniform = [0.5, 4.0] }}\neta1 = {{ normal = [1.0, 0.3] }}\n"
    );
    let scene = dir.join("scene.toml");
    std::fs::write(&scene, text).unwrap();
    let out = dir.join("result.jsonl");
    let o = simulate_json(scene.to_str().unwrap(), &out, &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    let v = lines(&out);
    assert_eq!(v[0]["varying"], serde_json::json!(["m"]));
    assert_eq!(v[0]["outputs"], serde_json::json!(["theta", "momentum"]));
    let mut masses = Vec::new();
    for m in &v[1..] {
        let (mass, eta1) = (f(&m["given"]["m"]), f(&m["given"]["eta1"]));
        let got = f(&m["values"]["momentum"][0]);
        assert!(
            (got - mass * eta1).abs() <= 1e-12 * (mass * eta1).abs(),
            "{got} vs {}",
            mass * eta1
        );
        masses.push(mass);
    }
    masses.dedup();
    assert_eq!(masses.len(), 50, "every member has its own mass");
}

/// An ensemble over the gains of a control law (the Segway balanced by a PD law on its pitch,
/// pushed by a disturbance of the time): the gains the members draw are inputs of the core,
/// the time is live in it, every member is balanced, and a member equals the single run of the
/// interpreted evaluator with its gain `--set`.
#[test]
fn members_may_vary_the_gains_of_a_control_law() {
    let dir = scratch("ensemble_gains");
    let model = Path::new(env!("CARGO_MANIFEST_DIR")).join("models/segway.toml");
    let text = format!(
        "model = {model:?}\neta = \"body\"\nt_end = 6.0\noutputs = 7\nrequest = [\"theta\"]\n\n\
         [gains]\nk_th = -53.4\nk_d = -11.0\nk_v = -7.1\nd = 0.05\n\n\
         [inputs]\nT_L = \"-(k_th*theta + k_d*eta1 + k_v*eta2) + d*sin(3*t)\"\nT_R = \"-(k_th*theta + k_d*eta1 + k_v*eta2) + d*sin(3*t)\"\n\n\
         [initial]\nq = {{ x = 0.0, y = 0.0, psi = 0.0, theta = 0.1, phiL = 0.0, phiR = 0.0 }}\neta = [0.0, 0.0, 0.0]\n\n\
         [integrator]\nmethod = \"dop853\"\nrtol = 1e-10\natol = 1e-12\n"
    );
    let single = dir.join("single.toml");
    std::fs::write(&single, &text).unwrap();
    let scene = dir.join("scene.toml");
    let vary = "[ensemble]\nmembers = 6\nseed = 3\nsave = \"outputs\"\n\n[ensemble.vary]\nk_th = { uniform = [-80.0, -40.0] }\n";
    std::fs::write(&scene, format!("{text}\n{vary}")).unwrap();
    let out = dir.join("result.jsonl");
    let o = simulate_json(scene.to_str().unwrap(), &out, &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    let v = lines(&out);
    assert_eq!(v[0]["varying"], serde_json::json!(["k_th"]));
    assert_eq!(v[0]["failed"], 0);
    let finals: Vec<f64> = v[1..]
        .iter()
        .map(|m| f(m["values"]["theta"].as_array().unwrap().last().unwrap()))
        .collect();
    assert!(finals.iter().all(|t| t.abs() < 2e-2), "{finals:?}");
    assert!(finals.windows(2).any(|w| w[0] != w[1]), "the gains differ");
    // The first member again, alone, on the interpreted evaluator.
    let member = &v[1];
    let k = f(&member["given"]["k_th"]);
    let alone = dir.join("alone.json");
    let set = format!("k_th={k:?}");
    let o = simulate_json(
        single.to_str().unwrap(),
        &alone,
        &["--engine", "interpreted", "--set", &set],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let a: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(alone).unwrap()).unwrap();
    let (x, y) = (
        a["q"]["theta"].as_array().unwrap(),
        member["values"]["theta"].as_array().unwrap(),
    );
    assert_eq!(x.len(), y.len());
    for (p, q) in x.iter().zip(y) {
        assert!(
            (f(p) - f(q)).abs() <= 1e-8,
            "member {} vs alone {}",
            f(q),
            f(p)
        );
    }
}
