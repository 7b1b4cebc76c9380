//! File tests: every `tests/filetests/*.toml` is a model whose leading comments say what to run
//! and what must come out (in the manner of Cranelift's file tests):
//!
//! ```text
//! # test: derive [ETA]           derive the model (choice ETA, default the first)
//! # expect: TEXT                 the text rendering contains TEXT
//! # expect-error: TEXT           the command fails and its message contains TEXT
//! # expect-location: LINE:COL    ... and the error points at LINE:COL of the file
//! ```
//!
//! The CAS runs in-process, on its one worker thread.

use std::path::{Path, PathBuf};

use hamel_model::Model;

#[derive(Debug, Default)]
struct Spec {
    command: Vec<String>,
    expect: Vec<String>,
    expect_error: Vec<String>,
    location: Option<(usize, usize)>,
}

fn spec(path: &Path, text: &str) -> Spec {
    let mut s = Spec::default();
    for line in text.lines().take_while(|l| l.starts_with('#')) {
        let line = line.trim_start_matches('#').trim();
        if let Some(rest) = line.strip_prefix("test:") {
            s.command = rest.split_whitespace().map(str::to_string).collect();
        } else if let Some(rest) = line.strip_prefix("expect-error:") {
            s.expect_error.push(rest.trim().to_string());
        } else if let Some(rest) = line.strip_prefix("expect-location:") {
            let (l, c) = rest.trim().split_once(':').expect("LINE:COL");
            s.location = Some((l.parse().unwrap(), c.parse().unwrap()));
        } else if let Some(rest) = line.strip_prefix("expect:") {
            s.expect.push(rest.trim().to_string());
        }
    }
    assert!(
        !s.command.is_empty(),
        "{}: no `# test:` line",
        path.display()
    );
    s
}

fn run(path: &Path) -> Result<(), String> {
    let text = std::fs::read_to_string(path).unwrap();
    let s = spec(path, &text);
    let outcome = match s.command[0].as_str() {
        "derive" => Model::load(path)
            .and_then(|m| hamel_derive::derive(&m, s.command.get(1).map(String::as_str)))
            .map(|d| d.to_text()),
        other => return Err(format!("unknown test command `{other}`")),
    };
    match outcome {
        Ok(out) => {
            if !s.expect_error.is_empty() {
                return Err(format!("expected an error, the command succeeded:\n{out}"));
            }
            for e in &s.expect {
                if !out.contains(e.as_str()) {
                    return Err(format!("output lacks `{e}`:\n{out}"));
                }
            }
        }
        Err(err) => {
            let msg = err.to_string();
            if s.expect_error.is_empty() {
                return Err(format!("unexpected error: {msg}"));
            }
            let file = path.display().to_string();
            if !msg.starts_with(&file) {
                return Err(format!(
                    "the message does not name the file `{file}`: {msg}"
                ));
            }
            for e in &s.expect_error {
                if !msg.contains(e.as_str()) {
                    return Err(format!("message lacks `{e}`: {msg}"));
                }
            }
            if let Some(loc) = s.location
                && err.line_col() != Some(loc)
            {
                return Err(format!(
                    "error at {:?}, expected {loc:?}: {msg}",
                    err.line_col()
                ));
            }
        }
    }
    Ok(())
}

#[test]
fn file_tests() {
    let dir = PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/tests/filetests"));
    let mut files: Vec<PathBuf> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "toml"))
        .collect();
    files.sort();
    let failures: Vec<String> = files
        .iter()
        .filter_map(|f| {
            run(f)
                .err()
                .map(|e| format!("{}: {e}", f.file_name().unwrap().to_string_lossy()))
        })
        .collect();
    assert!(files.len() >= 15, "found only {} file tests", files.len());
    assert!(
        failures.is_empty(),
        "{} of {} file tests failed:\n{}",
        failures.len(),
        files.len(),
        failures.join("\n\n")
    );
}
