//! The library of `crates/hamel-models`: every generated core as a module, and a table of them.

use std::fmt::Write;

use crate::escape::{rust_ident, rust_str};

/// One generated core: module name, model, choice, and the scene whose control laws close its
/// loop (empty for a model file's own equations).
pub struct Member {
    /// Directory under `generated/` (also the module name).
    pub dir: String,
    /// Model name.
    pub model: String,
    /// Quasi-velocity choice.
    pub eta: String,
    /// The scene (a path relative to the repository) whose `[inputs]` laws are closed into the
    /// forces, or empty.
    pub scene: String,
}

/// The text of `crates/hamel-models/src/lib.rs` for the given members (sorted by the caller).
/// Errors: a member's directory is not an identifier (it names a module).
pub fn models_lib(members: &[Member]) -> Result<String, crate::CodegenError> {
    for m in members {
        rust_ident(&m.dir)?;
    }
    let mut o = String::from(
        "//! The generated numeric cores of every bundled model, compiled together.\n\
         //!\n\
         //! **Job**: give tests and benchmarks the generated code of `generated/*` (written by\n\
         //! `hamel codegen`) over the one runtime (`hamel-runtime`), and a table [`MODELS`] to iterate.\n\
         //! **Inputs**: none at run time; **outputs**: right-hand sides, Jacobians, reconstructions.\n\
         //! **Invariant**: engine-free (no computer algebra). This file is generated too: regenerate\n\
         //! with `UPDATE_GENERATED=1 cargo test --release --test codegen`.\n\n\
         #![allow(non_snake_case)]\n\n\
         pub use hamel_runtime as runtime;\n\n\
         use runtime::{Dims, DualN, EvalError, Rhs};\n\n",
    );
    for m in members {
        let _ = writeln!(
            o,
            "#[rustfmt::skip] // generated text, compared with a fresh generation\n#[path = \"../../../generated/{0}/src/model.rs\"]\npub mod {0};",
            m.dir
        );
    }
    o.push_str(
        "\n/// A full right-hand side at (q, η) in f64.\npub type FullFn = fn(&[f64], &[f64]) -> Result<Rhs<f64>, EvalError>;\n\
         /// A full right-hand side over dual numbers.\npub type FullDualFn = fn(&[DualN<1>], &[DualN<1>]) -> Result<Rhs<DualN<1>>, EvalError>;\n\
         /// A function of (q, η) giving a vector.\npub type VectorFn = fn(&[f64], &[f64]) -> Result<Vec<f64>, EvalError>;\n\
         /// A Jacobian of the reduced state.\npub type MatrixFn = fn(&[f64]) -> Result<Vec<Vec<f64>>, EvalError>;\n\
         \n/// One generated core, at the model's default parameters.\npub struct Core {\n    \
         /// Model name.\n    pub model: &'static str,\n    /// Quasi-velocity choice.\n    pub eta: &'static str,\n    \
         /// The scene whose control laws close the loop (relative to the repository), or empty\n    \
         /// for the model file's own equations.\n    pub scene: &'static str,\n    \
         /// ℓ, μ, σ.\n    pub dims: Dims,\n    /// Eliminated coordinates.\n    pub eliminated: &'static [usize],\n    \
         /// Kept coordinates (reduced state: these, then η).\n    pub kept: &'static [usize],\n    \
         /// Full right-hand side at (q, η).\n    pub full: FullFn,\n    \
         /// The same over dual numbers (one direction).\n    pub full_dual: FullDualFn,\n    \
         /// The structured f64 evaluation without the double-double repeat (a baseline).\n    pub full_unchecked: FullFn,\n    \
         /// Reduced right-hand side at x = (kept q, η).\n    pub reduced: fn(&[f64]) -> Result<Vec<f64>, EvalError>,\n    \
         /// The same into a slice, without allocation, parameters prepared once.\n    pub reduced_into: fn(&[f64], &mut [f64]) -> Result<(), EvalError>,\n    \
         /// d(q, η)/dt into a slice, without allocation (η̇ true form only), parameters prepared once.\n    pub full_into: fn(&[f64], &mut [f64]) -> Result<(), EvalError>,\n    \
         /// The same, the parameter-only values computed at each call.\n    pub full_into_per_call: fn(&[f64], &mut [f64]) -> Result<(), EvalError>,\n    \
         /// Its Jacobian.\n    pub jacobian: MatrixFn,\n    \
         /// Rates of the eliminated coordinates.\n    pub reconstruction: VectorFn,\n    \
         /// α(q)q̇.\n    pub constraint_residual: fn(&[f64], &[f64]) -> Vec<f64>,\n    \
         /// The energy at (q, η), by the core's own path (closed form, or structured).\n    pub energy: fn(&[f64], &[f64]) -> Result<f64, EvalError>,\n    \
         /// ‖α(q)Γ(q)η‖∞ at (q, η).\n    pub residual: fn(&[f64], &[f64]) -> Result<f64, EvalError>,\n    \
         /// [`Core::energy`] at full states (q, η) one after another, one entry each (None where\n    \
         /// it fails): four at a time where the core has a closed form.\n    \
         pub energies: fn(&[f64], &mut [Option<f64>]),\n    \
         /// [`Core::residual`] at full states, as [`Core::energies`].\n    \
         pub residuals: fn(&[f64], &mut [Option<f64>]),\n    \
         /// The constraint forces' components ([`Core::constraint_forces`]), in order.\n    \
         pub constraint_force_names: &'static [&'static str],\n    \
         /// The constraint forces at (q, η) (issue 58).\n    pub constraint_forces: VectorFn,\n    \
         /// Operation counts (trees, shared).\n    pub operations: (usize, usize),\n    \
         /// The Taylor coefficients at x to an order by the compiled recurrences\n    \
         /// (`reduced_series`; None without a closed form).\n    pub series: SeriesFn,\n    \
         /// The same by the loop alone (`reduced_series_looped`, what a CPU without FMA runs).\n    \
         pub series_looped: SeriesFn,\n    \
         /// The same by tracing `reduced_with` (`runtime::taylor_by_trace`; None where a\n    \
         /// coefficient is not finite).\n    pub series_traced: SeriesFn,\n}\n\n\
         /// Taylor coefficients at a reduced state to an order, into the buffer.\n\
         pub type SeriesFn = fn(&[f64], usize, &mut Vec<f64>) -> Result<Option<()>, EvalError>;\n\n\
         /// The default parameters of module `$m`, prepared once (`Prepared::new`), or its error.\n\
         macro_rules! prepared {\n    ($m:ident) => {{\n        static PREPARED: std::sync::LazyLock<Result<$m::Prepared, EvalError>> =\n            std::sync::LazyLock::new(|| $m::Prepared::new(&$m::Parameters::default()));\n        PREPARED.as_ref().map_err(Clone::clone)?\n    }};\n}\n\n\
         macro_rules! core {\n    ($m:ident, $model:expr, $eta:expr, $scene:expr) => {\n        Core {\n            model: $model,\n            eta: $eta,\n            scene: $scene,\n            dims: $m::DIMS,\n            eliminated: &$m::ELIMINATED,\n            kept: &$m::KEPT,\n            full: |q, e| $m::full_rhs(q, e, &$m::Parameters::default()),\n            full_dual: |q, e| $m::rhs(q, e, &$m::Parameters::default()),\n            full_unchecked: |q, e| {\n                $m::structured_unchecked(q, e, &$m::Parameters::default(), true).map(Rhs::from)\n            },\n            reduced: |x| $m::reduced_rhs(x, &$m::Parameters::default()),\n            reduced_into: |x, dx| $m::reduced_into_with(x, dx, prepared!($m)),\n            full_into: |y, dy| $m::full_into_with(y, dy, prepared!($m)),\n            full_into_per_call: |y, dy| $m::full_into(y, dy, &$m::Parameters::default()),\n            jacobian: |x| $m::reduced_jacobian(x, &$m::Parameters::default()),\n            reconstruction: |q, e| $m::reconstruction(q, e, &$m::Parameters::default()),\n            constraint_residual: |q, qd| $m::constraint_residual(q, qd, &$m::Parameters::default()),\n            energy: |q, e| $m::energy(q, e, &$m::Parameters::default()),\n            residual: |q, e| $m::residual_max(q, e, &$m::Parameters::default()),\n            \
         energies: |rows, out| $m::energy_many(rows, &$m::Parameters::default(), out),\n            \
         residuals: |rows, out| $m::residual_max_many(rows, &$m::Parameters::default(), out),\n            constraint_force_names: &$m::CONSTRAINT_FORCES,\n            \
         constraint_forces: |q, e| $m::constraint_forces(q, e, &$m::Parameters::default()),\n            \
         operations: $m::OPERATIONS,\n            \
         series: |x, order, out| $m::reduced_series(x, prepared!($m), order, out).transpose(),\n            \
         series_looped: |x, order, out| {\n                \
         $m::reduced_series_looped(x, prepared!($m), order, out).transpose()\n            },\n            \
         series_traced: |x, order, out| {\n                let prep = prepared!($m);\n                \
         let f = |x: &[runtime::Traced], dx: &mut [runtime::Traced]| {\n                    \
         dx.copy_from_slice(&$m::reduced_with(x, prep)?);\n                    Ok::<(), EvalError>(())\n                };\n                \
         match runtime::taylor_by_trace(x, order, out, f) {\n                    Ok(()) => Ok(Some(())),\n                    \
         Err(runtime::SeriesFailure::System(e)) => Err(e),\n                    Err(runtime::SeriesFailure::NonFinite) => Ok(None),\n                }\n            },\n        \
         }\n    };\n}\n\n\
         /// Every generated core.\n#[rustfmt::skip]\npub const MODELS: &[Core] = &[\n",
    );
    for m in members {
        let _ = writeln!(
            o,
            "    core!({}, {}, {}, {}),",
            m.dir,
            rust_str(&m.model),
            rust_str(&m.eta),
            rust_str(&m.scene)
        );
    }
    o.push_str("];\n");
    Ok(o)
}
