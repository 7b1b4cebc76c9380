//! Canonical text of an expression.

use crate::field::Ex;

/// The normal form printed in the model-file expression syntax. The text is deterministic and
/// the term order does not depend on the engine's symbol order.
pub(crate) fn text(e: &Ex) -> String {
    e.to_expr().to_string()
}

impl std::fmt::Display for Ex {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}", text(self))
    }
}
