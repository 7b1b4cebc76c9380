//! The Taylor method's recurrences compiled (issue 63): the reduced right-hand side's tape
//! written as straight-line Rust that computes the solution's Taylor coefficients, every
//! operation's recurrence inlined at its place (`runtime::recur`), as heyoka compiles them —
//! where the scene core otherwise traces the right-hand side at each step and interprets the
//! recurrences over the trace (`runtime::taylor_by_trace`), dispatching on every node.
//!
//! The tape's operations that depend on no state variable (parameters, constants and what is
//! made of them) are f64 values computed once per call; the others are series nodes, each with
//! `order + 1` coefficients in one buffer. A node's coefficient 0 is its value at the state,
//! computed first for all; then for k = 1 … p − 1 coefficient k of every node, and the state's
//! coefficient k + 1 is its rate's coefficient k over k + 1. Operations with an f64 operand
//! become the cheaper node they are (a sum with one touches coefficient 0 only, a product
//! scales), as the tracer makes them.

use std::fmt::Write;

use hamel_expr::{Func, Op, Tape};

use super::emit::lit;

/// What a tape input is for the series.
#[derive(Clone, Debug)]
pub(super) enum SeriesInput {
    /// The reduced state's component i.
    State(usize),
    /// A value fixed over the step (a parameter), as Rust text.
    Fixed(String),
}

/// A tape operation's value in the series program.
#[derive(Clone, Debug)]
enum Val {
    /// An f64 computed once (`s{k}`), or a literal.
    Scalar(String),
    /// A series node.
    Node(usize),
}

/// The program being written: the f64 lets, the coefficient-0 statements, the statements for
/// coefficient k ≥ 1, one per node.
#[derive(Default)]
struct Program {
    /// The state's dimension.
    n: usize,
    scalars: String,
    zero: String,
    step: String,
    nodes: usize,
    /// sin and cos nodes of an operation, once made.
    sin_cos: std::collections::HashMap<usize, (usize, usize)>,
}

/// `c[node·w + k]` and the slices the recurrences read.
fn at(node: usize, k: &str) -> String {
    format!("c[{node} * w + {k}]")
}
fn from(node: usize) -> String {
    format!("&c[{node} * w..]")
}
fn own(node: usize) -> String {
    format!("&c[{node} * w..{node} * w + k]")
}

impl Program {
    /// A new node: its value at the state and its coefficient k ≥ 1, as Rust expressions.
    fn node(&mut self, zero: String, step: String) -> usize {
        let j = self.nodes;
        self.nodes += 1;
        let _ = writeln!(self.zero, "    {} = {zero};", at(j, "0"));
        let _ = writeln!(self.step, "            {} = {step};", at(j, "k"));
        j
    }

    fn scalar(&mut self, k: usize, text: String) -> Val {
        let _ = writeln!(self.scalars, "    let s{k}: f64 = {text};");
        Val::Scalar(format!("s{k}"))
    }

    /// The value's text at the state (coefficient 0).
    fn value(v: &Val) -> String {
        match v {
            Val::Scalar(s) => s.clone(),
            Val::Node(n) => at(*n, "0"),
        }
    }

    /// A scalar as a node of its own (what a recurrence reading both operands needs).
    fn as_node(&mut self, v: &Val) -> usize {
        match v {
            Val::Node(n) => *n,
            Val::Scalar(s) => self.node(s.clone(), "0.0".into()),
        }
    }

    fn product(&mut self, a: usize, b: usize) -> usize {
        self.node(
            format!("{} * {}", at(a, "0"), at(b, "0")),
            format!("runtime::recur::product({}, {}, k)", from(a), from(b)),
        )
    }

    fn scale(&mut self, a: usize, by: &str) -> usize {
        self.node(
            format!("{by} * {}", at(a, "0")),
            format!("{by} * {}", at(a, "k")),
        )
    }

    /// a / b with `a_zero` the dividend's value and `a_k` its coefficient k.
    fn quotient(&mut self, a_zero: String, a_k: String, b: usize) -> usize {
        let j = self.nodes;
        self.node(
            format!("{a_zero} / {}", at(b, "0")),
            format!(
                "runtime::recur::quotient({a_k}, {}, {}, k)",
                from(b),
                own(j)
            ),
        )
    }

    fn unary(&mut self, f: &str, a: usize, recurrence: &str) -> usize {
        let j = self.nodes;
        let step = match recurrence {
            "sqrt" => format!("runtime::recur::sqrt({}, {}, k)", at(a, "k"), own(j)),
            _ => format!("runtime::recur::{recurrence}({}, {}, k)", from(a), own(j)),
        };
        self.node(format!("{}.{f}()", at(a, "0")), step)
    }

    fn sin_cos(&mut self, op: usize, a: usize) -> (usize, usize) {
        if let Some(&pair) = self.sin_cos.get(&op) {
            return pair;
        }
        let (s, c) = (self.nodes, self.nodes + 1);
        self.node(
            format!("{}.sin()", at(a, "0")),
            format!("runtime::recur::sin({}, {}, k)", from(a), from(c)),
        );
        self.node(
            format!("{}.cos()", at(a, "0")),
            format!("runtime::recur::cos({}, {}, k)", from(a), from(s)),
        );
        self.sin_cos.insert(op, (s, c));
        (s, c)
    }

    /// exp(m·ln a) for a node a and a multiplier m (an f64 text or a node).
    fn power(&mut self, a: usize, m: &Val) -> usize {
        let l = self.unary("ln", a, "ln");
        let e = match m {
            Val::Scalar(s) => self.scale(l, s),
            Val::Node(n) => self.product(*n, l),
        };
        self.unary("exp", e, "exp")
    }

    fn square_sum(&mut self, x: usize, y: usize, one: bool) -> usize {
        let (xx, yy) = (
            self.product(x, x),
            if one { None } else { Some(self.product(y, y)) },
        );
        match yy {
            Some(yy) => self.node(
                format!("{} + {}", at(xx, "0"), at(yy, "0")),
                format!("{} + {}", at(xx, "k"), at(yy, "k")),
            ),
            None => self.node(format!("1.0 + {}", at(xx, "0")), at(xx, "k")),
        }
    }
}

/// The series program of `tape` (its inputs playing `inputs`), for the rates `rates` (the tape
/// output of each state component's rate): the body of `reduced_series`, which fills `out` with
/// `order + 1` rows of the state's coefficients from `x`. None where an operation has no
/// recurrence here.
pub(super) fn series_body(tape: &Tape, inputs: &[SeriesInput], rates: &[usize]) -> String {
    let ops = tape.ops();
    let mut needed = vec![false; ops.len()];
    for &r in rates {
        needed[tape.outputs()[r]] = true;
    }
    for k in (0..ops.len()).rev() {
        if needed[k] {
            for a in operands(&ops[k]) {
                needed[a] = true;
            }
        }
    }
    let mut p = Program {
        n: rates.len(),
        ..Program::default()
    };
    let mut vals: Vec<Val> = Vec::with_capacity(ops.len());
    for (k, op) in ops.iter().enumerate() {
        let v = if needed[k] {
            value(&mut p, k, op, &vals, inputs)
        } else {
            Val::Scalar("f64::NAN".into())
        };
        vals.push(v);
    }
    let n = rates.len();
    let mut o = String::new();
    let _ = writeln!(o, "    let w = order + 1;");
    let _ = writeln!(o, "    out.clear();\n    out.resize(w * {n}, 0.0);");
    let _ = writeln!(o, "    out[..{n}].copy_from_slice(&x[..{n}]);");
    o += &p.scalars;
    let _ = writeln!(o, "    let mut c = vec![0.0; {} * w];", p.nodes.max(1));
    o += &p.zero;
    let mut rows = String::new();
    for (i, &r) in rates.iter().enumerate() {
        match &vals[tape.outputs()[r]] {
            Val::Node(j) => {
                let _ = writeln!(
                    rows,
                    "        out[(k + 1) * {n} + {i}] = {} / (k + 1) as f64;",
                    at(*j, "k")
                );
            }
            Val::Scalar(s) => {
                let _ = writeln!(o, "    if order > 0 {{ out[{n} + {i}] = {s}; }}");
            }
        }
    }
    let _ = writeln!(o, "    for k in 0..order {{\n        if k > 0 {{");
    o += &p.step;
    let _ = writeln!(o, "        }}");
    o += &rows;
    let _ = writeln!(o, "    }}");
    o
}

/// The operands of an operation.
fn operands(op: &Op) -> Vec<usize> {
    match op {
        Op::Input(_) | Op::Const(_) => vec![],
        Op::Add(v) | Op::Mul(v) => v.clone(),
        Op::Neg(a) | Op::PowI(a, _) | Op::Call(_, a) => vec![*a],
        Op::Div(a, b) | Op::PowF(a, b) | Op::Atan2(a, b) => vec![*a, *b],
    }
}

/// The value of operation `k`.
fn value(p: &mut Program, k: usize, op: &Op, vals: &[Val], inputs: &[SeriesInput]) -> Val {
    let all_scalar = operands(op)
        .iter()
        .all(|&a| matches!(vals[a], Val::Scalar(_)));
    if let Op::Input(s) = op {
        return match &inputs[*s] {
            SeriesInput::State(i) => {
                let step = format!("out[k * {} + {i}]", p.n);
                Val::Node(p.node(format!("x[{i}]"), step))
            }
            SeriesInput::Fixed(text) => p.scalar(k, text.clone()),
        };
    }
    if all_scalar {
        return p.scalar(k, scalar_text(op, vals));
    }
    let v = |a: &usize| &vals[*a];
    Val::Node(match op {
        Op::Add(list) => sum(p, list, vals),
        Op::Mul(list) => product(p, list, vals),
        Op::Neg(a) => {
            let a = p.as_node(v(a));
            p.node(format!("-{}", at(a, "0")), format!("-{}", at(a, "k")))
        }
        Op::Div(a, b) => match (v(a), v(b)) {
            (Val::Node(a), Val::Scalar(s)) => {
                let (a, r) = (*a, format!("(1.0 / {s})"));
                p.scale(a, &r)
            }
            (Val::Scalar(s), Val::Node(b)) => p.quotient(s.clone(), "0.0".into(), *b),
            (Val::Node(a), Val::Node(b)) => p.quotient(at(*a, "0"), at(*a, "k"), *b),
            (Val::Scalar(_), Val::Scalar(_)) => unreachable!("scalar above"),
        },
        Op::PowI(a, e) => {
            let a = p.as_node(v(a));
            integer_power(p, a, *e)
        }
        Op::PowF(a, b) => match v(a) {
            Val::Node(a) => {
                let m = v(b).clone();
                p.power(*a, &m)
            }
            // c^b = exp(b ln c)
            Val::Scalar(s) => {
                let b = p.as_node(v(b));
                let m = format!("{s}.ln()");
                let e = p.scale(b, &m);
                p.unary("exp", e, "exp")
            }
        },
        Op::Call(f, a) => {
            let a_node = p.as_node(v(a));
            call(p, *f, *a, a_node)
        }
        Op::Atan2(y, x) => {
            let (y, x) = (p.as_node(v(y)), p.as_node(v(x)));
            let r = p.square_sum(x, y, false);
            let j = p.nodes;
            p.node(
                format!("{}.atan2({})", at(y, "0"), at(x, "0")),
                format!(
                    "runtime::recur::atan2({}, {}, {}, {}, k)",
                    from(y),
                    from(x),
                    from(r),
                    own(j)
                ),
            )
        }
        Op::Input(_) | Op::Const(_) => unreachable!("scalar above"),
    })
}

fn sum(p: &mut Program, list: &[usize], vals: &[Val]) -> usize {
    let (mut zero, mut step) = (Vec::new(), Vec::new());
    for &a in list {
        zero.push(Program::value(&vals[a]));
        if let Val::Node(n) = vals[a] {
            step.push(at(n, "k"));
        }
    }
    p.node(zero.join(" + "), step.join(" + "))
}

fn product(p: &mut Program, list: &[usize], vals: &[Val]) -> usize {
    let scalars: Vec<String> = (list.iter())
        .filter_map(|&a| match &vals[a] {
            Val::Scalar(s) => Some(s.clone()),
            Val::Node(_) => None,
        })
        .collect();
    let nodes: Vec<usize> = (list.iter())
        .filter_map(|&a| match vals[a] {
            Val::Node(n) => Some(n),
            Val::Scalar(_) => None,
        })
        .collect();
    let mut acc = nodes[0];
    for &b in &nodes[1..] {
        acc = p.product(acc, b);
    }
    if scalars.is_empty() {
        acc
    } else {
        let by = format!("({})", scalars.join(" * "));
        p.scale(acc, &by)
    }
}

/// a^e by squaring (a quotient for a negative e).
fn integer_power(p: &mut Program, a: usize, e: i32) -> usize {
    if e == 0 {
        return p.node("1.0".into(), "0.0".into());
    }
    let (mut result, mut base, mut n) = (None, a, e.unsigned_abs());
    while n > 0 {
        if n & 1 == 1 {
            result = Some(match result {
                None => base,
                Some(r) => p.product(r, base),
            });
        }
        n >>= 1;
        if n > 0 {
            base = p.product(base, base);
        }
    }
    let positive = result.expect("e ≠ 0");
    if e < 0 {
        p.quotient("1.0".into(), "0.0".into(), positive)
    } else {
        positive
    }
}

fn call(p: &mut Program, f: Func, op: usize, a: usize) -> usize {
    match f {
        Func::Sin => p.sin_cos(op, a).0,
        Func::Cos => p.sin_cos(op, a).1,
        Func::Tan => {
            let (s, c) = p.sin_cos(op, a);
            p.quotient(at(s, "0"), at(s, "k"), c)
        }
        Func::Sqrt => p.unary("sqrt", a, "sqrt"),
        Func::Exp => p.unary("exp", a, "exp"),
        Func::Log => p.unary("ln", a, "ln"),
        Func::Atan => {
            let r = p.square_sum(a, a, true);
            let j = p.nodes;
            p.node(
                format!("{}.atan()", at(a, "0")),
                format!(
                    "runtime::recur::atan({}, {}, {}, k)",
                    from(a),
                    from(r),
                    own(j)
                ),
            )
        }
    }
}

/// An operation of f64 operands as an f64 expression.
fn scalar_text(op: &Op, vals: &[Val]) -> String {
    let s = |a: &usize| Program::value(&vals[*a]);
    match op {
        Op::Input(_) => unreachable!("inputs are handled first"),
        Op::Const(r) => lit(hamel_expr::Expr::rational_to_f64(r)),
        Op::Add(v) => format!("({})", v.iter().map(s).collect::<Vec<_>>().join(" + ")),
        Op::Mul(v) => format!("({})", v.iter().map(s).collect::<Vec<_>>().join(" * ")),
        Op::Neg(a) => format!("(-{})", s(a)),
        Op::Div(a, b) => format!("({} / {})", s(a), s(b)),
        Op::PowI(a, n) => format!("{}.powi({n})", s(a)),
        Op::PowF(a, b) => format!("{}.powf({})", s(a), s(b)),
        Op::Call(f, a) => {
            let m = match f {
                Func::Sin => "sin",
                Func::Cos => "cos",
                Func::Tan => "tan",
                Func::Sqrt => "sqrt",
                Func::Exp => "exp",
                Func::Log => "ln",
                Func::Atan => "atan",
            };
            format!("{}.{m}()", s(a))
        }
        Op::Atan2(y, x) => format!("{}.atan2({})", s(y), s(x)),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Parameter-only operations are f64 lets, computed once; an operation with one becomes
    /// the cheaper node (a scale); sin and cos of one argument are one pair of nodes; the
    /// unused output costs nothing.
    #[test]
    fn the_series_program_folds_the_parameters_and_pairs_sin_with_cos() {
        let exprs: Vec<hamel_expr::Expr> = [
            "m*g*sin(a)*b",
            "cos(a)/(m*g) + sqrt(1 + b^2)",
            "atan2(a, b)*exp(m) - b^3",
        ]
        .iter()
        .map(|s| hamel_expr::parse(s).unwrap().expr)
        .collect();
        let inputs: Vec<String> = ["a", "m", "g", "b"].map(String::from).to_vec();
        let tape = Tape::compile(&exprs.iter().collect::<Vec<_>>(), &inputs).unwrap();
        let roles = [
            SeriesInput::State(0),
            SeriesInput::Fixed("p.m".into()),
            SeriesInput::Fixed("p.g".into()),
            SeriesInput::State(1),
        ];
        let body = series_body(&tape, &roles, &[0, 1]);
        assert_eq!(body.matches(".sin()").count(), 1, "{body}");
        assert_eq!(body.matches(".cos()").count(), 1, "{body}");
        assert!(body.contains("let s0: f64 = p.m;"), "{body}");
        assert!(
            body.contains("= (s0 * s1) * c[4 * w + k];"),
            "a scale: {body}"
        );
        assert!(
            !body.contains("atan2"),
            "the third output is not a rate: {body}"
        );
        assert!(body.contains("runtime::recur::sqrt"), "{body}");
    }
}
