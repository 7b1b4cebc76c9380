//! Expression builders that fold exact zeros and ones as they build, so that structural zeros
//! (of a Jacobian, of Γ, of a rotation's rate) vanish from built trees instead of being carried
//! as `0*x`. They decide nothing: equality is decided downstream, on canonical forms.

use crate::ast::{Expr, Func};

/// a + b.
pub fn add(a: Expr, b: Expr) -> Expr {
    tidy::add(a.tidy(), b.tidy())
}

/// a − b.
pub fn sub(a: Expr, b: Expr) -> Expr {
    tidy::sub(a.tidy(), b.tidy())
}

/// −a.
pub fn neg(a: Expr) -> Expr {
    tidy::neg(a.tidy())
}

/// a·b.
pub fn mul(a: Expr, b: Expr) -> Expr {
    tidy::mul(a.tidy(), b.tidy())
}

/// a / b.
pub fn div(a: Expr, b: Expr) -> Expr {
    if a.is_zero_literal() || b.is_one_literal() {
        a
    } else {
        Expr::Div(Box::new(a), Box::new(b))
    }
}

/// aⁿ.
pub fn powi(a: Expr, n: i64) -> Expr {
    match n {
        0 => Expr::int(1),
        1 => a,
        _ if a.is_zero_literal() && n > 0 => a,
        _ => Expr::powi(a, n),
    }
}

/// f(a) for a built-in f.
pub fn call(f: Func, a: Expr) -> Expr {
    Expr::call(f, a)
}

/// The sum of the terms (0 for none).
pub fn sum(terms: impl IntoIterator<Item = Expr>) -> Expr {
    tidy::sum(terms.into_iter().map(Expr::tidy))
}

/// The product of the factors (1 for none).
pub fn product(factors: impl IntoIterator<Item = Expr>) -> Expr {
    tidy::product(factors.into_iter().map(Expr::tidy))
}

/// The same builders for operands that are tidy already ([`Expr::tidy`]): only the new node
/// is cleaned up, so that building a tree node by node (a derivative) takes time linear in
/// the nodes built, not in the tree below each. Given tidy operands they build what the
/// builders above build.
pub mod tidy {
    use crate::ast::Expr;

    /// a + b.
    pub fn add(a: Expr, b: Expr) -> Expr {
        Expr::Add(vec![a, b]).tidy_top()
    }

    /// a − b.
    pub fn sub(a: Expr, b: Expr) -> Expr {
        add(a, neg(b))
    }

    /// −a.
    pub fn neg(a: Expr) -> Expr {
        Expr::Neg(Box::new(a)).tidy_top()
    }

    /// a·b.
    pub fn mul(a: Expr, b: Expr) -> Expr {
        Expr::Mul(vec![a, b]).tidy_top()
    }

    /// The sum of the terms (0 for none).
    pub fn sum(terms: impl IntoIterator<Item = Expr>) -> Expr {
        Expr::Add(terms.into_iter().collect()).tidy_top()
    }

    /// The product of the factors (1 for none).
    pub fn product(factors: impl IntoIterator<Item = Expr>) -> Expr {
        Expr::Mul(factors.into_iter().collect()).tidy_top()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn zeros_and_ones_fold_and_nothing_else_does() {
        let x = Expr::sym("x");
        assert_eq!(mul(Expr::int(0), x.clone()), Expr::int(0));
        assert_eq!(mul(Expr::int(1), x.clone()), x);
        assert_eq!(add(Expr::int(0), x.clone()), x);
        assert_eq!(sub(x.clone(), Expr::int(0)), x);
        assert_eq!(div(Expr::int(0), x.clone()), Expr::int(0));
        assert_eq!(powi(x.clone(), 1), x);
        assert_eq!(sum([]), Expr::int(0));
        assert_eq!(product([]), Expr::int(1));
        // x − x is not decided here
        assert_ne!(sub(x.clone(), x.clone()), Expr::int(0));
    }
}
