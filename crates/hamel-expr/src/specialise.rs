//! Specialisation: parameters replaced by exact values, constants folded.
//!
//! A scene fixes the parameters of a model (masses, lengths, g). Before code is generated for
//! it, each parameter symbol becomes the exact rational value of its f64 (every finite f64 is
//! a dyadic rational, so nothing is rounded), and every subtree without symbols is folded to one
//! literal by exact rational arithmetic: sums and products of literals, quotients, integer
//! powers. Zero terms vanish, products with a zero factor vanish, unit factors go. Calls of
//! functions on constants (sin 0.3) cannot be folded exactly and stay as calls; so do real
//! powers. The result is the same function of the remaining symbols (up to the rounding of
//! the folded literals when they are finally printed as f64).

use std::collections::HashMap;

use num_traits::{One, Signed, Zero};

use crate::ast::{Expr, Rational};

impl Expr {
    /// Replace the symbols in `values` by their exact values and fold constants (see the
    /// module doc). A division by an exact zero is kept unfolded (the evaluators report it).
    pub fn specialise(&self, values: &HashMap<String, Rational>) -> Expr {
        self.map(&mut |e| match e {
            Expr::Sym(n) => match values.get(&n) {
                Some(v) => Expr::Num(v.clone()),
                None => Expr::Sym(n),
            },
            Expr::Add(v) => fold_sum(v),
            Expr::Mul(v) => fold_product(v),
            Expr::Neg(x) => match *x {
                Expr::Num(r) => Expr::Num(-r),
                Expr::Neg(y) => *y,
                x => Expr::Neg(Box::new(x)),
            },
            Expr::Div(a, b) => match (*a, *b) {
                (a, _) if a.is_zero_literal() => Expr::int(0),
                (a, b) if b.is_one_literal() => a,
                (Expr::Num(x), Expr::Num(y)) if !y.is_zero() => Expr::Num(x / y),
                (a, b) => Expr::Div(Box::new(a), Box::new(b)),
            },
            Expr::Pow(b, x) => match (*b, x.as_integer()) {
                (_, Some(0)) => Expr::int(1),
                (b, Some(1)) => b,
                (Expr::Num(r), Some(n)) if n.unsigned_abs() <= 64 && !(n < 0 && r.is_zero()) => {
                    let p = num_traits::pow(r, n.unsigned_abs() as usize);
                    Expr::Num(if n < 0 { p.recip() } else { p })
                }
                (b, _) => Expr::Pow(Box::new(b), x),
            },
            other => other,
        })
    }
}

/// The exact rational value of a finite f64; `None` for infinities and NaN.
pub fn rational_of_f64(x: f64) -> Option<Rational> {
    Rational::from_float(x)
}

fn fold_sum(v: Vec<Expr>) -> Expr {
    let mut constant = Rational::zero();
    let mut out = Vec::new();
    for t in v {
        match t {
            Expr::Num(r) => constant += r,
            Expr::Add(inner) => out.extend(inner),
            t => out.push(t),
        }
    }
    if !constant.is_zero() {
        out.push(Expr::Num(constant));
    }
    match out.len() {
        0 => Expr::int(0),
        1 => out.pop().expect("one term"),
        _ => Expr::Add(out),
    }
}

fn fold_product(v: Vec<Expr>) -> Expr {
    let mut constant = Rational::one();
    let mut out = Vec::new();
    for t in v {
        match t {
            Expr::Num(r) => constant *= r,
            Expr::Mul(inner) => out.extend(inner),
            t => out.push(t),
        }
    }
    if constant.is_zero() {
        return Expr::int(0);
    }
    let negative = constant.is_negative();
    let magnitude = constant.abs();
    if !magnitude.is_one() || out.is_empty() {
        out.insert(0, Expr::Num(magnitude));
    }
    let product = match out.len() {
        1 => out.pop().expect("one factor"),
        _ => Expr::Mul(out),
    };
    if negative {
        match product {
            Expr::Num(r) => Expr::Num(-r),
            p => Expr::Neg(Box::new(p)),
        }
    } else {
        product
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::parse;
    use crate::tape::Tape;

    fn values(pairs: &[(&str, f64)]) -> HashMap<String, Rational> {
        pairs
            .iter()
            .map(|(k, v)| (k.to_string(), rational_of_f64(*v).expect("finite")))
            .collect()
    }

    fn eval(e: &Expr, inputs: &[&str], at: &[f64]) -> f64 {
        let names: Vec<String> = inputs.iter().map(|s| s.to_string()).collect();
        Tape::compile(&[e], &names)
            .expect("compiles")
            .eval(at)
            .expect("finite")[0]
    }

    #[test]
    fn same_function_of_the_remaining_symbols_with_fewer_operations() {
        let e = parse("(m*r^2 + I)*sin(th)*x/(2*m*r) - g*m*r*cos(th) + 0*x")
            .expect("parses")
            .expr;
        let v = values(&[("m", 2.0), ("r", 0.3), ("I", 0.125), ("g", 9.81)]);
        let s = e.specialise(&v);
        let all = ["m", "r", "I", "g", "th", "x"];
        for (th, x) in [(0.3, 1.7), (-2.0, 0.01), (1.0, -5.0)] {
            let full = eval(&e, &all, &[2.0, 0.3, 0.125, 9.81, th, x]);
            let spec = eval(&s, &["th", "x"], &[th, x]);
            assert!(
                (full - spec).abs() <= 4.0 * f64::EPSILON * full.abs().max(1.0),
                "{full} vs {spec}"
            );
        }
        let ops = |e: &Expr, n: &[&str]| {
            let names: Vec<String> = n.iter().map(|s| s.to_string()).collect();
            Tape::compile(&[e], &names)
                .expect("compiles")
                .operation_count()
        };
        assert!(ops(&s, &["th", "x"]) < ops(&e, &all), "{s}");
        assert!(!s.any(&mut |x| matches!(x, Expr::Sym(n) if n == "m")));
    }

    #[test]
    fn zero_parameters_remove_terms_and_factors() {
        let e = parse("g*m*cos(th) + k*x^2 + c/(m + 1)")
            .expect("parses")
            .expr;
        let s = e.specialise(&values(&[("g", 0.0), ("c", 0.0)]));
        assert_eq!(s, parse("k*x^2").expect("parses").expr, "{s}");
        let s = e.specialise(&values(&[("g", 0.0), ("k", 0.0), ("c", 0.0)]));
        assert!(s.is_zero_literal(), "{s}");
    }

    #[test]
    fn exact_folding_of_quotients_and_powers() {
        let e = parse("(a/b)^3 - a^-2").expect("parses").expr;
        let s = e.specialise(&values(&[("a", 0.5), ("b", 0.25)]));
        // (2)^3 − 4 = 4, exactly.
        assert_eq!(s.as_rational(), Some(Rational::from_integer(4.into())));
        // 1/0 stays a quotient for the evaluator to report.
        let z = parse("1/a")
            .expect("parses")
            .expr
            .specialise(&values(&[("a", 0.0)]));
        assert!(matches!(z, Expr::Div(..)), "{z}");
    }
}
