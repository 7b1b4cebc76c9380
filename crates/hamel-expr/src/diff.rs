//! Exact differentiation of expression trees with respect to a symbol, for kinematics: the
//! partial derivatives ∂p/∂q_k of positions and of rotation angles, and ∂h/∂q_k of holonomic
//! constraints. The result is built with the folding builders of [`crate::build::tidy`]
//! (structural zeros vanish; the expression is tidied once, so each node built costs the same
//! whatever lies below it) but is not simplified: equality is decided downstream, on canonical
//! forms.

use crate::ast::{Expr, Func};
use crate::build::tidy::{add, mul, neg, product, sub, sum};
use crate::build::{call, div, powi};

/// Why an expression could not be differentiated.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum DiffError {
    /// A velocity `der(q)` in an expression of the configuration (positions, angles and
    /// holonomic constraints are functions of q alone).
    #[error("`der({0})` in an expression of the configuration (it may depend on q, not on q̇)")]
    Velocity(String),
    /// The derivative would have more than [`MAX_DERIVATIVE_NODES`] nodes (a product of
    /// thousands of factors that each hold the variable, say).
    #[error(
        "the derivative by `{0}` would have more than {MAX_DERIVATIVE_NODES} nodes: write the expression in fewer factors"
    )]
    TooLarge(String),
}

/// The most nodes a derivative may copy from the expression: far above a mechanism's (the
/// derivatives of the Whipple bicycle's positions have a few hundred), and far below what
/// exhausts the machine (a node takes tens of bytes).
pub const MAX_DERIVATIVE_NODES: usize = 2_000_000;

/// What a derivative may still copy, in nodes.
struct Budget {
    left: usize,
    of: String,
}

impl Budget {
    fn charge(&mut self, nodes: usize) -> Result<(), DiffError> {
        self.left = self
            .left
            .checked_sub(nodes)
            .ok_or_else(|| DiffError::TooLarge(self.of.clone()))?;
        Ok(())
    }
}

impl Expr {
    /// True when the symbol `x` occurs (as a symbol, or as an argument of a free function).
    pub fn mentions(&self, x: &str) -> bool {
        self.any(&mut |e| match e {
            Expr::Sym(n) => n == x,
            Expr::Free { args, .. } => args.iter().any(|a| a == x),
            _ => false,
        })
    }

    /// ∂self/∂x, exactly.
    pub fn diff(&self, x: &str) -> Result<Expr, DiffError> {
        if let Some(q) = self.velocity() {
            return Err(DiffError::Velocity(q));
        }
        let mut budget = Budget {
            left: MAX_DERIVATIVE_NODES,
            of: x.to_string(),
        };
        self.clone().tidy().d_by(&Var::Symbol(x), &mut budget)
    }

    /// ∂self/∂der(q): the coefficient of the velocity `der(q)` in an expression linear in the
    /// velocities (for one of higher degree, the partial derivative), taken on the tree as
    /// [`Expr::diff`] does, so that the structure of the expression is kept.
    ///
    /// It copies at most as many nodes as [`Expr::diff`] may in all: an expression of a loaded
    /// model is at most quadratic in the velocities, so each product has at most two factors
    /// that hold `der(q)` and the coefficient stays small.
    pub fn velocity_coefficient(&self, q: &str) -> Expr {
        let mut budget = Budget {
            left: usize::MAX,
            of: format!("der({q})"),
        };
        let d = self.clone().tidy().d_by(&Var::Velocity(q), &mut budget);
        d.expect("an unlimited budget is never exceeded")
    }

    /// The first velocity `der(q)` in the tree, if any.
    fn velocity(&self) -> Option<String> {
        let mut found = None;
        self.visit(&mut |e| {
            if let (None, Expr::Der(q)) = (&found, e) {
                found = Some(q.clone());
            }
        });
        found
    }

    /// ∂self/∂x, each copy of a subtree charged to `budget` before it is made.
    fn d_by(&self, x: &Var, budget: &mut Budget) -> Result<Expr, DiffError> {
        if !x.in_tree(self) {
            return Ok(Expr::int(0));
        }
        Ok(match self {
            Expr::Num(_) => Expr::int(0),
            Expr::Sym(_) | Expr::Der(_) => Expr::int(1),
            Expr::Add(v) => sum(derivatives(v, x, budget)?),
            Expr::Mul(v) => product_rule(v, x, budget)?,
            Expr::Neg(a) => neg(a.d_by(x, budget)?),
            Expr::Div(a, b) if !x.in_tree(b) => {
                budget.charge(b.nodes())?;
                div(a.d_by(x, budget)?, (**b).clone())
            }
            Expr::Div(a, b) => {
                let (a, b) = (&**a, &**b);
                budget.charge(a.nodes() + 2 * b.nodes())?;
                let top = sub(
                    mul(a.d_by(x, budget)?, b.clone()),
                    mul(a.clone(), b.d_by(x, budget)?),
                );
                div(top, powi(b.clone(), 2))
            }
            Expr::Pow(a, e) => power_rule(a, e, x, budget)?,
            Expr::Call(f, a) => {
                budget.charge(a.nodes())?;
                mul(outer_derivative(*f, a), a.d_by(x, budget)?)
            }
            // d atan2(y, x) = (x dy − y dx)/(x² + y²)
            Expr::Atan2(y, w) => {
                let (y, w) = (&**y, &**w);
                budget.charge(3 * (y.nodes() + w.nodes()))?;
                let top = sub(
                    mul(w.clone(), y.d_by(x, budget)?),
                    mul(y.clone(), w.d_by(x, budget)?),
                );
                div(top, sum([powi(w.clone(), 2), powi(y.clone(), 2)]))
            }
            Expr::Free { name, args, orders } => sum(args.iter().enumerate().map(|(j, arg)| {
                if !x.is_symbol(arg) {
                    return Expr::int(0);
                }
                let mut orders = orders.clone();
                orders[j] += 1;
                Expr::Free {
                    name: name.clone(),
                    args: args.clone(),
                    orders,
                }
            })),
        })
    }

    /// Nodes of the tree.
    fn nodes(&self) -> usize {
        let mut n = 0;
        self.visit(&mut |_| n += 1);
        n
    }
}

fn derivatives(v: &[Expr], x: &Var, budget: &mut Budget) -> Result<Vec<Expr>, DiffError> {
    v.iter().map(|t| t.d_by(x, budget)).collect()
}

/// Σ_i (∏_{j≠i} f_j)·f_i' over the factors f_i that hold x (the others give no term).
fn product_rule(v: &[Expr], x: &Var, budget: &mut Budget) -> Result<Expr, DiffError> {
    let holding: Vec<usize> = (0..v.len()).filter(|&i| x.in_tree(&v[i])).collect();
    let all: usize = v.iter().map(Expr::nodes).sum();
    budget.charge(holding.len().saturating_mul(all))?;
    let terms = holding.iter().map(|&i| {
        let others = v.iter().enumerate().filter(|&(j, _)| j != i);
        let d = v[i].d_by(x, budget)?;
        Ok(product(others.map(|(_, f)| f.clone()).chain([d])))
    });
    Ok(sum(terms.collect::<Result<Vec<_>, DiffError>>()?))
}

/// ∂(aᵉ)/∂x: e·a^(e−1)·a' for a constant exponent, aᵉ·(e'·log a + e·a'/a) otherwise.
fn power_rule(a: &Expr, e: &Expr, x: &Var, budget: &mut Budget) -> Result<Expr, DiffError> {
    budget.charge(3 * (a.nodes() + e.nodes()))?;
    if !x.in_tree(e) {
        let lowered = match e.as_integer() {
            Some(n) => powi(a.clone(), n - 1),
            None => Expr::Pow(Box::new(a.clone()), Box::new(sub(e.clone(), Expr::int(1)))),
        };
        return Ok(product([e.clone(), lowered, a.d_by(x, budget)?]));
    }
    let pow = Expr::Pow(Box::new(a.clone()), Box::new(e.clone()));
    let log_a = call(Func::Log, a.clone());
    let inner = add(
        mul(e.d_by(x, budget)?, log_a),
        div(mul(e.clone(), a.d_by(x, budget)?), a.clone()),
    );
    Ok(mul(pow, inner))
}

/// What is differentiated by: a symbol (a coordinate or parameter), or a velocity `der(q)`.
enum Var<'a> {
    Symbol(&'a str),
    Velocity(&'a str),
}

impl Var<'_> {
    /// Whether the variable occurs in `e` (a symbol also as a free function's argument).
    fn in_tree(&self, e: &Expr) -> bool {
        match *self {
            Var::Symbol(x) => e.mentions(x),
            Var::Velocity(q) => e.any(&mut |n| matches!(n, Expr::Der(p) if p == q)),
        }
    }

    /// Whether the symbol `name` is the variable.
    fn is_symbol(&self, name: &str) -> bool {
        matches!(*self, Var::Symbol(x) if x == name)
    }
}

/// f'(a) for a built-in f.
fn outer_derivative(f: Func, a: &Expr) -> Expr {
    let a = a.clone();
    match f {
        Func::Sin => call(Func::Cos, a),
        Func::Cos => neg(call(Func::Sin, a)),
        Func::Tan => div(Expr::int(1), powi(call(Func::Cos, a), 2)),
        Func::Sqrt => div(Expr::int(1), mul(Expr::int(2), call(Func::Sqrt, a))),
        Func::Exp => call(Func::Exp, a),
        Func::Log => div(Expr::int(1), a),
        Func::Atan => div(Expr::int(1), Expr::Add(vec![Expr::int(1), powi(a, 2)])),
    }
}

#[cfg(test)]
mod tests {
    use crate::parse;
    use crate::{Dual, Env, Expr};
    use std::collections::HashMap;

    struct At(HashMap<&'static str, Dual>);
    impl Env<Dual> for At {
        fn symbol(&self, name: &str) -> Option<Dual> {
            self.0.get(name).copied()
        }
    }

    /// ∂e/∂x by the tree against the dual-number derivative of e, at a point.
    fn check(text: &str) {
        let e = parse(text).unwrap().expr;
        let point = [("x", 0.7), ("y", -1.3), ("a", 2.1)];
        let at = |seed: &str| {
            At(point
                .iter()
                .map(|&(n, v)| (n, Dual::new(v, f64::from(n == seed))))
                .collect())
        };
        for var in ["x", "y", "a"] {
            let exact = e.eval(&at(var)).unwrap().d;
            let tree = e.diff(var).unwrap().eval(&at(var)).unwrap().v;
            let scale = exact.abs().max(1.0);
            assert!(
                (exact - tree).abs() <= 1e-13 * scale,
                "{text} by {var}: {tree} vs {exact}"
            );
        }
    }

    #[test]
    fn derivatives_agree_with_dual_numbers() {
        for text in [
            "a*x^3*sin(y) - cos(x*y)/(1 + x^2)",
            "sqrt(1 - (sin(x)*cos(y))^2)*a",
            "tan(x/2) + exp(-y*x) + log(2 + x^2)",
            "x^y + (a + x)^(1/3)",
            "-(x*y*a)/(y^2 + 3)",
        ] {
            check(text);
        }
    }

    /// Found by fuzzing (fuzz/seeds/expression/timeout-power-tower): a tower of powers took
    /// 0.4 s to differentiate, because every node built was tidied with the whole tree below it.
    /// And a product of 20,000 factors that each hold x has a derivative of 4·10⁸ nodes: it is
    /// refused before it is built. The same product with one factor holding x is quick.
    #[test]
    fn derivatives_are_linear_in_what_they_build_and_bounded() {
        let tower = std::iter::repeat_n("x^(y + ", 45).collect::<String>() + "x" + &")".repeat(45);
        let e = parse(&tower).unwrap().expr;
        let d = e.diff("x").unwrap();
        assert!(d.nodes() < 200_000, "{} nodes", d.nodes());
        let many = parse(&vec!["x"; 20_000].join("*")).unwrap().expr;
        assert_eq!(many.diff("x"), Err(super::DiffError::TooLarge("x".into())));
        let one = parse(&(vec!["y"; 20_000].join("*") + "*x")).unwrap().expr;
        assert_eq!(one.diff("x").unwrap().nodes(), 20_001);
        check("x*y*a*x*(x + a)*y");
    }

    #[test]
    fn structural_zeros_vanish_and_velocities_are_refused() {
        let e = parse("a*sin(y) + x").unwrap().expr;
        assert_eq!(e.diff("x").unwrap(), Expr::int(1));
        assert_eq!(e.diff("b").unwrap(), Expr::int(0));
        let v = parse("x*der(y)").unwrap().expr;
        assert!(v.diff("x").is_err());
        let f = parse("z13(x, y)").unwrap().expr;
        assert_eq!(f.diff("y").unwrap().to_string(), "z13_dy(x, y)");
    }

    /// The coefficient of der(q), against the value of the row with der(q) = 1 and the other
    /// velocities 0, at a point; the coefficients keep the tree (no expansion).
    #[test]
    fn velocity_coefficients_are_the_rows_entries() {
        let row = parse("cos(x)*(a*der(x) - sin(y)*der(y)) + der(x)/(1 + y^2) - 3*der(z)")
            .unwrap()
            .expr;
        let point = [("x", 0.7), ("y", -1.3), ("a", 2.1), ("z", 0.2)];
        for q in ["x", "y", "z"] {
            let at = At(point.iter().map(|&(n, v)| (n, Dual::new(v, 0.0))).collect());
            let with_unit = row.map(&mut |e| match e {
                Expr::Der(p) => Expr::int(i64::from(p == q)),
                other => other,
            });
            let coefficient = row.velocity_coefficient(q);
            assert!(!coefficient.has_velocity());
            let (c, v) = (
                coefficient.eval(&at).unwrap().v,
                with_unit.eval(&at).unwrap().v,
            );
            assert!((c - v).abs() <= 1e-14, "der({q}): {c} vs {v}");
        }
        assert_eq!(row.velocity_coefficient("w"), Expr::int(0));
        let product = parse("der(x)*cos(y)*a").unwrap().expr;
        assert_eq!(product.velocity_coefficient("x").to_string(), "cos(y)*a");
    }
}
