//! `hamel bench`: derivation time and size per model and choice, with SymPy doing the same
//! derivation in the same run as the baseline, twice: with its polynomial normal form (`cancel`)
//! and with `simplify` (optional: `bench/sympy_derive.py`, skipped with a message when Python or
//! SymPy is missing). The Whipple bicycle's baseline is SymPy's own bicycle instead
//! (`bench/sympy_bicycle.py`: test_kane3, Kane's method with Cramer's rule), as SymPy users
//! derive it. The bicycle's linearisation about upright running, swept over the speed, is timed
//! too, against SymPy's linearisation of its own bicycle (the rest of test_kane3: `KM.linearize`
//! with Cramer's rule) in the same run.

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use hamel_model::{ChoiceOrigin, Model, ModelError};
use serde::Serialize;

#[derive(Serialize)]
pub struct Row {
    model: String,
    eta: String,
    ell: usize,
    sigma: usize,
    /// Median of the repeats, seconds.
    hamel_seconds: f64,
    /// Fastest repeat, seconds.
    hamel_min_seconds: f64,
    /// How many times it was derived and printed ([`Repeats`]).
    repeats: usize,
    /// The time those took in all (derivations and printings), seconds.
    seconds_spent: f64,
    /// Median time of printing the derivation as `hamel derive` writes it (collected,
    /// factored, named, checked; `hamel_print::derivation::text`), seconds.
    print_seconds: f64,
    /// Characters of A_Γ as hamel prints it (all entries); none for a structured derivation,
    /// which has no closed A_Γ (docs/derivation.md §6).
    hamel_a_gamma_chars: Option<usize>,
    /// Characters of the whole derivation's printed objects ([`hamel_derive::Derivation::sizes`]).
    hamel_total_chars: usize,
    /// SymPy with its polynomial normal form (`cancel` modulo sin² + cos² − 1).
    sympy: Baseline,
    /// SymPy with `simplify`.
    sympy_simplify: Baseline,
}

/// One SymPy run of the same derivation.
#[derive(Serialize)]
pub struct Baseline {
    /// Seconds, when measured (the timeout on a timeout).
    seconds: Option<f64>,
    /// "ok", "timeout", "skipped: …", "not run (use --sympy)".
    status: String,
    /// Characters of A_Γ as SymPy prints it, when it finished.
    a_gamma_chars: Option<usize>,
    /// SymPy time / hamel time (median), when it finished.
    ratio: Option<f64>,
    /// How SymPy derived: "boltzmann-hamel" (`bench/sympy_derive.py`, hamel's algorithm), or
    /// "kane" (SymPy's own model of the same system, [`KANE_BASELINES`]).
    method: &'static str,
}

impl Baseline {
    fn not_run() -> Baseline {
        Baseline::skipped("not run (use --sympy)".into())
    }

    fn cell(&self) -> String {
        match (self.seconds, self.status.as_str()) {
            (Some(t), "ok") if self.method == "kane" => format!("{t:.3} s (Kane, test_kane3)"),
            (Some(t), "ok") => format!("{t:.3} s"),
            (Some(t), "timeout") => format!("> {t:.0} s (timeout)"),
            (_, other) => other.to_string(),
        }
    }

    fn ratio_cell(&self, hamel: f64) -> String {
        match (self.ratio, self.status.as_str(), self.seconds) {
            (Some(x), _, _) => format!("{x:.0}×"),
            (None, "timeout", Some(t)) => format!("> {:.0}×", t / hamel),
            _ => "–".into(),
        }
    }
}

/// The quasi-velocity choice as the SymPy script takes it: the name, and the rows when hamel
/// made the choice itself (the file does not list it).
struct Choice<'a> {
    name: &'a str,
    rows: Option<String>,
}

impl Baseline {
    /// A run that gave no measurement, for this reason.
    fn skipped(status: String) -> Baseline {
        Baseline {
            seconds: None,
            status,
            a_gamma_chars: None,
            ratio: None,
            method: "boltzmann-hamel",
        }
    }
}

/// The SymPy baseline (`bench/sympy_derive.py`), carried in the binary so that an installed
/// `hamel` runs it from anywhere (`python3 -c`).
const SYMPY_SCRIPT: &str = include_str!("../bench/sympy_derive.py");

/// SymPy's own Whipple bicycle (`bench/sympy_bicycle.py`: test_kane3, KanesMethod with
/// Cramer's rule), the baseline of the bicycle's row in place of [`SYMPY_SCRIPT`].
const SYMPY_BICYCLE: &str = include_str!("../bench/sympy_bicycle.py");

/// The models whose SymPy baseline is SymPy's own derivation of the same system by Kane's
/// method, and the choice it corresponds to (the same independent speeds).
const KANE_BASELINES: [(&str, &str, &str); 1] = [("whipple_bicycle", "benchmark", SYMPY_BICYCLE)];

/// Run the SymPy script on one choice (`simplify`: its `--simplify` mode).
fn sympy(model: &Path, eta: &Choice, timeout: f64, simplify: bool) -> Baseline {
    let mut command = Command::new("python3");
    command.arg("-c").arg(SYMPY_SCRIPT).arg(model).arg(eta.name);
    if simplify {
        command.arg("--simplify");
    }
    if let Some(rows) = &eta.rows {
        command.arg("--eta-rows").arg(rows);
    }
    command.arg("--timeout").arg(format!("{timeout}"));
    run_script(command, timeout)
}

/// The Kane baseline of `model`'s choice `eta`, if it has one ([`KANE_BASELINES`]).
fn kane(model: &str, eta: &str, timeout: f64) -> Option<Baseline> {
    let (_, _, script) = KANE_BASELINES
        .iter()
        .find(|(m, e, _)| *m == model && *e == eta)?;
    let mut command = Command::new("python3");
    command.arg("-c").arg(script);
    Some(Baseline {
        method: "kane",
        ..run_script(command, timeout)
    })
}

/// Run a baseline script, killed `timeout` + 60 s after the start, and read its JSON line.
fn run_script(mut command: Command, timeout: f64) -> Baseline {
    let child = command
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn();
    let mut child = match child {
        Ok(c) => c,
        Err(e) => return Baseline::skipped(format!("skipped: cannot run python3 ({e})")),
    };
    // The script enforces its own timeout; this is a safety net.
    let deadline = Instant::now() + Duration::from_secs_f64(timeout + 60.0);
    loop {
        match child.try_wait() {
            Ok(Some(_)) => break,
            Ok(None) if Instant::now() > deadline => {
                let _ = child.kill();
                return Baseline {
                    seconds: Some(timeout),
                    ..Baseline::skipped("timeout".into())
                };
            }
            Ok(None) => std::thread::sleep(Duration::from_millis(50)),
            Err(e) => return Baseline::skipped(format!("skipped: {e}")),
        }
    }
    match child.wait_with_output() {
        Ok(out) => parse_output(&out),
        Err(e) => Baseline::skipped(format!("skipped: {e}")),
    }
}

/// The script's one JSON line (exit status 3: SymPy is missing).
fn parse_output(out: &std::process::Output) -> Baseline {
    if out.status.code() == Some(3) {
        return Baseline::skipped("skipped: SymPy is not installed (pip install sympy)".into());
    }
    let text = String::from_utf8_lossy(&out.stdout);
    let json = text
        .lines()
        .rev()
        .find_map(|l| serde_json::from_str::<serde_json::Value>(l.trim()).ok());
    match json {
        Some(v) => Baseline {
            seconds: v["seconds"].as_f64(),
            status: v["status"].as_str().unwrap_or("?").to_string(),
            a_gamma_chars: v["a_gamma_chars"].as_u64().map(|c| c as usize),
            ratio: None,
            method: "boltzmann-hamel",
        },
        None => Baseline::skipped(format!(
            "skipped: the script failed: {}",
            String::from_utf8_lossy(&out.stderr)
                .lines()
                .last()
                .unwrap_or("")
        )),
    }
}

/// What `hamel bench` measured.
#[derive(Serialize)]
pub struct Report {
    /// One row per model and choice.
    derivations: Vec<Row>,
    /// One row per linearisation benched ([`LINEARISATIONS`]) whose model was given.
    linearisations: Vec<LinearRow>,
}

/// A linearisation: `hamel linearize MODEL --steady STEADY --sweep SWEEP` in-process, the
/// derivation included, against SymPy's derivation and linearisation of the same system.
#[derive(Serialize)]
pub struct LinearRow {
    model: String,
    steady: String,
    sweep: String,
    /// Median of the repeats, seconds.
    hamel_seconds: f64,
    /// Fastest repeat, seconds.
    hamel_min_seconds: f64,
    /// SymPy: test_kane3's derivation and linearisation (`bench/sympy_bicycle.py --linearize`).
    sympy: Baseline,
}

/// The linearisations benched, by model name: the steady motion and the sweep.
const LINEARISATIONS: [(&str, &str, &str); 1] = [("whipple_bicycle", "upright", "v=0:10:21")];

/// Time the linearisations of `model` ([`LINEARISATIONS`]), with SymPy's when asked.
fn linearisations(
    model: &Model,
    repeat: usize,
    with_sympy: bool,
    timeout: f64,
) -> Result<Vec<LinearRow>, ModelError> {
    let mut out = Vec::new();
    for (_, steady, sweep) in LINEARISATIONS.iter().filter(|(m, _, _)| *m == model.name) {
        let range = hamel_study::Range::parse(sweep).map_err(|e| model.error(e))?;
        let mut times = Vec::new();
        for _ in 0..repeat.max(1) {
            let t = Instant::now();
            let study =
                hamel_study::Study::prepare(model, None, steady).map_err(|e| e.locate(model))?;
            let base = hamel_study::Point::default();
            study
                .sweep(&base, &range, &|| ())
                .map_err(|e| study.locate(&e))?;
            times.push(t.elapsed().as_secs_f64());
        }
        times.sort_by(f64::total_cmp);
        let hamel = times[times.len() / 2];
        let mut sympy = if with_sympy {
            let mut command = Command::new("python3");
            command.arg("-c").arg(SYMPY_BICYCLE).arg("--linearize");
            Baseline {
                method: "kane",
                ..run_script(command, timeout)
            }
        } else {
            Baseline::not_run()
        };
        if let (Some(s), "ok") = (sympy.seconds, sympy.status.as_str()) {
            sympy.ratio = Some(s / hamel);
        }
        eprintln!(
            "{:<18} linearize {steady} --sweep {sweep}: hamel {hamel:.4} s   sympy {}",
            model.name,
            sympy.cell()
        );
        out.push(LinearRow {
            model: model.name.clone(),
            steady: steady.to_string(),
            sweep: sweep.to_string(),
            hamel_seconds: hamel,
            hamel_min_seconds: times[0],
            sympy,
        });
    }
    Ok(out)
}

/// How many times each model and choice is derived: at least `at_least` times, and until
/// `min_seconds` have been spent on it (as criterion does: a fast derivation is timed many
/// times, so that its median does not rest on a few).
#[derive(Clone, Copy, Debug)]
pub struct Repeats {
    pub at_least: usize,
    pub min_seconds: f64,
}

impl Repeats {
    /// Whether `done` repeats, which took `spent` seconds, are enough.
    fn enough(self, done: usize, spent: f64) -> bool {
        done >= self.at_least.max(1) && spent >= self.min_seconds
    }
}

/// Run the benchmark over `models` (files), each model and choice derived `repeats` times.
pub fn run(
    models: &[PathBuf],
    repeats: Repeats,
    with_sympy: bool,
    timeout: f64,
) -> Result<Report, ModelError> {
    let mut rows = Vec::new();
    let mut linear = Vec::new();
    for path in models {
        let model = Model::load(path)?;
        linear.extend(linearisations(
            &model,
            repeats.at_least,
            with_sympy,
            timeout,
        )?);
        for choice in &model.choices {
            let mut row = time_hamel(&model, &choice.name, repeats)?;
            if with_sympy {
                let rows: Vec<String> = choice.eta.iter().map(|e| e.expr.to_string()).collect();
                let eta = Choice {
                    name: &choice.name,
                    rows: matches!(choice.origin, ChoiceOrigin::Independent)
                        .then(|| serde_json::to_string(&rows).expect("serialisable")),
                };
                match kane(&model.name, &choice.name, timeout) {
                    Some(baseline) => {
                        row.sympy = baseline;
                        row.sympy_simplify = Baseline::skipped(
                            "n/a: SymPy's own bicycle (Kane) is the baseline".into(),
                        );
                    }
                    None => {
                        row.sympy = sympy(path, &eta, timeout, false);
                        row.sympy_simplify = sympy(path, &eta, timeout, true);
                    }
                }
            }
            for b in [&mut row.sympy, &mut row.sympy_simplify] {
                if let (Some(s), "ok") = (b.seconds, b.status.as_str()) {
                    b.ratio = Some(s / row.hamel_seconds);
                }
            }
            eprintln!(
                "{:<18} {:<14} hamel {:>9.4} s   sympy {}   sympy simplify {}",
                row.model,
                row.eta,
                row.hamel_seconds,
                row.sympy.cell(),
                row.sympy_simplify.cell()
            );
            rows.push(row);
        }
    }
    Ok(Report {
        derivations: rows,
        linearisations: linear,
    })
}

/// hamel's median time over the `repeats` derivations, and the sizes of the last.
fn time_hamel(model: &Model, eta: &str, repeats: Repeats) -> Result<Row, ModelError> {
    let mut times = Vec::with_capacity(repeats.at_least);
    let mut printing = Vec::with_capacity(repeats.at_least);
    let mut spent = 0.0;
    let mut last = None;
    while !repeats.enough(times.len(), spent) {
        let t = Instant::now();
        let d = hamel_derive::derive(model, Some(eta)).map_err(|e| e.locate(model))?;
        times.push(t.elapsed().as_secs_f64());
        let t = Instant::now();
        hamel_print::derivation::text(&d)
            .map_err(|e| ModelError::engine(format!("printing the derivation: {e}")))?;
        printing.push(t.elapsed().as_secs_f64());
        spent += times[times.len() - 1] + printing[printing.len() - 1];
        last = Some(d);
    }
    let repeated = times.len();
    let d = last.expect("at least one derivation");
    times.sort_by(f64::total_cmp);
    printing.sort_by(f64::total_cmp);
    let sizes = d.sizes();
    Ok(Row {
        model: model.name.clone(),
        eta: eta.to_string(),
        ell: d.ell,
        sigma: d.sigma,
        hamel_seconds: times[times.len() / 2],
        hamel_min_seconds: times[0],
        repeats: repeated,
        seconds_spent: spent,
        print_seconds: printing[printing.len() / 2],
        hamel_a_gamma_chars: sizes.get("a_gamma").map(|s| s.characters),
        hamel_total_chars: sizes.values().map(|s| s.characters).sum(),
        sympy: Baseline::not_run(),
        sympy_simplify: Baseline::not_run(),
    })
}

/// Markdown tables of the report: the derivations, then the linearisations.
pub fn table(report: &Report) -> String {
    let mut s = derivation_table(&report.derivations);
    if !report.linearisations.is_empty() {
        s.push_str("\n| linearisation | hamel (median, derivation included) | SymPy (derivation + linearisation) | ratio |\n|---|---|---|---|\n");
        for r in &report.linearisations {
            s.push_str(&format!(
                "| {} --steady {} --sweep {} | {:.1} ms | {} | {} |\n",
                r.model,
                r.steady,
                r.sweep,
                r.hamel_seconds * 1e3,
                r.sympy.cell(),
                r.sympy.ratio_cell(r.hamel_seconds),
            ));
        }
    }
    s
}

/// A Markdown table of the derivations.
fn derivation_table(rows: &[Row]) -> String {
    let mut s = String::from(
        "| model | choice | ℓ | σ | hamel (median) | runs | printing | printing / derivation | SymPy (cancel) | ratio | SymPy (simplify) | ratio | A_Γ chars: hamel | SymPy (cancel) | SymPy (simplify) |\n|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n",
    );
    let chars = |c: Option<usize>| c.map_or("–".to_string(), |c| c.to_string());
    for r in rows {
        s.push_str(&format!(
            "| {} | {} | {} | {} | {:.1} ms | {} | {:.1} ms | {:.0} % | {} | {} | {} | {} | {} | {} | {} |\n",
            r.model,
            r.eta,
            r.ell,
            r.sigma,
            r.hamel_seconds * 1e3,
            r.repeats,
            r.print_seconds * 1e3,
            r.print_seconds / r.hamel_seconds * 100.0,
            r.sympy.cell(),
            r.sympy.ratio_cell(r.hamel_seconds),
            r.sympy_simplify.cell(),
            r.sympy_simplify.ratio_cell(r.hamel_seconds),
            chars(r.hamel_a_gamma_chars),
            chars(r.sympy.a_gamma_chars),
            chars(r.sympy_simplify.a_gamma_chars),
        ));
    }
    s
}

/// Every `models/*.toml` under the current directory (the repository's bundled models when run
/// from a checkout), sorted.
pub fn bundled_models() -> Result<Vec<PathBuf>, ModelError> {
    let dir = PathBuf::from("models");
    let mut v: Vec<PathBuf> = std::fs::read_dir(&dir)
        .map_err(|e| {
            ModelError::new(
                &dir.display().to_string(),
                std::sync::Arc::new(String::new()),
                None,
                None,
                format!(
                    "cannot list models: {e} (give model files, or run `hamel bench` in a directory with models/)"
                ),
            )
        })?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|e| e == "toml"))
        .collect();
    v.sort();
    Ok(v)
}
