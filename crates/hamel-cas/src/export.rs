//! From the normal form back to plain expression trees (for printing, numeric evaluation and
//! code generation, none of which needs the engine).

use std::cmp::Reverse;

use hamel_expr::{Expr, Func, Rational};
use num_bigint::BigInt;
use num_traits::{One, Signed};

use symbolica::prelude::Factorize;

use crate::field::Ex;
use crate::vars::{Angle, FieldInner, Poly, Sym, VarKind, integer_to_big};

fn sym_name(f: &FieldInner, s: Sym) -> String {
    match s {
        Sym::Coord(i) => f.coordinates[i].clone(),
        Sym::Param(i) => f.parameters[i].clone(),
    }
}

/// The meaning of field variable `v` as a tree.
pub(crate) fn var_expr(f: &FieldInner, v: usize) -> Expr {
    match &f.kinds[v] {
        VarKind::Coord(i) => Expr::Sym(f.coordinates[*i].clone()),
        VarKind::Param(i) => Expr::Sym(f.parameters[*i].clone()),
        VarKind::Velocity(i) => Expr::Der(f.coordinates[*i].clone()),
        VarKind::Unknown(i) => Expr::Sym(f.unknowns[*i].clone()),
        VarKind::Sin(a) | VarKind::Cos(a) => {
            let func = if matches!(f.kinds[v], VarKind::Sin(_)) {
                Func::Sin
            } else {
                Func::Cos
            };
            let arg = match &f.angles[*a].angle {
                Angle::Symbol { sym, denom } => {
                    let s = Expr::Sym(sym_name(f, *sym));
                    if *denom == 1 {
                        s
                    } else {
                        Expr::Div(Box::new(s), Box::new(Expr::int(*denom as i64)))
                    }
                }
                Angle::Kernel { arg } => quotient_expr(f, &arg.0, &arg.1, None),
            };
            Expr::call(func, arg)
        }
        VarKind::Free { func, orders } => {
            let (name, args) = &f.free[*func];
            Expr::Free {
                name: name.clone(),
                args: args.iter().map(|&i| f.coordinates[i].clone()).collect(),
                orders: orders.clone(),
            }
        }
        VarKind::Kernel(k) => {
            let kernel = f.kernels.borrow()[*k].clone();
            Expr::call(
                kernel.func,
                quotient_expr(f, &kernel.arg.0, &kernel.arg.1, None),
            )
        }
    }
}

/// Terms of a polynomial in a deterministic order: higher total degree first, then by exponent
/// vector (variables in field order), independently of the engine's internal term order.
pub(crate) fn sorted_terms(p: &Poly) -> Vec<(BigInt, Vec<u16>)> {
    let mut terms: Vec<(BigInt, Vec<u16>)> = p
        .into_iter()
        .map(|t| (integer_to_big(t.coefficient), t.exponents.to_vec()))
        .collect();
    terms.sort_by_key(|(_, e)| {
        (
            Reverse(e.iter().map(|&x| x as u32).sum::<u32>()),
            Reverse(e.clone()),
        )
    });
    terms
}

fn monomial_factors(f: &FieldInner, exps: &[u16], var_cache: &mut [Option<Expr>]) -> Vec<Expr> {
    let mut out = Vec::new();
    for (v, &e) in exps.iter().enumerate() {
        if e == 0 {
            continue;
        }
        let base = var_cache[v].get_or_insert_with(|| var_expr(f, v)).clone();
        out.push(if e == 1 {
            base
        } else {
            Expr::powi(base, e as i64)
        });
    }
    out
}

/// `p / scale` as a sum of terms with rational coefficients.
fn poly_expr(f: &FieldInner, p: &Poly, scale: Option<&BigInt>, cache: &mut [Option<Expr>]) -> Expr {
    let terms = sorted_terms(p);
    if terms.is_empty() {
        return Expr::int(0);
    }
    let mut out = Vec::new();
    for (c, e) in terms {
        let coef = match scale {
            Some(s) => Rational::new(c, s.clone()),
            None => Rational::from_integer(c),
        };
        let negative = coef.is_negative();
        let coef = coef.abs();
        let mut factors = monomial_factors(f, &e, cache);
        if !coef.is_one() || factors.is_empty() {
            factors.insert(0, Expr::Num(coef));
        }
        let term = if factors.len() == 1 {
            factors.pop().unwrap()
        } else {
            Expr::Mul(factors)
        };
        out.push(if negative {
            Expr::Neg(Box::new(term))
        } else {
            term
        });
    }
    if out.len() == 1 {
        out.pop().unwrap()
    } else {
        Expr::Add(out)
    }
}

fn quotient_expr(
    f: &FieldInner,
    n: &Poly,
    d: &Poly,
    cache: Option<&mut Vec<Option<Expr>>>,
) -> Expr {
    let mut local = vec![None; f.nvars()];
    let cache = cache.unwrap_or(&mut local);
    if d.is_constant() {
        let dc = integer_to_big(&d.lcoeff());
        let scale = (!dc.is_one()).then_some(dc);
        return poly_expr(f, n, scale.as_ref(), cache);
    }
    let num = poly_expr(f, n, None, cache);
    let den = poly_expr(f, d, None, cache);
    Expr::Div(Box::new(num), Box::new(den))
}

/// `num / (c · ∏ fᵢ^eᵢ)` as a tree, the denominator kept as a product of its factors: expanding
/// powers of a denominator creates huge terms that cancel, which ruins f64 evaluation.
pub(crate) fn factored_expr(
    f: &FieldInner,
    num: &Poly,
    c: &BigInt,
    factors: &[(Poly, u32)],
) -> Expr {
    let mut cache = vec![None; f.nvars()];
    let factors: Vec<&(Poly, u32)> = factors.iter().filter(|(_, e)| *e > 0).collect();
    if factors.is_empty() {
        let scale = (!c.is_one()).then_some(c.clone());
        return poly_expr(f, num, scale.as_ref(), &mut cache);
    }
    let mut den: Vec<Expr> = Vec::new();
    if !c.is_one() {
        den.push(Expr::Num(Rational::from_integer(c.clone())));
    }
    let mut sorted: Vec<(Expr, u32)> = factors
        .iter()
        .map(|(p, e)| (poly_expr(f, p, None, &mut cache), *e))
        .collect();
    sorted.sort_by_cached_key(|(e, _)| e.to_string());
    for (base, e) in sorted {
        den.push(if e == 1 {
            base
        } else {
            Expr::powi(base, e as i64)
        });
    }
    let den = if den.len() == 1 {
        den.pop().unwrap()
    } else {
        Expr::Mul(den)
    };
    Expr::Div(Box::new(poly_expr(f, num, None, &mut cache)), Box::new(den))
}

/// The expression as a tree: the numerator expanded (terms in the deterministic order of
/// [`sorted_terms`]) over the denominator as a product of its factors (for sin and cos, those of
/// [`crate::half::trig_factors`]).
pub(crate) fn to_expr(e: &Ex) -> Expr {
    if e.den.is_constant() {
        return quotient_expr(&e.f, &e.num, &e.den, None);
    }
    if let Some((kappa, factors)) = crate::half::trig_factors(&e.f, &e.den) {
        return factored_trig(e, kappa, &factors);
    }
    plain_factored(e)
}

/// [`to_expr`] for a value whose denominator's half-angle factorisation is known.
pub(crate) fn to_expr_with(e: &Ex, hf: &crate::half::HalfFactors) -> Expr {
    if e.den.is_constant() {
        return quotient_expr(&e.f, &e.num, &e.den, None);
    }
    match crate::half::trig_factors_of(&e.f, &e.den, hf) {
        Some((kappa, factors)) => factored_trig(e, kappa, &factors),
        None => to_expr(e),
    }
}

/// N / (κ · ∏ Tᵢ^eᵢ), the sign of κ moved to the numerator.
fn factored_trig(e: &Ex, kappa: symbolica::prelude::Integer, factors: &[(Poly, u32)]) -> Expr {
    let kappa = integer_to_big(&kappa);
    if kappa.is_negative() {
        factored_expr(&e.f, &-e.num.clone(), &-kappa, factors)
    } else {
        factored_expr(&e.f, &e.num, &kappa, factors)
    }
}

/// The denominator factored over the integers with all variables independent.
fn plain_factored(e: &Ex) -> Expr {
    let mut c = integer_to_big(&e.den.lcoeff());
    let mut factors: Vec<(Poly, u32)> = Vec::new();
    let mut constant = BigInt::one();
    for (p, k) in e.den.factor() {
        if p.is_constant() {
            constant *= num_traits::pow(integer_to_big(&p.lcoeff()), k);
            continue;
        }
        let p = if p.lcoeff().is_negative() {
            if k % 2 == 1 {
                constant = -constant;
            }
            -p
        } else {
            p
        };
        factors.push((p, k as u32));
    }
    // The leading coefficient of the product is the product of the leading coefficients.
    let lead: BigInt = factors
        .iter()
        .map(|(p, k)| num_traits::pow(integer_to_big(&p.lcoeff()), *k as usize))
        .product();
    if &lead * &constant == c {
        c = constant;
    } else {
        // Should not happen; fall back to the expanded denominator.
        return quotient_expr(&e.f, &e.num, &e.den, None);
    }
    factored_expr(&e.f, &e.num, &c, &factors)
}

impl Ex {
    /// The expression as a plain tree (numerator over denominator, expanded), for printing,
    /// numeric evaluation and code generation outside the worker.
    pub fn to_expr(&self) -> Expr {
        to_expr(self)
    }
}
