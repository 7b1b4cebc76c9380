//! Why code could not be generated.

use hamel_expr::TapeError;

/// Why a derivation could not be turned into a crate.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum CodegenError {
    /// A name that becomes code (a coordinate, a parameter, a module) is not an identifier.
    #[error("{0:?} is not an identifier (ASCII letters, digits and _, not a keyword)")]
    NotAnIdentifier(String),
    /// The quasi-velocities use free functions, which have no code until they are defined.
    #[error(
        "the quasi-velocities use free functions ({0}): define them in the model before generating code"
    )]
    FreeFunctions(String),
    /// The derivation's ingredients could not be read as expressions.
    #[error("the ingredients of the derivation: {0}")]
    Ingredients(String),
    /// An expression uses a name that is not an input of the generated code.
    #[error(transparent)]
    Tape(#[from] TapeError),
    /// The derivation cannot be evaluated to choose the solved form.
    #[error("choosing the solved form: {0}")]
    Path(String),
    /// The generator contradicts itself (its template, its manifests): a bug.
    #[error("internal error: {0}")]
    Internal(String),
}
