//! File tests, in the manner of Cranelift's: each `tests/filetests/*.toml` holds the input (a
//! model, or a scene for `plan`), the command to run on it, and the expected output, in one
//! file:
//!
//! ```text
//! # test: reduce --eta paper --eliminate x,y      the command (derive, reduce, search, plan)
//! name = "knife"                                  the input: the rest of the file above the
//! ...                                             marker
//! # ==== output (BLESS=1 cargo test --release --test filetests) ====
//! # Reduction of `knife` with quasi-velocities `paper`: eliminate x, y
//! # ...                                           what the command printed, or `error: ` and
//! #                                               its located message, each line behind `# `
//! ```
//!
//! A file must reproduce its output exactly (the seconds of a search are written as
//! `<seconds>`). With `BLESS=1` every file's output block is rewritten from what the command
//! prints now: review the diff before committing. The CAS runs in-process, on its one worker
//! thread; no `hamel` process is started.

use std::path::{Path, PathBuf};

use hamel_model::{Model, ModelError};

/// The line that starts the expected output.
const MARKER: &str = "# ==== output (BLESS=1 cargo test --release --test filetests) ====";

/// A file's command: what to run and its options.
#[derive(Debug, Default)]
struct Command {
    name: String,
    eta: Option<String>,
    eliminate: Vec<String>,
    budget: f64,
}

fn command(path: &Path, text: &str) -> Result<Command, String> {
    let line = text
        .lines()
        .next()
        .and_then(|l| l.strip_prefix("# test:"))
        .ok_or_else(|| {
            format!(
                "{}: the first line must be `# test: COMMAND`",
                path.display()
            )
        })?;
    let mut words = line.split_whitespace();
    let mut c = Command {
        name: words.next().unwrap_or_default().to_string(),
        budget: 60.0,
        ..Command::default()
    };
    while let Some(flag) = words.next() {
        let value = words
            .next()
            .ok_or_else(|| format!("`{flag}` needs a value"))?;
        match flag {
            "--eta" => c.eta = Some(value.to_string()),
            "--eliminate" => c.eliminate = value.split(',').map(str::to_string).collect(),
            "--budget" => c.budget = value.parse().map_err(|e| format!("--budget: {e}"))?,
            other => return Err(format!("unknown option `{other}`")),
        }
    }
    Ok(c)
}

/// What the command prints for the file at `path`, or `error: ` and its message.
fn output(path: &Path, c: &Command) -> Result<String, String> {
    let eta = c.eta.as_deref();
    let result: Result<String, ModelError> = match c.name.as_str() {
        "derive" => Model::load(path).and_then(|m| {
            hamel_derive::derive(&m, eta)
                .map(|d| d.to_text())
                .map_err(|e| e.locate(&m))
        }),
        "reduce" => Model::load(path).and_then(|m| {
            hamel_reduce::reduce(&m, eta, &c.eliminate)
                .map(|r| r.to_text())
                .map_err(|e| e.locate(&m))
        }),
        "search" => Model::load(path).and_then(|m| {
            let options = hamel_reduce::SearchOptions {
                budget: std::time::Duration::from_secs_f64(c.budget),
                max_candidates: 12,
            };
            hamel_reduce::search(&m, &c.eliminate, options, Box::new(|_| {}))
                .map(|r| r.to_text())
                .map_err(|e| e.locate(&m))
        }),
        "plan" => hamel_run::load(path).map(|l| l.plan.to_text()),
        other => return Err(format!("unknown test command `{other}`")),
    };
    Ok(match result {
        Ok(text) => seconds_hidden(&text),
        Err(e) => format!("error: {e}\n"),
    })
}

/// The search's running time, `(0.12 s;`, as `(<seconds> s;`.
fn seconds_hidden(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    let mut rest = text;
    while let Some(at) = rest.find(" s; stopped:") {
        let head = &rest[..at];
        let start = head
            .rfind(|c: char| !(c.is_ascii_digit() || c == '.'))
            .map_or(0, |i| i + 1);
        out.push_str(&head[..start]);
        out.push_str("<seconds>");
        out.push_str(" s; stopped:");
        rest = &rest[at + " s; stopped:".len()..];
    }
    out.push_str(rest);
    out
}

/// The output as the file writes it: each line behind `# ` (`#` alone for an empty one).
fn commented(output: &str) -> String {
    output
        .lines()
        .map(|l| {
            if l.is_empty() {
                "#\n".to_string()
            } else {
                format!("# {l}\n")
            }
        })
        .collect()
}

/// Run one file: compare its output block with the command's output, or rewrite it (`bless`).
fn run(path: &Path, bless: bool) -> Result<(), String> {
    let text = std::fs::read_to_string(path).map_err(|e| e.to_string())?;
    let (input, expected) = match text.find(MARKER) {
        Some(at) => (&text[..at], &text[at + MARKER.len()..]),
        None => (text.as_str(), ""),
    };
    let c = command(path, &text)?;
    let actual = commented(&output(path, &c)?);
    let expected = expected.strip_prefix('\n').unwrap_or(expected);
    if bless {
        let input = input.trim_end_matches('\n');
        std::fs::write(path, format!("{input}\n{MARKER}\n{actual}")).map_err(|e| e.to_string())?;
        return Ok(());
    }
    if expected != actual {
        return Err(format!(
            "the output differs (BLESS=1 rewrites it)\n--- expected\n{expected}--- actual\n{actual}"
        ));
    }
    Ok(())
}

#[test]
fn file_tests() {
    // Relative paths (tests run in the package's root), so that messages name the file as a
    // user would (`tests/filetests/…`).
    let bless = std::env::var_os("BLESS").is_some_and(|v| v == "1");
    let dir = PathBuf::from("tests/filetests");
    let mut files: Vec<PathBuf> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "toml"))
        .collect();
    files.sort();
    let failures: Vec<String> = files
        .iter()
        .filter_map(|f| run(f, bless).err().map(|e| format!("{}: {e}", f.display())))
        .collect();
    let commands = ["derive", "reduce", "search", "plan"];
    for c in commands {
        let n = files
            .iter()
            .filter(|f| {
                std::fs::read_to_string(f).is_ok_and(|t| t.starts_with(&format!("# test: {c}")))
            })
            .count();
        assert!(n >= 2, "only {n} file tests of `{c}`");
    }
    assert!(
        failures.is_empty(),
        "{} of {} file tests failed:\n{}",
        failures.len(),
        files.len(),
        failures.join("\n\n")
    );
}
