//! The scene file, through to the scene checked against its model (the syntax and keys, the
//! `[expressions]`, the request, the integrator, the parameters, the initial configuration with
//! the holonomic constraints completed, the output times), without the computer algebra. The
//! model a scene names is looked up among the bundled ones by its file name. Errors are fine; a
//! panic, a hang or an exhausted machine is a finding.
//!
//!     cargo +nightly fuzz run scene seeds/scene -- -max_total_time=60
#![no_main]

use hamel_model::{Model, ModelError};
use libfuzzer_sys::fuzz_target;

const MODELS: [(&str, &str); 10] = [
    ("bar_blade.toml", include_str!("../../models/bar_blade.toml")),
    ("bar_wheels.toml", include_str!("../../models/bar_wheels.toml")),
    ("chaplygin_sleigh.toml", include_str!("../../models/chaplygin_sleigh.toml")),
    ("knife.toml", include_str!("../../models/knife.toml")),
    ("remark22.toml", include_str!("../../models/remark22.toml")),
    ("rolling_disk.toml", include_str!("../../models/rolling_disk.toml")),
    ("snakeboard.toml", include_str!("../../models/snakeboard.toml")),
    ("unicycle_rider.toml", include_str!("../../models/unicycle_rider.toml")),
    ("vertical_knife.toml", include_str!("../../models/vertical_knife.toml")),
    ("whipple_bicycle.toml", include_str!("../../models/whipple_bicycle.toml")),
];

fn model_of(path: &str) -> Result<Model, ModelError> {
    let name = path.rsplit('/').next().unwrap_or(path);
    match MODELS.iter().find(|(n, _)| *n == name) {
        Some((n, text)) => Model::from_source(n, text),
        None => Model::from_source(path, ""),
    }
}

fuzz_target!(|text: &str| {
    if let Ok(c) = hamel_scene::check("fuzz_scene.toml", text, &Default::default(), &model_of) {
        assert_eq!(c.q0.len(), c.model.coordinates.len());
    }
});
