//! Numeric evaluation over a generic scalar.

use hamel_runtime::{RationalParts, Scalar};
use num_traits::ToPrimitive;

use crate::ast::{Expr, Func, Rational};

/// An exact rational literal in the form the scalars take it ([`RationalParts`]): numerator
/// and denominator each split into two doubles, and the nearest f64.
pub fn rational_parts(r: &Rational) -> RationalParts {
    let split = |n: &num_bigint::BigInt| -> (f64, f64) {
        let hi = n.to_f64().unwrap_or(f64::INFINITY);
        if !hi.is_finite() {
            return (hi, 0.0);
        }
        let rest = n - num_bigint::BigInt::from(hi as i128);
        (hi, rest.to_f64().unwrap_or(0.0))
    };
    RationalParts {
        numer: split(r.numer()),
        denom: split(r.denom()),
        nearest: Expr::rational_to_f64(r),
    }
}

/// Why an evaluation failed.
#[derive(Clone, Debug, PartialEq)]
pub enum EvalError {
    /// A name the environment does not know.
    Unbound(String),
    /// A mathematical domain error (division by zero, log of a non-positive number, …).
    Domain(String),
}

impl std::fmt::Display for EvalError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            EvalError::Unbound(n) => write!(f, "no value for `{n}`"),
            EvalError::Domain(m) => write!(f, "{m}"),
        }
    }
}

impl std::error::Error for EvalError {}

/// Values of the names an expression mentions.
pub trait Env<S: Scalar> {
    /// The value of a coordinate or parameter.
    fn symbol(&self, name: &str) -> Option<S>;
    /// The value of `der(q)`.
    fn velocity(&self, _coordinate: &str) -> Option<S> {
        None
    }
    /// The value of a free function (or one of its partial derivatives) at the current point.
    fn free(&self, _name: &str, _args: &[String], _orders: &[u32]) -> Option<S> {
        None
    }
}

impl<S: Scalar, F: Fn(&str) -> Option<S>> Env<S> for F {
    fn symbol(&self, name: &str) -> Option<S> {
        self(name)
    }
}

/// The text of an expression for a message: at most 120 characters.
fn brief(e: &Expr) -> String {
    let s = e.to_string();
    if s.chars().count() <= 120 {
        s
    } else {
        format!("{}…", s.chars().take(120).collect::<String>())
    }
}

impl Expr {
    /// Evaluate in `env`. Division by zero, `log`/`sqrt` outside their domain and non-finite
    /// results are errors, never NaN.
    pub fn eval<S: Scalar>(&self, env: &dyn Env<S>) -> Result<S, EvalError> {
        let out = match self {
            Expr::Num(r) => S::rational(&rational_parts(r)),
            Expr::Sym(n) => env.symbol(n).ok_or_else(|| EvalError::Unbound(n.clone()))?,
            Expr::Der(q) => env
                .velocity(q)
                .ok_or_else(|| EvalError::Unbound(format!("der({q})")))?,
            Expr::Free { name, args, orders } => env.free(name, args, orders).ok_or_else(|| {
                EvalError::Unbound(format!("{name}({}) or its derivative", args.join(", ")))
            })?,
            Expr::Add(v) => {
                let mut acc = S::constant(0.0);
                for t in v {
                    acc = acc + t.eval(env)?;
                }
                acc
            }
            Expr::Mul(v) => {
                let mut acc = S::constant(1.0);
                for t in v {
                    acc = acc * t.eval(env)?;
                }
                acc
            }
            Expr::Neg(e) => -e.eval(env)?,
            Expr::Div(a, b) => {
                let d = b.eval(env)?;
                if d.value() == 0.0 {
                    return Err(EvalError::Domain(format!(
                        "division by zero in `{}`",
                        brief(self)
                    )));
                }
                a.eval(env)? / d
            }
            Expr::Pow(b, e) => {
                let base = b.eval(env)?;
                match e.as_integer() {
                    Some(n) if i32::try_from(n).is_ok() => {
                        if n < 0 && base.value() == 0.0 {
                            return Err(EvalError::Domain(format!(
                                "zero to a negative power in `{}`",
                                brief(self)
                            )));
                        }
                        base.powi(n as i32)
                    }
                    _ => {
                        if base.value() <= 0.0 {
                            return Err(EvalError::Domain(format!(
                                "non-integer power of a non-positive number in `{}`",
                                brief(self)
                            )));
                        }
                        base.powf(e.eval(env)?)
                    }
                }
            }
            Expr::Call(f, a) => {
                let x = a.eval(env)?;
                match f {
                    Func::Sin => x.sin(),
                    Func::Cos => x.cos(),
                    Func::Tan => {
                        let c = x.cos();
                        if c.value() == 0.0 {
                            return Err(EvalError::Domain(format!(
                                "tan at a pole in `{}`",
                                brief(self)
                            )));
                        }
                        x.sin() / c
                    }
                    Func::Sqrt => {
                        if x.value() < 0.0 {
                            return Err(EvalError::Domain(format!(
                                "square root of a negative number in `{}`",
                                brief(self)
                            )));
                        }
                        x.sqrt()
                    }
                    Func::Exp => x.exp(),
                    Func::Log => {
                        if x.value() <= 0.0 {
                            return Err(EvalError::Domain(format!(
                                "logarithm of a non-positive number in `{}`",
                                brief(self)
                            )));
                        }
                        x.ln()
                    }
                    Func::Atan => x.atan(),
                }
            }
            Expr::Atan2(y, x) => {
                let (y, x) = (y.eval(env)?, x.eval(env)?);
                if y.value() == 0.0 && x.value() == 0.0 {
                    return Err(EvalError::Domain(format!(
                        "atan2 of the origin (0, 0) in `{}`",
                        brief(self)
                    )));
                }
                y.atan2(x)
            }
        };
        if !out.value().is_finite() {
            return Err(EvalError::Domain(format!(
                "non-finite value of `{}`",
                brief(self)
            )));
        }
        Ok(out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::parse;
    use hamel_runtime::Dual;

    fn env(x: f64) -> impl Fn(&str) -> Option<f64> {
        move |n: &str| (n == "x").then_some(x)
    }

    #[test]
    fn evaluates_with_exact_literals() {
        let e = parse("0.5*x^2 + 3/4 - sin(x)^2 - cos(x)^2").unwrap().expr;
        let v = e.eval(&env(2.0)).unwrap();
        assert!((v - (2.0 + 0.75 - 1.0)).abs() < 1e-15);
    }

    #[test]
    fn dual_numbers_give_exact_derivatives() {
        let e = parse("x^3*sin(x)/(1 + x^2)").unwrap().expr;
        let x = 0.7_f64;
        let f = |n: &str| (n == "x").then_some(Dual::new(x, 1.0_f64));
        let d = e.eval(&f).unwrap();
        let exact = (3.0 * x * x * x.sin() + x.powi(3) * x.cos()) / (1.0 + x * x)
            - x.powi(3) * x.sin() * 2.0 * x / (1.0 + x * x).powi(2);
        assert!((d.d - exact).abs() < 1e-14, "{} vs {}", d.d, exact);
    }

    #[test]
    fn domain_errors_are_errors_not_nan() {
        let e = parse("1/(x - 2)").unwrap().expr;
        assert!(matches!(e.eval(&env(2.0)), Err(EvalError::Domain(_))));
        let e = parse("log(x)").unwrap().expr;
        assert!(matches!(e.eval(&env(-1.0)), Err(EvalError::Domain(_))));
        let e = parse("sqrt(x) + y").unwrap().expr;
        assert_eq!(e.eval(&env(1.0)), Err(EvalError::Unbound("y".into())));
    }
}
