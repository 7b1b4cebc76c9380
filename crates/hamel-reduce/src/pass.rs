//! The one computer-algebra pass (issue 59): a derivation and the analysis a later stage asks of
//! it, made once, stored, and taken by every stage after.
//!
//! **Job**: for a [`Job`] (a model, a choice, whether the wheels' supports are released, whether
//! with the ingredients code generation uses, and the [`Analysis`] asked), make the
//! [`Artefact`]: the [`Derivation`], the [`Reduction`] and the steady motion's exact check
//! where asked, in **one** job on the computer-algebra thread ([`make`]). [`obtain`] takes it
//! from the derivation store ([`hamel_derive::store`]) when it holds it, so that a command whose
//! artefact is stored starts no computer algebra at all; else it makes it, in a worker process
//! when the program has named one ([`derive_in_worker`]: `hamel derive-worker`), so that the
//! licence's one thread is given back when the process exits, before any numeric work, and
//! stores it.
//!
//! **Invariant**: no stage derives for itself: codegen, scenes, studies, linearisation and
//! eval take an artefact from here. Symbolica's notice is printed by whichever process runs it
//! (the worker's stdout is the command's), untouched.

use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::sync::OnceLock;

use hamel_derive::{Derivation, FormRequest, store};
use hamel_model::{Coord, Model, SteadyCheck};

use crate::error::{ReduceError, WorkerFailure};
use serde::{Deserialize, Serialize};

use crate::Reduction;

/// What the pass analyses besides deriving.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum Analysis {
    /// The equations only (`hamel eval`, `hamel codegen` without `--eliminate`).
    Equations,
    /// The elimination of these coordinates (indices) analysed (`hamel reduce`, `hamel
    /// codegen --eliminate`).
    Eliminate(Vec<Coord>),
    /// Every coordinate asked about: which the true equations (11) are free of, decided exactly
    /// (a scene's plan is checked against it).
    Survey,
    /// The coordinates the true equations are free of, dropped as far as the reduced system
    /// stays closed (`hamel linearize`), and the steady motion named checked exactly.
    Drop {
        /// The steady motion to check (`[steady.NAME]`).
        steady: Option<String>,
    },
}

/// What to make: the input of the pass, and (with hamel's build) the key of its artefact in
/// the store.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Job {
    /// The model as the stage has it (parameters set, loop closed, choices added).
    pub model: Model,
    /// The quasi-velocity choice's name.
    pub choice: String,
    /// With the supports of the wheels the frames keep on the ground released
    /// ([`Model::with_supports`]: for the constraint forces).
    pub supports: bool,
    /// With the ingredients code generation uses ([`hamel_derive::derive_for_code`]).
    pub code: bool,
    /// The analysis asked.
    pub analysis: Analysis,
    /// With `hamel eval`'s evaluator ([`hamel_derive::states::Evaluator`]).
    pub evaluator: bool,
}

/// What the pass makes.
#[derive(Debug, Serialize, Deserialize)]
pub struct Artefact {
    /// The derivation (of the model with its supports released when the job says so), decoded
    /// when asked for ([`Artefact::into_derivation`]).
    derivation: store::Held,
    /// The reduction: of the coordinates asked ([`Analysis::Eliminate`]), of every coordinate
    /// ([`Analysis::Survey`]), of those dropped ([`Analysis::Drop`], `None` when none drop).
    pub reduction: Option<Reduction>,
    /// The steady motion's check ([`Analysis::Drop`] with a steady motion).
    pub steady_check: Option<SteadyCheck>,
    /// `hamel eval`'s evaluator, when asked ([`Job::evaluator`]); `None` too when the equations
    /// do not compile (the derivation, compiled by the caller, says why).
    pub evaluator: Option<hamel_derive::states::Evaluator>,
}

impl Artefact {
    /// The derivation.
    pub fn into_derivation(self) -> Result<Derivation, ReduceError> {
        (self.derivation.into_derivation())
            .map_err(|e| ReduceError::StoredUnreadable(e.to_string()))
    }
}

impl Job {
    /// The job for `model`'s choice `eta` (its first when `None`).
    pub fn new(model: &Model, eta: Option<&str>, analysis: Analysis) -> Result<Job, ReduceError> {
        Ok(Job {
            choice: model.choice(eta)?.name.clone(),
            model: model.clone(),
            supports: false,
            code: false,
            analysis,
            evaluator: false,
        })
    }

    /// The same job with the supports released.
    pub fn with_supports(mut self, supports: bool) -> Job {
        self.supports = supports;
        self
    }

    /// The same job with the ingredients code generation uses.
    pub fn for_code(mut self) -> Job {
        self.code = true;
        self
    }

    /// The same job with `hamel eval`'s evaluator.
    pub fn with_evaluator(mut self) -> Job {
        self.evaluator = true;
        self
    }

    /// The key of the artefact in the store.
    fn key(&self) -> Result<store::Key, ReduceError> {
        let purpose = format!(
            "{:?}; ingredients for code: {}; evaluator: {}",
            self.analysis, self.code, self.evaluator
        );
        Ok(store::Key::new(&self.model, &self.choice, self.supports)?.with(&purpose))
    }
}

/// Make the artefact of `job` here, in one job on the computer-algebra thread.
pub fn make(job: &Job) -> Result<Artefact, ReduceError> {
    let model = match job.supports {
        true => job.model.with_supports()?,
        false => job.model.clone(),
    };
    model.choice(Some(&job.choice))?;
    let job = Job {
        model,
        ..job.clone()
    };
    hamel_cas::run(move || in_pass(&job)).map_err(ReduceError::Engine)?
}

/// The pass itself, on the computer-algebra thread.
fn in_pass(job: &Job) -> Result<Artefact, ReduceError> {
    let model = &job.model;
    let derived = hamel_derive::derive_form(model, &job.choice, FormRequest::Auto)?;
    let d = derived.to_derivation(job.code);
    let (reduction, steady_check) = match &job.analysis {
        Analysis::Equations => (None, None),
        Analysis::Eliminate(p) => {
            let p: Vec<usize> = p.iter().map(|k| k.index()).collect();
            (Some(crate::analyse(model, &derived, &p, Some(&d))?), None)
        }
        Analysis::Survey => {
            let all: Vec<usize> = (0..d.ell).collect();
            (Some(crate::analyse(model, &derived, &all, Some(&d))?), None)
        }
        Analysis::Drop { steady } => {
            let r = drop(model, &derived, &d)?;
            let check = match steady {
                Some(name) => Some(crate::steady::check_dropped(model, name, &d, r.as_ref())?),
                None => None,
            };
            (r, check)
        }
    };
    let evaluator = match job.evaluator {
        true => hamel_derive::states::Evaluator::of(&d).ok(),
        false => None,
    };
    Ok(Artefact {
        derivation: store::Held::Decoded(Box::new(d)),
        reduction,
        steady_check,
        evaluator,
    })
}

/// The coordinates the true equations (11) are free of, decided exactly, dropped as far as the
/// reduced system stays closed (a kept coordinate's kinematic equation may need one back: it
/// is then kept); the reduction that proves it (`None` when none drop out).
fn drop(
    model: &Model,
    derived: &hamel_derive::Derived,
    d: &Derivation,
) -> Result<Option<Reduction>, ReduceError> {
    let all: Vec<usize> = (0..d.ell).collect();
    let truth = crate::analyse(model, derived, &all, Some(d))?.ground_truth;
    let index = |n: &String| model.coordinate(n).map(Coord::index);
    let mut p: Vec<usize> = truth.absent_in(model).iter().map(|k| k.index()).collect();
    while !p.is_empty() {
        let r = crate::analyse(model, derived, &p, Some(d))?;
        let back = r.ground_truth.kinematics_witness.as_ref();
        match back.and_then(|w| w.coordinate.as_ref()).and_then(index) {
            Some(k) if !r.ground_truth.kinematics_closed => p.retain(|&c| c != k),
            _ if r.ground_truth.kinematics_closed => return Ok(Some(r)),
            _ => break,
        }
    }
    Ok(None)
}

/// The program that makes artefacts in a process of its own: `program args… RESULT`, the job
/// (CBOR) on its stdin ([`work`]).
struct Worker {
    program: PathBuf,
    args: Vec<String>,
}

static WORKER: OnceLock<Worker> = OnceLock::new();

/// From now on, [`obtain`] makes what the store lacks in a worker process: `program` with
/// `args`, then the path of the result (`hamel` calls itself as `hamel derive-worker`). The
/// worker's exit gives the computer algebra's thread back. Set once; later calls are ignored.
pub fn derive_in_worker(program: PathBuf, args: Vec<String>) {
    let _ = WORKER.set(Worker { program, args });
}

/// The artefact of `job`: from the derivation store when it holds a sound one (no computer
/// algebra then) unless `fresh` (`--no-store`), else made (in the worker process when one is
/// named, [`derive_in_worker`]; else here) and stored.
pub fn obtain(job: &Job, fresh: bool) -> Result<Artefact, ReduceError> {
    let key = job.key()?;
    if !fresh && let Some(a) = store::lookup::<Artefact>(&key) {
        return Ok(a);
    }
    // A process that has started the computer algebra already (a library caller that ran a
    // search or a derivation here) holds the thread: the pass runs here then.
    let artefact = match WORKER.get() {
        Some(w) if !hamel_cas::started() => in_worker(w, job)?,
        _ => make(job)?,
    };
    store::put(&key, &artefact);
    Ok(artefact)
}

/// The cache's private directory where workers leave their results.
fn results_dir() -> Result<PathBuf, hamel_cache::RootError> {
    hamel_cache::private(&hamel_cache::root()?.join("work"))
}

/// Make the artefact of `job` in the worker process; where the cache cannot hold its result,
/// here (with a warning).
fn in_worker(w: &Worker, job: &Job) -> Result<Artefact, ReduceError> {
    let dir = match results_dir() {
        Ok(d) => d,
        Err(e) => {
            log::warn!("deriving in this process: {e}");
            return make(job);
        }
    };
    let nanos = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.as_nanos());
    let result = dir.join(format!("derive-{}-{nanos}.result", std::process::id()));
    let failed = |failure: WorkerFailure| ReduceError::DeriveWorker {
        program: w.program.clone(),
        failure,
    };
    let exchange = |why: String| failed(WorkerFailure::Exchange(why));
    let mut input = Vec::new();
    ciborium::into_writer(job, &mut input).map_err(|e| exchange(e.to_string()))?;
    let mut child = Command::new(&w.program)
        .args(&w.args)
        .arg(&result)
        .stdin(Stdio::piped())
        .spawn()
        .map_err(|e| failed(WorkerFailure::Start(e.to_string())))?;
    let written = child.stdin.take().map(|mut s| s.write_all(&input));
    let status = child.wait().map_err(|e| exchange(e.to_string()))?;
    let bytes = std::fs::read(&result);
    let _ = std::fs::remove_file(&result);
    match (bytes, written) {
        (Ok(bytes), _) => read_result(&bytes).map_err(|e| exchange(e.to_string()))?,
        (Err(_), Some(Err(e))) => Err(exchange(format!("cannot give it the job: {e}"))),
        (Err(_), _) => Err(failed(ended_without_result(status))),
    }
}

/// Why a worker left no result: its status, and for an abort the likely cause.
fn ended_without_result(status: std::process::ExitStatus) -> WorkerFailure {
    use std::os::unix::process::ExitStatusExt;
    let text = status.to_string();
    match status.signal() {
        Some(libc::SIGABRT) => WorkerFailure::LicenceHeld { status: text },
        Some(libc::SIGPIPE) => WorkerFailure::OutputClosed { status: text },
        _ => WorkerFailure::NoResult { status: text },
    }
}

/// The worker's result as written by [`work`].
fn read_result(
    bytes: &[u8],
) -> Result<Result<Artefact, ReduceError>, ciborium::de::Error<std::io::Error>> {
    store::from_cbor(bytes)
}

/// The worker's side (`hamel derive-worker RESULT`): read a [`Job`] (CBOR) from stdin, make its
/// artefact here ([`make`]) and write the outcome, the artefact or the located error, to
/// `result` (whole or not at all). An error is the caller's to report: `Err` only when the job
/// cannot be read or the result written.
pub fn work(result: &Path) -> Result<(), ReduceError> {
    let job: Job = store::from_cbor(std::io::stdin().lock())
        .map_err(|e| ReduceError::WorkerSide(format!("no job on stdin: {e}")))?;
    let outcome = make(&job);
    let mut bytes = Vec::new();
    ciborium::into_writer(&outcome, &mut bytes)
        .map_err(|e| ReduceError::WorkerSide(e.to_string()))?;
    let (dir, name) = match (result.parent(), result.file_name()) {
        (Some(d), Some(n)) => (d, n.to_string_lossy()),
        _ => return Err(ReduceError::WorkerSide("no result file named".into())),
    };
    hamel_cache::write_atomic(dir, &name, &bytes)
        .map_err(|e| ReduceError::WorkerSide(format!("{}: {e}", result.display())))
}
