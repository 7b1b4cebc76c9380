//! The scene language: a scene file read and checked against its model, with no computer
//! algebra.
//!
//! **Job**: a scene file names a model, a quasi-velocity choice, parameter values, an initial
//! state, the outputs wanted, inputs and forces, an integrator (or an accuracy target) and
//! perhaps an ensemble's members. This crate reads it ([`file`]) and checks every part of it
//! against the model ([`check`]: the `[expressions]`, the [`request`], the [`initial`] state,
//! the [`inputs`] and their tables, the [`forces`], the [`members`]), before anything is
//! derived. The run engine (`hamel-run`: load, plan, the code cache, integration, ensembles,
//! the trade-off) takes a [`Checked`] scene from here.
//!
//! **Inputs**: a scene's text and a way to load the model it names. **Outputs**: a
//! [`Checked`] scene (the file, the model, the parsed expressions, the request), or an error
//! naming the scene file, the key and the reason.
//!
//! **Invariants**: nothing here links the computer algebra (what the fuzz targets and the
//! exported cores need); every error names the scene (or model) file, the key and the reason.
//!
//! The modules follow the data: [`file`] → [`check`] (with [`expressions`], [`request`],
//! [`initial`], [`inputs`], [`forces`], [`members`]).

pub mod check;
pub mod expressions;
pub mod file;
pub mod forces;
pub mod initial;
pub mod inputs;
pub mod members;
pub mod request;

pub use check::{Checked, check};
pub use request::Request;
