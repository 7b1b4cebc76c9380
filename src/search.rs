//! `hamel search`: the search run by `hamel_reduce::supervised` in a worker process
//! (`hamel search-worker`, this binary), with its progress on stderr.
//!
//! An exact check (a derivation on the CAS worker) cannot be interrupted from inside, and one
//! can take minutes. So `hamel search` is a supervisor that makes no CAS call itself: it loads
//! and checks the model, then runs the search in a worker process (`hamel search-worker`, the
//! same binary) that reports [`SearchEvent`]s as JSON lines on its stdout. At the deadline (the
//! budget, measured from the command's start, plus [`GRACE`]) the supervisor ends the worker
//! and reports what the events told it: the candidates found so far, the counts per family, and
//! the reason it stopped, naming the exact check that was abandoned. Only one Symbolica
//! instance runs at a time (the worker's), and its notice, printed on the worker's stdout, is
//! passed through unchanged to the supervisor's.

use std::time::Instant;

use hamel_model::ModelError;
use hamel_reduce::supervised::{Job, Outcome, supervise};
use hamel_reduce::{SearchEvent, SearchReport};

/// When `hamel search` shows its progress on stderr.
#[derive(Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum ProgressMode {
    /// A bar on a terminal, for searches that last over a second; nothing otherwise.
    Auto,
    /// From the start: a bar on a terminal, plain lines (`search: N/M candidates`, at most
    /// one every 0.2 s, and a last one) when stderr is a file or a pipe.
    Always,
    /// Never.
    Never,
}

/// `hamel search`: [`supervise`] with progress on stderr as `mode` says. A worker that failed
/// has said why on stderr: the process exits with its status, writing nothing.
pub fn run(job: &Job, mode: ProgressMode) -> Result<SearchReport, ModelError> {
    use std::io::IsTerminal;
    let terminal = std::io::stderr().is_terminal();
    let bar =
        indicatif::ProgressBar::with_draw_target(None, indicatif::ProgressDrawTarget::hidden());
    bar.set_style(
        indicatif::ProgressStyle::with_template(
            "{elapsed_precise} [{bar:30}] {pos}/{len} candidates",
        )
        .expect("valid template"),
    );
    let mut shown = false;
    let mut last_line: Option<Instant> = None;
    let mut progress = |done: u64, total: u64| {
        bar.set_length(total);
        bar.set_position(done);
        let due = match mode {
            ProgressMode::Never => false,
            ProgressMode::Always => true,
            // Auto: drawn only for searches that last over a second.
            ProgressMode::Auto => terminal && job.started.elapsed().as_secs_f64() > 1.0,
        };
        if due && terminal && !shown {
            shown = true;
            bar.set_draw_target(indicatif::ProgressDrawTarget::stderr());
        } else if due && !terminal && last_line.is_none_or(|t| t.elapsed().as_secs_f64() >= 0.2) {
            eprintln!("search: {done}/{total} candidates");
            last_line = Some(Instant::now());
        }
    };
    let exe = std::env::current_exe().map_err(|e| {
        job.model
            .error(format!("cannot find the hamel executable: {e}"))
    })?;
    let mut worker = std::process::Command::new(exe);
    worker.arg("search-worker");
    let outcome = supervise(job, worker, |e| {
        if let SearchEvent::Progress { done, total, .. } = e {
            progress(*done, *total)
        }
    })
    .map_err(|e| e.locate(job.model))?;
    bar.finish_and_clear();
    let r = match outcome {
        Outcome::Report(r) => *r,
        Outcome::Failed(code) => std::process::exit(code),
    };
    if mode == ProgressMode::Always && !terminal {
        let done: usize = r.families.values().map(|f| f.generated).sum();
        eprintln!(
            "search: done, {done} candidates in {:.2} s (stopped: {})",
            r.seconds,
            r.stop.describe()
        );
    }
    Ok(r)
}
