//! Why an evaluation failed, and the checks that fail instead of passing NaN on.

use crate::structured::Failure;

/// Why an evaluation failed.
#[derive(Clone, Debug, PartialEq)]
#[non_exhaustive]
pub enum EvalError {
    /// The structured evaluation failed: [Z; α] or A_Γ is numerically singular, or its
    /// storage or inputs are too small.
    Structured(Failure),
    /// A value came out infinite or NaN (which value).
    NotFinite(&'static str),
    /// A check generated code makes failed (what it found).
    Check(&'static str),
    /// A parameter name the model does not have.
    UnknownParameter(String),
}

impl std::fmt::Display for EvalError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            EvalError::Structured(failure) => write!(f, "{failure}"),
            EvalError::NotFinite(what) => write!(f, "{what} is not finite at this state"),
            EvalError::Check(message) => f.write_str(message),
            EvalError::UnknownParameter(name) => write!(f, "unknown parameter `{name}`"),
        }
    }
}

impl std::error::Error for EvalError {}

impl From<Failure> for EvalError {
    fn from(f: Failure) -> Self {
        EvalError::Structured(f)
    }
}

/// Fail on a non-finite value instead of passing NaN on.
#[inline]
pub fn finite(what: &'static str, v: &[f64]) -> Result<(), EvalError> {
    if v.iter().all(|x| x.is_finite()) {
        Ok(())
    } else {
        Err(EvalError::NotFinite(what))
    }
}

/// A failed check, built out of line: the failing branch stays small in the hot code.
#[cold]
#[inline(never)]
pub fn cold_error(message: &'static str) -> EvalError {
    EvalError::Check(message)
}
