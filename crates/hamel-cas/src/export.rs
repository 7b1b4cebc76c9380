//! From the normal form back to plain data: polynomials over the value's atoms
//! ([`Canonical`], which printing reads) and the expression trees written from them (for
//! numeric evaluation and code generation), none of which needs the engine.

use hamel_expr::{Canonical, Expr, Func, Term, Terms};
use num_bigint::BigInt;
use num_traits::{One, Signed};

use symbolica::prelude::Factorize;

use crate::field::Ex;
use crate::vars::{Angle, FieldInner, KernelFunc, Poly, Sym, VarKind, integer_to_big};

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
                Angle::Kernel { arg } => quotient_expr(f, &arg.0, &arg.1),
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
            match kernel.func {
                KernelFunc::Of(func) => {
                    Expr::call(func, quotient_expr(f, &kernel.arg.0, &kernel.arg.1))
                }
                KernelFunc::Atan2 => Expr::atan2(
                    quotient_expr(f, &kernel.arg.0, &f.one()),
                    quotient_expr(f, &kernel.arg.1, &f.one()),
                ),
            }
        }
    }
}

/// Terms of a polynomial in a deterministic order: higher total degree first, then by exponent
/// vector (variables in field order), independently of the engine's internal term order.
pub(crate) fn sorted_terms(p: &Poly) -> Vec<(BigInt, Vec<u16>)> {
    let degree = |e: &[u16]| e.iter().map(|&x| u32::from(x)).sum::<u32>();
    let mut terms: Vec<(u32, BigInt, Vec<u16>)> = p
        .into_iter()
        .map(|t| {
            let e = t.exponents.to_vec();
            (degree(&e), integer_to_big(t.coefficient), e)
        })
        .collect();
    // Compared in place (a key made per comparison cloned the exponents: about a sixth of the
    // instructions of deriving the unicycle's family).
    terms.sort_by(|(d, _, e), (f, _, g)| f.cmp(d).then_with(|| g.cmp(e)));
    terms.into_iter().map(|(_, c, e)| (c, e)).collect()
}

/// `num / (scale · ∏ fᵢ^eᵢ)` over the field variables its polynomials use (in field order),
/// the terms in [`sorted_terms`]' order, the factors in their text's.
fn canonical(f: &FieldInner, num: &Poly, scale: BigInt, factors: &[(&Poly, u32)]) -> Canonical {
    let num = sorted_terms(num);
    let factors: Vec<_> = factors.iter().map(|(p, e)| (sorted_terms(p), *e)).collect();
    let mut used = vec![false; f.nvars()];
    for (_, exps) in num.iter().chain(factors.iter().flat_map(|(t, _)| t)) {
        if used.len() < exps.len() {
            used.resize(exps.len(), false);
        }
        for (v, &x) in exps.iter().enumerate() {
            used[v] |= x > 0;
        }
    }
    let mut index = vec![0u32; used.len()];
    let mut atoms = Vec::new();
    let mut ids = Vec::new();
    for (v, _) in used.iter().enumerate().filter(|(_, u)| **u) {
        index[v] = u32::try_from(atoms.len()).expect("fewer than 2^32 variables");
        atoms.push(var_expr(f, v));
        ids.push(f.atom_id(v));
    }
    let terms = |ts: Vec<(BigInt, Vec<u16>)>| -> Terms {
        ts.into_iter()
            .map(|(coef, exps)| Term {
                coef: coef.into(),
                powers: exps
                    .iter()
                    .enumerate()
                    .filter(|(_, x)| **x > 0)
                    .map(|(v, &x)| (index[v], u32::from(x)))
                    .collect(),
            })
            .collect()
    };
    let mut c = Canonical {
        atoms,
        ids,
        num: terms(num),
        scale,
        factors: factors.into_iter().map(|(t, e)| (terms(t), e)).collect(),
    };
    c.order_factors();
    c
}

/// `n / d`: over an integer when `d` is constant, else over `d` expanded.
fn quotient(f: &FieldInner, n: &Poly, d: &Poly) -> Canonical {
    if d.is_constant() {
        return canonical(f, n, integer_to_big(&d.lcoeff()), &[]);
    }
    canonical(f, n, BigInt::one(), &[(d, 1)])
}

/// `n / d` as a tree (a kernel's argument).
fn quotient_expr(f: &FieldInner, n: &Poly, d: &Poly) -> Expr {
    quotient(f, n, d).to_expr()
}

/// `num / (c · ∏ fᵢ^eᵢ)`, the denominator kept as a product of its factors: expanding powers
/// of a denominator creates huge terms that cancel, which ruins f64 evaluation.
fn factored(f: &FieldInner, num: &Poly, c: &BigInt, factors: &[(Poly, u32)]) -> Canonical {
    let factors: Vec<(&Poly, u32)> = factors
        .iter()
        .filter(|(_, e)| *e > 0)
        .map(|(p, e)| (p, *e))
        .collect();
    canonical(f, num, c.clone(), &factors)
}

/// The expression as polynomials: the numerator expanded (terms in the deterministic order of
/// [`sorted_terms`]) over the denominator as a product of its factors (for sin and cos, those of
/// [`crate::half::trig_factors`]).
pub(crate) fn to_canonical(e: &Ex) -> Canonical {
    if e.den.is_constant() {
        return quotient(&e.f, &e.num, &e.den);
    }
    if let Some((kappa, factors)) = crate::half::trig_factors(&e.f, &e.den) {
        return factored_trig(e, kappa, &factors);
    }
    plain_factored(e)
}

/// [`to_canonical`] for a value whose denominator's half-angle factorisation is known.
pub(crate) fn to_canonical_with(e: &Ex, hf: &crate::half::HalfFactors) -> Canonical {
    if e.den.is_constant() {
        return quotient(&e.f, &e.num, &e.den);
    }
    match crate::half::trig_factors_of(&e.f, &e.den, hf) {
        Some((kappa, factors)) => factored_trig(e, kappa, &factors),
        None => to_canonical(e),
    }
}

/// N / (κ · ∏ Tᵢ^eᵢ), the sign of κ moved to the numerator.
fn factored_trig(e: &Ex, kappa: symbolica::prelude::Integer, factors: &[(Poly, u32)]) -> Canonical {
    let kappa = integer_to_big(&kappa);
    if kappa.is_negative() {
        factored(&e.f, &-e.num.clone(), &-kappa, factors)
    } else {
        factored(&e.f, &e.num, &kappa, factors)
    }
}

/// The denominator factored over the integers with all variables independent.
fn plain_factored(e: &Ex) -> Canonical {
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
        return quotient(&e.f, &e.num, &e.den);
    }
    factored(&e.f, &e.num, &c, &factors)
}

impl Ex {
    /// The expression as a plain tree (numerator over denominator, expanded), for printing,
    /// numeric evaluation and code generation outside the worker.
    pub fn to_expr(&self) -> Expr {
        to_canonical(self).to_expr()
    }

    /// The expression as polynomials over its atoms, from which [`Ex::to_expr`] writes its
    /// tree.
    pub fn to_canonical(&self) -> Canonical {
        to_canonical(self)
    }
}
