//! Taylor coefficients of the solution of y' = f(t, y, p) by automatic differentiation
//! recurrences over a [`Tape`] (issue 63): what a Taylor integrator needs (Jorba & Zou 2005,
//! "A software package for the numerical integration of ODEs by means of high-order Taylor
//! methods"; heyoka and TIDES use the same recurrences).
//!
//! The tape is rewritten once into a program of unary and binary nodes ([`Series::new`]): an
//! n-ary product into a chain, an integer power into multiplications by squaring (a negative
//! one through a quotient), a constant real power into the power recurrence, sin and cos into
//! a pair that advances together (each needs the other's lower coefficients), tan into
//! sin/cos, a variable power into exp(b log a), atan with its 1 + a², atan2 with x² + y². Then
//! for k = 0, 1, …, p − 1 every node's coefficient k is computed from the lower ones and the
//! inputs' coefficient k, and the state's coefficient k + 1 is f's coefficient k over k + 1:
//! O(p²) per node for p coefficients.
//!
//! Normalised coefficients throughout: x(t₀ + τ) = Σ_k x[k] τ^k.

use crate::ast::{Expr, Func, Rational};
use crate::tape::{Op, Tape};

fn rational(r: &Rational) -> f64 {
    Expr::rational_to_f64(r)
}

/// One node of the series program; operands are earlier nodes.
#[derive(Clone, Debug)]
enum Node {
    /// The state variable number i.
    State(usize),
    /// The independent variable t.
    Time,
    /// A constant (a parameter's value, or a literal).
    Const(f64),
    Add(Vec<usize>),
    Neg(usize),
    Mul(usize, usize),
    Div(usize, usize),
    /// a^r for a constant real r (a[0] ≠ 0).
    Pow(usize, f64),
    Sqrt(usize),
    /// sin a, with the node of cos a.
    Sin(usize, usize),
    /// cos a, with the node of sin a.
    Cos(usize, usize),
    Exp(usize),
    Log(usize),
    /// atan a, with the node of 1 + a².
    Atan(usize, usize),
    /// atan2(y, x), with the node of x² + y².
    Atan2(usize, usize, usize),
}

/// What an input of the tape is.
#[derive(Clone, Debug, PartialEq)]
pub enum Role {
    /// State variable number i.
    State(usize),
    /// The independent variable.
    Time,
    /// A value fixed during the integration.
    Fixed(f64),
}

/// Why a tape has no series program, or coefficients could not be computed.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum SeriesError {
    /// The roles do not match the tape's inputs.
    #[error("{0} roles for {1} inputs")]
    Roles(usize, usize),
    /// The outputs are not one per state variable.
    #[error("{0} outputs for {1} state variables")]
    Outputs(usize, usize),
    /// A division by a series whose constant term is 0, a power or logarithm of one, or a
    /// non-finite value.
    #[error(
        "the series of node {0} is undefined at this state (a zero divisor, or a power, root or logarithm at 0)"
    )]
    Undefined(usize),
}

/// A tape's series program for y' = f.
#[derive(Clone, Debug)]
pub struct Series {
    nodes: Vec<Node>,
    /// f_i's node, per state variable.
    outputs: Vec<usize>,
    dim: usize,
}

/// Rewriting a tape's ops into nodes.
struct Rewrite {
    nodes: Vec<Node>,
    /// Node of each tape op.
    of: Vec<usize>,
}

impl Rewrite {
    fn push(&mut self, n: Node) -> usize {
        self.nodes.push(n);
        self.nodes.len() - 1
    }

    fn constant(&mut self, x: f64) -> usize {
        self.push(Node::Const(x))
    }

    /// a^n for an integer n, by squaring.
    fn power(&mut self, a: usize, n: i32) -> usize {
        if n == 0 {
            return self.constant(1.0);
        }
        if n.unsigned_abs() > 64 {
            return self.push(Node::Pow(a, f64::from(n)));
        }
        let result = hamel_runtime::power_by_squaring(a, n.unsigned_abs(), |x, y| {
            self.push(Node::Mul(x, y))
        });
        let positive = result.expect("n ≠ 0");
        if n < 0 {
            let one = self.constant(1.0);
            self.push(Node::Div(one, positive))
        } else {
            positive
        }
    }

    /// sin and cos of a: both nodes.
    fn sin_cos(&mut self, a: usize) -> (usize, usize) {
        let s = self.nodes.len();
        self.nodes.push(Node::Sin(a, s + 1));
        self.nodes.push(Node::Cos(a, s));
        (s, s + 1)
    }

    fn op(&mut self, op: &Op, roles: &[Role]) -> usize {
        let of = |i: &usize| self.of[*i];
        match op {
            Op::Input(slot) => match roles[*slot] {
                Role::State(i) => self.push(Node::State(i)),
                Role::Time => self.push(Node::Time),
                Role::Fixed(x) => self.constant(x),
            },
            Op::Const(r) => self.constant(rational(r)),
            Op::Add(a) => {
                let a = a.iter().map(of).collect();
                self.push(Node::Add(a))
            }
            Op::Mul(a) => {
                let a: Vec<usize> = a.iter().map(of).collect();
                let mut acc = a[0];
                for &b in &a[1..] {
                    acc = self.push(Node::Mul(acc, b));
                }
                acc
            }
            Op::Neg(a) => {
                let a = of(a);
                self.push(Node::Neg(a))
            }
            Op::Div(a, b) => {
                let (a, b) = (of(a), of(b));
                self.push(Node::Div(a, b))
            }
            Op::PowI(a, n) => {
                let a = of(a);
                self.power(a, *n)
            }
            Op::PowF(a, b) => {
                let (a, b) = (of(a), of(b));
                match self.nodes[b] {
                    Node::Const(r) => self.push(Node::Pow(a, r)),
                    _ => {
                        let log = self.push(Node::Log(a));
                        let e = self.push(Node::Mul(b, log));
                        self.push(Node::Exp(e))
                    }
                }
            }
            Op::Call(f, a) => {
                let a = of(a);
                self.call(*f, a)
            }
            Op::Atan2(y, x) => {
                let (y, x) = (of(y), of(x));
                let (yy, xx) = (self.push(Node::Mul(y, y)), self.push(Node::Mul(x, x)));
                let r = self.push(Node::Add(vec![xx, yy]));
                self.push(Node::Atan2(y, x, r))
            }
        }
    }

    fn call(&mut self, f: Func, a: usize) -> usize {
        match f {
            Func::Sin => self.sin_cos(a).0,
            Func::Cos => self.sin_cos(a).1,
            Func::Tan => {
                let (s, c) = self.sin_cos(a);
                self.push(Node::Div(s, c))
            }
            Func::Sqrt => self.push(Node::Sqrt(a)),
            Func::Exp => self.push(Node::Exp(a)),
            Func::Log => self.push(Node::Log(a)),
            Func::Atan => {
                let one = self.constant(1.0);
                let aa = self.push(Node::Mul(a, a));
                let d = self.push(Node::Add(vec![one, aa]));
                self.push(Node::Atan(a, d))
            }
        }
    }
}

impl Series {
    /// The series program of `tape`, whose input number j plays `roles[j]` and whose output i
    /// is f_i, the rate of state variable i.
    pub fn new(tape: &Tape, roles: &[Role]) -> Result<Series, SeriesError> {
        if roles.len() != tape.inputs().len() {
            return Err(SeriesError::Roles(roles.len(), tape.inputs().len()));
        }
        let dim = roles.iter().filter(|r| matches!(r, Role::State(_))).count();
        if tape.outputs().len() != dim {
            return Err(SeriesError::Outputs(tape.outputs().len(), dim));
        }
        let mut w = Rewrite {
            nodes: Vec::new(),
            of: Vec::with_capacity(tape.ops().len()),
        };
        for op in tape.ops() {
            let node = w.op(op, roles);
            w.of.push(node);
        }
        let outputs = tape.outputs().iter().map(|&o| w.of[o]).collect();
        Ok(Series {
            nodes: w.nodes,
            outputs,
            dim,
        })
    }

    /// The number of state variables.
    pub fn dim(&self) -> usize {
        self.dim
    }

    /// The number of nodes (each costs O(p²) per step of order p).
    pub fn len(&self) -> usize {
        self.nodes.len()
    }

    /// Whether the program is empty.
    pub fn is_empty(&self) -> bool {
        self.nodes.is_empty()
    }

    /// The Taylor coefficients of the solution through (t₀, y₀) up to order `order`: `out`
    /// gets `order + 1` rows of `dim` (row k: y[k]). `work` is scratch, resized as needed.
    pub fn coefficients(
        &self,
        t0: f64,
        y0: &[f64],
        order: usize,
        out: &mut Vec<f64>,
        work: &mut Vec<f64>,
    ) -> Result<(), SeriesError> {
        let (n, width) = (self.dim, order + 1);
        out.clear();
        out.resize(width * n, 0.0);
        out[..n].copy_from_slice(y0);
        work.clear();
        work.resize(self.nodes.len() * width, 0.0);
        for k in 0..order {
            for (i, node) in self.nodes.iter().enumerate() {
                let value = self.coefficient(node, i, k, t0, out, work, width);
                if !value.is_finite() {
                    return Err(SeriesError::Undefined(i));
                }
                work[i * width + k] = value;
            }
            for (s, &o) in self.outputs.iter().enumerate() {
                out[(k + 1) * n + s] = work[o * width + k] / (k + 1) as f64;
            }
        }
        Ok(())
    }

    /// Coefficient k of node number `i`, the lower ones of every node in `work`.
    #[allow(clippy::too_many_arguments)]
    fn coefficient(
        &self,
        node: &Node,
        i: usize,
        k: usize,
        t0: f64,
        state: &[f64],
        work: &[f64],
        width: usize,
    ) -> f64 {
        use hamel_runtime::recur;
        let x = |j: usize, m: usize| work[j * width + m];
        // operand j's series to k, the node's own to k − 1
        let s = |j: usize| &work[j * width..j * width + k + 1];
        let own = &work[i * width..i * width + k];
        if k == 0 {
            return match *node {
                Node::State(s) => state[s],
                Node::Time => t0,
                Node::Const(c) => c,
                Node::Add(ref a) => a.iter().map(|&j| x(j, 0)).sum(),
                Node::Neg(a) => -x(a, 0),
                Node::Mul(a, b) => x(a, 0) * x(b, 0),
                Node::Div(a, b) => x(a, 0) / x(b, 0),
                Node::Pow(a, r) => x(a, 0).powf(r),
                Node::Sqrt(a) => x(a, 0).sqrt(),
                Node::Sin(a, _) => x(a, 0).sin(),
                Node::Cos(a, _) => x(a, 0).cos(),
                Node::Exp(a) => x(a, 0).exp(),
                Node::Log(a) => x(a, 0).ln(),
                Node::Atan(a, _) => x(a, 0).atan(),
                Node::Atan2(y, xn, _) => x(y, 0).atan2(x(xn, 0)),
            };
        }
        match *node {
            Node::State(s) => state[k * self.dim + s],
            Node::Time => f64::from(k == 1),
            Node::Const(_) => 0.0,
            Node::Add(ref a) => a.iter().map(|&j| x(j, k)).sum(),
            Node::Neg(a) => -x(a, k),
            Node::Mul(a, b) => recur::product(s(a), s(b), k),
            Node::Div(a, b) => recur::quotient(x(a, k), s(b), own, k),
            Node::Pow(a, r) => recur::power(s(a), own, r, k),
            Node::Sqrt(a) => recur::sqrt(x(a, k), own, k),
            Node::Sin(a, c) => recur::sin(s(a), s(c), k),
            Node::Cos(a, sn) => recur::cos(s(a), s(sn), k),
            Node::Exp(a) => recur::exp(s(a), own, k),
            Node::Log(a) => recur::ln(s(a), own, k),
            Node::Atan(a, d) => recur::atan(s(a), s(d), own, k),
            Node::Atan2(y, xn, r) => recur::atan2(s(y), s(xn), s(r), own, k),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::{Role, Series};
    use crate::{Tape, parse};

    /// The series of y' = f(t, y) for expressions `f` in `y` and `t`.
    fn series(f: &[&str], state: &[&str]) -> Series {
        let exprs: Vec<crate::Expr> = f.iter().map(|s| parse(s).unwrap().expr).collect();
        let mut inputs: Vec<String> = state.iter().map(|s| s.to_string()).collect();
        inputs.push("t".into());
        let refs: Vec<&crate::Expr> = exprs.iter().collect();
        let tape = Tape::compile(&refs, &inputs).unwrap();
        let mut roles: Vec<Role> = (0..state.len()).map(Role::State).collect();
        roles.push(Role::Time);
        Series::new(&tape, &roles).unwrap()
    }

    fn coefficients(s: &Series, t0: f64, y0: &[f64], order: usize) -> Vec<f64> {
        let (mut out, mut work) = (Vec::new(), Vec::new());
        s.coefficients(t0, y0, order, &mut out, &mut work).unwrap();
        out
    }

    fn factorial(k: usize) -> f64 {
        (1..=k).map(|j| j as f64).product()
    }

    /// y' = y: y[k] = 1/k!; x' = −y, y' = x (a rotation): cos and sin's coefficients.
    #[test]
    fn linear_systems_have_their_exponential_series() {
        let s = series(&["y"], &["y"]);
        let c = coefficients(&s, 0.0, &[1.0], 20);
        for (k, ck) in c.iter().enumerate() {
            assert!((ck - 1.0 / factorial(k)).abs() <= 1e-15 * ck.abs(), "{k}");
        }
        let s = series(&["-y", "x"], &["x", "y"]);
        let c = coefficients(&s, 0.0, &[1.0, 0.0], 12);
        for k in 0..=12 {
            let (cos_k, sin_k) = match k % 4 {
                0 => (1.0, 0.0),
                1 => (0.0, 1.0),
                2 => (-1.0, 0.0),
                _ => (0.0, -1.0),
            };
            assert!((c[2 * k] - cos_k / factorial(k)).abs() < 1e-17, "{k}");
            assert!((c[2 * k + 1] - sin_k / factorial(k)).abs() < 1e-17, "{k}");
        }
    }

    /// Nonlinear right-hand sides against their closed-form solutions' derivatives at 0:
    /// y' = y² (y = 1/(1 − t)), y' = 1/(2y) (y = √(1 + t)), y' = cos(y)·… through a solution
    /// whose series is known: y = atan(t) solves y' = cos(y)², y = tan t solves y' = 1 + y².
    #[test]
    fn nonlinear_recurrences_give_known_series() {
        let c = coefficients(&series(&["y^2"], &["y"]), 0.0, &[1.0], 15);
        assert!(c.iter().all(|ck| (ck - 1.0).abs() < 1e-15));
        // √(1 + t) = Σ binom(1/2, k) t^k
        let c = coefficients(&series(&["1/(2*y)"], &["y"]), 0.0, &[1.0], 10);
        let mut binom = 1.0;
        for (k, ck) in c.iter().enumerate() {
            assert!((ck - binom).abs() < 1e-15, "{k}: {ck} vs {binom}");
            binom *= (0.5 - k as f64) / (k + 1) as f64;
        }
        // tan t = t + t³/3 + 2t⁵/15 + 17t⁷/315
        let c = coefficients(&series(&["1 + y^2"], &["y"]), 0.0, &[0.0], 7);
        for (k, want) in [(1, 1.0), (3, 1.0 / 3.0), (5, 2.0 / 15.0), (7, 17.0 / 315.0)] {
            assert!((c[k] - want).abs() < 1e-16, "{k}");
        }
        // atan t = t − t³/3 + t⁵/5: y' = cos(y)^2 and y' = 1/(1 + tan(y)^2) alike
        for f in ["cos(y)^2", "1/(1 + tan(y)^2)"] {
            let c = coefficients(&series(&[f], &["y"]), 0.0, &[0.0], 7);
            for (k, want) in [(1, 1.0), (3, -1.0 / 3.0), (5, 0.2), (7, -1.0 / 7.0)] {
                assert!((c[k] - want).abs() < 1e-15, "{f} {k}: {}", c[k]);
            }
        }
    }

    /// The elementary functions through a state that moves linearly (y' = 1, z = …): each
    /// output's series equals the function's own Taylor series about t₀, checked by the
    /// coefficients of z' = g'(t) integrated: z[k] = g^(k)(t₀)/k!. g = exp, log, sqrt, atan,
    /// atan2(sin t, cos t) = t, powers.
    #[test]
    fn elementary_functions_of_time_integrate_to_their_series() {
        // z' = d/dt g(t) written through g's own recurrences: z' = exp(t) gives z[k] = e/k!
        type Derivative = fn(f64, usize) -> f64;
        let cases: [(&str, Derivative); 5] = [
            ("exp(t)", |t, k| t.exp() / factorial(k)),
            ("log(t)", |t, k| {
                // d^k log t/dt^k = (−1)^{k−1}(k−1)!/t^k
                if k == 0 {
                    return t.ln();
                }
                let j = k as i32;
                (-1f64).powi(j - 1) / (j as f64 * t.powi(j))
            }),
            ("sqrt(t)", |t, k| {
                let mut b = 1.0;
                for j in 0..k {
                    b *= (0.5 - j as f64) / (j + 1) as f64;
                }
                b * t.powf(0.5 - k as f64)
            }),
            (
                "atan2(sin(t), cos(t))",
                |_, k| if k == 1 { 1.0 } else { 0.0 },
            ),
            ("t^(-3)", |t, k| {
                let mut b = 1.0;
                for j in 0..k {
                    b *= (-3.0 - j as f64) / (j + 1) as f64;
                }
                b * t.powf(-3.0 - k as f64)
            }),
        ];
        let t0 = 0.7;
        for (g, want) in cases {
            // z' = g(t): z[k+1] = g[k]/(k+1), g[k] = g^(k)(t₀)/k!
            let c = coefficients(&series(&[g], &["z"]), t0, &[0.0], 9);
            for k in 0..9 {
                let got = c[k + 1] * (k + 1) as f64;
                let w = want(t0, k);
                let w = if k == 0 && g == "atan2(sin(t), cos(t))" {
                    t0
                } else {
                    w
                };
                assert!(
                    (got - w).abs() <= 1e-13 * w.abs().max(1.0),
                    "{g} {k}: {got} vs {w}"
                );
            }
        }
    }
}
