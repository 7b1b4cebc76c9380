//! Multivariate Horner form of expanded polynomials, for code generation.
//!
//! The symbolic stage exports its normal forms expanded (a sum of monomials over a sum of
//! monomials); evaluated as written, a sum of n monomials of degree d costs about n·d
//! multiplications. [`Expr::horner`] rewrites every sum of monomials greedily, as
//! p = a^k · q + r with `a` the factor occurring in the most monomials and k its least
//! exponent among them (the occurrence-order Horner scheme), then recurses into q and r.
//! The result is the same polynomial (exactly, as a tree of exact rationals); only the order of
//! floating-point operations changes. Deterministic: ties go to the factor met first.

use num_traits::{One, Signed, Zero};

use crate::ast::{Expr, Rational};

/// A monomial: coefficient times factors raised to positive integer powers.
#[derive(Clone, Debug)]
struct Monomial {
    coeff: Rational,
    factors: Vec<(Expr, i64)>,
}

impl Monomial {
    fn exponent(&self, a: &Expr) -> i64 {
        self.factors
            .iter()
            .find(|(f, _)| f == a)
            .map_or(0, |(_, k)| *k)
    }

    fn divide(mut self, a: &Expr, k: i64) -> Monomial {
        if let Some(i) = self.factors.iter().position(|(f, _)| f == a) {
            self.factors[i].1 -= k;
            if self.factors[i].1 == 0 {
                self.factors.remove(i);
            }
        }
        self
    }

    fn to_expr(&self) -> Expr {
        let mut v: Vec<Expr> = Vec::new();
        let neg = self.coeff.is_negative();
        let c = self.coeff.abs();
        if !c.is_one() || self.factors.is_empty() {
            v.push(Expr::Num(c));
        }
        v.extend(self.factors.iter().map(|(f, k)| power(f.clone(), *k)));
        let m = if v.len() == 1 {
            v.pop().unwrap()
        } else {
            Expr::Mul(v)
        };
        if neg { Expr::Neg(Box::new(m)) } else { m }
    }
}

fn power(f: Expr, k: i64) -> Expr {
    if k == 1 { f } else { Expr::powi(f, k) }
}

/// `e` as a monomial, if it is one (factors already in Horner form).
fn monomial(e: &Expr, late: &dyn Fn(&Expr) -> bool) -> Monomial {
    let mut m = Monomial {
        coeff: Rational::one(),
        factors: Vec::new(),
    };
    fn push(m: &mut Monomial, f: Expr, k: i64) {
        match m.factors.iter_mut().find(|(g, _)| *g == f) {
            Some(slot) => slot.1 += k,
            None => m.factors.push((f, k)),
        }
    }
    fn walk(m: &mut Monomial, e: &Expr, late: &dyn Fn(&Expr) -> bool) {
        match e {
            Expr::Num(r) => m.coeff *= r,
            Expr::Neg(x) => {
                m.coeff = -m.coeff.clone();
                walk(m, x, late);
            }
            Expr::Mul(v) => v.iter().for_each(|x| walk(m, x, late)),
            Expr::Pow(b, n) => match n.as_integer() {
                Some(k) if k > 0 && !matches!(**b, Expr::Num(_)) => push(m, b.horner_by(late), k),
                _ => push(m, e.horner_by(late), 1),
            },
            other => push(m, other.horner_by(late), 1),
        }
    }
    walk(&mut m, e, late);
    m
}

/// Horner form of a sum of monomials.
fn scheme(mut terms: Vec<Monomial>, late: &dyn Fn(&Expr) -> bool) -> Expr {
    terms.retain(|t| !t.coeff.is_zero());
    if terms.is_empty() {
        return Expr::int(0);
    }
    // The factor occurring in the most terms (at least two), first met on ties.
    let mut counts: Vec<(Expr, usize)> = Vec::new();
    for t in &terms {
        for (f, _) in &t.factors {
            match counts.iter_mut().find(|(g, _)| g == f) {
                Some(slot) => slot.1 += 1,
                None => counts.push((f.clone(), 1)),
            }
        }
    }
    let best = counts
        .iter()
        .enumerate()
        .filter(|(_, (_, n))| *n >= 2)
        .max_by_key(|(i, (f, n))| (!late(f), *n, std::cmp::Reverse(*i)))
        .map(|(_, (f, n))| (f.clone(), *n));
    match best {
        Some((a, _)) => {
            let (with, without): (Vec<Monomial>, Vec<Monomial>) =
                terms.into_iter().partition(|t| t.exponent(&a) > 0);
            let k = with.iter().map(|t| t.exponent(&a)).min().unwrap_or(1);
            let inner = scheme(with.into_iter().map(|t| t.divide(&a, k)).collect(), late);
            let head = Expr::Mul(vec![power(a, k), inner]).tidy();
            if without.is_empty() {
                head
            } else {
                Expr::Add(vec![head, scheme(without, late)]).tidy()
            }
        }
        _ => {
            let v: Vec<Expr> = terms.iter().map(Monomial::to_expr).collect();
            if v.len() == 1 {
                v.into_iter().next().unwrap()
            } else {
                Expr::Add(v)
            }
        }
    }
}

impl Expr {
    /// The same expression with every sum of monomials in (greedy, occurrence-order)
    /// multivariate Horner form; see the module doc.
    pub fn horner(&self) -> Expr {
        self.horner_by(&|_| false)
    }

    /// [`Expr::horner`], taking out the factors for which `late` holds only when no other
    /// factor repeats. With `late` true for parameters, the coefficients of the state monomials
    /// are left as polynomials in the parameters alone: loop-invariant code, which the
    /// compiler computes once when the parameters are fixed.
    pub fn horner_by(&self, late: &dyn Fn(&Expr) -> bool) -> Expr {
        match self {
            Expr::Add(v) => scheme(v.iter().map(|t| monomial(t, late)).collect(), late),
            Expr::Mul(_) | Expr::Neg(_) => scheme(vec![monomial(self, late)], late),
            Expr::Div(a, b) => Expr::Div(Box::new(a.horner_by(late)), Box::new(b.horner_by(late))),
            Expr::Pow(a, b) => Expr::Pow(Box::new(a.horner_by(late)), b.clone()),
            Expr::Call(f, a) => Expr::Call(*f, Box::new(a.horner_by(late))),
            Expr::Atan2(y, x) => Expr::atan2(y.horner_by(late), x.horner_by(late)),
            Expr::Num(_) | Expr::Sym(_) | Expr::Der(_) | Expr::Free { .. } => self.clone(),
        }
    }
}

#[cfg(test)]
mod tests {
    use crate::{Expr, Tape, parse};

    fn value(e: &Expr, x: &[f64]) -> f64 {
        Tape::compile(&[e], &["x".into(), "y".into(), "z".into()])
            .unwrap()
            .eval::<f64>(x)
            .unwrap()[0]
    }

    fn ops(e: &Expr) -> usize {
        Tape::compile(&[e], &["x".into(), "y".into(), "z".into()])
            .unwrap()
            .operation_count()
    }

    #[test]
    fn horner_keeps_the_value_and_saves_operations() {
        let text = "3*x^3*y + 2*x^2*y^2 - x*y*z + 5*x + sin(z)*x^2 - 7 + (x*y + x*z)/(y^2*x + y)";
        let e = parse(text).unwrap().expr;
        let h = e.horner();
        for x in [[0.3, -1.2, 2.0], [1.7, 0.4, -0.9], [-2.5, 3.0, 0.1]] {
            let (a, b) = (value(&e, &x), value(&h, &x));
            assert!((a - b).abs() <= 1e-13 * a.abs().max(1.0), "{a} vs {b}");
        }
        assert!(ops(&h) < ops(&e), "{} !< {}: {h}", ops(&h), ops(&e));
    }

    #[test]
    fn horner_factors_the_most_frequent_variable_first() {
        let e = parse("x*y + x*z + x").unwrap().expr;
        assert_eq!(
            e.horner().to_string(),
            parse("x*(y + z + 1)").unwrap().expr.to_string()
        );
    }
}
