//! Code generation: a derivation as a standalone Rust crate.
//!
//! **Job**: turn the plain result of a derivation ([`hamel_derive::Derivation`], made by the CAS
//! stage) into the source of a crate that evaluates the equations without any computer algebra:
//! straight-line f64 code (generic over a scalar type, so dual numbers give exact Jacobians) for
//! the ingredients Z, α, A, U, ∇U, ∂A/∂q, ∂Z/∂q, ∂α/∂q, with common subexpressions shared
//! ([`hamel_expr::Tape`]), over the numeric runtime (`hamel-runtime`, vendored) that assembles the
//! Boltzmann–Hamel right-hand side (6), (9), (11) from them, the reduced system, the
//! reconstruction, the energy, the constraint residual and the reduced Jacobian.
//!
//! **Inputs**: a derivation (free functions defined), the coordinates proven eliminated (by
//! `hamel reduce`'s exact ground truth). **Outputs**: [`Generated`]: files (path, text) and the
//! operation counts before and after sharing.
//!
//! Without the default feature `derive` only the derivation-free parts are built (escaping
//! text into generated source, manifests, the registry, the Python export's text): what the
//! fuzz targets link, without the computer algebra.
//!
//! **Invariant**: the generated crate depends on its vendored `hamel-runtime`, serde and
//! serde_json only, never on the CAS; its text depends only on the derivation (deterministic,
//! so checked-in copies can be compared with a fresh generation).
#![warn(missing_docs)]

pub use error::CodegenError;
#[cfg(feature = "derive")]
pub use generate::*;

/// The numeric runtime (`crates/hamel-runtime/src/*.rs`, listed by `build.rs`), vendored into
/// every generated crate as a path dependency under `vendor/`: (path inside the crate, text).
pub const RUNTIME_SOURCES: &[(&str, &str)] =
    include!(concat!(env!("OUT_DIR"), "/runtime_sources.rs"));

mod error;
pub mod escape;
#[cfg(feature = "derive")]
mod generate;
pub mod manifest;
pub mod python;
pub mod registry;
#[cfg(feature = "derive")]
pub mod write;
