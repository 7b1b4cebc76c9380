//! The generated numeric cores of every bundled model, compiled together.
//!
//! **Job**: give tests and benchmarks the generated code of `generated/*` (written by
//! `hamel codegen`) over the one runtime (`hamel-runtime`), and a table [`MODELS`] to iterate.
//! **Inputs**: none at run time; **outputs**: right-hand sides, Jacobians, reconstructions.
//! **Invariant**: engine-free (no computer algebra). This file is generated too: regenerate
//! with `UPDATE_GENERATED=1 cargo test --release --test codegen`.

#![allow(non_snake_case)]

pub use hamel_runtime as runtime;

use runtime::{Dims, DualN, EvalError, Rhs};

#[rustfmt::skip] // generated text, compared with a fresh generation
#[path = "../../../generated/bar_blade__paper/src/model.rs"]
pub mod bar_blade__paper;
#[rustfmt::skip] // generated text, compared with a fresh generation
#[path = "../../../generated/bar_blade__a_orthogonal/src/model.rs"]
pub mod bar_blade__a_orthogonal;
#[rustfmt::skip] // generated text, compared with a fresh generation
#[path = "../../../generated/bar_wheels__paper/src/model.rs"]
pub mod bar_wheels__paper;
#[rustfmt::skip] // generated text, compared with a fresh generation
#[path = "../../../generated/bar_wheels__a_orthogonal/src/model.rs"]
pub mod bar_wheels__a_orthogonal;
#[rustfmt::skip] // generated text, compared with a fresh generation
#[path = "../../../generated/bar_wheels__search_ansatz/src/model.rs"]
pub mod bar_wheels__search_ansatz;
#[rustfmt::skip] // generated text, compared with a fresh generation
#[path = "../../../generated/chaplygin_sleigh__paper_style/src/model.rs"]
pub mod chaplygin_sleigh__paper_style;
#[rustfmt::skip] // generated text, compared with a fresh generation
#[path = "../../../generated/diff_drive__wheels/src/model.rs"]
pub mod diff_drive__wheels;
#[rustfmt::skip] // generated text, compared with a fresh generation
#[path = "../../../generated/diff_drive__body/src/model.rs"]
pub mod diff_drive__body;
#[rustfmt::skip] // generated text, compared with a fresh generation
#[path = "../../../generated/knife__paper/src/model.rs"]
pub mod knife__paper;
#[rustfmt::skip] // generated text, compared with a fresh generation
#[path = "../../../generated/remark22__paper/src/model.rs"]
pub mod remark22__paper;
#[rustfmt::skip] // generated text, compared with a fresh generation
#[path = "../../../generated/rolling_disk__momenta/src/model.rs"]
pub mod rolling_disk__momenta;
#[rustfmt::skip] // generated text, compared with a fresh generation
#[path = "../../../generated/rolling_disk__velocities/src/model.rs"]
pub mod rolling_disk__velocities;
#[rustfmt::skip] // generated text, compared with a fresh generation
#[path = "../../../generated/segway__wheels/src/model.rs"]
pub mod segway__wheels;
#[rustfmt::skip] // generated text, compared with a fresh generation
#[path = "../../../generated/segway__body/src/model.rs"]
pub mod segway__body;
#[rustfmt::skip] // generated text, compared with a fresh generation
#[path = "../../../generated/snakeboard__velocities/src/model.rs"]
pub mod snakeboard__velocities;
#[rustfmt::skip] // generated text, compared with a fresh generation
#[path = "../../../generated/sprung_sleigh__forward/src/model.rs"]
pub mod sprung_sleigh__forward;
#[rustfmt::skip] // generated text, compared with a fresh generation
#[path = "../../../generated/unicycle_rider__momenta/src/model.rs"]
pub mod unicycle_rider__momenta;
#[rustfmt::skip] // generated text, compared with a fresh generation
#[path = "../../../generated/unicycle_rider__velocities/src/model.rs"]
pub mod unicycle_rider__velocities;
#[rustfmt::skip] // generated text, compared with a fresh generation
#[path = "../../../generated/vertical_knife__paper/src/model.rs"]
pub mod vertical_knife__paper;
#[rustfmt::skip] // generated text, compared with a fresh generation
#[path = "../../../generated/whipple_bicycle__benchmark/src/model.rs"]
pub mod whipple_bicycle__benchmark;
#[rustfmt::skip] // generated text, compared with a fresh generation
#[path = "../../../generated/segway_lqr__body/src/model.rs"]
pub mod segway_lqr__body;

/// A full right-hand side at (q, η) in f64.
pub type FullFn = fn(&[f64], &[f64]) -> Result<Rhs<f64>, EvalError>;
/// A full right-hand side over dual numbers.
pub type FullDualFn = fn(&[DualN<1>], &[DualN<1>]) -> Result<Rhs<DualN<1>>, EvalError>;
/// A function of (q, η) giving a vector.
pub type VectorFn = fn(&[f64], &[f64]) -> Result<Vec<f64>, EvalError>;
/// A Jacobian of the reduced state.
pub type MatrixFn = fn(&[f64]) -> Result<Vec<Vec<f64>>, EvalError>;

/// One generated core, at the model's default parameters.
pub struct Core {
    /// Model name.
    pub model: &'static str,
    /// Quasi-velocity choice.
    pub eta: &'static str,
    /// The scene whose control laws close the loop (relative to the repository), or empty
    /// for the model file's own equations.
    pub scene: &'static str,
    /// ℓ, μ, σ.
    pub dims: Dims,
    /// Eliminated coordinates.
    pub eliminated: &'static [usize],
    /// Kept coordinates (reduced state: these, then η).
    pub kept: &'static [usize],
    /// Full right-hand side at (q, η).
    pub full: FullFn,
    /// The same over dual numbers (one direction).
    pub full_dual: FullDualFn,
    /// The structured f64 evaluation without the double-double repeat (a baseline).
    pub full_unchecked: FullFn,
    /// Reduced right-hand side at x = (kept q, η).
    pub reduced: fn(&[f64]) -> Result<Vec<f64>, EvalError>,
    /// The same into a slice, without allocation, parameters prepared once.
    pub reduced_into: fn(&[f64], &mut [f64]) -> Result<(), EvalError>,
    /// d(q, η)/dt into a slice, without allocation (η̇ true form only), parameters prepared once.
    pub full_into: fn(&[f64], &mut [f64]) -> Result<(), EvalError>,
    /// The same, the parameter-only values computed at each call.
    pub full_into_per_call: fn(&[f64], &mut [f64]) -> Result<(), EvalError>,
    /// Its Jacobian.
    pub jacobian: MatrixFn,
    /// Rates of the eliminated coordinates.
    pub reconstruction: VectorFn,
    /// α(q)q̇.
    pub constraint_residual: fn(&[f64], &[f64]) -> Vec<f64>,
    /// The energy at (q, η), by the core's own path (closed form, or structured).
    pub energy: fn(&[f64], &[f64]) -> Result<f64, EvalError>,
    /// ‖α(q)Γ(q)η‖∞ at (q, η).
    pub residual: fn(&[f64], &[f64]) -> Result<f64, EvalError>,
    /// [`Core::energy`] at full states (q, η) one after another, one entry each (None where
    /// it fails): four at a time where the core has a closed form.
    pub energies: fn(&[f64], &mut [Option<f64>]),
    /// [`Core::residual`] at full states, as [`Core::energies`].
    pub residuals: fn(&[f64], &mut [Option<f64>]),
    /// The constraint forces' components ([`Core::constraint_forces`]), in order.
    pub constraint_force_names: &'static [&'static str],
    /// The constraint forces at (q, η) (issue 58).
    pub constraint_forces: VectorFn,
    /// Operation counts (trees, shared).
    pub operations: (usize, usize),
    /// The Taylor coefficients at x to an order by the compiled recurrences
    /// (`reduced_series`; None without a closed form).
    pub series: SeriesFn,
    /// The same by the loop alone (`reduced_series_looped`, what a CPU without FMA runs).
    pub series_looped: SeriesFn,
    /// The same by tracing `reduced_with` (`runtime::taylor_by_trace`; None where a
    /// coefficient is not finite).
    pub series_traced: SeriesFn,
}

/// Taylor coefficients at a reduced state to an order, into the buffer.
pub type SeriesFn = fn(&[f64], usize, &mut Vec<f64>) -> Result<Option<()>, EvalError>;

/// The default parameters of module `$m`, prepared once (`Prepared::new`), or its error.
macro_rules! prepared {
    ($m:ident) => {{
        static PREPARED: std::sync::LazyLock<Result<$m::Prepared, EvalError>> =
            std::sync::LazyLock::new(|| $m::Prepared::new(&$m::Parameters::default()));
        PREPARED.as_ref().map_err(Clone::clone)?
    }};
}

macro_rules! core {
    ($m:ident, $model:expr, $eta:expr, $scene:expr) => {
        Core {
            model: $model,
            eta: $eta,
            scene: $scene,
            dims: $m::DIMS,
            eliminated: &$m::ELIMINATED,
            kept: &$m::KEPT,
            full: |q, e| $m::full_rhs(q, e, &$m::Parameters::default()),
            full_dual: |q, e| $m::rhs(q, e, &$m::Parameters::default()),
            full_unchecked: |q, e| {
                $m::structured_unchecked(q, e, &$m::Parameters::default(), true).map(Rhs::from)
            },
            reduced: |x| $m::reduced_rhs(x, &$m::Parameters::default()),
            reduced_into: |x, dx| $m::reduced_into_with(x, dx, prepared!($m)),
            full_into: |y, dy| $m::full_into_with(y, dy, prepared!($m)),
            full_into_per_call: |y, dy| $m::full_into(y, dy, &$m::Parameters::default()),
            jacobian: |x| $m::reduced_jacobian(x, &$m::Parameters::default()),
            reconstruction: |q, e| $m::reconstruction(q, e, &$m::Parameters::default()),
            constraint_residual: |q, qd| $m::constraint_residual(q, qd, &$m::Parameters::default()),
            energy: |q, e| $m::energy(q, e, &$m::Parameters::default()),
            residual: |q, e| $m::residual_max(q, e, &$m::Parameters::default()),
            energies: |rows, out| $m::energy_many(rows, &$m::Parameters::default(), out),
            residuals: |rows, out| $m::residual_max_many(rows, &$m::Parameters::default(), out),
            constraint_force_names: &$m::CONSTRAINT_FORCES,
            constraint_forces: |q, e| $m::constraint_forces(q, e, &$m::Parameters::default()),
            operations: $m::OPERATIONS,
            series: |x, order, out| $m::reduced_series(x, prepared!($m), order, out).transpose(),
            series_looped: |x, order, out| {
                $m::reduced_series_looped(x, prepared!($m), order, out).transpose()
            },
            series_traced: |x, order, out| {
                let prep = prepared!($m);
                let f = |x: &[runtime::Traced], dx: &mut [runtime::Traced]| {
                    dx.copy_from_slice(&$m::reduced_with(x, prep)?);
                    Ok::<(), EvalError>(())
                };
                match runtime::taylor_by_trace(x, order, out, f) {
                    Ok(()) => Ok(Some(())),
                    Err(runtime::SeriesFailure::System(e)) => Err(e),
                    Err(runtime::SeriesFailure::NonFinite) => Ok(None),
                }
            },
        }
    };
}

/// Every generated core.
#[rustfmt::skip]
pub const MODELS: &[Core] = &[
    core!(bar_blade__paper, "bar_blade", "paper", ""),
    core!(bar_blade__a_orthogonal, "bar_blade", "a_orthogonal", ""),
    core!(bar_wheels__paper, "bar_wheels", "paper", ""),
    core!(bar_wheels__a_orthogonal, "bar_wheels", "a_orthogonal", ""),
    core!(bar_wheels__search_ansatz, "bar_wheels", "search_ansatz", ""),
    core!(chaplygin_sleigh__paper_style, "chaplygin_sleigh", "paper_style", ""),
    core!(diff_drive__wheels, "diff_drive", "wheels", ""),
    core!(diff_drive__body, "diff_drive", "body", ""),
    core!(knife__paper, "knife", "paper", ""),
    core!(remark22__paper, "remark22", "paper", ""),
    core!(rolling_disk__momenta, "rolling_disk", "momenta", ""),
    core!(rolling_disk__velocities, "rolling_disk", "velocities", ""),
    core!(segway__wheels, "segway", "wheels", ""),
    core!(segway__body, "segway", "body", ""),
    core!(snakeboard__velocities, "snakeboard", "velocities", ""),
    core!(sprung_sleigh__forward, "sprung_sleigh", "forward", ""),
    core!(unicycle_rider__momenta, "unicycle_rider", "momenta", ""),
    core!(unicycle_rider__velocities, "unicycle_rider", "velocities", ""),
    core!(vertical_knife__paper, "vertical_knife", "paper", ""),
    core!(whipple_bicycle__benchmark, "whipple_bicycle", "benchmark", ""),
    core!(segway_lqr__body, "segway", "body", "scenes/segway_lqr.toml"),
];
