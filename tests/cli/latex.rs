//! `hamel derive --format latex` (issue 22): the document of every model file's every choice of
//! quasi-velocities compiles with pdflatex on landscape A4 with 1 cm margins, with no error and
//! no overfull line. Skipped, with a message, where pdflatex is missing (.ci/run installs
//! texlive-latex-base).

use std::path::Path;
use std::process::Command;

use super::{hamel, scratch, stderr};

/// Every `(model file, choice)` under models/.
fn choices() -> Vec<(String, String)> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut out = Vec::new();
    for f in super::toml_files(&["models", "models/bodies"]) {
        let t: toml::Value = toml::from_str(&std::fs::read_to_string(&f).unwrap()).unwrap();
        let rel = f.strip_prefix(root).unwrap().to_string_lossy().to_string();
        let table = t.get("quasi_velocities").and_then(|q| q.as_table());
        for name in table.into_iter().flat_map(|t| t.keys()) {
            out.push((rel.clone(), name.clone()));
        }
    }
    out
}

/// pdflatex's verdict on `tex`: None when it compiled with no overfull box, else the reason.
fn pdflatex(tex: &Path) -> Option<String> {
    let dir = tex.parent().unwrap();
    let o = Command::new("pdflatex")
        .args(["-interaction=nonstopmode", "-halt-on-error"])
        .arg(tex.file_name().unwrap())
        .current_dir(dir)
        .output()
        .unwrap();
    let log = std::fs::read_to_string(tex.with_extension("log")).unwrap_or_default();
    if !o.status.success() {
        let error = log
            .lines()
            .find(|l| l.starts_with('!'))
            .unwrap_or("no message");
        return Some(format!("pdflatex failed: {error}"));
    }
    let overfull: Vec<&str> = log.lines().filter(|l| l.starts_with("Overfull")).collect();
    (!overfull.is_empty()).then(|| format!("{} overfull: {}", overfull.len(), overfull[0]))
}

#[test]
fn every_derivation_compiles_with_pdflatex_and_fits_the_page() {
    if Command::new("pdflatex").arg("--version").output().is_err() {
        eprintln!("skipped: pdflatex is not installed (apt install texlive-latex-base)");
        return;
    }
    let dir = scratch("latex");
    let mut failures = Vec::new();
    for (model, eta) in choices() {
        let stem = format!(
            "{}_{eta}",
            Path::new(&model).file_stem().unwrap().to_string_lossy()
        );
        let tex = dir.join(format!("{stem}.tex"));
        let o = hamel(
            &[
                "derive",
                &model,
                "--eta",
                &eta,
                "--format",
                "latex",
                "--output",
                tex.to_str().unwrap(),
            ],
            None,
        );
        let err = stderr(&o);
        assert!(
            o.status.success(),
            "{model} {eta}: {}",
            &err[..err.len().min(2000)]
        );
        if let Some(why) = pdflatex(&tex) {
            failures.push(format!("{model} --eta {eta}: {why}"));
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}
