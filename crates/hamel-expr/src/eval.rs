//! Numeric evaluation over a generic scalar.

use std::ops::{Add, Div, Mul, Neg, Sub};

use crate::ast::{Expr, Func, Rational};

/// A number type expressions can be evaluated in.
pub trait Scalar:
    Clone
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<Output = Self>
    + Div<Output = Self>
    + Neg<Output = Self>
{
    /// A constant.
    fn constant(v: f64) -> Self;
    /// An exact rational literal, as accurately as the type allows.
    fn rational(r: &Rational) -> Self {
        Self::constant(Expr::rational_to_f64(r))
    }
    /// The value part (for domain checks).
    fn value(&self) -> f64;
    /// sine
    fn sin(&self) -> Self;
    /// cosine
    fn cos(&self) -> Self;
    /// square root
    fn sqrt(&self) -> Self;
    /// exponential
    fn exp(&self) -> Self;
    /// natural logarithm
    fn ln(&self) -> Self;
    /// integer power
    fn powi(&self, n: i32) -> Self;
    /// real power `self^e` of a positive base
    fn powf(&self, e: &Self) -> Self {
        (self.ln() * e.clone()).exp()
    }
}

impl Scalar for f64 {
    fn constant(v: f64) -> Self {
        v
    }
    fn value(&self) -> f64 {
        *self
    }
    fn sin(&self) -> Self {
        f64::sin(*self)
    }
    fn cos(&self) -> Self {
        f64::cos(*self)
    }
    fn sqrt(&self) -> Self {
        f64::sqrt(*self)
    }
    fn exp(&self) -> Self {
        f64::exp(*self)
    }
    fn ln(&self) -> Self {
        f64::ln(*self)
    }
    fn powi(&self, n: i32) -> Self {
        f64::powi(*self, n)
    }
    fn powf(&self, e: &Self) -> Self {
        f64::powf(*self, *e)
    }
}

/// A first-order dual number `v + d ε` with ε² = 0: evaluating `f(x + ε ẋ)` gives `f(x)` and the
/// exact directional derivative `f'(x) ẋ` (forward-mode automatic differentiation), over any
/// [`Scalar`] (f64 by default).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Dual<T = f64> {
    /// Value.
    pub v: T,
    /// Derivative part.
    pub d: T,
}

impl<T> Dual<T> {
    /// `v + d ε`.
    pub fn new(v: T, d: T) -> Dual<T> {
        Dual { v, d }
    }
}

impl<T: Scalar> Add for Dual<T> {
    type Output = Dual<T>;
    fn add(self, o: Dual<T>) -> Dual<T> {
        Dual::new(self.v + o.v, self.d + o.d)
    }
}
impl<T: Scalar> Sub for Dual<T> {
    type Output = Dual<T>;
    fn sub(self, o: Dual<T>) -> Dual<T> {
        Dual::new(self.v - o.v, self.d - o.d)
    }
}
impl<T: Scalar> Mul for Dual<T> {
    type Output = Dual<T>;
    fn mul(self, o: Dual<T>) -> Dual<T> {
        Dual::new(self.v.clone() * o.v.clone(), self.d * o.v + self.v * o.d)
    }
}
impl<T: Scalar> Div for Dual<T> {
    type Output = Dual<T>;
    fn div(self, o: Dual<T>) -> Dual<T> {
        let q = self.v.clone() / o.v.clone();
        Dual::new(q.clone(), (self.d - q * o.d) / o.v)
    }
}
impl<T: Scalar> Neg for Dual<T> {
    type Output = Dual<T>;
    fn neg(self) -> Dual<T> {
        Dual::new(-self.v, -self.d)
    }
}

impl<T: Scalar> Scalar for Dual<T> {
    fn constant(v: f64) -> Self {
        Dual::new(T::constant(v), T::constant(0.0))
    }
    fn rational(r: &Rational) -> Self {
        Dual::new(T::rational(r), T::constant(0.0))
    }
    fn value(&self) -> f64 {
        self.v.value()
    }
    fn sin(&self) -> Self {
        Dual::new(self.v.sin(), self.d.clone() * self.v.cos())
    }
    fn cos(&self) -> Self {
        Dual::new(self.v.cos(), -(self.d.clone() * self.v.sin()))
    }
    fn sqrt(&self) -> Self {
        let s = self.v.sqrt();
        Dual::new(s.clone(), self.d.clone() / (s.clone() + s))
    }
    fn exp(&self) -> Self {
        let e = self.v.exp();
        Dual::new(e.clone(), self.d.clone() * e)
    }
    fn ln(&self) -> Self {
        Dual::new(self.v.ln(), self.d.clone() / self.v.clone())
    }
    fn powi(&self, n: i32) -> Self {
        if n == 0 {
            return Dual::constant(1.0);
        }
        Dual::new(
            self.v.powi(n),
            self.d.clone() * T::constant(n as f64) * self.v.powi(n - 1),
        )
    }
}

/// An LU factorisation with partial pivoting over any [`Scalar`] (pivots chosen by the
/// magnitude of their f64 value).
#[derive(Clone, Debug)]
pub struct Lu<S> {
    lu: Vec<Vec<S>>,
    perm: Vec<usize>,
}

impl<S: Scalar> Lu<S> {
    /// Factor a square matrix; `None` when a pivot is exactly zero (singular).
    pub fn new(mut a: Vec<Vec<S>>) -> Option<Lu<S>> {
        let n = a.len();
        let mut perm: Vec<usize> = (0..n).collect();
        for col in 0..n {
            let p = (col..n)
                .max_by(|&i, &j| a[i][col].value().abs().total_cmp(&a[j][col].value().abs()))?;
            if a[p][col].value() == 0.0 {
                return None;
            }
            a.swap(p, col);
            perm.swap(p, col);
            let (top, below) = a.split_at_mut(col + 1);
            let pivot_row = &top[col];
            for row in below {
                let f = row[col].clone() / pivot_row[col].clone();
                for (x, t) in row[col + 1..].iter_mut().zip(&pivot_row[col + 1..]) {
                    *x = x.clone() - f.clone() * t.clone();
                }
                row[col] = f;
            }
        }
        Some(Lu { lu: a, perm })
    }

    /// Solve `a x = b`.
    pub fn solve(&self, b: &[S]) -> Vec<S> {
        let n = b.len();
        let mut y: Vec<S> = self.perm.iter().map(|&i| b[i].clone()).collect();
        for r in 0..n {
            for c in 0..r {
                y[r] = y[r].clone() - self.lu[r][c].clone() * y[c].clone();
            }
        }
        for r in (0..n).rev() {
            for c in r + 1..n {
                y[r] = y[r].clone() - self.lu[r][c].clone() * y[c].clone();
            }
            y[r] = y[r].clone() / self.lu[r][r].clone();
        }
        y
    }
}

/// Solve the square system `a x = b` (LU with partial pivoting); `None` when singular.
pub fn solve<S: Scalar>(a: Vec<Vec<S>>, b: Vec<S>) -> Option<Vec<S>> {
    Lu::new(a).map(|lu| lu.solve(&b))
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
            Expr::Num(r) => S::rational(r),
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
                        base.powf(&e.eval(env)?)
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
                }
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
    fn lu_solves_with_pivoting() {
        let a = vec![
            vec![0.0, 2.0, 1.0],
            vec![1.0, 1.0, 0.0],
            vec![3.0, 0.0, 1.0],
        ];
        let x = [1.0, -2.0, 0.5];
        let b: Vec<f64> = a
            .iter()
            .map(|r| r.iter().zip(&x).map(|(p, q)| p * q).sum())
            .collect();
        let got = solve(a, b).unwrap();
        for (g, e) in got.iter().zip(&x) {
            assert!((g - e).abs() < 1e-14);
        }
        assert!(solve(vec![vec![1.0, 2.0], vec![2.0, 4.0]], vec![1.0, 2.0]).is_none());
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
