//! Why a study failed.

/// Why a steady motion could not be built, checked or linearised.
#[derive(Clone, Debug, thiserror::Error)]
pub enum StudyError {
    /// The model or the steady motion named is refused where it is read (located).
    #[error(transparent)]
    Model(#[from] hamel_model::ModelError),
    /// The pass (the derivation, which coordinates drop out, the steady check) failed.
    #[cfg(feature = "cas")]
    #[error(transparent)]
    Reduce(#[from] hamel_reduce::ReduceError),
    /// The derived equations do not compile for evaluation.
    #[error("the equations cannot be compiled: {0}")]
    Compile(String),
    /// An expression of the steady motion could not be evaluated.
    #[error("`{key}` cannot be evaluated: {reason}")]
    Value {
        /// The key of the value (`steady.NAME.q.roll`).
        key: String,
        /// Why.
        reason: String,
    },
    /// The holonomic constraints could not be solved for the dependent coordinates.
    #[error(
        "the holonomic constraints cannot be solved for {coordinates} at the steady motion: {reason}"
    )]
    Completion {
        /// The dependent coordinates.
        coordinates: String,
        /// Why.
        reason: String,
    },
    /// The velocities given do not determine the others through the constraints.
    #[error("{0}")]
    Velocities(String),
    /// The state is not steady: η̇ or a kept coordinate's rate is not zero there.
    #[error("not a steady motion: {residuals} (largest {largest:.3e}, allowed {allowed:.1e})")]
    NotSteady {
        /// The components that do not vanish, with their values.
        residuals: String,
        /// The largest of them.
        largest: f64,
        /// The tolerance.
        allowed: f64,
    },
    /// The equations could not be evaluated at the steady state.
    #[error("the equations cannot be evaluated at the steady state: {0}")]
    Numeric(String),
    /// A parameter value is not accepted.
    #[error("{0}")]
    Parameter(String),
    /// The eigenvalue iteration did not converge.
    #[error("the eigenvalues did not converge (real Schur form, {iterations} iterations) at {at}")]
    Eigen {
        /// The iteration cap.
        iterations: usize,
        /// The point.
        at: String,
    },
    /// A sweep or map was asked for with an unusable range.
    #[error("{0}")]
    Range(String),
}

impl StudyError {
    /// The located diagnostic of `model`'s file, for the edge: what the pass or the model
    /// refused is located there; the numeric failures name the model.
    pub fn locate(self, model: &hamel_model::Model) -> hamel_model::ModelError {
        match self {
            StudyError::Model(e) => e,
            #[cfg(feature = "cas")]
            StudyError::Reduce(e) => e.locate(model),
            e => model.error(e.to_string()),
        }
    }
}
