//! A search whose budget is a wall: the supervisor and the worker of `hamel search`.
//!
//! An exact check (a derivation on the CAS worker) cannot be interrupted from inside, and one
//! can take minutes. So the supervisor ([`supervise`]) makes no CAS call itself: it runs the
//! search in a worker process (which calls [`work`]) that reports [`SearchEvent`]s as JSON
//! lines on its stdout. At the deadline (the budget, measured from the job's start, plus
//! [`GRACE`]) the supervisor ends the worker and reports what the events told it: the
//! candidates found so far, the counts per family, and the reason it stopped, naming the exact
//! check that was abandoned. Only one Symbolica instance runs at a time (the worker's), and its
//! notice, printed on the worker's stdout, is passed through unchanged to the supervisor's.
//!
//! The worker is any program that, given the arguments `MODEL --eliminate X,Y --budget SECONDS
//! --max N` after those the caller puts in its command, loads the model and calls [`work`]
//! (`hamel search-worker` does).

use std::io::{BufRead, BufReader, Write};
use std::path::Path;
use std::process::{Command, Stdio};
use std::sync::mpsc;
use std::time::{Duration, Instant};

use hamel_model::Model;

use crate::ReduceError;
use indexmap::IndexMap;
use serde::{Deserialize, Serialize};

use crate::{Candidate, FamilyStats, SearchEvent, SearchReport, StopReason};

/// Time the worker gets past the budget to finish on its own (its own check of the budget,
/// between candidates, and its report) before it is ended.
pub const GRACE: Duration = Duration::from_millis(1000);

/// Each line of the worker's protocol starts with this; other lines of its stdout (Symbolica's
/// notice) are passed through.
const PREFIX: &str = "hamel-search-worker: ";

/// A line of the worker's protocol.
#[derive(Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
enum Message {
    /// An event of the running search.
    Event(SearchEvent),
    /// The search's own report (it finished within its budget).
    Report(SearchReport),
}

/// What the supervisor got: the report, or the worker's exit status when it failed (it has
/// printed its error on stderr, which the supervisor shares).
pub enum Outcome {
    /// The search's report.
    Report(Box<SearchReport>),
    /// The worker failed with this exit status.
    Failed(i32),
}

/// A search to run.
pub struct Job<'a> {
    /// The model file (the worker loads it again).
    pub model_path: &'a Path,
    /// The model, loaded and checked.
    pub model: &'a Model,
    /// The coordinates to eliminate.
    pub eliminate: &'a [String],
    /// The budget of the whole command.
    pub budget: Duration,
    /// Most candidates.
    pub max: usize,
    /// When the command started.
    pub started: Instant,
}

/// The worker program and its arguments, once named ([`search_in_worker`]).
static WORKER: std::sync::OnceLock<(std::path::PathBuf, Vec<String>)> = std::sync::OnceLock::new();

/// From now on, [`run_search`] searches in a worker process: `program` with `args`, then the
/// job's (`hamel` calls itself as `hamel search-worker`). Set once; later calls are ignored.
pub fn search_in_worker(program: std::path::PathBuf, args: Vec<String>) {
    let _ = WORKER.set((program, args));
}

/// A search of `model` (loaded from `model_path`) within `options.budget`, for a library
/// caller such as a scene's `eta = "auto"`: in the worker process named by
/// [`search_in_worker`] unless this process has started the computer algebra already (the
/// licence's thread is then the worker's, given back when it ends, and the budget is a wall),
/// else here ([`crate::search`]).
pub fn run_search(
    model_path: &Path,
    model: &Model,
    eliminate: &[String],
    options: crate::SearchOptions,
) -> Result<SearchReport, ReduceError> {
    let Some((program, args)) = WORKER.get().filter(|_| !hamel_cas::started()) else {
        return crate::search(model, eliminate, options, Box::new(|_| {}));
    };
    let job = Job {
        model_path,
        model,
        eliminate,
        budget: options.budget,
        max: options.max_candidates,
        started: Instant::now(),
    };
    let mut worker = Command::new(program);
    worker.args(args);
    match supervise(&job, worker, |_| {})? {
        Outcome::Report(r) => Ok(*r),
        Outcome::Failed(code) => Err(ReduceError::SearchWorker(format!(
            "the search worker failed (exit status {code}; its error is above)"
        ))),
    }
}

/// Run the search of `job` in a worker process (`worker`, to which the job's arguments are
/// added), within its budget of its start; `on_event` sees every event (for a progress bar).
pub fn supervise(
    job: &Job,
    mut worker: Command,
    mut on_event: impl FnMut(&SearchEvent),
) -> Result<Outcome, ReduceError> {
    let Job {
        model_path,
        model,
        eliminate,
        budget,
        max,
        started,
    } = *job;
    crate::coordinate_indices(model, eliminate)?;
    let left = budget.saturating_sub(started.elapsed());
    let mut child = worker
        .arg(model_path)
        .arg("--eliminate")
        .arg(eliminate.join(","))
        .arg("--budget")
        .arg(format!("{}", left.as_secs_f64()))
        .arg("--max")
        .arg(max.to_string())
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::inherit())
        .spawn()
        .map_err(|e| ReduceError::SearchWorker(format!("cannot start the search worker: {e}")))?;
    let (tx, rx) = mpsc::channel();
    let stdout = child.stdout.take().expect("piped");
    let reader = std::thread::spawn(move || relay(stdout, tx));
    let deadline = started + budget + GRACE;
    let mut seen = Seen::default();
    let report = loop {
        let wait = deadline.saturating_duration_since(Instant::now());
        match rx.recv_timeout(wait) {
            Ok(Message::Event(e)) => {
                on_event(&e);
                seen.record(e);
            }
            Ok(Message::Report(r)) => break Some(r),
            Err(mpsc::RecvTimeoutError::Disconnected) => break None,
            Err(mpsc::RecvTimeoutError::Timeout) => {
                let _ = child.kill();
                break None;
            }
        }
    };
    let status = child
        .wait()
        .map_err(|e| ReduceError::SearchWorker(format!("search worker: {e}")))?;
    let _ = reader.join();
    Ok(match report {
        Some(r) => Outcome::Report(Box::new(r)),
        None if Instant::now() >= deadline => {
            Outcome::Report(Box::new(seen.report(model, eliminate, budget, started)))
        }
        None => Outcome::Failed(status.code().unwrap_or(1)),
    })
}

/// Read the worker's stdout: protocol lines to `tx`, other lines to our stdout unchanged.
fn relay(stdout: impl std::io::Read, tx: mpsc::Sender<Message>) {
    let mut out = std::io::stdout();
    for line in BufReader::new(stdout).lines() {
        let Ok(line) = line else { break };
        match line
            .strip_prefix(PREFIX)
            .and_then(|m| serde_json::from_str(m).ok())
        {
            Some(m) => {
                if tx.send(m).is_err() {
                    break;
                }
            }
            None => {
                let _ = writeln!(out, "{line}");
            }
        }
    }
}

/// What the events said, for the report of an ended worker.
#[derive(Default)]
struct Seen {
    families: IndexMap<String, FamilyStats>,
    found: Vec<Candidate>,
    /// The exact check under way, if any: (family, η).
    checking: Option<(String, Vec<String>)>,
}

impl Seen {
    fn record(&mut self, e: SearchEvent) {
        match e {
            SearchEvent::Progress { families, .. } => {
                self.families = families;
                self.checking = None;
            }
            SearchEvent::Checking { family, eta } => self.checking = Some((family, eta)),
            SearchEvent::Found(c) => self.found.push(c),
        }
    }

    fn report(
        self,
        model: &Model,
        eliminate: &[String],
        budget: Duration,
        started: Instant,
    ) -> SearchReport {
        let mut candidates = self.found;
        crate::sort_candidates(&mut candidates);
        let none_found = candidates.is_empty().then(|| {
            format!(
                "the budget of {:.3} s ran out before any reducing choice was found",
                budget.as_secs_f64()
            )
        });
        SearchReport {
            model: model.name.clone(),
            eliminate: eliminate.to_vec(),
            candidates,
            families: self.families,
            none_found,
            unsolved_conditions: Vec::new(),
            stop: match self.checking {
                Some((family, eta)) => StopReason::BudgetDuringCheck { family, eta },
                None => StopReason::Budget,
            },
            seconds: started.elapsed().as_secs_f64(),
        }
    }
}

/// The worker: run the search in-process and write the protocol on stdout.
pub fn work(
    model: &Model,
    eliminate: &[String],
    budget: Duration,
    max: usize,
) -> Result<(), ReduceError> {
    let send = |m: &Message| {
        let line = serde_json::to_string(m).expect("serialisable");
        let mut out = std::io::stdout().lock();
        let _ = writeln!(out, "{PREFIX}{line}");
        let _ = out.flush();
    };
    let options = crate::SearchOptions {
        budget,
        max_candidates: max,
    };
    let events: crate::Events = Box::new(move |e| send(&Message::Event(e)));
    let r = crate::search(model, eliminate, options, events)?;
    send(&Message::Report(r));
    Ok(())
}
