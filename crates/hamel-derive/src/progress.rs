//! Which stage a derivation is in, for a caller's progress display: the derivation runs on the
//! computer-algebra thread and says where it is; [`stage`] reads it from any thread.

use std::sync::Mutex;

static STAGE: Mutex<Option<&'static str>> = Mutex::new(None);

/// The stage the derivation running now is in (none between derivations).
pub fn stage() -> Option<&'static str> {
    *STAGE.lock().unwrap_or_else(|e| e.into_inner())
}

pub(crate) fn set(stage: Option<&'static str>) {
    *STAGE.lock().unwrap_or_else(|e| e.into_inner()) = stage;
}
