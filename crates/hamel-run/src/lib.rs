//! The run engine of scenes: what `hamel simulate`, `plan` and `tradeoff` run, as a library.
//!
//! **Job**: a scene (read and checked by the scene language, `hamel-scene`, whose modules are
//! re-exported here) is loaded with its derivation from the store ([`load`]); this crate
//! decides exactly what must be integrated for the outputs requested ([`plan`]), integrates
//! it on the scene's compiled core or the interpreted evaluator ([`simulate`]), runs
//! ensembles on the core's pool ([`ensemble`]), and measures the speed–accuracy trade of
//! every integrator ([`tradeoff`]).
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
//! The modules follow the data: [`check`] → [`load`] (with [`expressions`], [`initial`],
//! [`auto`], [`plan`]) → [`system`] / [`cache`] → [`integrate`] → [`trajectory`],
//! [`compare`] → [`tradeoff`] → [`simulate`]; [`measure`] and [`plot`] at the side.
//!
//! ```no_run
//! let loaded = hamel_run::load(std::path::Path::new("scenes/knife_spin.toml"))?;
//! println!("{}", loaded.plan.to_text());
//! let hamel_run::simulate::Simulated { trajectory, failure, .. } = hamel_run::simulate::run_loaded(&loaded, hamel_run::Engine::Interpreted, false)?;
//! assert!(failure.is_none());
//! print!("{}", trajectory.to_csv());
//! # Ok::<(), hamel_model::ModelError>(())
//! ```

pub mod animate;
pub mod auto;
pub mod cache;
pub mod compare;
pub mod dla;
pub mod ensemble;
pub mod initial;
pub mod integrate;
pub mod load;
pub mod measure;
pub mod plan;
pub mod plot;
pub mod simulate;
pub mod system;
pub mod traced;
pub mod tradeoff;
pub mod trajectory;

pub use hamel_scene::{Checked, Request};
/// The scene language's modules, as the run engine reads them.
pub use hamel_scene::{check, expressions, file, forces, inputs, members, request};

pub use integrate::{Engine, Run, Timed, Usable};
pub use load::{LoadOptions, Loaded, load, load_with, load_with_options};
pub use plan::Plan;
pub use trajectory::Trajectory;
