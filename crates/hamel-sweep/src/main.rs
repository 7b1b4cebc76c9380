//! `hamel-sweep STUDY.json [--sweep P=START:STOP:COUNT]… [--set NAME=VALUE]…`: run a study that
//! `hamel linearize --export` wrote after its one symbolic pass — the linearisation at a point,
//! a sweep (with its crossings) or a stability map, exactly as `hamel linearize` computes them —
//! in a process without the computer algebra. Built alone (`cargo build --release -p
//! hamel-sweep`) it does not link it at all, so any number of these run at once: the tasks of a
//! job array on an existing scheduler (docs/linearisation.md §7).
//!
//! Errors name the study file (or the model inside it, located) and exit 1; the output is
//! written whole or not at all.

use std::io::Write;
use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::Arc;

use clap::Parser;
use hamel_model::ModelError;
use hamel_study::{Bar, Exported, Point, Range, Study};

#[derive(Parser)]
#[command(
    name = "hamel-sweep",
    version,
    about = "Run a study exported by `hamel linearize --export`, without the computer algebra"
)]
struct Cli {
    /// The study file (JSON) written by `hamel linearize --export`.
    study: PathBuf,
    /// Sweep a steady or model parameter: P=START:STOP:COUNT (twice for a map).
    #[arg(long = "sweep", value_name = "P=START:STOP:COUNT", value_parser = Range::parse)]
    sweep: Vec<Range>,
    /// Set a steady parameter, a model parameter or an input (repeatable).
    #[arg(long = "set", value_name = "NAME=VALUE", value_parser = hamel_model::parse_assignment)]
    set: Vec<(String, f64)>,
    /// Threads for the points (default: every core).
    #[arg(long)]
    threads: Option<usize>,
    /// Output format.
    #[arg(long, value_enum, default_value = "text")]
    format: Format,
    /// Write the result to this file instead of stdout.
    #[arg(long)]
    output: Option<PathBuf>,
}

/// Output of the command.
#[derive(Clone, Copy, clap::ValueEnum)]
enum Format {
    Text,
    Json,
}

fn main() -> ExitCode {
    let _ = miette::set_hook(Box::new(|_| {
        Box::new(miette::MietteHandlerOpts::new().wrap_lines(false).build())
    }));
    match run(Cli::parse()) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("{:?}", miette::Report::new(e));
            ExitCode::FAILURE
        }
    }
}

/// An error about a file, not located inside it.
fn error(file: &str, message: String) -> ModelError {
    ModelError::new(file, Arc::new(String::new()), None, None, message)
}

fn run(cli: Cli) -> Result<(), ModelError> {
    let file = cli.study.display().to_string();
    let text = std::fs::read_to_string(&cli.study)
        .map_err(|e| error(&file, format!("cannot read the file: {e}")))?;
    let exported: Exported = serde_json::from_str(&text).map_err(|e| {
        error(
            &file,
            format!("not a study file written by `hamel linearize --export`: {e}"),
        )
    })?;
    let study = Study::import(exported, &file)?;
    let study = match cli.threads {
        Some(n) => study.with_threads(n),
        None => study,
    };
    let point = Point(cli.set.into_iter().collect());
    let outcome = study.run(&point, &cli.sweep, &Bar::default())?;
    let text = match cli.format {
        Format::Json => outcome.json(),
        Format::Text => outcome.text(&study),
    };
    write(cli.output, &text)
}

/// The whole result to stdout, or to a file through a temporary one renamed into place.
fn write(output: Option<PathBuf>, text: &str) -> Result<(), ModelError> {
    match output {
        None => {
            let mut out = std::io::stdout().lock();
            out.write_all(text.as_bytes())
                .and_then(|_| out.flush())
                .map_err(|e| error("<stdout>", format!("cannot write: {e}")))
        }
        Some(p) => hamel_model::files::write_whole(&p, text.as_bytes()).map_err(|e| {
            error(
                &p.display().to_string(),
                format!("cannot write the output: {e}"),
            )
        }),
    }
}
