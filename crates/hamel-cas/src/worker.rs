//! The one thread that runs the computer-algebra engine.
//!
//! Symbolica, unlicensed, allows one thread per user at a time. Every symbolic computation of
//! hamel therefore runs here: callers (CLI commands, parallel test threads) send a job and wait
//! for its result. Field values ([`crate::Ex`]) are `!Send`, so they cannot leave a job.

use std::cell::Cell;
use std::panic::{AssertUnwindSafe, catch_unwind};
use std::sync::mpsc::{self, Sender};
use std::sync::{Mutex, OnceLock};

use crate::CasError;

type Job = Box<dyn FnOnce() + Send>;

static WORKER: OnceLock<Mutex<Sender<Job>>> = OnceLock::new();

thread_local! {
    static ON_WORKER: Cell<bool> = const { Cell::new(false) };
}

fn sender() -> Result<Sender<Job>, CasError> {
    let lock = WORKER.get_or_init(|| {
        let (tx, rx) = mpsc::channel::<Job>();
        std::thread::Builder::new()
            .name("hamel-cas".into())
            .stack_size(256 << 20)
            .spawn(move || {
                ON_WORKER.with(|w| w.set(true));
                for job in rx {
                    job();
                }
            })
            .expect("cannot start the computer-algebra thread");
        Mutex::new(tx)
    });
    let guard = lock
        .lock()
        .map_err(|_| CasError::Internal("the computer-algebra thread is unavailable".into()))?;
    Ok(guard.clone())
}

/// True once this process has started its computer-algebra thread (it then holds the
/// licence's one thread until it exits: a worker process started now could not run).
pub fn started() -> bool {
    WORKER.get().is_some()
}

/// True on the computer-algebra thread.
pub fn on_worker() -> bool {
    ON_WORKER.with(Cell::get)
}

/// Run `job` on the computer-algebra thread and return its result.
///
/// Jobs run one at a time, in the order they arrive. Called from the worker itself (a job that
/// calls `run`), the job runs inline. A panic inside the job is caught and returned as
/// [`CasError::Internal`]; the worker stays usable.
pub fn run<R, F>(job: F) -> Result<R, CasError>
where
    R: Send + 'static,
    F: FnOnce() -> R + Send + 'static,
{
    if on_worker() {
        return catch_unwind(AssertUnwindSafe(job)).map_err(panic_message);
    }
    let (tx, rx) = mpsc::channel();
    sender()?
        .send(Box::new(move || {
            let out = catch_unwind(AssertUnwindSafe(job)).map_err(panic_message);
            let _ = tx.send(out);
        }))
        .map_err(|_| CasError::Internal("the computer-algebra thread has stopped".into()))?;
    rx.recv()
        .map_err(|_| CasError::Internal("the computer-algebra thread dropped a job".into()))?
}

fn panic_message(p: Box<dyn std::any::Any + Send>) -> CasError {
    let msg = p
        .downcast_ref::<&str>()
        .map(|s| s.to_string())
        .or_else(|| p.downcast_ref::<String>().cloned())
        .unwrap_or_else(|| "unknown panic".into());
    CasError::Internal(format!("the symbolic computation failed: {msg}"))
}
