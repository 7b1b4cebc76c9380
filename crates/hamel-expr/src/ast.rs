//! The expression tree.

use num_bigint::BigInt;
use num_traits::{One, Signed, ToPrimitive, Zero};

/// An exact rational number.
pub type Rational = num_rational::BigRational;

/// Built-in functions of one argument.
#[derive(
    Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, serde::Serialize, serde::Deserialize,
)]
pub enum Func {
    /// sine
    Sin,
    /// cosine
    Cos,
    /// tangent
    Tan,
    /// square root (principal branch)
    Sqrt,
    /// exponential
    Exp,
    /// natural logarithm
    Log,
    /// arctangent (principal branch, in (−π/2, π/2))
    Atan,
}

impl Func {
    /// All built-in functions.
    pub const ALL: [Func; 7] = [
        Func::Sin,
        Func::Cos,
        Func::Tan,
        Func::Sqrt,
        Func::Exp,
        Func::Log,
        Func::Atan,
    ];

    /// The name used in expression text.
    pub fn name(self) -> &'static str {
        match self {
            Func::Sin => "sin",
            Func::Cos => "cos",
            Func::Tan => "tan",
            Func::Sqrt => "sqrt",
            Func::Exp => "exp",
            Func::Log => "log",
            Func::Atan => "atan",
        }
    }

    /// The built-in function with this name, if any.
    pub fn from_name(name: &str) -> Option<Func> {
        Func::ALL.into_iter().find(|f| f.name() == name)
    }
}

/// An expression.
///
/// Sums and products are n-ary; subtraction is a sum with a negated term and division is
/// [`Expr::Div`]. Symbols are resolved by name by whoever evaluates or converts the tree.
/// Serialised structurally (a stored derivation, `hamel_derive::store`); the text a user reads
/// is the printer's.
#[derive(Clone, Debug, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
pub enum Expr {
    /// An exact rational literal.
    Num(Rational),
    /// A coordinate or a parameter.
    Sym(String),
    /// `der(q)`: the velocity of coordinate `q`.
    Der(String),
    /// Sum of the terms.
    Add(Vec<Expr>),
    /// Product of the factors.
    Mul(Vec<Expr>),
    /// Negation.
    Neg(Box<Expr>),
    /// Quotient.
    Div(Box<Expr>, Box<Expr>),
    /// Power `base ^ exponent`.
    Pow(Box<Expr>, Box<Expr>),
    /// A built-in function applied to one argument.
    Call(Func, Box<Expr>),
    /// `atan2(y, x)`: the angle of the point (x, y), in (−π, π] (the two-argument
    /// arctangent; y first, as in C and NumPy).
    Atan2(Box<Expr>, Box<Expr>),
    /// An unknown (free) function of coordinates, such as `z13(phi)`, or one of its partial
    /// derivatives: `orders[j]` is the order of differentiation in the `j`-th argument.
    Free {
        /// Function name.
        name: String,
        /// Coordinate names it depends on.
        args: Vec<String>,
        /// Derivative orders, one per argument (all zero for the function itself).
        orders: Vec<u32>,
    },
}

impl Expr {
    /// The integer `n`.
    pub fn int(n: i64) -> Expr {
        Expr::Num(Rational::from_integer(BigInt::from(n)))
    }

    /// The symbol `name`.
    pub fn sym(name: &str) -> Expr {
        Expr::Sym(name.to_string())
    }

    /// `f(arg)` for a built-in `f`.
    pub fn call(f: Func, arg: Expr) -> Expr {
        Expr::Call(f, Box::new(arg))
    }

    /// `atan2(y, x)`.
    pub fn atan2(y: Expr, x: Expr) -> Expr {
        Expr::Atan2(Box::new(y), Box::new(x))
    }

    /// `base ^ n` for an integer `n`.
    pub fn powi(base: Expr, n: i64) -> Expr {
        Expr::Pow(Box::new(base), Box::new(Expr::int(n)))
    }

    /// True when this is the literal zero.
    pub fn is_zero_literal(&self) -> bool {
        matches!(self, Expr::Num(r) if r.is_zero())
    }

    /// True when this is the literal one.
    pub fn is_one_literal(&self) -> bool {
        matches!(self, Expr::Num(r) if r.is_one())
    }

    /// The value of a literal as an integer, if it is one.
    pub fn as_integer(&self) -> Option<i64> {
        match self {
            // In lowest terms: an integer is its numerator (no division, no allocation).
            Expr::Num(r) if r.is_integer() => r.numer().to_i64(),
            Expr::Neg(e) => e.as_integer().map(|n| -n),
            _ => None,
        }
    }

    /// The value of a literal (possibly negated) as a rational, if it is one.
    pub fn as_rational(&self) -> Option<Rational> {
        match self {
            Expr::Num(r) => Some(r.clone()),
            Expr::Neg(e) => e.as_rational().map(|r| -r),
            _ => None,
        }
    }

    /// Visit every node, parents before children.
    pub fn visit(&self, f: &mut impl FnMut(&Expr)) {
        f(self);
        match self {
            Expr::Num(_) | Expr::Sym(_) | Expr::Der(_) | Expr::Free { .. } => {}
            Expr::Add(v) | Expr::Mul(v) => v.iter().for_each(|e| e.visit(f)),
            Expr::Neg(e) | Expr::Call(_, e) => e.visit(f),
            Expr::Div(a, b) | Expr::Pow(a, b) | Expr::Atan2(a, b) => {
                a.visit(f);
                b.visit(f);
            }
        }
    }

    /// Rebuild the tree bottom-up, replacing each node by `f(node)` after its children.
    pub fn map(&self, f: &mut impl FnMut(Expr) -> Expr) -> Expr {
        let rebuilt = match self {
            Expr::Num(_) | Expr::Sym(_) | Expr::Der(_) | Expr::Free { .. } => self.clone(),
            Expr::Add(v) => Expr::Add(v.iter().map(|e| e.map(f)).collect()),
            Expr::Mul(v) => Expr::Mul(v.iter().map(|e| e.map(f)).collect()),
            Expr::Neg(e) => Expr::Neg(Box::new(e.map(f))),
            Expr::Call(g, e) => Expr::Call(*g, Box::new(e.map(f))),
            Expr::Div(a, b) => Expr::Div(Box::new(a.map(f)), Box::new(b.map(f))),
            Expr::Pow(a, b) => Expr::Pow(Box::new(a.map(f)), Box::new(b.map(f))),
            Expr::Atan2(a, b) => Expr::Atan2(Box::new(a.map(f)), Box::new(b.map(f))),
        };
        f(rebuilt)
    }

    /// True when some node satisfies `pred`.
    pub fn any(&self, pred: &mut impl FnMut(&Expr) -> bool) -> bool {
        let mut found = false;
        self.visit(&mut |e| found = found || pred(e));
        found
    }

    /// Arithmetic operations of the tree, nothing shared (an n-ary sum or product counts
    /// n − 1; a negation, a function call, a quotient and a power count one each).
    pub fn tree_operations(&self) -> usize {
        match self {
            Expr::Num(_) | Expr::Sym(_) | Expr::Der(_) | Expr::Free { .. } => 0,
            Expr::Add(v) | Expr::Mul(v) => {
                v.len().saturating_sub(1) + v.iter().map(Expr::tree_operations).sum::<usize>()
            }
            Expr::Neg(a) | Expr::Call(_, a) => 1 + a.tree_operations(),
            Expr::Div(a, b) | Expr::Pow(a, b) | Expr::Atan2(a, b) => {
                1 + a.tree_operations() + b.tree_operations()
            }
        }
    }

    /// True when the expression mentions a velocity `der(q)`.
    pub fn has_velocity(&self) -> bool {
        self.any(&mut |e| matches!(e, Expr::Der(_)))
    }

    /// Replace the free function `name` (of any arguments) by `by`, an expression in its
    /// argument names; fails for derivative nodes of it (substitute before differentiating).
    pub fn substitute_free(&self, name: &str, by: &Expr) -> Result<Expr, SubstituteError> {
        let mut err = None;
        let out = self.map(&mut |e| match e {
            Expr::Free {
                name: n, orders, ..
            } if n == name => {
                if orders.iter().any(|&o| o != 0) {
                    err = Some(SubstituteError::Derivative(name.to_string()));
                }
                by.clone()
            }
            other => other,
        });
        match err {
            Some(e) => Err(e),
            None => Ok(out),
        }
    }

    /// A light clean-up for readability of built trees: flattens nested sums and products,
    /// drops zero terms and unit factors, folds a zero factor. It does not decide equality.
    pub fn tidy(self) -> Expr {
        self.map(&mut Expr::tidy_top)
    }

    /// [`Expr::tidy`] of a node whose children are tidy already: the clean-up of the top node
    /// only, in time independent of the tree below it.
    pub fn tidy_top(self) -> Expr {
        match self {
            Expr::Add(v) => {
                let mut out = Vec::new();
                for t in v {
                    match t {
                        Expr::Add(inner) => out.extend(inner),
                        t if t.is_zero_literal() => {}
                        t => out.push(t),
                    }
                }
                match out.len() {
                    0 => Expr::int(0),
                    1 => out.pop().unwrap(),
                    _ => Expr::Add(out),
                }
            }
            Expr::Mul(v) => {
                let mut out = Vec::new();
                for t in v {
                    match t {
                        Expr::Mul(inner) => out.extend(inner),
                        t if t.is_one_literal() => {}
                        t => out.push(t),
                    }
                }
                if out.iter().any(Expr::is_zero_literal) {
                    return Expr::int(0);
                }
                match out.len() {
                    0 => Expr::int(1),
                    1 => out.pop().unwrap(),
                    _ => Expr::Mul(out),
                }
            }
            Expr::Neg(inner) => match *inner {
                Expr::Num(r) => Expr::Num(-r),
                Expr::Neg(x) => *x,
                x => Expr::Neg(Box::new(x)),
            },
            other => other,
        }
    }

    /// A literal as `f64` (used by the evaluators).
    pub fn rational_to_f64(r: &Rational) -> f64 {
        // Exact enough: numerator and denominator each rounded once, then divided.
        let (n, d) = (r.numer(), r.denom());
        match (n.to_f64(), d.to_f64()) {
            (Some(a), Some(b)) if a.is_finite() && b.is_finite() => a / b,
            _ => {
                // Very large parts: scale both down by the same power of two.
                let shift = n.bits().max(d.bits()).saturating_sub(1000);
                let a = (n.abs() >> shift).to_f64().unwrap_or(f64::INFINITY);
                let b = (d >> shift).to_f64().unwrap_or(f64::INFINITY);
                if n.is_negative() { -a / b } else { a / b }
            }
        }
    }
}

/// Why a free function could not be substituted.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum SubstituteError {
    /// The expression holds a derivative of the function (substitute before differentiating).
    #[error("cannot substitute a derivative of `{0}`")]
    Derivative(String),
}
