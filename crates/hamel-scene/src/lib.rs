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
//! Without the default feature `derive` only [`file`], [`check`] (with [`expressions`],
//! [`request`], [`initial`]) are built: a scene read and checked against its model, with no
//! computer algebra (what the fuzz target links).
//!
//! The modules follow the data: [`file`] → [`check`] → [`load`] (with [`expressions`],
//! [`initial`], [`auto`], [`plan`]) → [`system`] / [`cache`] → [`integrate`] → [`trajectory`],
//! [`compare`] → [`tradeoff`] → [`simulate`]; [`measure`] and [`plot`] at the side.
//!
//! ```no_run
//! let loaded = hamel_scene::load(std::path::Path::new("scenes/knife_spin.toml"))?;
//! println!("{}", loaded.plan.to_text());
//! let hamel_scene::simulate::Simulated { trajectory, failure } = hamel_scene::simulate::run_loaded(&loaded, hamel_scene::Engine::Interpreted, false)?;
//! assert!(failure.is_none());
//! print!("{}", trajectory.to_csv());
//! # Ok::<(), hamel_model::ModelError>(())
//! ```

#[cfg(feature = "derive")]
pub mod auto;
#[cfg(feature = "derive")]
pub mod cache;
pub mod check;
#[cfg(feature = "derive")]
pub mod compare;
#[cfg(feature = "derive")]
pub mod ensemble;
pub mod expressions;
pub mod file;
pub mod forces;
pub mod initial;
pub(crate) mod inputs;
#[cfg(feature = "derive")]
pub mod integrate;
#[cfg(feature = "derive")]
pub mod load;
#[cfg(feature = "derive")]
pub mod measure;
pub mod members;
#[cfg(feature = "derive")]
pub mod plan;
#[cfg(feature = "derive")]
pub mod plot;
pub mod request;
#[cfg(feature = "derive")]
pub mod simulate;
#[cfg(feature = "derive")]
pub mod system;
#[cfg(feature = "derive")]
pub mod tradeoff;
#[cfg(feature = "derive")]
pub mod trajectory;

pub use check::{Checked, check};
#[cfg(feature = "derive")]
pub use integrate::{Engine, Run};
#[cfg(feature = "derive")]
pub use load::{Loaded, load, load_with, load_with_options};
#[cfg(feature = "derive")]
pub use plan::Plan;
pub use request::Request;
#[cfg(feature = "derive")]
pub use trajectory::Trajectory;
