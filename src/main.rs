//! `hamel`: the command-line front end.
//!
//! Each subcommand is one stage of the pipeline (model → derivation → analysis → code →
//! simulation) run on a model file. Results go to stdout or to `--output FILE`; errors go to
//! stderr with the file, the place and the reason, and a non-zero exit status; nothing is
//! written when a command fails.

mod bench;
mod choice;
mod codegen;
mod output;
mod plan;
mod plot;
mod scene_core;
mod search;
mod simulate;
mod state;
mod tradeoff;

use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Instant;

use clap::{Parser, Subcommand, ValueEnum};
use hamel_model::{Model, ModelError};

use crate::output::Output;

#[derive(Parser)]
#[command(
    name = "hamel",
    version,
    about = "Boltzmann–Hamel equations of nonholonomic systems: derive, reduce, generate code, simulate"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Clone, Copy, ValueEnum)]
enum Format {
    Text,
    Json,
    Latex,
}

/// Output of `hamel bench`.
#[derive(Clone, Copy, ValueEnum)]
enum TableFormat {
    /// A Markdown table.
    Markdown,
    Json,
}

/// Output of `hamel simulate`.
#[derive(Clone, Copy, ValueEnum)]
enum TrajectoryFormat {
    Csv,
    Json,
}

/// Output of `hamel reduce` and `hamel search`.
#[derive(Clone, Copy, ValueEnum)]
enum ReportFormat {
    Text,
    Json,
}

#[derive(Subcommand)]
enum Command {
    /// Derive the Boltzmann–Hamel equations of a model: Γ, Θ, δ, A_Γ, Q (true, paper's,
    /// correction), the equations, the kinematic equations, the energy and the singular set.
    Derive {
        /// The model file (TOML).
        model: PathBuf,
        /// The quasi-velocity choice (a `[quasi_velocities.NAME]` of the model; default: the first).
        #[arg(long)]
        eta: Option<String>,
        /// Output format.
        #[arg(long, value_enum, default_value = "text")]
        format: Format,
        /// Write the result to this file instead of stdout.
        #[arg(long)]
        output: Option<PathBuf>,
    },
    /// Decide which coordinates drop out of the equations: classification (31), block structure
    /// (17)/(18), Properties 2.1–2.2, hypotheses H0–H6 with witnesses, the ground truth and the
    /// reduced system.
    Reduce {
        /// The model file (TOML).
        model: PathBuf,
        /// The quasi-velocity choice (default: the first).
        #[arg(long)]
        eta: Option<String>,
        /// Coordinates to eliminate, comma-separated (e.g. `x,y,theta`).
        #[arg(long, value_delimiter = ',', required = true)]
        eliminate: Vec<String>,
        /// Output format.
        #[arg(long, value_enum, default_value = "text")]
        format: ReportFormat,
        /// Write the result to this file instead of stdout.
        #[arg(long)]
        output: Option<PathBuf>,
    },
    /// Write the equations as a standalone Rust crate (straight-line f64 code, an engine-free
    /// runtime, an `eval` binary): the full and, with --eliminate, the reduced system.
    Codegen {
        /// The model file (TOML).
        model: PathBuf,
        /// The quasi-velocity choice (default: the first).
        #[arg(long)]
        eta: Option<String>,
        /// Coordinates to eliminate (checked exactly, as `hamel reduce` does).
        #[arg(long, value_delimiter = ',')]
        eliminate: Vec<String>,
        /// Directory of the crate to write.
        #[arg(long)]
        out: PathBuf,
        /// Overwrite the generated files of a non-empty directory.
        #[arg(long)]
        force: bool,
        /// Also write a `simulate` binary (vendors the integrators into the crate).
        #[arg(long)]
        with_simulator: bool,
    },
    /// Integrate a scene (model, quasi-velocities, parameters, initial state, integrator) and
    /// write the trajectory; a one-line summary goes to stderr.
    Simulate {
        /// The scene file (TOML); its `model` path is relative to it.
        scene: PathBuf,
        /// Output format.
        #[arg(long, value_enum, default_value = "csv")]
        format: TrajectoryFormat,
        /// Write the trajectory to this file instead of stdout.
        #[arg(long)]
        output: Option<PathBuf>,
        /// Also draw the coordinates and quasi-velocities against time (FILE.svg or FILE.png).
        #[arg(long)]
        plot: Option<PathBuf>,
        /// `compiled`: the scene's generated core, specialised for its parameters, built with
        /// cargo on first use and cached (falls back to `interpreted`, with a warning, when it
        /// cannot be built); `interpreted`: the structured evaluator, nothing compiled.
        #[arg(long, value_enum, default_value = "compiled")]
        engine: simulate::Engine,
        /// Estimate the global error on the requested outputs with a check run (1/1000 of the
        /// tolerances, or half the step) and report it (stderr, and `stats.error_estimate`).
        /// Done without asking when a tolerance is loose (≥ 1e-3).
        #[arg(long)]
        estimate_error: bool,
    },
    /// Plan a scene: from the outputs it requests, which coordinates are integrated,
    /// reconstructed or dropped, and the operation count of the right-hand side (all decided
    /// exactly).
    Plan {
        /// The scene file (TOML).
        scene: PathBuf,
        /// Output format.
        #[arg(long, value_enum, default_value = "text")]
        format: ReportFormat,
        /// Write the result to this file instead of stdout.
        #[arg(long)]
        output: Option<PathBuf>,
        /// Also measure the plan: integrate the scene on its compiled core and the full
        /// unreduced system (every coordinate, parameters not specialised) on its own compiled
        /// core with the same integrator, and report both times and the largest difference
        /// of the requested outputs.
        #[arg(long)]
        measure: bool,
    },
    /// Measure the speed–accuracy trade on a scene: every integrator over a range of
    /// tolerances and fixed steps against a DOP853 reference at 1e-14; error on the requested
    /// outputs, time, RHS evaluations, drifts; the fastest setting that meets the target.
    Tradeoff {
        /// The scene file (TOML).
        scene: PathBuf,
        /// Output format.
        #[arg(long, value_enum, default_value = "text")]
        format: ReportFormat,
        /// Write the result to this file instead of stdout.
        #[arg(long)]
        output: Option<PathBuf>,
        /// Also draw the work–precision diagram (FILE.svg or FILE.png).
        #[arg(long)]
        plot: Option<PathBuf>,
        /// Instead, write the planned system as Python with the reference solution and hamel's
        /// adaptive runs, for `bench/scipy_tradeoff.py` (JSON).
        #[arg(long, conflicts_with_all = ["plot", "format"])]
        export_python: Option<PathBuf>,
        /// What the timed runs evaluate: the scene's compiled core (as `hamel simulate` runs
        /// it; the interpreted evaluator, with a warning, when it cannot be built) or the
        /// interpreted evaluator.
        #[arg(long, value_enum, default_value = "compiled")]
        engine: simulate::Engine,
    },
    /// Search for quasi-velocities that eliminate the given coordinates from the true
    /// equations: A-orthogonal choices, a finite ansatz, and unknown functions.
    Search {
        /// The model file (TOML).
        model: PathBuf,
        /// Coordinates to eliminate, comma-separated.
        #[arg(long, value_delimiter = ',', required = true)]
        eliminate: Vec<String>,
        /// Time budget in seconds for the whole command: it returns within the budget plus
        /// about a second, with what it found and why it stopped (an exact check under way at
        /// the deadline is abandoned, and named).
        #[arg(long, default_value_t = 60.0)]
        budget: f64,
        /// Most reducing choices to collect from the finite ansatz.
        #[arg(long, default_value_t = 12)]
        max: usize,
        /// Progress on stderr.
        #[arg(long, value_enum, default_value = "auto")]
        progress: search::ProgressMode,
        /// Output format.
        #[arg(long, value_enum, default_value = "text")]
        format: ReportFormat,
        /// Write the result to this file instead of stdout.
        #[arg(long)]
        output: Option<PathBuf>,
    },
    /// The worker process of `hamel search` (internal: its output is a protocol).
    #[command(hide = true)]
    SearchWorker {
        model: PathBuf,
        #[arg(long, value_delimiter = ',', required = true)]
        eliminate: Vec<String>,
        #[arg(long)]
        budget: f64,
        #[arg(long)]
        max: usize,
    },
    /// Evaluate the derived equations at states given as JSON: η̇ (true and paper's), q̇, energy.
    Eval {
        /// The model file (TOML).
        model: PathBuf,
        /// The quasi-velocity choice (default: the first).
        #[arg(long)]
        eta: Option<String>,
        /// JSON file with one state object or a list of them (`-` for stdin):
        /// {"q": {"x": 0.1, …}, "eta": [1.0, 0.5], "params": {"m": 2.0}, "functions": {"z13": "…"}}.
        #[arg(long)]
        state: String,
        /// Write the result to this file instead of stdout.
        #[arg(long)]
        output: Option<PathBuf>,
    },
    /// Time the derivation of every model and choice; with --sympy, SymPy does the same
    /// derivation in the same run as the baseline (bench/sympy_derive.py).
    Bench {
        /// Model files (default: every models/*.toml).
        models: Vec<PathBuf>,
        /// Derivations per model and choice (the median is reported).
        #[arg(long, default_value_t = 5)]
        repeat: usize,
        /// Also run the SymPy baseline (needs python3 with sympy).
        #[arg(long)]
        sympy: bool,
        /// Time limit for each SymPy derivation, seconds.
        #[arg(long, default_value_t = 300.0)]
        timeout: f64,
        /// Output format.
        #[arg(long, value_enum, default_value = "markdown")]
        format: TableFormat,
        /// Write the result to this file instead of stdout.
        #[arg(long)]
        output: Option<PathBuf>,
    },
}

fn main() -> ExitCode {
    // One line per message (`file:line:col: key: reason`), then the source snippet.
    let _ = miette::set_hook(Box::new(|_| {
        Box::new(miette::MietteHandlerOpts::new().wrap_lines(false).build())
    }));
    let cli = Cli::parse();
    match run(cli) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("{:?}", miette::Report::new(e));
            ExitCode::FAILURE
        }
    }
}

fn run(cli: Cli) -> Result<(), ModelError> {
    match cli.command {
        Command::Derive {
            model,
            eta,
            format,
            output,
        } => {
            let out = Output::new(output)?;
            let model = choice::load_for(&model, eta.as_deref())?;
            let started = Instant::now();
            let d = hamel_derive::derive(&model, eta.as_deref())?;
            eprintln!(
                "derived {} with quasi-velocities `{}` in {:.3} s",
                d.model,
                d.eta_name,
                started.elapsed().as_secs_f64()
            );
            let text = match format {
                Format::Text => d.to_text(),
                Format::Latex => d.to_latex(),
                Format::Json => {
                    serde_json::to_string_pretty(&d.json()).expect("serialisable") + "\n"
                }
            };
            out.write(&text)
        }
        Command::Reduce {
            model,
            eta,
            eliminate,
            format,
            output,
        } => {
            let out = Output::new(output)?;
            let model = choice::load_for(&model, eta.as_deref())?;
            let started = Instant::now();
            let r = hamel_reduce::reduce(&model, eta.as_deref(), &eliminate)?;
            eprintln!(
                "analysed {} with quasi-velocities `{}` in {:.3} s",
                r.model,
                r.eta_name,
                started.elapsed().as_secs_f64()
            );
            let text = match format {
                ReportFormat::Text => r.to_text(),
                ReportFormat::Json => {
                    serde_json::to_string_pretty(&r).expect("serialisable") + "\n"
                }
            };
            out.write(&text)
        }
        Command::Simulate {
            scene,
            format,
            output,
            plot,
            engine,
            estimate_error,
        } => {
            let out = Output::new(output)?;
            plot::check(plot.as_deref())?;
            let (traj, failure) = simulate::run(&scene, engine, estimate_error)?;
            let text = match format {
                TrajectoryFormat::Csv => traj.to_csv(),
                TrajectoryFormat::Json => {
                    serde_json::to_string_pretty(&traj).expect("serialisable") + "\n"
                }
            };
            // A failure during the integration keeps what was computed, marked incomplete.
            out.write(&text)?;
            if let Some(p) = &plot {
                plot::write(p, &traj)?;
            }
            eprintln!("{}", traj.summary());
            match failure {
                Some(e) => Err(e),
                None => Ok(()),
            }
        }
        Command::Plan {
            scene,
            format,
            output,
            measure,
        } => {
            let out = Output::new(output)?;
            let loaded = simulate::load(&scene)?;
            let measured = if measure {
                Some(simulate::measure_plan(&loaded)?)
            } else {
                None
            };
            let plan = &loaded.plan;
            out.write(&match format {
                ReportFormat::Text => {
                    plan.to_text()
                        + measured
                            .as_ref()
                            .map_or(String::new(), |m| m.to_text())
                            .as_str()
                }
                ReportFormat::Json => {
                    #[derive(serde::Serialize)]
                    struct Measured<'a> {
                        #[serde(flatten)]
                        plan: &'a plan::Plan,
                        #[serde(skip_serializing_if = "Option::is_none")]
                        measured: Option<&'a simulate::Measured>,
                    }
                    let v = Measured {
                        plan,
                        measured: measured.as_ref(),
                    };
                    serde_json::to_string_pretty(&v).expect("serialisable") + "\n"
                }
            })
        }
        Command::Tradeoff {
            scene,
            format,
            output,
            plot,
            export_python,
            engine,
        } => {
            if let Some(file) = export_python {
                let out = Output::new(Some(file))?;
                let loaded = simulate::load(&scene)?;
                let v = tradeoff::export_python(&loaded, engine)?;
                return out
                    .write(&(serde_json::to_string_pretty(&v).expect("serialisable") + "\n"));
            }
            let out = Output::new(output)?;
            plot::check(plot.as_deref())?;
            let loaded = simulate::load(&scene)?;
            let table = tradeoff::table(&loaded, tradeoff::Range::All, engine)?;
            out.write(&match format {
                ReportFormat::Text => table.to_text(),
                ReportFormat::Json => {
                    serde_json::to_string_pretty(&table).expect("serialisable") + "\n"
                }
            })?;
            if let Some(p) = &plot {
                plot::write_tradeoff(p, &table)?;
            }
            Ok(())
        }
        Command::Codegen {
            model,
            eta,
            eliminate,
            out,
            force,
            with_simulator,
        } => {
            let started = Instant::now();
            let w = codegen::run(
                &model,
                eta.as_deref(),
                &eliminate,
                &out,
                force,
                with_simulator,
            )?;
            eprintln!(
                "wrote {} files to {} in {:.2} s; ingredients: {} operations as trees, {} shared",
                w.files,
                out.display(),
                started.elapsed().as_secs_f64(),
                w.ops_trees,
                w.ops_shared
            );
            Ok(())
        }
        Command::Search {
            model,
            eliminate,
            budget,
            max,
            progress,
            format,
            output,
        } => {
            // The budget counts from here.
            let started = Instant::now();
            let out = Output::new(output)?;
            let loaded = Model::load(&model)?;
            if !(budget.is_finite() && budget > 0.0) {
                return Err(loaded.error(format!(
                    "--budget must be a positive number of seconds, got {budget}"
                )));
            }
            let budget = std::time::Duration::from_secs_f64(budget);
            let job = search::Job {
                model_path: &model,
                model: &loaded,
                eliminate: &eliminate,
                budget,
                max,
                started,
            };
            let r = search::run(&job, progress)?;
            out.write(&match format {
                ReportFormat::Text => r.to_text(),
                ReportFormat::Json => {
                    serde_json::to_string_pretty(&r).expect("serialisable") + "\n"
                }
            })
        }
        Command::SearchWorker {
            model,
            eliminate,
            budget,
            max,
        } => {
            let model = Model::load(&model)?;
            let budget = std::time::Duration::from_secs_f64(budget.max(0.0));
            search::work(&model, &eliminate, budget, max)
        }
        Command::Eval {
            model,
            eta,
            state,
            output,
        } => {
            let out = Output::new(output)?;
            let model = choice::load_for(&model, eta.as_deref())?;
            let text = state::eval(&model, eta.as_deref(), &state)?;
            out.write(&text)
        }
        Command::Bench {
            models,
            repeat,
            sympy,
            timeout,
            format,
            output,
        } => {
            let out = Output::new(output)?;
            let models = if models.is_empty() {
                bundled_models()?
            } else {
                models
            };
            let rows = bench::run(&models, repeat, sympy, timeout)?;
            let text = match format {
                TableFormat::Json => {
                    serde_json::to_string_pretty(&rows).expect("serialisable") + "\n"
                }
                TableFormat::Markdown => bench::table(&rows),
            };
            out.write(&text)
        }
    }
}

/// Every `models/*.toml` of the repository, sorted.
fn bundled_models() -> Result<Vec<PathBuf>, ModelError> {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("models");
    let mut v: Vec<PathBuf> = std::fs::read_dir(&dir)
        .map_err(|e| {
            ModelError::new(
                &dir.display().to_string(),
                std::sync::Arc::new(String::new()),
                None,
                None,
                format!("cannot list models: {e}"),
            )
        })?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|e| e == "toml"))
        .collect();
    v.sort();
    Ok(v)
}
