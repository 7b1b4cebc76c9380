//! `hamel bench`: derivation time per model and choice, with SymPy doing the same derivation
//! in the same run as the baseline (optional: `bench/sympy_derive.py`, skipped with a message
//! when Python or SymPy is missing).

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use hamel_model::{Model, ModelError};
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
    /// SymPy's time for the same derivation, when measured.
    sympy_seconds: Option<f64>,
    /// "ok", "timeout", "skipped: …".
    sympy_status: String,
    /// SymPy time / hamel time.
    ratio: Option<f64>,
}

fn sympy(script: &Path, model: &Path, eta: &str, timeout: f64) -> (Option<f64>, String) {
    let child = Command::new("python3")
        .arg(script)
        .arg(model)
        .arg(eta)
        .arg("--timeout")
        .arg(format!("{timeout}"))
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn();
    let mut child = match child {
        Ok(c) => c,
        Err(e) => return (None, format!("skipped: cannot run python3 ({e})")),
    };
    // The script enforces its own timeout; this is a safety net.
    let deadline = Instant::now() + Duration::from_secs_f64(timeout + 60.0);
    loop {
        match child.try_wait() {
            Ok(Some(_)) => break,
            Ok(None) if Instant::now() > deadline => {
                let _ = child.kill();
                return (Some(timeout), "timeout".into());
            }
            Ok(None) => std::thread::sleep(Duration::from_millis(50)),
            Err(e) => return (None, format!("skipped: {e}")),
        }
    }
    let out = match child.wait_with_output() {
        Ok(o) => o,
        Err(e) => return (None, format!("skipped: {e}")),
    };
    if out.status.code() == Some(3) {
        return (
            None,
            "skipped: SymPy is not installed (pip install sympy)".into(),
        );
    }
    let text = String::from_utf8_lossy(&out.stdout);
    let line = text.lines().rev().find(|l| l.trim_start().starts_with('{'));
    match line.and_then(|l| serde_json::from_str::<serde_json::Value>(l).ok()) {
        Some(v) => {
            let status = v["status"].as_str().unwrap_or("?").to_string();
            (v["seconds"].as_f64(), status)
        }
        None => (
            None,
            format!(
                "skipped: the script failed: {}",
                String::from_utf8_lossy(&out.stderr)
                    .lines()
                    .last()
                    .unwrap_or("")
            ),
        ),
    }
}

/// Run the benchmark over `models` (files), `repeat` derivations each.
pub fn run(
    models: &[PathBuf],
    repeat: usize,
    with_sympy: bool,
    timeout: f64,
) -> Result<Vec<Row>, ModelError> {
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("bench/sympy_derive.py");
    let mut rows = Vec::new();
    for path in models {
        let model = Model::load(path)?;
        for choice in &model.choices {
            let mut times = Vec::with_capacity(repeat);
            let mut shape = (0, 0);
            for _ in 0..repeat.max(1) {
                let t = Instant::now();
                let d = hamel_derive::derive(&model, Some(&choice.name))?;
                times.push(t.elapsed().as_secs_f64());
                shape = (d.ell, d.sigma);
            }
            times.sort_by(f64::total_cmp);
            let median = times[times.len() / 2];
            let (sympy_seconds, sympy_status) = if with_sympy {
                sympy(&script, path, &choice.name, timeout)
            } else {
                (None, "not run (use --sympy)".into())
            };
            let ratio = match (sympy_seconds, sympy_status.as_str()) {
                (Some(s), "ok") => Some(s / median),
                _ => None,
            };
            eprintln!(
                "{:<18} {:<12} hamel {:>9.4} s   sympy {}",
                model.name,
                choice.name,
                median,
                match sympy_seconds {
                    Some(s) => format!("{s:.3} s ({sympy_status})"),
                    None => sympy_status.clone(),
                }
            );
            rows.push(Row {
                model: model.name.clone(),
                eta: choice.name.clone(),
                ell: shape.0,
                sigma: shape.1,
                hamel_seconds: median,
                hamel_min_seconds: times[0],
                sympy_seconds,
                sympy_status,
                ratio,
            });
        }
    }
    Ok(rows)
}

/// A Markdown table of the rows.
pub fn table(rows: &[Row]) -> String {
    let mut s = String::from(
        "| model | choice | ℓ | σ | hamel (median) | SymPy | SymPy / hamel |\n|---|---|---|---|---|---|---|\n",
    );
    for r in rows {
        let sympy = match (r.sympy_seconds, r.sympy_status.as_str()) {
            (Some(t), "ok") => format!("{t:.3} s"),
            (Some(t), "timeout") => format!("> {t:.0} s (timeout)"),
            (_, other) => other.to_string(),
        };
        let ratio = match (r.ratio, r.sympy_status.as_str(), r.sympy_seconds) {
            (Some(x), _, _) => format!("{x:.0}×"),
            (None, "timeout", Some(t)) => format!("> {:.0}×", t / r.hamel_seconds),
            _ => "–".into(),
        };
        s.push_str(&format!(
            "| {} | {} | {} | {} | {:.1} ms | {} | {} |\n",
            r.model,
            r.eta,
            r.ell,
            r.sigma,
            r.hamel_seconds * 1e3,
            sympy,
            ratio
        ));
    }
    s
}
