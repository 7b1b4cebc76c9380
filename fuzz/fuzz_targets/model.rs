//! The model file, with bodies, frames and wheels: any text through to the loaded, checked
//! model, then one step further without the computer algebra: the mass matrix, the constraint
//! matrix, U, the forces and every choice's Z evaluated at sample configurations, and the
//! holonomic constraints completed there. Errors are fine; a panic, a hang or an exhausted
//! machine is a finding.
//!
//!     cargo +nightly fuzz run model seeds/model -- -max_total_time=60
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|text: &str| {
    if let Ok(model) = hamel_model::Model::from_source("fuzz.toml", text) {
        hamel_fuzz::exercise(&model);
    }
});
