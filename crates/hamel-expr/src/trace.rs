//! Tracing: a computation generic over [`Scalar`] (a tape's evaluation, the structured
//! right-hand side's LU and contractions) run once on [`Traced`] numbers, which record every
//! operation into a new [`Tape`].
//!
//! A traced number carries its value at the tracing point, so that what the computation decides
//! by value (a pivot, a branch) is decided there and the tape follows that path: the tape is the
//! computation *along the path taken at the tracing point*, straight-line code that
//! `hamel tradeoff --export-python` writes out. Operations whose operands are all constants are
//! folded in f64, as the traced computation would compute them; multiplications by 0 and ±1,
//! additions of 0 and divisions by 1 are not recorded (exact for finite values, up to the sign
//! of a zero). Common subexpressions are shared, and operations no output needs are dropped.
//!
//! Tracing nests: each [`trace`] records into its own tape; a number of another trace (or of
//! none) counts as the constant of its value.

use std::cell::RefCell;
use std::collections::HashMap;
use std::ops::{Add, Div, Mul, Neg, Sub};

use crate::ast::Func;
use crate::tape::{Interned, Op, Tape};
use hamel_runtime::Scalar;

/// A number recorded on the innermost running [`trace`]: its value at the tracing point and,
/// unless it is a constant, the instruction that computes it.
#[derive(Clone, Copy, Debug)]
pub struct Traced {
    value: f64,
    /// The instruction and the trace it belongs to; `None` for a constant.
    at: Option<(u32, u32)>,
}

struct Recorder {
    id: u32,
    ops: Interned,
    constants: HashMap<u64, usize>,
    /// A constant that is not a finite number was needed (the tape cannot hold it).
    non_finite: bool,
    /// The decisions taken by value ([`Scalar::decided`]), their operands as instructions.
    guards: Vec<Guard>,
    /// A decision was taken that no guard states ([`Scalar::undecidable`]).
    undecidable: bool,
}

/// A decision the traced computation took by value: the tape computes what the computation
/// would wherever |`chosen`| > `factor` · max |`others`| (the max of none is 0). `chosen` and
/// `others` index [`Guarded::tape`]'s outputs.
#[derive(Clone, Debug, PartialEq)]
pub struct Guard {
    /// The output whose magnitude must stay above the others'.
    pub chosen: usize,
    /// The multiple of the others' largest magnitude it must exceed.
    pub factor: f64,
    /// The outputs it is compared with.
    pub others: Vec<usize>,
}

/// A trace with the decisions it took by value ([`trace_guarded`]).
#[derive(Clone, Debug)]
pub struct Guarded {
    /// The tape: the computation's outputs (the first [`Guarded::outputs`]), then the values
    /// the guards compare.
    pub tape: Tape,
    /// How many of the tape's outputs are the computation's.
    pub outputs: usize,
    /// The decisions, each a condition on the tape's outputs at a state.
    pub guards: Vec<Guard>,
    /// Whether a decision was taken that no guard states: the tape then holds at the tracing
    /// point only, and the guards do not say where else.
    pub undecidable: bool,
}

impl Guard {
    /// Whether it holds for these values of the tape's outputs (false where the chosen one is
    /// NaN; a NaN among the others is passed over by `f64::max`, as the generated code does).
    pub fn holds(&self, values: &[f64]) -> bool {
        let largest = (self.others.iter()).fold(0.0_f64, |m, &o| m.max(values[o].abs()));
        values[self.chosen].abs() > self.factor * largest
    }
}

impl Guarded {
    /// Whether every guard holds for these values of the tape's outputs.
    pub fn holds(&self, values: &[f64]) -> bool {
        !self.undecidable && self.guards.iter().all(|g| g.holds(values))
    }
}

/// A guard in the recorder: instructions, not yet outputs.
fn record_guard(chosen: Traced, factor: f64, others: &[Traced]) {
    let fixed = |x: &Traced| x.is_constant();
    if fixed(&chosen) && others.iter().all(fixed) {
        return; // decided alike at every state
    }
    let nonzero: Vec<Traced> = others.iter().copied().filter(|x| !x.is(0.0)).collect();
    RECORDERS.with(|r| {
        let mut r = r.borrow_mut();
        let Some(rec) = r.last_mut() else { return };
        let others: Vec<usize> = nonzero.iter().map(|&x| rec.operand(x)).collect();
        let chosen = rec.operand(chosen);
        let guard = Guard {
            chosen,
            // against nothing, any multiple says the same: |chosen| > 0
            factor: if others.is_empty() { 0.0 } else { factor },
            others,
        };
        if !rec.guards.contains(&guard) {
            rec.guards.push(guard);
        }
    });
}

thread_local! {
    static RECORDERS: RefCell<Vec<Recorder>> = const { RefCell::new(Vec::new()) };
    static NEXT_ID: std::cell::Cell<u32> = const { std::cell::Cell::new(0) };
}

/// Pops its recorder when the trace ends, even by unwinding.
struct Running;

impl Drop for Running {
    fn drop(&mut self) {
        RECORDERS.with(|r| r.borrow_mut().pop());
    }
}

impl Recorder {
    fn push(&mut self, op: Op) -> usize {
        self.ops.push(op)
    }

    /// The instruction of `x` on this recorder (a constant, or a number of another trace,
    /// becomes a constant instruction).
    fn operand(&mut self, x: Traced) -> usize {
        match x.at {
            Some((op, id)) if id == self.id => op as usize,
            _ => {
                if let Some(&i) = self.constants.get(&x.value.to_bits()) {
                    return i;
                }
                let r = crate::specialise::rational_of_f64(x.value).unwrap_or_else(|| {
                    self.non_finite = true;
                    crate::ast::Rational::from_integer(0.into())
                });
                let i = self.push(Op::Const(r));
                self.constants.insert(x.value.to_bits(), i);
                i
            }
        }
    }
}

impl Traced {
    /// The constant `v` (recorded only where it is used).
    fn constant_of(value: f64) -> Traced {
        Traced { value, at: None }
    }

    /// Whether this number is a constant of the innermost trace (or of none).
    fn is_constant(self) -> bool {
        RECORDERS.with(|r| match (self.at, r.borrow().last()) {
            (Some((_, id)), Some(rec)) => id != rec.id,
            _ => true,
        })
    }

    /// Whether this number is the constant `v`.
    fn is(self, v: f64) -> bool {
        self.value == v && self.is_constant()
    }

    /// The result `value` of `make(operands)`, recorded unless every operand is a constant.
    fn record(value: f64, operands: &[Traced], make: impl FnOnce(&[usize]) -> Op) -> Traced {
        if operands.iter().all(|x| x.is_constant()) {
            return Traced::constant_of(value);
        }
        RECORDERS.with(|r| {
            let mut r = r.borrow_mut();
            let rec = r
                .last_mut()
                .expect("a traced operand implies a running trace");
            let ids: Vec<usize> = operands.iter().map(|&x| rec.operand(x)).collect();
            let op = rec.push(make(&ids));
            Traced {
                value,
                at: Some((op as u32, rec.id)),
            }
        })
    }

    fn binary(value: f64, a: Traced, b: Traced, make: fn(usize, usize) -> Op) -> Traced {
        Traced::record(value, &[a, b], |i| make(i[0], i[1]))
    }

    fn call(self, f: Func, value: f64) -> Traced {
        Traced::record(value, &[self], |i| Op::Call(f, i[0]))
    }

    /// Input `i` of the innermost trace, at `value`.
    fn input(i: usize, value: f64) -> Traced {
        RECORDERS.with(|r| {
            let mut r = r.borrow_mut();
            let rec = r.last_mut().expect("inputs are made by a running trace");
            let op = rec.push(Op::Input(i));
            Traced {
                value,
                at: Some((op as u32, rec.id)),
            }
        })
    }

    /// The value at the tracing point.
    pub fn value_at_trace(self) -> f64 {
        self.value
    }
}

fn sorted(a: usize, b: usize) -> Vec<usize> {
    vec![a.min(b), a.max(b)]
}

impl Add for Traced {
    type Output = Traced;
    fn add(self, b: Traced) -> Traced {
        if b.is(0.0) {
            return self;
        }
        if self.is(0.0) {
            return b;
        }
        let value = self.value + b.value;
        Traced::binary(value, self, b, |x, y| Op::Add(sorted(x, y)))
    }
}

impl Sub for Traced {
    type Output = Traced;
    /// a − b as a + (−b): the same f64 value, exactly.
    fn sub(self, b: Traced) -> Traced {
        self + -b
    }
}

impl Mul for Traced {
    type Output = Traced;
    fn mul(self, b: Traced) -> Traced {
        let value = self.value * b.value;
        if self.is(0.0) || b.is(0.0) {
            return Traced::constant_of(value);
        }
        for (x, y) in [(self, b), (b, self)] {
            if y.is(1.0) {
                return x;
            }
            if y.is(-1.0) {
                return -x;
            }
        }
        Traced::binary(value, self, b, |x, y| Op::Mul(sorted(x, y)))
    }
}

impl Div for Traced {
    type Output = Traced;
    fn div(self, b: Traced) -> Traced {
        let value = self.value / b.value;
        if b.is(1.0) {
            return self;
        }
        if self.is(0.0) && value.is_finite() {
            return Traced::constant_of(value);
        }
        Traced::binary(value, self, b, Op::Div)
    }
}

impl Neg for Traced {
    type Output = Traced;
    fn neg(self) -> Traced {
        Traced::record(-self.value, &[self], |i| Op::Neg(i[0]))
    }
}

impl Scalar for Traced {
    hamel_runtime::plain_itself!();
    fn constant(v: f64) -> Self {
        Traced::constant_of(v)
    }
    fn value(&self) -> f64 {
        self.value
    }
    fn sin(self) -> Self {
        self.call(Func::Sin, self.value.sin())
    }
    fn cos(self) -> Self {
        self.call(Func::Cos, self.value.cos())
    }
    fn tan(self) -> Self {
        self.call(Func::Tan, self.value.tan())
    }
    fn sqrt(self) -> Self {
        self.call(Func::Sqrt, self.value.sqrt())
    }
    fn exp(self) -> Self {
        self.call(Func::Exp, self.value.exp())
    }
    fn ln(self) -> Self {
        self.call(Func::Log, self.value.ln())
    }
    fn atan(self) -> Self {
        self.call(Func::Atan, self.value.atan())
    }
    fn atan2(self, x: Self) -> Self {
        Traced::binary(self.value.atan2(x.value), self, x, Op::Atan2)
    }
    fn powi(self, n: i32) -> Self {
        match n {
            0 => Traced::constant_of(1.0),
            1 => self,
            _ => Traced::record(self.value.powi(n), &[self], |i| Op::PowI(i[0], n)),
        }
    }
    fn powf(self, e: Self) -> Self {
        Traced::binary(self.value.powf(e.value), self, e, Op::PowF)
    }
    const RECORDS_DECISIONS: bool = true;
    fn decided(chosen: Self, factor: f64, others: &[Self]) {
        record_guard(chosen, factor, others);
    }
    fn undecidable() {
        RECORDERS.with(|r| {
            if let Some(rec) = r.borrow_mut().last_mut() {
                rec.undecidable = true;
            }
        });
    }
}

/// Why a computation could not be traced.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum TraceError<E> {
    /// The traced computation failed at the tracing point.
    #[error("{0}")]
    Computation(E),
    /// It needed a constant that is not a finite number (a quotient by an exact zero of
    /// constants, say), which a tape cannot hold.
    #[error("the traced computation needs a constant that is not a finite number")]
    NonFinite,
}

/// Run `f` on traced inputs (`names[i]` at `values[i]`) and record what it computes into a tape
/// whose outputs are what `f` returns, in order (the path taken at `values`: see
/// [`trace_guarded`] for where else it holds).
pub fn trace<E>(
    names: &[String],
    values: &[f64],
    f: impl FnOnce(&[Traced]) -> Result<Vec<Traced>, E>,
) -> Result<Tape, TraceError<E>> {
    let (tape, _, _) = record(names, values, f, false)?;
    Ok(tape)
}

/// [`trace`], with the decisions `f` took by value ([`Scalar::decided`]) as guards: the tape's
/// outputs are `f`'s, then the values the guards compare; at a state where every guard holds
/// (and no decision was undecidable) the tape computes what `f` would.
pub fn trace_guarded<E>(
    names: &[String],
    values: &[f64],
    f: impl FnOnce(&[Traced]) -> Result<Vec<Traced>, E>,
) -> Result<Guarded, TraceError<E>> {
    let (tape, guards, undecidable) = record(names, values, f, true)?;
    let outputs = tape.outputs().len() - guards.iter().map(|g| 1 + g.others.len()).sum::<usize>();
    Ok(Guarded {
        tape,
        outputs,
        guards,
        undecidable,
    })
}

/// The trace proper: the tape, its guards (operands as the tape's outputs after `f`'s, when
/// `guarded`) and whether a decision was undecidable.
fn record<E>(
    names: &[String],
    values: &[f64],
    f: impl FnOnce(&[Traced]) -> Result<Vec<Traced>, E>,
    guarded: bool,
) -> Result<(Tape, Vec<Guard>, bool), TraceError<E>> {
    assert_eq!(names.len(), values.len(), "one value per traced input");
    let id = NEXT_ID.with(|n| {
        let id = n.get();
        n.set(id.wrapping_add(1));
        id
    });
    RECORDERS.with(|r| {
        r.borrow_mut().push(Recorder {
            id,
            ops: Interned::default(),
            constants: HashMap::new(),
            non_finite: false,
            guards: Vec::new(),
            undecidable: false,
        })
    });
    let running = Running;
    let inputs: Vec<Traced> = values
        .iter()
        .enumerate()
        .map(|(i, &v)| Traced::input(i, v))
        .collect();
    let outputs = f(&inputs).map_err(TraceError::Computation)?;
    let recorded = RECORDERS.with(|r| {
        let mut r = r.borrow_mut();
        let rec = r.last_mut().expect("this trace's recorder");
        let mut outputs: Vec<usize> = outputs.iter().map(|&x| rec.operand(x)).collect();
        let mut guards = std::mem::take(&mut rec.guards);
        if !guarded {
            guards.clear();
        }
        // each guard's operands become outputs, and the guard indexes them
        for g in &mut guards {
            let at = outputs.len();
            outputs.push(g.chosen);
            outputs.extend(&g.others);
            g.chosen = at;
            g.others = (at + 1..at + 1 + g.others.len()).collect();
        }
        let ops = std::mem::take(&mut rec.ops.ops);
        (ops, outputs, rec.non_finite, guards, rec.undecidable)
    });
    let (ops, outputs, non_finite, guards, undecidable) = recorded;
    drop(running);
    if non_finite {
        return Err(TraceError::NonFinite);
    }
    let (ops, outputs) = live(ops, &outputs);
    Ok((
        Tape::from_parts(names.to_vec(), ops, outputs),
        guards,
        undecidable,
    ))
}

/// The instructions that the outputs need, renumbered in order.
fn live(ops: Vec<Op>, outputs: &[usize]) -> (Vec<Op>, Vec<usize>) {
    let mut needed = vec![false; ops.len()];
    for &o in outputs {
        needed[o] = true;
    }
    for k in (0..ops.len()).rev() {
        if needed[k] {
            ops[k].for_each_operand(|a| needed[a] = true);
        }
    }
    let mut new = vec![usize::MAX; ops.len()];
    let mut kept = Vec::new();
    for (k, mut op) in ops.into_iter().enumerate() {
        if needed[k] {
            renumber(&mut op, &new);
            new[k] = kept.len();
            kept.push(op);
        }
    }
    (kept, outputs.iter().map(|&o| new[o]).collect())
}

fn renumber(op: &mut Op, new: &[usize]) {
    match op {
        Op::Input(_) | Op::Const(_) => {}
        Op::Add(v) | Op::Mul(v) => v.iter_mut().for_each(|a| *a = new[*a]),
        Op::Neg(a) | Op::PowI(a, _) | Op::Call(_, a) => *a = new[*a],
        Op::Div(a, b) | Op::PowF(a, b) | Op::Atan2(a, b) => {
            *a = new[*a];
            *b = new[*b];
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn names(n: usize) -> Vec<String> {
        (0..n).map(|i| format!("x{i}")).collect()
    }

    #[test]
    fn a_traced_computation_replays_at_other_points() {
        let f = |x: &[Traced]| -> Result<Vec<Traced>, ()> {
            let s = x[0].sin() * x[1] + Traced::constant(2.0);
            Ok(vec![
                s / (x[1] * x[1] + Traced::constant(1.0)),
                x[0].sqrt() - x[1],
            ])
        };
        let tape = trace(&names(2), &[0.3, 0.7], f).unwrap();
        for p in [[0.3, 0.7], [1.9, -2.5]] {
            let got = tape.eval::<f64>(&p).unwrap();
            let want = [
                (p[0].sin() * p[1] + 2.0) / (p[1] * p[1] + 1.0),
                p[0].sqrt() - p[1],
            ];
            assert_eq!(got, want);
        }
    }

    #[test]
    fn a_branch_is_taken_as_at_the_tracing_point() {
        // |x| by its sign, as a pivot search decides by value: traced at x > 0, the tape is x.
        let abs = |x: &[Traced]| -> Result<Vec<Traced>, ()> {
            Ok(vec![if x[0].value() >= 0.0 { x[0] } else { -x[0] }])
        };
        let positive = trace(&names(1), &[2.0], abs).unwrap();
        assert_eq!(positive.eval::<f64>(&[-3.0]).unwrap(), [-3.0]);
        let negative = trace(&names(1), &[-2.0], abs).unwrap();
        assert_eq!(negative.eval::<f64>(&[5.0]).unwrap(), [-5.0]);
    }

    #[test]
    fn a_pivot_is_guarded_where_the_path_stays_valid() {
        // [[x0, 1], [x1, 1]] y = [1, 2] by LU with partial pivoting, traced at x = (3, 1):
        // row 0 is the pivot; the tape holds (exactly the same function) wherever
        // |x0| > ½|x1|, and its guards say so.
        let solve = |x: &[Traced]| -> Result<Vec<Traced>, ()> {
            let one = Traced::constant(1.0);
            let a = vec![vec![x[0], one], vec![x[1], one]];
            let b = vec![one, Traced::constant(2.0)];
            hamel_runtime::solve_system(a, b).ok_or(())
        };
        let g = trace_guarded(&names(2), &[3.0, 1.0], solve).unwrap();
        assert!(!g.undecidable);
        assert_eq!(g.outputs, 2);
        // the first choice (|x0| > ½|x1|) and its floor (1e-14 of the largest entry, the
        // evaluators' though this LU takes any nonzero pivot), the second pivot's floor
        // ((x0 − x1)/x0 against the same entries) and choice (≠ 0: no other candidate)
        assert_eq!(g.guards.len(), 4, "{:?}", g.guards);
        let floors: Vec<f64> = (g.guards.iter()).map(|g| g.factor).collect();
        assert_eq!(floors, [0.5, 1e-14, 0.0, 1e-14], "{:?}", g.guards);
        let exact = |x: [f64; 2]| {
            let y0 = -1.0 / (x[0] - x[1]);
            [y0, 1.0 - x[0] * y0]
        };
        for (x, inside) in [
            ([3.0, 1.0], true),
            ([2.0, -3.9], true),
            ([2.0, 4.1], false),
            ([0.0, 0.0], false),
        ] {
            let Ok(values) = g.tape.eval::<f64>(&x) else {
                assert!(!inside, "at {x:?}"); // a quotient by a zero pivot
                continue;
            };
            assert_eq!(g.holds(&values), inside, "at {x:?}");
            if inside {
                for (v, e) in values[..2].iter().zip(exact(x)) {
                    assert!((v - e).abs() <= 1e-15 * e.abs().max(1.0), "{v} {e}");
                }
            }
        }
        // untraced decisions: the plain trace has no guard outputs
        let plain = trace(&names(2), &[3.0, 1.0], solve).unwrap();
        assert_eq!(plain.outputs().len(), 2);
    }

    #[test]
    fn constants_fold_and_trivial_operations_are_not_recorded() {
        let f = |x: &[Traced]| -> Result<Vec<Traced>, ()> {
            let (zero, one, three) = (
                Traced::constant(0.0),
                Traced::constant(1.0),
                Traced::constant(3.0),
            );
            let folded = three * three + one; // 10, no instruction
            Ok(vec![
                x[0] * one + zero * x[0] + x[0] / one - zero,
                folded * x[0],
            ])
        };
        let tape = trace(&names(1), &[0.5], f).unwrap();
        // x0 + x0 and 10·x0: the input, one sum, the constant and one product.
        assert_eq!(tape.ops().len(), 4, "{:?}", tape.ops());
        assert_eq!(tape.eval::<f64>(&[4.0]).unwrap(), [8.0, 40.0]);
    }

    #[test]
    fn shared_subexpressions_are_one_instruction_and_dead_ones_are_dropped() {
        let f = |x: &[Traced]| -> Result<Vec<Traced>, ()> {
            let _unused = x[0].exp() * x[1];
            let a = x[0] * x[1];
            let b = x[1] * x[0];
            Ok(vec![a + b])
        };
        let tape = trace(&names(2), &[1.0, 2.0], f).unwrap();
        assert_eq!(tape.ops().len(), 4, "{:?}", tape.ops());
    }

    #[test]
    fn a_non_finite_constant_is_refused() {
        let r = trace(&names(1), &[1.0], |x| -> Result<Vec<Traced>, ()> {
            Ok(vec![x[0] + Traced::constant(1.0) / Traced::constant(0.0)])
        });
        assert_eq!(r.unwrap_err(), TraceError::NonFinite);
    }

    #[test]
    fn traces_nest_and_an_outer_number_is_a_constant_inside() {
        let outer = trace(&names(1), &[3.0], |x| -> Result<Vec<Traced>, ()> {
            let y = x[0] * x[0];
            let inner = trace(&names(1), &[1.0], |z| Ok::<_, ()>(vec![z[0] + y])).unwrap();
            // Inside, y was the constant 9.
            assert_eq!(inner.eval::<f64>(&[1.0]).unwrap(), [10.0]);
            Ok(vec![y])
        })
        .unwrap();
        assert_eq!(outer.eval::<f64>(&[5.0]).unwrap(), [25.0]);
    }

    #[test]
    fn an_error_of_the_traced_computation_is_returned() {
        let r = trace(&names(1), &[1.0], |_| Err::<Vec<Traced>, _>("singular"));
        assert_eq!(r.unwrap_err(), TraceError::Computation("singular"));
        // And the recorder was popped: a new trace starts clean.
        let t = trace(&names(1), &[1.0], |x| Ok::<_, ()>(vec![x[0] + x[0]])).unwrap();
        assert_eq!(t.ops().len(), 2);
    }
}
