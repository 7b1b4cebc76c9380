//! `hamel`: the command-line front end, a thin layer over the library crates.
//!
//! Each subcommand is one stage of the pipeline (model → derivation → analysis → code →
//! simulation) run on a model or scene file; the work is done by `hamel-derive`,
//! `hamel-reduce`, `hamel-codegen` and `hamel-run`, and this file only reads arguments,
//! calls them and writes what they return. Results go to stdout or to `--output FILE`; errors
//! go to stderr with the file, the place and the reason, and a non-zero exit status; nothing is
//! written when a command fails.

mod bench;
mod cli;
mod ensemble;
mod linearize;
mod messages;
mod output;
mod progress;
mod search;

use indexmap::IndexMap;
use std::path::Path;
use std::process::ExitCode;
use std::time::{Duration, Instant};

use clap::Parser;
use hamel_model::{Model, ModelError};
use hamel_reduce::pass::Analysis;

use crate::cli::{
    BenchArgs, Cli, Command, FormArg, Format, ObjectArg, ReportFormat, SearchArgs, TableFormat,
    TrajectoryFormat,
};
use crate::output::Output;

fn main() -> ExitCode {
    // One line per message (`file:line:col: key: reason`), then the source snippet.
    let _ = miette::set_hook(Box::new(|_| {
        Box::new(miette::MietteHandlerOpts::new().wrap_lines(false).build())
    }));
    messages::init();
    on_interrupt();
    let cli = Cli::parse();
    if matches!(
        cli.command,
        Command::DeriveWorker { .. } | Command::SearchWorker { .. }
    ) {
        // A worker shares the caller's stdout: when its reader has gone, the worker ends
        // quietly (as a shell's tools do) instead of failing in the middle of a print.
        // SAFETY: setting a signal's disposition before any thread is started.
        unsafe { libc::signal(libc::SIGPIPE, libc::SIG_DFL) };
    } else {
        derive_in_worker();
    }
    match run(cli.command, cli.no_store) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("{:?}", miette::Report::new(e));
            ExitCode::FAILURE
        }
    }
}

/// Interrupted (SIGINT): remove the files being written (`hamel_model::files`), so that no
/// partial result is left behind, and stop with the conventional status 130.
fn on_interrupt() {
    let handler = || {
        hamel_model::files::remove_pending();
        eprintln!("hamel: interrupted; no partial output left behind");
        std::process::exit(130);
    };
    if let Err(e) = ctrlc::set_handler(handler) {
        eprintln!("hamel: warning: cannot watch for interruption: {e}");
    }
}

/// The computer algebra in a worker process that exits (`hamel derive-worker`): a command
/// holds the licence's one thread only while it derives, none while it computes numbers.
fn derive_in_worker() {
    match std::env::current_exe() {
        Ok(exe) => {
            hamel_reduce::pass::derive_in_worker(exe.clone(), vec!["derive-worker".into()]);
            hamel_reduce::supervised::search_in_worker(exe, vec!["search-worker".into()]);
        }
        Err(e) => log::warn!("deriving in this process (the program's path is unknown: {e})"),
    }
}

fn run(command: Command, no_store: bool) -> Result<(), ModelError> {
    match command {
        Command::Derive {
            model,
            eta,
            format,
            fragment,
            only,
            form,
            output,
        } => {
            let how = Rendering::new(format, fragment, only);
            derive(&model, eta.as_deref(), how, form, Output::new(output)?)
        }
        Command::Expand { model, output } => {
            let out = Output::new(output)?;
            out.write(&Model::load(&model)?.to_lagrangian_toml())
        }
        Command::Reduce {
            model,
            eta,
            eliminate,
            format,
            output,
        } => reduce(
            &model,
            eta.as_deref(),
            &eliminate,
            format,
            Output::new(output)?,
        ),
        Command::Simulate(args) => simulate_command(args, no_store),
        Command::Plan {
            scene,
            format,
            output,
            measure,
            set,
        } => {
            let set = set.into_iter().collect();
            let options = hamel_run::LoadOptions {
                fresh: no_store,
                ..Default::default()
            };
            let loaded = hamel_run::load_with_options(&scene, &set, options)?;
            plan(&loaded, format, Output::new(output)?, measure)
        }
        Command::Tradeoff {
            scene,
            format,
            output,
            plot,
            export_python,
            engine,
            min_time: timing,
            set,
        } => {
            let set = set.into_iter().collect();
            let options = hamel_run::LoadOptions {
                fresh: no_store,
                ..Default::default()
            };
            let mut loaded = hamel_run::load_with_options(&scene, &set, options)?;
            match export_python {
                Some(file) => {
                    let out = Output::new(Some(file))?;
                    let export =
                        hamel_run::tradeoff::export_python(&mut loaded, engine.into(), timing)?;
                    out.write(&json(&export))
                }
                None => {
                    let out = Output::new(output)?;
                    hamel_run::plot::check(plot.as_deref())?;
                    tradeoff(&loaded, format, out, plot.as_deref(), engine.into(), timing)
                }
            }
        }
        Command::Codegen {
            model,
            eta,
            eliminate,
            out,
            force,
            with_simulator,
        } => {
            let options = hamel_codegen::write::WriteOptions {
                force,
                with_simulator,
                fresh: no_store,
            };
            codegen(&model, eta.as_deref(), &eliminate, &out, options)
        }
        Command::Search(args) => {
            // The budget counts from here.
            let started = Instant::now();
            search(args, started)
        }
        Command::SearchWorker {
            model,
            eliminate,
            budget,
            max,
        } => {
            let model = Model::load(&model)?;
            let budget = Duration::from_secs_f64(budget.max(0.0));
            hamel_reduce::supervised::work(&model, &eliminate, budget, max)
                .map_err(|e| e.locate(&model))
        }
        Command::Eval {
            model,
            eta,
            state,
            output,
            set,
        } => eval(
            &model,
            eta.as_deref(),
            &state,
            &set.into_iter().collect(),
            no_store,
            Output::new(output)?,
        ),
        Command::Linearize(args) => {
            let out = Output::new(args.output.clone())?;
            linearize::run(&args, no_store, out)
        }
        Command::Bench(args) => bench(args),
        // The worker's own failures only: the pass's are in the result, for the caller.
        Command::DeriveWorker { result } => worker_side(hamel_reduce::pass::work(&result)),
        Command::Store { action } => store(action),
    }
}

/// The deriving worker's own failure (no job, no result written): the machine's.
fn worker_side(r: Result<(), hamel_reduce::ReduceError>) -> Result<(), ModelError> {
    r.map_err(ModelError::environment)
}

/// Pretty JSON, with the final newline.
fn json<T: serde::Serialize>(value: &T) -> String {
    serde_json::to_string_pretty(value).expect("serialisable") + "\n"
}

/// Load a model for a command that uses the choice `eta`; when that choice is the default
/// hamel took (the file names no quasi-velocities), say so on stderr, with the table to paste.
fn load_for(path: &Path, eta: Option<&str>) -> Result<Model, ModelError> {
    let model = Model::load(path)?;
    if let Some(note) = model
        .choice(eta)
        .ok()
        .and_then(|c| model.default_choice_note(c))
    {
        eprintln!("{note}");
    }
    Ok(model)
}

/// How `hamel derive` writes its result.
struct Rendering {
    format: Format,
    fragment: bool,
    only: Option<ObjectArg>,
}

impl Rendering {
    /// The options as given; `--only` without `--format latex` is a usage error (exit 2).
    fn new(format: Format, fragment: bool, only: Option<ObjectArg>) -> Rendering {
        if only.is_some() && !matches!(format, Format::Latex) {
            use clap::CommandFactory;
            Cli::command()
                .error(
                    clap::error::ErrorKind::ArgumentConflict,
                    "--only chooses an object of the LaTeX output: use it with --format latex",
                )
                .exit();
        }
        Rendering {
            format,
            fragment,
            only,
        }
    }
}

fn derive(
    path: &Path,
    eta: Option<&str>,
    how: Rendering,
    form: FormArg,
    out: Output,
) -> Result<(), ModelError> {
    let model = load_for(path, eta)?;
    let started = Instant::now();
    let d = progress::while_deriving(&format!("deriving {}", model.name), || {
        hamel_derive::derive_with(&model, eta, form.into(), false)
    })
    .map_err(|e| e.locate(&model))?;
    eprintln!(
        "derived {} with quasi-velocities `{}` in {:.3} s",
        d.model,
        d.eta_name,
        started.elapsed().as_secs_f64()
    );
    out.write(&match how.format {
        Format::Text => hamel_print::derivation::text(&d)
            .map_err(|e| ModelError::engine(format!("printing the derivation: {e}")))?,
        Format::Latex => {
            let options = hamel_print::derivation::Options {
                fragment: how.fragment,
                only: how.only.map(Into::into),
            };
            hamel_print::derivation::latex(&d, options)
                .map_err(|e| ModelError::engine(format!("printing the derivation: {e}")))?
        }
        Format::Json => {
            let printed = hamel_print::derivation::json(&d)
                .map_err(|e| ModelError::engine(format!("printing the derivation: {e}")))?;
            json(&DeriveJson {
                derivation: d.json(),
                printed,
            })
        }
    })
}

/// `hamel derive --format json`: the derivation (entries canonical) and their printed forms.
#[derive(serde::Serialize)]
struct DeriveJson<'a> {
    #[serde(flatten)]
    derivation: hamel_derive::DerivationJson<'a>,
    printed: hamel_print::derivation::PrintedJson,
}

fn reduce(
    path: &Path,
    eta: Option<&str>,
    eliminate: &[String],
    format: ReportFormat,
    out: Output,
) -> Result<(), ModelError> {
    let model = load_for(path, eta)?;
    let started = Instant::now();
    let r = progress::while_deriving(&format!("reducing {}", model.name), || {
        hamel_reduce::reduce(&model, eta, eliminate)
    })
    .map_err(|e| e.locate(&model))?;
    eprintln!(
        "analysed {} with quasi-velocities `{}` in {:.3} s",
        r.model,
        r.eta_name,
        started.elapsed().as_secs_f64()
    );
    out.write(&match format {
        ReportFormat::Text => hamel_print::reduction::text(&r, &model)
            .map_err(|e| ModelError::engine(format!("printing the reduction: {e}")))?,
        ReportFormat::Json => json(&r),
    })
}

/// The figures `hamel simulate` draws beside the trajectory.
struct Figures<'a> {
    /// `--plot FILE.svg|png`.
    plot: Option<&'a Path>,
    /// `--animate FILE.html`.
    animate: Option<&'a Path>,
}

/// `hamel simulate`: a single run or an ensemble, with its figures.
fn simulate_command(args: cli::SimulateArgs, no_store: bool) -> Result<(), ModelError> {
    let cli::SimulateArgs {
        scene,
        format,
        output,
        plot,
        animate,
        engine,
        estimate_error,
        set,
        ensemble: ens,
    } = args;
    let out = Output::new(output)?;
    if let Some(page) = &animate {
        hamel_run::animate::check(page)?;
    }
    let set: IndexMap<String, f64> = set.into_iter().collect();
    let options = hamel_run::LoadOptions {
        fresh: no_store,
        every_coordinate: animate.is_some(),
    };
    let loaded = progress::while_deriving("deriving", || {
        hamel_run::load_with_options(&scene, &set, options)
    })?;
    if let Some(members) = loaded.members()? {
        let interpreted = matches!(engine, cli::EngineArg::Interpreted);
        ensemble::refuse_single(&scene, plot.is_some(), estimate_error, interpreted)?;
        return ensemble::simulate(&loaded, &members, &ens, format, out, animate.as_deref());
    }
    ensemble::refuse_options(&scene, &ens)?;
    hamel_run::plot::check(plot.as_deref())?;
    simulate(
        loaded,
        format,
        out,
        Figures {
            plot: plot.as_deref(),
            animate: animate.as_deref(),
        },
        engine.into(),
        estimate_error,
    )
}

fn simulate(
    loaded: hamel_run::Loaded,
    format: TrajectoryFormat,
    out: Output,
    figures: Figures,
    engine: hamel_run::Engine,
    estimate_error: bool,
) -> Result<(), ModelError> {
    let run = hamel_run::simulate::run_loaded(&loaded, engine, estimate_error)?;
    let traj = &run.trajectory;
    // A failure during the integration keeps what was computed, marked incomplete.
    out.write(&match format {
        TrajectoryFormat::Csv => traj.to_csv(),
        TrajectoryFormat::Json => json(traj),
    })?;
    if let Some(p) = figures.plot {
        hamel_run::plot::write(p, traj)?;
    }
    if let Some(p) = figures.animate {
        let page = hamel_run::animate::animation(&loaded, &run)?.html();
        hamel_run::animate::write(p, &page)?;
    }
    eprintln!("{}", traj.summary());
    run.failure.map_or(Ok(()), Err)
}

fn plan(
    loaded: &hamel_run::Loaded,
    format: ReportFormat,
    out: Output,
    measure: bool,
) -> Result<(), ModelError> {
    let core = loaded
        .core()
        .map_err(|e| loaded.core_error(e, ""))?
        .summary();
    let measured = if measure {
        Some(hamel_run::measure::measure_plan(loaded)?)
    } else {
        None
    };
    let plan = &loaded.plan;
    out.write(&match format {
        ReportFormat::Text => {
            let measured = measured.as_ref().map_or(String::new(), |m| m.to_text());
            format!("{}{}{measured}", plan.to_text(), core.to_text())
        }
        ReportFormat::Json => {
            #[derive(serde::Serialize)]
            struct Report<'a> {
                #[serde(flatten)]
                plan: &'a hamel_run::Plan,
                #[serde(flatten)]
                core: hamel_run::cache::Summary,
                #[serde(skip_serializing_if = "Option::is_none")]
                measured: Option<&'a hamel_run::measure::Measured>,
            }
            json(&Report {
                plan,
                core,
                measured: measured.as_ref(),
            })
        }
    })
}

fn tradeoff(
    loaded: &hamel_run::Loaded,
    format: ReportFormat,
    out: Output,
    plot: Option<&Path>,
    engine: hamel_run::Engine,
    timing: hamel_run::tradeoff::Timing,
) -> Result<(), ModelError> {
    use hamel_run::tradeoff::{Range, table_timed};
    let table = table_timed(loaded, Range::All, engine, timing)?;
    out.write(&match format {
        ReportFormat::Text => table.to_text(),
        ReportFormat::Json => json(&table),
    })?;
    if let Some(p) = plot {
        hamel_run::plot::write_tradeoff(p, &table)?;
    }
    Ok(())
}

fn codegen(
    path: &Path,
    eta: Option<&str>,
    eliminate: &[String],
    out: &Path,
    options: hamel_codegen::write::WriteOptions,
) -> Result<(), ModelError> {
    let started = Instant::now();
    let model = load_for(path, eta)?;
    let w = hamel_codegen::write::write_crate(&model, eta, eliminate, out, options)
        .map_err(|e| e.locate(&model))?;
    let partials = match w.partials {
        0 => String::new(),
        k => format!(
            " (the derivatives of Z, α and A not written: taken at run time by dual numbers in {k} coordinates)"
        ),
    };
    eprintln!(
        "wrote {} files to {} in {:.2} s; ingredients: {} operations as trees, {} shared{partials}",
        w.files,
        out.display(),
        started.elapsed().as_secs_f64(),
        w.ops_trees,
        w.ops_shared
    );
    Ok(())
}

fn search(args: SearchArgs, started: Instant) -> Result<(), ModelError> {
    let out = Output::new(args.output)?;
    let model = Model::load(&args.model)?;
    let budget = args.budget;
    if !(budget.is_finite() && budget > 0.0) {
        return Err(model.error(format!(
            "--budget must be a positive number of seconds, got {budget}"
        )));
    }
    let job = hamel_reduce::supervised::Job {
        model_path: &args.model,
        model: &model,
        eliminate: &args.eliminate,
        budget: std::time::Duration::from_secs_f64(budget),
        max: args.max,
        started,
    };
    let r = search::run(&job, args.progress)?;
    out.write(&match args.format {
        ReportFormat::Text => r.to_text(),
        ReportFormat::Json => json(&r),
    })
}

/// `set`: parameter values for every state (a state's own `params` win).
fn eval(
    path: &Path,
    eta: Option<&str>,
    state: &str,
    set: &IndexMap<String, f64>,
    no_store: bool,
    out: Output,
) -> Result<(), ModelError> {
    let mut model = load_for(path, eta)?;
    model.parameters = model
        .parameter_values(set)
        .map_err(|e| model.error(format!("--set: {e}")))?;
    let (file, text) = output::read_input(state)?;
    // the derivation store's artefact: no computer algebra when it is stored
    let derive = move |m: &Model, choice: &str| {
        let located = |e: hamel_reduce::ReduceError| e.locate(m);
        let job = hamel_reduce::pass::Job::new(m, Some(choice), Analysis::Equations)
            .map_err(located)?
            .with_supports(true)
            .with_evaluator();
        let mut artefact = hamel_reduce::pass::obtain(&job, no_store).map_err(located)?;
        match artefact.evaluator.take() {
            Some(e) => Ok(e),
            None => {
                hamel_derive::states::Evaluator::of(&artefact.into_derivation().map_err(located)?)
                    .map_err(|e| m.error(format!("the equations cannot be compiled: {e}")))
            }
        }
    };
    out.write(&hamel_derive::states::evaluate_json(
        &model, eta, &file, &text, &derive,
    )?)
}

/// `hamel store ls|clear`.
fn store(action: cli::StoreAction) -> Result<(), ModelError> {
    match action {
        cli::StoreAction::Ls => {
            let entries = hamel_derive::store::list().map_err(ModelError::environment)?;
            let mut text = String::new();
            for e in &entries {
                text += &format!(
                    "{}  {}  choice {}  {}  {} bytes\n",
                    e.name, e.model, e.choice, e.purpose, e.bytes
                );
            }
            let total: u64 = entries.iter().map(|e| e.bytes).sum();
            let mb = |b: u64| b as f64 / f64::from(1 << 20);
            text += &format!(
                "{} stored derivations, {:.1} MiB (limit {:.0} MiB: HAMEL_STORE_MAX_MB; the least recently used go first)\n",
                entries.len(),
                mb(total),
                mb(hamel_derive::store::limit())
            );
            Output::new(None)?.write(&text)
        }
        cli::StoreAction::Clear => {
            let n = hamel_derive::store::clear().map_err(ModelError::environment)?;
            eprintln!("hamel: removed {n} stored derivations");
            Ok(())
        }
    }
}

fn bench(args: BenchArgs) -> Result<(), ModelError> {
    let out = Output::new(args.output)?;
    let models = if args.models.is_empty() {
        bench::bundled_models()?
    } else {
        args.models
    };
    let repeats = bench::Repeats {
        at_least: args.repeat,
        min_seconds: args.min_time,
    };
    let rows = bench::run(&models, repeats, args.sympy, args.timeout)?;
    out.write(&match args.format {
        TableFormat::Json => json(&rows),
        TableFormat::Markdown => bench::table(&rows),
    })
}
