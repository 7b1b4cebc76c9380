//! A [`Tape`] as plain data, for files ([`TapeData`]): what a study exported by `hamel
//! linearize --export` carries to a process that has no computer algebra. Reading one back checks
//! every instruction (operands before their use, outputs and inputs in range, exact constants,
//! known functions), so a damaged file is an error, never a panic.

use serde::{Deserialize, Serialize};

use crate::ast::{Func, Rational};
use crate::tape::{Op, Tape, TapeError};

/// One instruction as data: constants as exact `p/q` text, functions by name.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum OpData {
    /// Input slot.
    Input(usize),
    /// Exact constant, `p` or `p/q`.
    Const(String),
    /// Sum.
    Add(Vec<usize>),
    /// Product.
    Mul(Vec<usize>),
    /// Negation.
    Neg(usize),
    /// Quotient.
    Div(usize, usize),
    /// Integer power.
    PowI(usize, i32),
    /// Real power.
    PowF(usize, usize),
    /// Built-in function, by name.
    Call(String, usize),
    /// atan2(y, x).
    Atan2(usize, usize),
}

/// A tape as data.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct TapeData {
    /// Input names, in slot order.
    pub inputs: Vec<String>,
    /// Instructions.
    pub ops: Vec<OpData>,
    /// The instructions whose values are the outputs.
    pub outputs: Vec<usize>,
}

impl Tape {
    /// The tape as data.
    pub fn to_data(&self) -> TapeData {
        let op = |o: &Op| match o {
            Op::Input(i) => OpData::Input(*i),
            Op::Const(r) => OpData::Const(r.to_string()),
            Op::Add(a) => OpData::Add(a.clone()),
            Op::Mul(a) => OpData::Mul(a.clone()),
            Op::Neg(a) => OpData::Neg(*a),
            Op::Div(a, b) => OpData::Div(*a, *b),
            Op::PowI(a, n) => OpData::PowI(*a, *n),
            Op::PowF(a, b) => OpData::PowF(*a, *b),
            Op::Call(f, a) => OpData::Call(f.name().to_string(), *a),
            Op::Atan2(y, x) => OpData::Atan2(*y, *x),
        };
        TapeData {
            inputs: self.inputs().to_vec(),
            ops: self.ops().iter().map(op).collect(),
            outputs: self.outputs().to_vec(),
        }
    }

    /// A tape from data, checked instruction by instruction.
    pub fn from_data(d: TapeData) -> Result<Tape, TapeError> {
        let bad = |k: usize, why: &str| TapeError::Malformed(format!("instruction {k}: {why}"));
        let mut ops = Vec::with_capacity(d.ops.len());
        for (k, o) in d.ops.into_iter().enumerate() {
            let earlier = |i: usize| {
                if i < k {
                    Ok(i)
                } else {
                    Err(bad(k, "uses a later value"))
                }
            };
            let many = |a: Vec<usize>| {
                if a.is_empty() {
                    return Err(bad(k, "has no operands"));
                }
                a.into_iter().map(earlier).collect::<Result<Vec<_>, _>>()
            };
            ops.push(match o {
                OpData::Input(i) if i < d.inputs.len() => Op::Input(i),
                OpData::Input(_) => return Err(bad(k, "reads an input that does not exist")),
                OpData::Const(t) => Op::Const(
                    t.parse::<Rational>()
                        .map_err(|_| bad(k, &format!("`{t}` is not an exact rational")))?,
                ),
                OpData::Add(a) => Op::Add(many(a)?),
                OpData::Mul(a) => Op::Mul(many(a)?),
                OpData::Neg(a) => Op::Neg(earlier(a)?),
                OpData::Div(a, b) => Op::Div(earlier(a)?, earlier(b)?),
                OpData::PowI(a, n) => Op::PowI(earlier(a)?, n),
                OpData::PowF(a, b) => Op::PowF(earlier(a)?, earlier(b)?),
                OpData::Atan2(y, x) => Op::Atan2(earlier(y)?, earlier(x)?),
                OpData::Call(f, a) => Op::Call(
                    Func::from_name(&f)
                        .ok_or_else(|| bad(k, &format!("`{f}` is not a function")))?,
                    earlier(a)?,
                ),
            });
        }
        if let Some(o) = d.outputs.iter().find(|&&o| o >= ops.len()) {
            return Err(TapeError::Malformed(format!(
                "output {o} is not an instruction"
            )));
        }
        Ok(Tape::from_parts(d.inputs, ops, d.outputs))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_tape_survives_its_data_and_damaged_data_is_refused() {
        let e = crate::parse("sin(x)^2/3 + 5/7*y*x - sqrt(y)").unwrap().expr;
        let inputs = vec!["x".to_string(), "y".to_string()];
        let t = Tape::compile(&[&e], &inputs).unwrap();
        let d = t.to_data();
        let json = serde_json::to_string(&d).unwrap();
        let back = Tape::from_data(serde_json::from_str(&json).unwrap()).unwrap();
        assert_eq!(
            back.eval(&[0.3, 2.0]).unwrap(),
            t.eval(&[0.3, 2.0]).unwrap()
        );
        let mut later = d.clone();
        later.ops[0] = OpData::Neg(3);
        assert!(Tape::from_data(later).is_err());
        let mut empty = d.clone();
        empty.ops.push(OpData::Add(vec![]));
        assert!(Tape::from_data(empty).is_err());
        let mut out = d.clone();
        out.outputs = vec![99];
        assert!(Tape::from_data(out).is_err());
        let mut input = d;
        input.ops[0] = OpData::Input(7);
        assert!(Tape::from_data(input).is_err());
    }
}
