//! A spinner on stderr while symbolic work runs: the time so far and the derivation's stage
//! (`hamel_derive::progress`), drawn on a terminal once the work has lasted a second, and
//! cleared when it ends. Nothing is drawn when stderr is a file or a pipe.

use std::io::IsTerminal;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};

/// Run `work` (which sends its symbolic jobs to the computer-algebra thread) with the spinner.
pub fn while_deriving<T>(what: &str, work: impl FnOnce() -> T) -> T {
    if !std::io::stderr().is_terminal() {
        return work();
    }
    let done = Arc::new(AtomicBool::new(false));
    let spinner = {
        let (done, what) = (done.clone(), what.to_string());
        std::thread::spawn(move || spin(&what, &done))
    };
    let out = work();
    done.store(true, Ordering::Relaxed);
    let _ = spinner.join();
    out
}

fn spin(what: &str, done: &AtomicBool) {
    let started = Instant::now();
    let bar = ProgressBar::with_draw_target(None, ProgressDrawTarget::hidden());
    bar.set_style(
        ProgressStyle::with_template("{spinner} {elapsed} {msg}").expect("valid template"),
    );
    let mut shown = false;
    while !done.load(Ordering::Relaxed) {
        std::thread::sleep(Duration::from_millis(200));
        if started.elapsed() < Duration::from_secs(1) {
            continue;
        }
        if !shown {
            shown = true;
            bar.set_draw_target(ProgressDrawTarget::stderr());
        }
        let stage = hamel_derive::progress::stage().unwrap_or("");
        bar.set_message(format!("{what}: {stage}"));
        bar.tick();
    }
    bar.finish_and_clear();
}
