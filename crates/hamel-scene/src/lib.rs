//! Scenes: what `hamel simulate`, `plan` and `tradeoff` run, as a library.
//!
//! **Job**: a scene file names a model, a quasi-velocity choice, parameter values, an initial
//! state, the outputs wanted and an integrator (or an accuracy target). This crate reads and
//! checks it ([`load`]), decides exactly what must be integrated for the outputs requested
//! ([`plan`]), integrates it on the scene's compiled core or the interpreted evaluator
//! ([`simulate`]), and measures the speed–accuracy trade of every integrator ([`tradeoff`]).
//!
//! **Inputs**: a scene file (TOML) and the model file it names. **Outputs**: a [`Loaded`]
//! scene (its derivation, [`Plan`] and initial state), [`Trajectory`]s, tradeoff
//! [`Table`](tradeoff::Table)s, plots.
//!
//! **Invariants**: every error names the scene (or model) file, the key and the reason; the
//! plan's decisions are exact (canonical forms, confirmed by `hamel-reduce`'s ground truth);
//! the compiled core is engine-free (no CAS), built once per scene and cached
//! ([`cache`]); a failed integration keeps what was computed, marked incomplete.
//!
//! The modules follow the data: [`file`] → [`load`] (with [`expressions`], [`initial`],
//! [`auto`], [`plan`]) → [`system`] / [`cache`] → [`integrate`] → [`trajectory`],
//! [`compare`] → [`tradeoff`] → [`simulate`]; [`measure`] and [`plot`] at the side.
//!
//! ```no_run
//! let loaded = hamel_scene::load(std::path::Path::new("scenes/knife_spin.toml"))?;
//! println!("{}", loaded.plan.to_text());
//! let (trajectory, failure) = hamel_scene::simulate::run_loaded(&loaded, hamel_scene::Engine::Interpreted, false)?;
//! assert!(failure.is_none());
//! print!("{}", trajectory.to_csv());
//! # Ok::<(), hamel_model::ModelError>(())
//! ```

pub mod auto;
pub mod cache;
pub mod compare;
pub mod expressions;
pub mod file;
pub mod initial;
pub mod integrate;
pub mod load;
pub mod measure;
pub mod plan;
pub mod plot;
pub mod simulate;
pub mod system;
pub mod tradeoff;
pub mod trajectory;

pub use integrate::{Engine, Run};
pub use load::{Loaded, load, load_with};
pub use plan::{Plan, Request};
pub use trajectory::Trajectory;
