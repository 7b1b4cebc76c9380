//! A traced tape written as data for the Taylor method (issue 63): the nodes of
//! `hamel_runtime::taylor_by_program`, which runs the series recurrences over them at any
//! state. What a scene core with a trace of its start (the Whipple bicycle) computes its series
//! from, instead of tracing the structured evaluation at every step.
//!
//! Written as instructions (every recurrence inlined, as `generate/series.rs` does for the
//! closed forms) the bicycle's five thousand operations made a function that rustc could not
//! compile within the machine's memory; as data the program is one static array, and the
//! recurrences are the runtime's loop (compiled for FMA where the CPU has it).
//!
//! The tape's operations become the nodes `hamel_runtime::Traced` records for the same
//! arithmetic: an n-ary sum or product a chain of binary ones, an operation with a constant
//! operand the cheaper node it is (a shift, a scale, c/b), constants folded, integer powers by
//! squaring, sin and cos of one argument one pair, tan as their quotient, a real power
//! exp(b ln a), atan with 1 + a², atan2 with x² + y². The first nodes are the tape's inputs,
//! in order.

use std::collections::HashMap;

use hamel_expr::{Func, Op, Tape};

use super::emit::lit;

/// A value of the program: a constant (folded) or a node.
#[derive(Clone, Copy, Debug)]
enum V {
    C(f64),
    N(u32),
}

/// The nodes written so far (Rust expressions of `runtime::SeriesNode`), and each argument's
/// sine–cosine pair once made.
#[derive(Default)]
struct Builder {
    nodes: Vec<String>,
    pairs: HashMap<u32, (u32, u32)>,
}

impl Builder {
    fn push(&mut self, node: String) -> V {
        self.nodes.push(format!("runtime::SeriesNode::{node}"));
        V::N((self.nodes.len() - 1) as u32)
    }

    fn add(&mut self, a: V, b: V) -> V {
        match (a, b) {
            (V::C(x), V::C(y)) => V::C(x + y),
            (V::N(n), V::C(c)) | (V::C(c), V::N(n)) => {
                self.push(format!("AddConst({n}, {})", lit(c)))
            }
            (V::N(x), V::N(y)) => self.push(format!("Add({x}, {y})")),
        }
    }

    fn mul(&mut self, a: V, b: V) -> V {
        match (a, b) {
            (V::C(x), V::C(y)) => V::C(x * y),
            (V::N(n), V::C(c)) | (V::C(c), V::N(n)) => self.push(format!("Scale({n}, {})", lit(c))),
            (V::N(x), V::N(y)) => self.push(format!("Mul({x}, {y})")),
        }
    }

    fn div(&mut self, a: V, b: V) -> V {
        match (a, b) {
            (V::C(x), V::C(y)) => V::C(x / y),
            (V::N(n), V::C(c)) => self.push(format!("Scale({n}, {})", lit(1.0 / c))),
            (V::C(c), V::N(n)) => self.push(format!("ConstDiv({n}, {})", lit(c))),
            (V::N(x), V::N(y)) => self.push(format!("Div({x}, {y})")),
        }
    }

    /// A unary function: `f` folds a constant, `node` names the node.
    fn unary(&mut self, a: V, f: fn(f64) -> f64, node: &str) -> V {
        match a {
            V::C(x) => V::C(f(x)),
            V::N(n) => self.push(format!("{node}({n})")),
        }
    }

    fn sin_cos(&mut self, a: V) -> (V, V) {
        let n = match a {
            V::C(x) => return (V::C(x.sin()), V::C(x.cos())),
            V::N(n) => n,
        };
        if let Some(&(s, c)) = self.pairs.get(&n) {
            return (V::N(s), V::N(c));
        }
        let s = self.nodes.len() as u32;
        self.push(format!("Sin({n})"));
        self.push(format!("Cos({n}, {s})"));
        self.pairs.insert(n, (s, s + 1));
        (V::N(s), V::N(s + 1))
    }

    /// a^e by squaring (1/a^|e| for a negative e), as `Traced::powi`.
    fn powi(&mut self, a: V, e: i32) -> V {
        if let V::C(x) = a {
            return V::C(x.powi(e));
        }
        let result = hamel_expr::power_by_squaring(a, e.unsigned_abs(), |x, y| self.mul(x, y));
        match result {
            None => V::C(1.0),
            Some(r) if e < 0 => self.div(V::C(1.0), r),
            Some(r) => r,
        }
    }

    fn call(&mut self, f: Func, a: V) -> V {
        match f {
            Func::Sin => self.sin_cos(a).0,
            Func::Cos => self.sin_cos(a).1,
            Func::Tan => {
                let (s, c) = self.sin_cos(a);
                self.div(s, c)
            }
            Func::Sqrt => self.unary(a, f64::sqrt, "Sqrt"),
            Func::Exp => self.unary(a, f64::exp, "Exp"),
            Func::Log => self.unary(a, f64::ln, "Ln"),
            Func::Atan => match a {
                V::C(x) => V::C(x.atan()),
                V::N(n) => {
                    let square = self.mul(a, a);
                    let V::N(r) = self.add(square, V::C(1.0)) else {
                        unreachable!("a node plus a constant is a node")
                    };
                    self.push(format!("Atan({n}, {r})"))
                }
            },
        }
    }

    fn atan2(&mut self, y: V, x: V) -> V {
        if let (V::C(y), V::C(x)) = (y, x) {
            return V::C(y.atan2(x));
        }
        // a constant operand as a node of its own: the recurrence reads both series
        let mut as_node = |v: V| match v {
            V::C(c) => self.push(format!("Const({})", lit(c))),
            node => node,
        };
        let (y, x) = (as_node(y), as_node(x));
        let (xx, yy) = (self.mul(x, x), self.mul(y, y));
        let (V::N(yn), V::N(xn), V::N(r)) = (y, x, self.add(xx, yy)) else {
            unreachable!("nodes")
        };
        self.push(format!("Atan2({yn}, {xn}, {r})"))
    }

    fn op(&mut self, op: &Op, vals: &[V]) -> V {
        let v = |a: &usize| vals[*a];
        match op {
            Op::Input(_) => unreachable!("the inputs are the first nodes"),
            Op::Const(r) => V::C(hamel_expr::Expr::rational_to_f64(r)),
            Op::Add(list) => (list[1..].iter()).fold(v(&list[0]), |acc, a| self.add(acc, v(a))),
            Op::Mul(list) => (list[1..].iter()).fold(v(&list[0]), |acc, a| self.mul(acc, v(a))),
            Op::Neg(a) => match v(a) {
                V::C(x) => V::C(-x),
                V::N(n) => self.push(format!("Neg({n})")),
            },
            Op::Div(a, b) => self.div(v(a), v(b)),
            Op::PowI(a, e) => self.powi(v(a), *e),
            Op::PowF(a, b) => {
                if let (V::C(x), V::C(y)) = (v(a), v(b)) {
                    return V::C(x.powf(y));
                }
                let ln = self.unary(v(a), f64::ln, "Ln");
                let product = self.mul(ln, v(b));
                self.unary(product, f64::exp, "Exp")
            }
            Op::Call(f, a) => self.call(*f, v(a)),
            Op::Atan2(y, x) => self.atan2(v(y), v(x)),
        }
    }
}

/// The tape as a program for `runtime::taylor_by_program`: the statics `TRACED_PROGRAM` (its
/// nodes, the tape's inputs first) and `TRACED_OUTPUTS` (the first `outputs` of the tape's
/// outputs: nodes, or constants), with their documentation.
pub(super) fn statics(tape: &Tape, outputs: usize) -> String {
    let mut b = Builder::default();
    for i in 0..tape.inputs().len() {
        b.push(format!("Input({i})"));
    }
    let mut vals: Vec<V> = Vec::with_capacity(tape.ops().len());
    for op in tape.ops() {
        let value = match op {
            Op::Input(i) => V::N(*i as u32),
            op => b.op(op, &vals),
        };
        vals.push(value);
    }
    let rates: Vec<String> = (tape.outputs()[..outputs].iter())
        .map(|&o| match vals[o] {
            V::N(n) => format!("runtime::Traced::node({n})"),
            V::C(c) => format!("runtime::Traced::fixed({})", lit(c)),
        })
        .collect();
    format!(
        "/// The trace as data for the Taylor method's recurrences (`runtime::taylor_by_program`): its\n\
         /// nodes, the reduced state's inputs first.\n\
         static TRACED_PROGRAM: [runtime::SeriesNode; {}] = [\n    {},\n];\n\n\
         /// The rates of [`reduced_series`]'s state among [`TRACED_PROGRAM`]'s nodes.\n\
         static TRACED_OUTPUTS: [runtime::Traced; {}] = [{}];\n",
        b.nodes.len(),
        b.nodes.join(",\n    "),
        rates.len(),
        rates.join(", ")
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Constants fold, an operation with one becomes a shift or a scale, sin and cos of one
    /// argument are one pair, and the inputs come first.
    #[test]
    fn a_tape_becomes_the_nodes_a_trace_records() {
        let exprs: Vec<hamel_expr::Expr> = ["2*sin(a)*cos(a) + b/4", "atan2(b, 3) - b^3"]
            .iter()
            .map(|s| hamel_expr::parse(s).unwrap().expr)
            .collect();
        let inputs: Vec<String> = ["a", "b"].map(String::from).to_vec();
        let tape = Tape::compile(&exprs.iter().collect::<Vec<_>>(), &inputs).unwrap();
        let text = statics(&tape, 2);
        assert!(text.starts_with("/// The trace as data"), "{text}");
        assert!(
            text.contains(
                "[\n    runtime::SeriesNode::Input(0),\n    runtime::SeriesNode::Input(1),"
            ),
            "{text}"
        );
        assert_eq!(text.matches("Sin(0)").count(), 1, "{text}");
        assert!(text.contains("Cos(0, 2)"), "{text}");
        assert!(text.contains("Scale(1, 0.25)"), "{text}");
        assert!(text.contains("Const(3.0)"), "{text}");
        assert!(text.contains("Atan2(1, "), "{text}");
        assert!(
            text.contains("static TRACED_OUTPUTS: [runtime::Traced; 2]"),
            "{text}"
        );
    }
}
