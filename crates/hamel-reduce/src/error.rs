//! Why a reduction, a search or the pass failed, typed ([`ReduceError`]): the cause as data.
//! The located diagnostic is made at the edge, with the model in hand
//! ([`ReduceError::locate`]).

use std::path::PathBuf;

use hamel_cas::CasError;
use hamel_derive::DeriveError;
use hamel_model::{ErrorKind, Model, ModelError};

/// Why a reduction, a search or the pass failed.
#[derive(Clone, Debug, thiserror::Error, serde::Serialize, serde::Deserialize)]
pub enum ReduceError {
    /// The derivation failed (or the model or choice was refused).
    #[error(transparent)]
    Derive(#[from] DeriveError),
    /// An elimination of no coordinate was asked for.
    #[error("no coordinate to eliminate was given")]
    NothingToEliminate,
    /// A name that is not one of the model's coordinates.
    #[error("`{name}` is not a coordinate of the model")]
    NotACoordinate {
        /// The name given.
        name: String,
    },
    /// A coordinate the equations are free of is needed to complete the dependent ones.
    #[error(
        "the holonomic constraints mention `{coordinate}`, which the equations are free of: hamel cannot drop it and complete the dependent coordinates without it"
    )]
    DroppedInHolonomic {
        /// The coordinate.
        coordinate: String,
    },
    /// A structured derivation whose equations do not compile.
    #[error("the structured equations do not compile: {0}")]
    NotCompiled(String),
    /// The stored derivation could not be decoded.
    #[error("the stored derivation cannot be read: {0}")]
    StoredUnreadable(String),
    /// The search worker could not be run.
    #[error("{0}")]
    SearchWorker(String),
    /// The deriving worker failed.
    #[error("the deriving worker ({}): {failure}", program.display())]
    DeriveWorker {
        /// Its program.
        program: PathBuf,
        /// What went wrong.
        failure: WorkerFailure,
    },
    /// The worker's own side: no job to read, or no result written.
    #[error("derive-worker: {0}")]
    WorkerSide(String),
    /// The computer-algebra engine failed: not the input's fault.
    #[error("{0}")]
    Engine(CasError),
}

/// What went wrong with the deriving worker process.
#[derive(Clone, Debug, thiserror::Error, serde::Serialize, serde::Deserialize)]
pub enum WorkerFailure {
    /// It could not be started.
    #[error("cannot start it: {0}")]
    Start(String),
    /// The job could not be given to it, or its result read.
    #[error("{0}")]
    Exchange(String),
    /// It ended without a result.
    #[error("it ended ({status}) without a result")]
    NoResult {
        /// Its exit status, as the system says it.
        status: String,
    },
    /// It was ended by a write to an output that was closed (its stdout, shared with the
    /// caller's: the reader of a pipe, such as `head`, ended early).
    #[error(
        "it ended ({status}): the output was closed before the computer algebra's notice could be written (a pipe's reader ended)"
    )]
    OutputClosed {
        /// Its exit status.
        status: String,
    },
    /// It aborted as the computer algebra does when another process holds its licence's one
    /// thread.
    #[error(
        "it ended ({status}) without a result; the computer algebra stops so when another process holds the one thread its licence allows (a `hamel search`, another derivation; see its notice above): run this again when that has finished"
    )]
    LicenceHeld {
        /// Its exit status.
        status: String,
    },
}

impl From<ModelError> for ReduceError {
    fn from(e: ModelError) -> ReduceError {
        ReduceError::Derive(DeriveError::Model(e))
    }
}

impl ReduceError {
    /// Whose fault it is: the input's, the engine's or the machine's.
    pub fn kind(&self) -> ErrorKind {
        use ReduceError as E;
        match self {
            E::Derive(e) => e.kind(),
            E::Engine(_) => ErrorKind::Engine,
            E::StoredUnreadable(_)
            | E::SearchWorker(_)
            | E::DeriveWorker { .. }
            | E::WorkerSide(_) => ErrorKind::Environment,
            E::NothingToEliminate
            | E::NotACoordinate { .. }
            | E::DroppedInHolonomic { .. }
            | E::NotCompiled(_) => ErrorKind::Input,
        }
    }

    /// The located diagnostic of `model`'s file (the edge's form).
    pub fn locate(self, model: &Model) -> ModelError {
        let coordinates = model.coordinates.join(", ");
        match self {
            ReduceError::Derive(e) => e.locate(model),
            e @ ReduceError::NothingToEliminate => model
                .error(e.to_string())
                .with_help(format!("name one or more of the coordinates {coordinates}")),
            e @ ReduceError::NotACoordinate { .. } => model
                .error(e.to_string())
                .with_help(format!("the coordinates are {coordinates}")),
            e => match e.kind() {
                ErrorKind::Input => model.error(e.to_string()),
                ErrorKind::Engine => ModelError::engine(e),
                ErrorKind::Environment => ModelError::environment(e),
            },
        }
    }
}
