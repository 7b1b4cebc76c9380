//! An ensemble's members file (`[ensemble] file`), read and checked against a model without the
//! computer algebra: CSV with a header line or JSON lines. The first byte picks the format and
//! the model (the knife or the unicycle with its rider). Errors are fine; a panic, a hang or an
//! exhausted machine is a finding.
//!
//!     cargo +nightly fuzz run members seeds/members -- -max_total_time=60
#![no_main]

use std::sync::OnceLock;

use hamel_model::Model;
use hamel_scene::file::Save;
use libfuzzer_sys::fuzz_target;

const KNIFE: &str = include_str!("../../models/knife.toml");
const UNICYCLE: &str = include_str!("../../models/unicycle_rider.toml");

fuzz_target!(|data: &[u8]| {
    let Some((&pick, rest)) = data.split_first() else {
        return;
    };
    let Ok(text) = std::str::from_utf8(rest) else {
        return;
    };
    // Parsed once: the target is the members file, not the model.
    static MODELS: OnceLock<[Model; 2]> = OnceLock::new();
    let models = MODELS.get_or_init(|| {
        [
            Model::from_source("knife.toml", KNIFE).expect("a bundled model"),
            Model::from_source("unicycle_rider.toml", UNICYCLE).expect("a bundled model"),
        ]
    });
    let model = &models[usize::from(pick & 2 != 0)];
    let name = if pick & 1 == 0 { "members.csv" } else { "members.jsonl" };
    if let Ok(m) = hamel_scene::members::read(name, text, model, Save::Final) {
        assert!(!m.rows.is_empty() && m.rows.len() <= hamel_scene::members::MAX_MEMBERS);
        assert!(m.rows.iter().all(|r| r.len() == m.columns.len()));
        assert!(m.rows.iter().flatten().flatten().all(|v| v.is_finite()));
    }
});
