//! Symbolica's own numeric evaluator, for comparison benchmarks only.
//!
//! **Job**: hand a set of expressions to Symbolica's evaluator (its guide: a Horner scheme,
//! common subexpressions, reused registers) and time it, on the worker thread, so that the
//! benchmarks can set hamel's generated code beside it. Nothing in hamel's pipeline uses it.
//!
//! **Inputs**: plain trees ([`Expr`]) and the names of their inputs, in order.
//! **Outputs**: a handle ([`SymbolicaEvaluator`]) to evaluate and time them; the evaluator
//! itself never leaves the worker thread.

use std::cell::RefCell;
use std::time::{Duration, Instant};

use hamel_expr::{Expr, Func};
use symbolica::prelude::*;

use crate::CasError;

/// The text of `e` in Symbolica's input syntax, input `inputs[i]` renamed `hamel_in{i}` (so no
/// name can clash with a built-in one), tan x written as sin x / cos x.
fn text(e: &Expr, inputs: &[String]) -> String {
    e.map(&mut |x| match x {
        Expr::Sym(n) => match inputs.iter().position(|i| *i == n) {
            Some(k) => Expr::sym(&format!("hamel_in{k}")),
            None => Expr::Sym(n),
        },
        Expr::Call(Func::Tan, a) => Expr::Div(
            Box::new(Expr::call(Func::Sin, (*a).clone())),
            Box::new(Expr::call(Func::Cos, *a)),
        ),
        other => other,
    })
    .to_string()
}

/// One evaluation: inputs in, values out.
type Evaluate = Box<dyn FnMut(&[f64], &mut [f64])>;

thread_local! {
    /// The evaluators built on this (the worker) thread, by handle.
    static EVALUATORS: RefCell<Vec<(Evaluate, usize)>> = const { RefCell::new(Vec::new()) };
}

/// A handle to a Symbolica evaluator kept on the worker thread.
#[derive(Clone, Copy, Debug)]
pub struct SymbolicaEvaluator(usize);

impl SymbolicaEvaluator {
    /// Build Symbolica's evaluator (default optimisation settings) for `exprs`, with `inputs`
    /// as its parameters, in that order.
    pub fn build(exprs: Vec<Expr>, inputs: Vec<String>) -> Result<Self, CasError> {
        crate::run(move || {
            let atoms: Vec<Atom> = exprs.iter().map(|e| parse!(&text(e, &inputs))).collect();
            let params: Vec<Atom> = (0..inputs.len())
                .map(|k| parse!(&format!("hamel_in{k}")))
                .collect();
            let mut evaluator = Atom::evaluator_multiple(&atoms, &params)
                .build()
                .map_err(|e| CasError::Unsupported(format!("Symbolica's evaluator: {e}")))?
                .map_coeff(&|c| c.re.to_f64());
            let f: Evaluate = Box::new(move |x, out| evaluator.evaluate(x, out));
            Ok(EVALUATORS.with_borrow_mut(|v| {
                v.push((f, atoms.len()));
                SymbolicaEvaluator(v.len() - 1)
            }))
        })?
    }

    /// The values at `at`.
    pub fn evaluate(self, at: Vec<f64>) -> Result<Vec<f64>, CasError> {
        crate::run(move || {
            EVALUATORS.with_borrow_mut(|v| {
                let (f, n) = &mut v[self.0];
                let mut out = vec![0.0; *n];
                f(&at, &mut out);
                out
            })
        })
    }

    /// The wall time of `iters` evaluations at `at`, measured on the worker thread (for
    /// criterion's `iter_custom`).
    pub fn time(self, at: Vec<f64>, iters: u64) -> Result<Duration, CasError> {
        crate::run(move || {
            EVALUATORS.with_borrow_mut(|v| {
                let (f, n) = &mut v[self.0];
                let mut out = vec![0.0; *n];
                let start = Instant::now();
                for _ in 0..iters {
                    f(std::hint::black_box(&at), &mut out);
                    std::hint::black_box(&out);
                }
                start.elapsed()
            })
        })
    }
}
