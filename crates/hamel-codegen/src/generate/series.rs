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

use super::emit::{NOT_DEFINITE, lit};
use super::monomials::{Factor, Monomials};
use super::recurrence::{Step, at};

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

/// The program being written: the f64 lets, the coefficient-0 statements, and each node's
/// recurrence for coefficient k ≥ 1.
#[derive(Default)]
struct Program {
    scalars: String,
    zero: String,
    steps: Vec<Step>,
    nodes: usize,
    /// sin and cos nodes of an operation, once made.
    sin_cos: std::collections::HashMap<usize, (usize, usize)>,
    /// The node of each shared pair of factors ([`Monomials::pairs`]), once made.
    pairs: std::collections::HashMap<usize, usize>,
}

impl Program {
    /// A new node: its value at the state (a Rust expression) and its recurrence.
    fn node(&mut self, zero: String, step: Step) -> usize {
        let j = self.nodes;
        self.nodes += 1;
        let _ = writeln!(self.zero, "    {} = {zero};", at(j, "0"));
        self.steps.push(step);
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
            Val::Scalar(s) => self.node(s.clone(), Step::Zero),
        }
    }

    fn product(&mut self, a: usize, b: usize) -> usize {
        let step = if a == b {
            Step::Square(a)
        } else {
            Step::Product(a, b)
        };
        self.node(format!("{} * {}", at(a, "0"), at(b, "0")), step)
    }

    fn scale(&mut self, a: usize, by: &str) -> usize {
        self.node(
            format!("{by} * {}", at(a, "0")),
            Step::Scale(a, by.to_string()),
        )
    }

    /// a / b with `a_zero` the dividend's value and `a` its node (None: fixed over the step).
    fn quotient(&mut self, a_zero: String, a: Option<usize>, b: usize) -> usize {
        let own = self.nodes;
        self.node(
            format!("{a_zero} / {}", at(b, "0")),
            Step::Quotient { a, b, own },
        )
    }

    /// √a, exp a or ln a (`f`: the f64 method and the recurrence's name).
    fn unary(&mut self, f: &'static str, a: usize) -> usize {
        let own = self.nodes;
        let step = match f {
            "sqrt" => Step::Sqrt { a, own },
            _ => Step::Call { f, a, own },
        };
        self.node(format!("{}.{f}()", at(a, "0")), step)
    }

    fn sin_cos(&mut self, op: usize, a: usize) -> (usize, usize) {
        if let Some(&pair) = self.sin_cos.get(&op) {
            return pair;
        }
        let (s, c) = (self.nodes, self.nodes + 1);
        self.node(format!("{}.sin()", at(a, "0")), Step::Sin { a, cos: c });
        self.node(format!("{}.cos()", at(a, "0")), Step::Cos { a, sin: s });
        self.sin_cos.insert(op, (s, c));
        (s, c)
    }

    /// exp(m·ln a) for a node a and a multiplier m (an f64 text or a node).
    fn power(&mut self, a: usize, m: &Val) -> usize {
        let l = self.unary("ln", a);
        let e = match m {
            Val::Scalar(s) => self.scale(l, s),
            Val::Node(n) => self.product(*n, l),
        };
        self.unary("exp", e)
    }

    fn square_sum(&mut self, x: usize, y: usize, one: bool) -> usize {
        let (xx, yy) = (
            self.product(x, x),
            if one { None } else { Some(self.product(y, y)) },
        );
        match yy {
            Some(yy) => self.node(
                format!("{} + {}", at(xx, "0"), at(yy, "0")),
                Step::Sum(vec![xx, yy]),
            ),
            None => self.node(format!("1.0 + {}", at(xx, "0")), Step::Sum(vec![xx])),
        }
    }
}

/// The series program of `tape` (its inputs playing `inputs`), for the rates `rates` (the tape
/// output of each state component's rate), checking the definiteness tests `tests` (tape
/// outputs, each to be > 0) at the state: the body of `reduced_series`, which fills `out` with
/// `order + 1` rows of the state's coefficients from `x`, or returns the failed test's error
/// before any coefficient beyond 0. Tests of the parameters alone are `Prepared::new`'s.
pub(super) fn series_body(
    tape: &Tape,
    inputs: &[SeriesInput],
    rates: &[usize],
    tests: &[usize],
) -> SeriesBodies {
    let (ops, outputs) = (tape.ops(), tape.outputs());
    let varying = tape.varying(|i| matches!(inputs[i], SeriesInput::State(_)));
    let tests: Vec<usize> = (tests.iter().map(|&o| outputs[o]))
        .filter(|&op| varying[op])
        .collect();
    let rate_ops: Vec<usize> = rates.iter().map(|&r| outputs[r]).collect();
    let direct = |k: usize| ops[k].operands();
    let mono = Monomials::new(ops, &reached(ops, &rate_ops, direct), &varying, &rate_ops);
    let needed = reached(ops, &rate_ops, |k| match &ops[k] {
        Op::Mul(_) if mono.of.contains_key(&k) => mono.operands(k),
        op => op.operands(),
    });
    let for_tests = reached(ops, &tests, direct);
    let mut p = Program::default();
    let mut checks = String::new();
    let mut vals: Vec<Val> = Vec::with_capacity(ops.len());
    for (k, op) in ops.iter().enumerate() {
        let v = if needed[k] {
            value(&mut p, (k, op), &vals, inputs, &mono)
        } else if for_tests[k] {
            // an f64 at the state, from the nodes' coefficient 0
            let _ = writeln!(checks, "let z{k}: f64 = {};", zero_text(op, &vals, inputs));
            Val::Scalar(format!("z{k}"))
        } else {
            Val::Scalar("f64::NAN".into())
        };
        vals.push(v);
    }
    if !tests.is_empty() {
        let all = tests
            .iter()
            .map(|&t| format!("{} > 0.0", Program::value(&vals[t])));
        let _ = writeln!(
            checks,
            "if !({}) {{\nreturn Some(Err(runtime::cold_error(\"{NOT_DEFINITE} here\")));\n}}",
            all.collect::<Vec<_>>().join(" && ")
        );
    }
    let n = rates.len();
    let mut w = Written {
        n,
        nodes: p.nodes.max(1),
        zero: p.zero,
        checks,
        fixed_rows: String::new(),
        steps: p.steps,
        rates: Vec::new(),
    };
    for (i, &r) in rates.iter().enumerate() {
        match &vals[tape.outputs()[r]] {
            Val::Node(j) => w.rates.push((i, *j)),
            Val::Scalar(s) => {
                let _ = writeln!(w.fixed_rows, "if order > 0 {{ out[{n} + {i}] = {s}; }}");
            }
        }
    }
    SeriesBodies {
        written: format!("{}{}{}", p.scalars, unrolled(&w), looped(&w)),
        looped: format!("{}{}", p.scalars, looped(&w)),
    }
}

/// The two bodies of a series program: the same coefficients, the same bits.
pub(super) struct SeriesBodies {
    /// Orders up to [`UNROLLED_ORDER`] written out, the loop beyond: what a CPU with FMA runs.
    pub(super) written: String,
    /// The loop alone (small code): what a CPU without FMA runs, its `mul_add`s the C
    /// library's.
    pub(super) looped: String,
}

/// The operations `from` depends on, `from` included, an operation `k` reading
/// `operands(k)`.
fn reached(ops: &[Op], from: &[usize], operands: impl Fn(usize) -> Vec<usize>) -> Vec<bool> {
    let mut reached = vec![false; ops.len()];
    from.iter().for_each(|&o| reached[o] = true);
    for k in (0..ops.len()).rev() {
        if reached[k] {
            for a in operands(k) {
                reached[a] = true;
            }
        }
    }
    reached
}

/// An operation's f64 value at the state, its operands' texts at coefficient 0.
fn zero_text(op: &Op, vals: &[Val], inputs: &[SeriesInput]) -> String {
    match op {
        Op::Input(s) => match &inputs[*s] {
            SeriesInput::State(i) => format!("x[{i}]"),
            SeriesInput::Fixed(text) => text.clone(),
        },
        _ => scalar_text(op, vals),
    }
}

/// The highest order written out whole: the order at rtol = ε (`hamel_sim::taylor::order`,
/// ⌈−ln ε/2 + 1⌉ = 20); a higher one takes the loop.
const UNROLLED_ORDER: usize = 20;

/// The series program, ready to write: the coefficient-0 statements (`c[j * w + 0] = …;`), the
/// definiteness tests at the state, the rows fixed over the step, each node's recurrence, and
/// the node of each state component's rate.
struct Written {
    n: usize,
    nodes: usize,
    zero: String,
    checks: String,
    fixed_rows: String,
    steps: Vec<Step>,
    /// (component i, the node of its rate).
    rates: Vec<(usize, usize)>,
}

impl Written {
    /// The statements that start either way: `out` sized and holding the state, the
    /// coefficient-0 values, the rows fixed over the step (lines indented by `pad`).
    fn start(&self, c: &str, pad: &str) -> String {
        let n = self.n;
        let mut o = String::new();
        let _ = writeln!(o, "out.clear();\nout.resize((order + 1) * {n}, 0.0);");
        let _ = writeln!(o, "out[..{n}].copy_from_slice(&x[..{n}]);");
        let _ = writeln!(o, "let mut c = {c};");
        o += &self.zero;
        o += &self.checks;
        o += &self.fixed_rows;
        o.lines()
            .map(|l| format!("{pad}{}\n", l.trim_start()))
            .collect()
    }
}

/// Orders up to [`UNROLLED_ORDER`], every coefficient's statements written out at constant
/// indices into a fixed array (`Step::unrolled`): the same numbers as [`looped`], bit for bit.
fn unrolled(w: &Written) -> String {
    let (n, width) = (w.n, UNROLLED_ORDER + 1);
    let mut o = format!("    if order <= {UNROLLED_ORDER} {{\n        let w: usize = {width};\n");
    o += &w.start(&format!("[0.0; {} * {width}]", w.nodes), "        ");
    for r in w.steps.iter().filter_map(Step::reciprocal) {
        let _ = writeln!(o, "        {r}");
    }
    for k in 0..UNROLLED_ORDER {
        let _ = writeln!(
            o,
            "        if order <= {k} {{\n            return Some(Ok(()));\n        }}"
        );
        let _ = writeln!(
            o,
            "        // coefficient {k}: c[j * {width} + {k}] for node j"
        );
        if k > 0 {
            for (j, step) in w.steps.iter().enumerate() {
                let at = j * width + k;
                let _ = writeln!(o, "        c[{at}] = {};", step.unrolled(n, k, width));
            }
        }
        for &(i, j) in &w.rates {
            let (row, at) = ((k + 1) * n + i, j * width + k);
            let _ = writeln!(
                o,
                "        out[{row}] = c[{at}] * {};",
                lit(1.0 / (k + 1) as f64)
            );
        }
    }
    o + "        return Some(Ok(()));\n    }\n"
}

/// Any order: the loop over k, each recurrence a call of `runtime::recur` (`Step::looped`).
fn looped(w: &Written) -> String {
    let n = w.n;
    let mut o = "    let w = order + 1;\n".to_string();
    o += &w.start(&format!("vec![0.0; {} * w]", w.nodes), "    ");
    o += "    for k in 0..order {\n        if k > 0 {\n";
    for (j, step) in w.steps.iter().enumerate() {
        let _ = writeln!(o, "            {} = {};", at(j, "k"), step.looped(n));
    }
    o += "        }\n";
    for &(i, j) in &w.rates {
        let _ = writeln!(
            o,
            "        out[(k + 1) * {n} + {i}] = {} * runtime::recur::inverse(k + 1);",
            at(j, "k")
        );
    }
    o + "    }\n"
}

/// The value of operation `k` (a product with its shared pairs, `mono`).
fn value(
    p: &mut Program,
    (k, op): (usize, &Op),
    vals: &[Val],
    inputs: &[SeriesInput],
    mono: &Monomials,
) -> Val {
    let all_scalar = op
        .operands()
        .iter()
        .all(|&a| matches!(vals[a], Val::Scalar(_)));
    if let Op::Input(s) = op {
        return match &inputs[*s] {
            SeriesInput::State(i) => Val::Node(p.node(format!("x[{i}]"), Step::State(*i))),
            SeriesInput::Fixed(text) => p.scalar(k, text.clone()),
        };
    }
    // (before the test for scalars: a split power is no operand of its own)
    if let Some(factors) = mono.of.get(&k) {
        let nodes = (factors.iter())
            .map(|&f| factor(p, f, vals, mono))
            .collect();
        return Val::Node(chain(p, nodes, scalars(&mono.fixed[&k], vals)));
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
            p.node(format!("-{}", at(a, "0")), Step::Neg(a))
        }
        Op::Div(a, b) => match (v(a), v(b)) {
            (Val::Node(a), Val::Scalar(s)) => {
                let (a, r) = (*a, format!("(1.0 / {s})"));
                p.scale(a, &r)
            }
            (Val::Scalar(s), Val::Node(b)) => p.quotient(s.clone(), None, *b),
            (Val::Node(a), Val::Node(b)) => p.quotient(at(*a, "0"), Some(*a), *b),
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
                p.unary("exp", e)
            }
        },
        Op::Call(f, a) => {
            let a_node = p.as_node(v(a));
            call(p, *f, *a, a_node)
        }
        Op::Atan2(y, x) => {
            let (y, x) = (p.as_node(v(y)), p.as_node(v(x)));
            let r = p.square_sum(x, y, false);
            let own = p.nodes;
            p.node(
                format!("{}.atan2({})", at(y, "0"), at(x, "0")),
                Step::Atan2 { y, x, r, own },
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
            step.push(n);
        }
    }
    p.node(zero.join(" + "), Step::Sum(step))
}

/// The fixed operands of a product, as f64 texts.
fn scalars(list: &[usize], vals: &[Val]) -> Vec<String> {
    (list.iter())
        .filter_map(|&a| match &vals[a] {
            Val::Scalar(s) => Some(s.clone()),
            Val::Node(_) => None,
        })
        .collect()
}

fn product(p: &mut Program, list: &[usize], vals: &[Val]) -> usize {
    let nodes: Vec<usize> = (list.iter())
        .filter_map(|&a| match vals[a] {
            Val::Node(n) => Some(n),
            Val::Scalar(_) => None,
        })
        .collect();
    chain(p, nodes, scalars(list, vals))
}

/// The node of a factor of a shared product: an operation's, or its pair's (made once).
fn factor(p: &mut Program, f: Factor, vals: &[Val], mono: &Monomials) -> usize {
    match f {
        Factor::Op(a) => match vals[a] {
            Val::Node(n) => n,
            Val::Scalar(_) => unreachable!("a factor depends on the state"),
        },
        Factor::Pair(i) => {
            if let Some(&n) = p.pairs.get(&i) {
                return n;
            }
            let (x, y) = mono.pairs[i];
            let (x, y) = (factor(p, x, vals, mono), factor(p, y, vals, mono));
            let n = p.product(x, y);
            p.pairs.insert(i, n);
            n
        }
    }
}

/// The product of nodes, one after another, scaled by the fixed factors.
fn chain(p: &mut Program, nodes: Vec<usize>, scalars: Vec<String>) -> usize {
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
        return p.node("1.0".into(), Step::Zero);
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
        p.quotient("1.0".into(), None, positive)
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
            p.quotient(at(s, "0"), Some(s), c)
        }
        Func::Sqrt => p.unary("sqrt", a),
        Func::Exp => p.unary("exp", a),
        Func::Log => p.unary("ln", a),
        Func::Atan => {
            let r = p.square_sum(a, a, true);
            let own = p.nodes;
            p.node(format!("{}.atan()", at(a, "0")), Step::Atan { a, r, own })
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
        let body = series_body(&tape, &roles, &[0, 1], &[]).written;
        // Twice: once in the orders written out, once in the loop.
        assert_eq!(body.matches(".sin()").count(), 2, "{body}");
        assert_eq!(body.matches(".cos()").count(), 2, "{body}");
        assert_eq!(body.matches("if order <= 20 {").count(), 1, "{body}");
        assert_eq!(body.matches("for k in 0..order {").count(), 1, "{body}");
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
