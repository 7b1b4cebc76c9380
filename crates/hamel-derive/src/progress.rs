//! Which stage a derivation (or a later analysis of it) is in, for a caller's progress display:
//! the work runs on the computer-algebra thread and says where it is with a [`Stage`];
//! [`stage`] reads it from any thread.

use std::sync::Mutex;

static STAGE: Mutex<Option<&'static str>> = Mutex::new(None);

/// The stage the derivation running now is in (none between derivations).
pub fn stage() -> Option<&'static str> {
    *STAGE.lock().unwrap_or_else(|e| e.into_inner())
}

fn set(stage: Option<&'static str>) {
    *STAGE.lock().unwrap_or_else(|e| e.into_inner()) = stage;
}

/// A stage of symbolic work: announced to [`stage`] as it starts, its time logged at debug level
/// as it ends (`HAMEL_LOG=debug`). Dropping it ends the last stage.
pub struct Stage {
    model: String,
    name: &'static str,
    at: std::time::Instant,
}

impl Stage {
    /// Start the first stage, `first`, of the work on `model`.
    pub fn start(model: &str, first: &'static str) -> Stage {
        set(Some(first));
        Stage {
            model: model.to_string(),
            name: first,
            at: std::time::Instant::now(),
        }
    }

    /// End this stage and start `next`.
    pub fn next(&mut self, next: &'static str) {
        let elapsed = self.at.elapsed().as_secs_f64();
        log::debug!("{}: {}: {elapsed:.3} s", self.model, self.name);
        set(Some(next));
        self.name = next;
        self.at = std::time::Instant::now();
    }
}

impl Drop for Stage {
    fn drop(&mut self) {
        self.next("");
        set(None);
    }
}
