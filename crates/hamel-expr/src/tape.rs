//! Compiled expressions: a straight-line program ("tape") with common subexpressions shared.
//!
//! Compiling a set of expressions hash-conses every subtree, so a term that occurs in many
//! outputs (sin θ, δ, a shared factor) is computed once; names are resolved to input slots once.
//! The tape evaluates over any [`Scalar`] and is also what the code generator prints as Rust.

use std::collections::HashMap;

use crate::ast::{Expr, Func, Rational};
use crate::eval::EvalError;
use hamel_runtime::Scalar;

/// One instruction; operands are indices of earlier instructions.
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub enum Op {
    /// Input slot.
    Input(usize),
    /// Exact constant.
    Const(Rational),
    /// Sum of the operands.
    Add(Vec<usize>),
    /// Product of the operands.
    Mul(Vec<usize>),
    /// Negation.
    Neg(usize),
    /// Quotient.
    Div(usize, usize),
    /// Integer power.
    PowI(usize, i32),
    /// Real power of a positive base.
    PowF(usize, usize),
    /// Built-in function.
    Call(Func, usize),
    /// atan2(y, x), operands (y, x).
    Atan2(usize, usize),
}

impl Op {
    /// `mark` each operand (an earlier instruction's index), in order.
    pub fn for_each_operand(&self, mut mark: impl FnMut(usize)) {
        match self {
            Op::Input(_) | Op::Const(_) => {}
            Op::Add(v) | Op::Mul(v) => v.iter().for_each(|&a| mark(a)),
            Op::Neg(a) | Op::PowI(a, _) | Op::Call(_, a) => mark(*a),
            Op::Div(a, b) | Op::PowF(a, b) | Op::Atan2(a, b) => {
                mark(*a);
                mark(*b);
            }
        }
    }

    /// The operands, in order ([`Op::for_each_operand`]).
    pub fn operands(&self) -> Vec<usize> {
        let mut out = Vec::new();
        self.for_each_operand(|a| out.push(a));
        out
    }

    /// Arithmetic operations of this instruction: an n-ary sum or product counts n − 1, an
    /// integer power its multiplications by squaring. With `varying` (per instruction, see
    /// [`Tape::varying`]), the fixed operands of a sum or product count as one, combined first.
    fn cost(&self, varying: Option<&[bool]>) -> usize {
        match self {
            Op::Input(_) | Op::Const(_) => 0,
            Op::Add(a) | Op::Mul(a) => match varying {
                None => a.len().saturating_sub(1),
                Some(v) => {
                    let n = a.iter().filter(|&&k| v[k]).count();
                    (n + usize::from(n < a.len())).saturating_sub(1)
                }
            },
            Op::PowI(_, n) => (n.unsigned_abs() as usize).max(2).ilog2() as usize + 1,
            _ => 1,
        }
    }
}

/// A compiled set of expressions.
#[derive(Clone, Debug)]
pub struct Tape {
    inputs: Vec<String>,
    ops: Vec<Op>,
    outputs: Vec<usize>,
}

/// Instructions with each one kept once: pushing an instruction already there returns its
/// index (common subexpressions shared). Used by compilation and by [`crate::trace`].
#[derive(Default)]
pub(crate) struct Interned {
    pub(crate) ops: Vec<Op>,
    index: HashMap<Op, usize>,
}

impl Interned {
    /// The index of `op`, pushed if new.
    pub(crate) fn push(&mut self, op: Op) -> usize {
        if let Some(&i) = self.index.get(&op) {
            return i;
        }
        self.ops.push(op.clone());
        self.index.insert(op, self.ops.len() - 1);
        self.ops.len() - 1
    }
}

struct Builder<'a> {
    slots: HashMap<&'a str, usize>,
    ops: Interned,
}

impl Builder<'_> {
    fn push(&mut self, op: Op) -> usize {
        self.ops.push(op)
    }

    fn input(&mut self, name: &str) -> Result<usize, TapeError> {
        let slot = *self
            .slots
            .get(name)
            .ok_or_else(|| TapeError::UnknownInput(name.to_string()))?;
        Ok(self.push(Op::Input(slot)))
    }

    fn expr(&mut self, e: &Expr) -> Result<usize, TapeError> {
        Ok(match e {
            Expr::Num(r) => self.push(Op::Const(r.clone())),
            Expr::Sym(n) => self.input(n)?,
            Expr::Der(q) => self.input(&format!("der({q})"))?,
            Expr::Free { .. } => self.input(&e.to_string())?,
            Expr::Add(v) => {
                let mut args = v
                    .iter()
                    .map(|t| self.expr(t))
                    .collect::<Result<Vec<_>, _>>()?;
                args.sort_unstable();
                self.push(Op::Add(args))
            }
            Expr::Mul(v) => {
                let mut args = v
                    .iter()
                    .map(|t| self.expr(t))
                    .collect::<Result<Vec<_>, _>>()?;
                args.sort_unstable();
                self.push(Op::Mul(args))
            }
            Expr::Neg(x) => {
                let a = self.expr(x)?;
                self.push(Op::Neg(a))
            }
            Expr::Div(a, b) => {
                let (a, b) = (self.expr(a)?, self.expr(b)?);
                self.push(Op::Div(a, b))
            }
            Expr::Pow(b, x) => {
                let base = self.expr(b)?;
                match x.as_integer().and_then(|n| i32::try_from(n).ok()) {
                    Some(n) => self.push(Op::PowI(base, n)),
                    None => {
                        let ex = self.expr(x)?;
                        self.push(Op::PowF(base, ex))
                    }
                }
            }
            Expr::Call(f, a) => {
                let a = self.expr(a)?;
                self.push(Op::Call(*f, a))
            }
            Expr::Atan2(y, x) => {
                let (y, x) = (self.expr(y)?, self.expr(x)?);
                self.push(Op::Atan2(y, x))
            }
        })
    }
}

/// Why expressions could not be compiled to a tape.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum TapeError {
    /// An expression uses a name that is not among the inputs.
    #[error("no input named `{0}`")]
    UnknownInput(String),
    /// A tape read from data is not well formed.
    #[error("the compiled equations are damaged: {0}")]
    Malformed(String),
}

impl Tape {
    /// Compile `exprs`; `inputs` names the input slots (coordinates, parameters, `der(q)`,
    /// free functions as printed, …). A name not in `inputs` is an error.
    pub fn compile(exprs: &[&Expr], inputs: &[String]) -> Result<Tape, TapeError> {
        let mut b = Builder {
            slots: inputs
                .iter()
                .enumerate()
                .map(|(i, n)| (n.as_str(), i))
                .collect(),
            ops: Interned::default(),
        };
        let outputs = exprs
            .iter()
            .map(|e| b.expr(e))
            .collect::<Result<Vec<_>, _>>()?;
        Ok(Tape {
            inputs: inputs.to_vec(),
            ops: b.ops.ops,
            outputs,
        })
    }

    /// A tape from checked parts ([`Tape::from_data`]).
    pub(crate) fn from_parts(inputs: Vec<String>, ops: Vec<Op>, outputs: Vec<usize>) -> Tape {
        Tape {
            inputs,
            ops,
            outputs,
        }
    }

    /// Input names, in slot order.
    pub fn inputs(&self) -> &[String] {
        &self.inputs
    }

    /// The instructions.
    pub fn ops(&self) -> &[Op] {
        &self.ops
    }

    /// Instruction index of each output.
    pub fn outputs(&self) -> &[usize] {
        &self.outputs
    }

    /// Number of arithmetic operations (an n-ary sum or product counts n − 1).
    pub fn operation_count(&self) -> usize {
        self.ops.iter().map(|op| op.cost(None)).sum()
    }

    /// For each instruction, whether its value depends on an input for which `varying` holds
    /// (the state, as opposed to fixed parameters and constants).
    pub fn varying(&self, varying: impl Fn(usize) -> bool) -> Vec<bool> {
        let mut v: Vec<bool> = Vec::with_capacity(self.ops.len());
        for op in &self.ops {
            let x = match op {
                Op::Input(i) => varying(*i),
                Op::Const(_) => false,
                Op::Add(a) | Op::Mul(a) => a.iter().any(|&k| v[k]),
                Op::Neg(a) | Op::PowI(a, _) | Op::Call(_, a) => v[*a],
                Op::Div(a, b) | Op::PowF(a, b) | Op::Atan2(a, b) => v[*a] || v[*b],
            };
            v.push(x);
        }
        v
    }

    /// Operations left to do once the inputs for which `varying` fails are fixed: those of
    /// instructions depending on a varying input, where an n-ary sum or product with c ≥ 1
    /// fixed operands counts as (its varying operands) − 1 + 1 (the fixed ones are combined
    /// first; see [`Tape::varying`]). This is what a loop with fixed parameters pays once the
    /// compiler has hoisted the rest.
    pub fn varying_operation_count(&self, varying: impl Fn(usize) -> bool) -> usize {
        let v = self.varying(varying);
        self.ops
            .iter()
            .enumerate()
            .filter(|(k, _)| v[*k])
            .map(|(_, op)| op.cost(Some(&v)))
            .sum()
    }

    /// Evaluate every output. Division by zero, domain errors and non-finite values are
    /// errors, never NaN.
    pub fn eval<S: Scalar>(&self, inputs: &[S]) -> Result<Vec<S>, EvalError> {
        let mut v = Vec::with_capacity(self.ops.len());
        let mut out = vec![S::constant(0.0); self.outputs.len()];
        self.eval_into(inputs, &mut v, &mut out)?;
        Ok(out)
    }

    /// [`Tape::eval`] into caller storage: `values` holds the intermediate values (reused
    /// between calls), `out` receives the outputs.
    pub fn eval_into<S: Scalar>(
        &self,
        inputs: &[S],
        values: &mut Vec<S>,
        out: &mut [S],
    ) -> Result<(), EvalError> {
        assert_eq!(inputs.len(), self.inputs.len(), "tape input count");
        let v = values;
        v.clear();
        for op in &self.ops {
            let x = match op {
                Op::Input(i) => inputs[*i],
                Op::Const(r) => S::rational(&crate::eval::rational_parts(r)),
                Op::Add(a) => {
                    let mut acc = v[a[0]];
                    for &k in &a[1..] {
                        acc = acc + v[k];
                    }
                    acc
                }
                Op::Mul(a) => {
                    let mut acc = v[a[0]];
                    for &k in &a[1..] {
                        acc = acc * v[k];
                    }
                    acc
                }
                Op::Neg(a) => -v[*a],
                Op::Div(a, b) => {
                    if v[*b].value() == 0.0 {
                        return Err(EvalError::Domain("division by zero".into()));
                    }
                    v[*a] / v[*b]
                }
                Op::PowI(a, n) => {
                    if *n < 0 && v[*a].value() == 0.0 {
                        return Err(EvalError::Domain("zero to a negative power".into()));
                    }
                    v[*a].powi(*n)
                }
                Op::PowF(a, b) => {
                    if v[*a].value() <= 0.0 {
                        return Err(EvalError::Domain(
                            "non-integer power of a non-positive number".into(),
                        ));
                    }
                    v[*a].powf(v[*b])
                }
                Op::Call(f, a) => {
                    let x = &v[*a];
                    match f {
                        Func::Sin => x.sin(),
                        Func::Cos => x.cos(),
                        Func::Tan => {
                            let c = x.cos();
                            if c.value() == 0.0 {
                                return Err(EvalError::Domain("tan at a pole".into()));
                            }
                            x.sin() / c
                        }
                        Func::Sqrt => {
                            if x.value() < 0.0 {
                                return Err(EvalError::Domain(
                                    "square root of a negative number".into(),
                                ));
                            }
                            x.sqrt()
                        }
                        Func::Exp => x.exp(),
                        Func::Log => {
                            if x.value() <= 0.0 {
                                return Err(EvalError::Domain(
                                    "logarithm of a non-positive number".into(),
                                ));
                            }
                            x.ln()
                        }
                        Func::Atan => x.atan(),
                    }
                }
                Op::Atan2(y, x) => {
                    if v[*y].value() == 0.0 && v[*x].value() == 0.0 {
                        return Err(EvalError::Domain("atan2 of the origin (0, 0)".into()));
                    }
                    v[*y].atan2(v[*x])
                }
            };
            if !x.value().is_finite() {
                return Err(EvalError::Domain("non-finite intermediate value".into()));
            }
            v.push(x);
        }
        for (o, &i) in out.iter_mut().zip(&self.outputs) {
            *o = v[i];
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::parse;

    #[test]
    fn shares_subexpressions_and_agrees_with_the_tree() {
        let a = parse("sin(x)^2*m + sin(x)^2*l").unwrap().expr;
        let b = parse("1/(sin(x)^2 + 1)").unwrap().expr;
        let names: Vec<String> = ["x", "m", "l"].iter().map(|s| s.to_string()).collect();
        let tape = Tape::compile(&[&a, &b], &names).unwrap();
        // sin(x) and sin(x)^2 are computed once
        let sins = tape
            .ops()
            .iter()
            .filter(|o| matches!(o, Op::Call(Func::Sin, _)))
            .count();
        assert_eq!(sins, 1);
        let out = tape.eval(&[0.3, 2.0, 0.5]).unwrap();
        let env = |n: &str| match n {
            "x" => Some(0.3),
            "m" => Some(2.0),
            "l" => Some(0.5),
            _ => None,
        };
        assert_eq!(out[0], a.eval(&env).unwrap());
        assert_eq!(out[1], b.eval(&env).unwrap());
        assert!(Tape::compile(&[&a], &names[..1]).is_err());
    }

    #[test]
    fn domain_errors() {
        let e = parse("1/(x - 1)").unwrap().expr;
        let t = Tape::compile(&[&e], &["x".to_string()]).unwrap();
        assert!(t.eval(&[1.0]).is_err());
        assert!(t.eval(&[2.0]).is_ok());
    }
}
