//! The smoke matrix (issue 56): every command on every bundled model, choice of
//! quasi-velocities and scene, as a user would type it. A command may succeed or refuse with a
//! located error (status 1); it may not panic, abort or be killed (status 101, a signal, a
//! backtrace on stderr). Long commands get small budgets; scenes are run from copies with a
//! short horizon (and a small ensemble), so the matrix stays within a few minutes.

use super::{ELIMINATE, scratch, stderr, toml_files};
use std::path::{Path, PathBuf};
use std::process::Output;

/// What the matrix ran, and what panicked.
struct Matrix {
    dir: PathBuf,
    ran: usize,
    failures: Vec<String>,
    /// The slowest commands (seconds), to keep the matrix within its few minutes.
    slowest: Vec<(f64, String)>,
}

impl Matrix {
    fn new(name: &str) -> Matrix {
        Matrix {
            dir: scratch(name),
            ran: 0,
            failures: Vec::new(),
            slowest: Vec::new(),
        }
    }

    /// A path in the matrix's scratch directory.
    fn file(&self, name: &str) -> String {
        self.dir.join(name).to_string_lossy().into_owned()
    }

    /// Run `hamel args`, recording it as a failure if it panicked or died.
    fn run(&mut self, args: &[&str]) -> Output {
        let (o, took) = super::hamel_timed(args);
        self.ran += 1;
        self.slowest.push((took.as_secs_f64(), args.join(" ")));
        self.slowest.sort_by(|a, b| b.0.total_cmp(&a.0));
        self.slowest.truncate(5);
        if let Some(why) = panicked(&o) {
            self.failures.push(format!(
                "hamel {}: {why}\n{}",
                args.join(" "),
                tail(&stderr(&o))
            ));
        }
        o
    }

    fn assert_none_panicked(&self) {
        assert!(self.ran > 0);
        assert!(
            self.failures.is_empty(),
            "{} of {} commands panicked or died:\n\n{}",
            self.failures.len(),
            self.ran,
            self.failures.join("\n\n")
        );
        eprintln!("{} commands, none panicked; the slowest:", self.ran);
        for (s, command) in &self.slowest {
            eprintln!("  {s:6.2} s  hamel {command}");
        }
    }
}

/// Why `o` is not a clean exit (success, or a located error with status 1).
fn panicked(o: &Output) -> Option<String> {
    let err = stderr(o);
    match o.status.code() {
        None => Some(format!("killed by a signal ({:?})", o.status)),
        Some(101) => Some("exit status 101 (a panic)".into()),
        _ if err.contains("panicked at") || err.contains("stack backtrace") => {
            Some("a panic on stderr".into())
        }
        // Success, a located error, or a usage error of the command line (clap's 2).
        Some(0..=2) => None,
        Some(c) => Some(format!("exit status {c}")),
    }
}

/// The arguments of `parts`, in order.
fn join<'a>(parts: &[&[&'a str]]) -> Vec<&'a str> {
    parts.iter().flat_map(|p| p.iter().copied()).collect()
}

fn tail(s: &str) -> String {
    let lines: Vec<&str> = s.lines().collect();
    lines[lines.len().saturating_sub(12)..].join("\n")
}

/// The names of the tables under `key` (`quasi_velocities`, `steady`) of a model file.
fn tables(model: &toml::Table, key: &str) -> Vec<String> {
    model
        .get(key)
        .and_then(toml::Value::as_table)
        .map(|t| t.keys().cloned().collect())
        .unwrap_or_default()
}

/// The coordinates the paper eliminates for this model file (a bodies model as its
/// hand-typed twin).
fn eliminate(path: &Path) -> &'static str {
    let stem = path.file_stem().unwrap().to_string_lossy();
    let name = stem.trim_end_matches("_bodies");
    ELIMINATE
        .iter()
        .find(|(m, _)| *m == name)
        .map(|(_, e)| *e)
        .unwrap_or_else(|| panic!("add the model `{name}` to ELIMINATE"))
}

/// A state file for `hamel eval` from a derivation's JSON: every coordinate and η at values
/// away from the seed models' singular sets, free functions as constants.
fn state_for(derivation: &serde_json::Value) -> serde_json::Value {
    let q: serde_json::Map<String, serde_json::Value> = derivation["coordinates"]
        .as_array()
        .unwrap()
        .iter()
        .enumerate()
        .map(|(i, c)| {
            (
                c.as_str().unwrap().to_string(),
                (0.1 + 0.07 * i as f64).into(),
            )
        })
        .collect();
    let sigma = derivation["sigma"].as_u64().unwrap() as usize;
    let eta: Vec<f64> = (0..sigma).map(|i| 0.3 - 0.1 * i as f64).collect();
    let functions: serde_json::Map<String, serde_json::Value> = derivation["free_functions"]
        .as_array()
        .into_iter()
        .flatten()
        .map(|f| {
            let name = f.as_str().unwrap().split('(').next().unwrap().to_string();
            (name, "0.25".into())
        })
        .collect();
    serde_json::json!({ "q": q, "eta": eta, "functions": functions })
}

/// derive (each format), eval, reduce and codegen for one choice of quasi-velocities.
fn one_choice(m: &mut Matrix, model: &str, eta: &[&str], eliminate: &str) {
    for format in ["text", "json", "latex"] {
        let out = m.file(&format!("derived.{format}"));
        m.run(&join(&[
            &["derive", model],
            eta,
            &["--format", format, "--output", &out],
        ]));
    }
    let (derived, states) = (m.file("derived.json"), m.file("states.json"));
    if let Ok(text) = std::fs::read_to_string(&derived) {
        let d: serde_json::Value = serde_json::from_str(&text).unwrap();
        std::fs::write(&states, state_for(&d).to_string()).unwrap();
        let out = m.file("eval.json");
        m.run(&join(&[
            &["eval", model],
            eta,
            &["--state", &states, "--output", &out],
        ]));
    }
    let _ = std::fs::remove_file(&derived);
    let out = m.file("reduce.json");
    let reduce = [
        "--eliminate",
        eliminate,
        "--format",
        "json",
        "--output",
        &out,
    ];
    m.run(&join(&[&["reduce", model], eta, &reduce]));
    let out = m.file("crate");
    m.run(&join(&[
        &["codegen", model],
        eta,
        &["--out", &out, "--force"],
    ]));
}

#[test]
fn no_command_panics_on_a_bundled_model_or_choice() {
    let mut m = Matrix::new("smoke_models");
    for path in toml_files(&["models", "models/bodies"]) {
        let model = path.to_string_lossy().into_owned();
        let table: toml::Table = std::fs::read_to_string(&path).unwrap().parse().unwrap();
        let eliminate = eliminate(&path);
        m.run(&["expand", &model, "--output", &m.file("expanded.txt")]);
        let choices = tables(&table, "quasi_velocities");
        if choices.is_empty() {
            // The default choice (the best-conditioned independent velocities).
            one_choice(&mut m, &model, &[], eliminate);
        }
        for c in &choices {
            one_choice(&mut m, &model, &["--eta", c], eliminate);
        }
        let out = m.file("search.json");
        let search = ["--budget", "2", "--format", "json", "--output", &out];
        m.run(&join(&[
            &["search", &model, "--eliminate", eliminate],
            &search,
        ]));
        for steady in tables(&table, "steady") {
            let out = m.file("linear.json");
            let args = ["--steady", &steady, "--format", "json", "--output", &out];
            m.run(&join(&[&["linearize", &model], &args]));
        }
    }
    // Options that change what is written, once each.
    let (tex, svg, study) = (m.file("d.tex"), m.file("l.svg"), m.file("study.json"));
    m.run(&[
        "derive",
        "models/knife.toml",
        "--format",
        "latex",
        "--fragment",
        "--output",
        &tex,
    ]);
    m.run(&[
        "derive",
        "models/knife.toml",
        "--only",
        "a-gamma",
        "--output",
        &tex,
    ]);
    let sweep = [
        "--steady", "upright", "--sweep", "v=0:10:5", "--plot", &svg, "--export", &study,
    ];
    m.run(&join(&[
        &["linearize", "models/whipple_bicycle.toml"],
        &sweep,
    ]));
    let out = m.file("bench.json");
    let bench = ["--repeat", "1", "--min-time", "0", "--format", "json"];
    m.run(&join(&[
        &["bench", "models/knife.toml"],
        &bench,
        &["--output", &out],
    ]));
    m.assert_none_panicked();
}

/// A copy of the scene at `path` in `dir`, its model named by absolute path, run for at most
/// `t_end` seconds over a few outputs, an ensemble cut to a few members (its members file
/// named by absolute path).
pub(crate) fn short_scene(path: &Path, dir: &Path, t_end: f64) -> PathBuf {
    let mut scene: toml::Table = std::fs::read_to_string(path).unwrap().parse().unwrap();
    let model = path
        .parent()
        .unwrap()
        .join(scene["model"].as_str().unwrap());
    scene.insert("model".into(), model.to_string_lossy().into_owned().into());
    let end = scene["t_end"].as_float().unwrap_or(t_end).min(t_end);
    scene.insert("t_end".into(), end.into());
    scene.insert("outputs".into(), 11.into());
    if let Some(toml::Value::Table(e)) = scene.get_mut("ensemble") {
        if e.contains_key("members") {
            e.insert("members".into(), 8.into());
        }
        if let Some(file) = e.get("file").and_then(|f| f.as_str()) {
            let file = path.parent().unwrap().join(file);
            e.insert("file".into(), file.to_string_lossy().into_owned().into());
        }
    }
    let copy = dir.join(path.file_name().unwrap());
    std::fs::write(&copy, toml::to_string(&scene).unwrap()).unwrap();
    copy
}

#[test]
fn no_command_panics_on_a_bundled_scene() {
    let mut m = Matrix::new("smoke_scenes");
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    for path in toml_files(&["scenes"]) {
        let scene = short_scene(&path, &m.dir, 1.0);
        let scene = scene.to_string_lossy().into_owned();
        m.run(&[
            "plan",
            &scene,
            "--format",
            "json",
            "--output",
            &m.file("plan.json"),
        ]);
        for engine in ["compiled", "interpreted"] {
            let out = m.file("run.csv");
            m.run(&["simulate", &scene, "--engine", engine, "--output", &out]);
        }
        let out = m.file("tradeoff.json");
        // One timed run per setting (--min-time 0): the matrix looks for panics, not times.
        let once = ["--min-time", "0"];
        let table = ["tradeoff", &scene, "--format", "json", "--output", &out];
        m.run(&join(&[&table, &once]));
        let out = m.file("export.json");
        m.run(&join(&[
            &["tradeoff", &scene, "--export-python", &out],
            &once,
        ]));
    }
    // Options that change what is written, once each.
    let knife = short_scene(&root.join("scenes/knife.toml"), &m.dir, 1.0);
    let knife = knife.to_string_lossy().into_owned();
    let (json, svg, png) = (m.file("k.json"), m.file("k.svg"), m.file("k.png"));
    m.run(&[
        "simulate", &knife, "--format", "json", "--output", &json, "--plot", &svg,
    ]);
    m.run(&[
        "simulate",
        &knife,
        "--estimate-error",
        "--output",
        &json,
        "--plot",
        &png,
    ]);
    m.run(&["tradeoff", &knife, "--plot", &svg, "--output", &json]);
    m.run(&["plan", &knife, "--measure", "--output", &json]);
    let ensemble = short_scene(&root.join("scenes/knife_ensemble.toml"), &m.dir, 1.0);
    let ensemble = ensemble.to_string_lossy().into_owned();
    m.run(&[
        "simulate",
        &ensemble,
        "--export-ensemble",
        &m.file("ensemble"),
    ]);
    m.run(&["simulate", &ensemble, "--shard", "1/2", "--output", &json]);
    m.assert_none_panicked();
}
