//! The expression parser, then one step further: every expression that parses is evaluated
//! at a point (f64 and dual numbers), differentiated by each of its symbols, printed and read
//! back. Errors are fine; a panic, a hang or an exhausted machine is a finding. Printing then
//! parsing must give an expression that evaluates to the same value.
#![no_main]

use hamel_expr::{Dual, Env, Expr, Scalar, parse};
use libfuzzer_sys::fuzz_target;

/// Every symbol and velocity has a value derived from its name; free functions are refused.
struct Point;

fn value_of(name: &str) -> f64 {
    let h = name.bytes().fold(7u32, |h, b| h.wrapping_mul(31).wrapping_add(b as u32));
    0.1 + (h % 1000) as f64 / 700.0
}

impl<S: Scalar> Env<S> for Point {
    fn symbol(&self, name: &str) -> Option<S> {
        Some(S::constant(value_of(name)))
    }
    fn velocity(&self, name: &str) -> Option<S> {
        Some(S::constant(-value_of(name)))
    }
}

fn symbols(e: &Expr) -> Vec<String> {
    let mut out = Vec::new();
    e.visit(&mut |n| {
        if let Expr::Sym(s) = n {
            if !out.contains(s) {
                out.push(s.clone());
            }
        }
    });
    out
}

fuzz_target!(|text: &str| {
    let Ok(parsed) = parse(text) else { return };
    let e = parsed.expr;
    let value = e.eval::<f64>(&Point);
    let _ = e.eval::<Dual>(&Point);
    for s in symbols(&e).iter().take(4) {
        if let Ok(d) = e.diff(s) {
            let _ = d.eval::<f64>(&Point);
        }
    }
    let printed = e.to_string();
    let again = parse(&printed)
        .unwrap_or_else(|err| panic!("`{printed}` (printed from `{text}`) does not parse: {err}"));
    let back = again.expr.eval::<f64>(&Point);
    if let (Ok(a), Ok(b)) = (value, back) {
        let same = a == b || (a.is_nan() && b.is_nan()) || (a - b).abs() <= 1e-9 * a.abs().max(b.abs()).max(1.0);
        assert!(same, "`{text}` = {a} but its printed form `{printed}` = {b}");
    }
});
