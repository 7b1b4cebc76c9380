//! The right-hand side as a Python function, for comparisons with Python integrators
//! (`hamel tradeoff --export-python`, read and executed by `bench/scipy_tradeoff.py`).
//!
//! The function is code of a tape and of typed inputs only; the one piece of free text, the
//! header, goes through [`crate::escape::python_comment`].

use hamel_expr::{Expr, Op, Tape};

use crate::escape;

/// Where an input of the tape comes from.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Input {
    /// Component `i` of the state vector `y`.
    State(usize),
    /// A number (a parameter's value, a dropped coordinate's reference value).
    Number(f64),
    /// The time `t` of `rhs(t, y)` (a control law's time).
    Time,
}

/// A Python float literal (non-finite values as `float("inf")` and the like).
fn float(x: f64) -> String {
    if x.is_finite() {
        format!("{x:?}")
    } else {
        format!("float({})", escape::python_str(&format!("{x}")))
    }
}

/// `tape` as a Python function `rhs(t, y)` returning a list: straight-line code, one assignment
/// per shared operation; `inputs[i]` gives the tape's input `i`. Each line of `header` becomes
/// a comment line above it. Functions are those of Python's `math` module, which the model
/// grammar names alike: the reader puts them in the namespace.
pub fn rhs_function(tape: &Tape, inputs: &[Input], header: &str) -> String {
    let outs: Vec<String> = tape.outputs().iter().map(|i| format!("t{i}")).collect();
    let mut o = function(tape, inputs, header, "rhs(t, y)");
    o += &format!("    return [{}]\n", outs.join(", "));
    o
}

/// [`rhs_function`] as `rhs_into(t, y, dy)`, writing the outputs into `dy` (the form
/// numba-compiled integrators call: `bench/numbalsoda_tradeoff.py`).
pub fn rhs_into_function(tape: &Tape, inputs: &[Input], header: &str) -> String {
    let mut o = function(tape, inputs, header, "rhs_into(t, y, dy)");
    for (k, i) in tape.outputs().iter().enumerate() {
        o += &format!("    dy[{k}] = t{i}\n");
    }
    o
}

/// The header, the signature and the straight-line body shared by both forms.
fn function(tape: &Tape, inputs: &[Input], header: &str, signature: &str) -> String {
    let mut o: String = header.lines().map(escape::python_comment).collect();
    o += &format!("def {signature}:\n");
    for (k, op) in tape.ops().iter().enumerate() {
        let join = |v: &[usize], sep: &str| {
            v.iter()
                .map(|a| format!("t{a}"))
                .collect::<Vec<_>>()
                .join(sep)
        };
        let text = match op {
            Op::Input(i) => match inputs[*i] {
                Input::State(j) => format!("y[{j}]"),
                Input::Number(x) => float(x),
                Input::Time => "t".to_string(),
            },
            Op::Const(r) => float(Expr::rational_to_f64(r)),
            Op::Add(v) => join(v, " + "),
            Op::Mul(v) => join(v, " * "),
            Op::Neg(a) => format!("-t{a}"),
            Op::Div(a, b) => format!("t{a} / t{b}"),
            Op::PowI(a, n) => format!("t{a} ** {n}"),
            Op::PowF(a, b) => format!("t{a} ** t{b}"),
            Op::Call(f, a) => format!("{}(t{a})", f.name()),
            Op::Atan2(y, x) => format!("atan2(t{y}, t{x})"),
        };
        o += &format!("    t{k} = {text}\n");
    }
    o
}
