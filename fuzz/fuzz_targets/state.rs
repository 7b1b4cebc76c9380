//! The state file of `hamel eval` (JSON), read and checked against bundled models and each of
//! their quasi-velocity choices, then one step further without the computer algebra: the
//! model's matrices at each state's configuration with its parameters. Errors are fine; a
//! panic, a hang or an exhausted machine is a finding.
//!
//!     cargo +nightly fuzz run state seeds/state -- -max_total_time=60
#![no_main]

use std::sync::OnceLock;

use hamel_model::{Model, NumericModel};
use libfuzzer_sys::fuzz_target;

fn models() -> &'static [Model] {
    static MODELS: OnceLock<Vec<Model>> = OnceLock::new();
    MODELS.get_or_init(|| {
        [
            ("knife.toml", include_str!("../../models/knife.toml")),
            ("rolling_disk.toml", include_str!("../../models/rolling_disk.toml")),
            ("bar_blade.toml", include_str!("../../models/bar_blade.toml")),
        ]
        .iter()
        .map(|(name, text)| Model::from_source(name, text).expect("bundled model"))
        .collect()
    })
}

fuzz_target!(|text: &str| {
    for model in models() {
        for choice in &model.choices {
            let Ok(read) = hamel_model::states::read(model, Some(&choice.name), "fuzz.json", text)
            else {
                continue;
            };
            for s in &read.states {
                if let Ok(numeric) = NumericModel::new(model, &s.params) {
                    let _ = numeric.mass_matrix::<f64>(&s.q);
                    let _ = numeric.constraint_matrix::<f64>(&s.q);
                }
            }
        }
    }
});
