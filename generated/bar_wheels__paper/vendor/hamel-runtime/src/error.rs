//! Why an evaluation failed, and the checks that fail instead of passing NaN on.

/// Why an evaluation failed.
#[derive(Clone, Debug, PartialEq)]
pub struct EvalError(pub String);

impl std::fmt::Display for EvalError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for EvalError {}

/// Fail on a non-finite value instead of passing NaN on.
pub fn finite(what: &str, v: &[f64]) -> Result<(), EvalError> {
    if v.iter().all(|x| x.is_finite()) {
        Ok(())
    } else {
        Err(EvalError(format!("{what} is not finite at this state")))
    }
}

/// An error, built out of line: the failing branch of a check stays small in the hot code.
#[cold]
#[inline(never)]
pub fn cold_error(message: &str) -> EvalError {
    EvalError(message.into())
}
