//! Canonical text of an expression.

use crate::field::Ex;

/// The canonical form printed in the model-file expression syntax. Two expressions print the
/// same iff they are equal; the term order does not depend on the engine's symbol order.
pub(crate) fn text(e: &Ex) -> String {
    e.to_expr().to_string()
}
