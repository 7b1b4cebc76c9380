//! Building a field from the expressions it must hold, and converting expression trees into it.
//!
//! sin and cos of a rational-linear combination of symbols (θ, θ + φ, 2θ, θ/2, …) are expanded
//! exactly into polynomials in sin u, cos u of one *base angle* u = symbol/d per symbol, d being
//! the least common denominator of that symbol's coefficients across all the expressions. Any
//! other argument of sin, cos, exp, log or sqrt becomes a *kernel*: one new variable per distinct
//! argument (equal arguments, decided exactly, share it), with the chain rule for its derivatives (sqrt kernels also carry the
//! relation r² = radicand). Kernels inside kernel arguments are not supported.

use std::cell::RefCell;
use std::collections::{BTreeMap, HashMap};
use std::rc::Rc;
use std::sync::Arc;

use hamel_expr::{Expr, Func, Rational};
use num_bigint::BigInt;
use num_integer::Integer as _;
use num_traits::{One, Signed, ToPrimitive, Zero};
use symbolica::prelude::*;

use crate::CasError;
use crate::field::{
    Angle, AngleVars, Ex, Field, FieldInner, FieldSpec, Kernel, KernelFunc, Poly, Sym, VarKind,
};
use crate::vars::HalfRing;

/// A rational constant value of a tree made only of numbers, if it is one.
fn const_rational(e: &Expr) -> Option<Rational> {
    match e {
        Expr::Num(r) => Some(r.clone()),
        Expr::Neg(x) => const_rational(x).map(|r| -r),
        Expr::Add(v) => v
            .iter()
            .try_fold(Rational::zero(), |acc, t| Some(acc + const_rational(t)?)),
        Expr::Mul(v) => v
            .iter()
            .try_fold(Rational::one(), |acc, t| Some(acc * const_rational(t)?)),
        Expr::Div(a, b) => {
            let d = const_rational(b)?;
            (!d.is_zero()).then(|| const_rational(a).map(|n| n / d))?
        }
        Expr::Pow(b, x) => {
            let base = const_rational(b)?;
            let n = x.as_integer()?;
            if n < 0 && base.is_zero() {
                return None;
            }
            let p = num_traits::pow(base.clone(), n.unsigned_abs() as usize);
            Some(if n < 0 { p.recip() } else { p })
        }
        _ => None,
    }
}

/// `Σ r_i · symbol_i` with no constant term, if the tree is one.
fn linear_form(e: &Expr) -> Option<BTreeMap<String, Rational>> {
    fn add_into(
        acc: &mut BTreeMap<String, Rational>,
        other: BTreeMap<String, Rational>,
        scale: &Rational,
    ) {
        for (k, v) in other {
            let slot = acc.entry(k).or_insert_with(Rational::zero);
            *slot = slot.clone() + v * scale.clone();
        }
    }
    let out = match e {
        Expr::Sym(s) => BTreeMap::from([(s.clone(), Rational::one())]),
        Expr::Num(r) if r.is_zero() => BTreeMap::new(),
        Expr::Neg(x) => {
            let mut m = BTreeMap::new();
            add_into(&mut m, linear_form(x)?, &-Rational::one());
            m
        }
        Expr::Add(v) => {
            let mut m = BTreeMap::new();
            for t in v {
                add_into(&mut m, linear_form(t)?, &Rational::one());
            }
            m
        }
        Expr::Mul(v) => {
            let mut scale = Rational::one();
            let mut lin = None;
            for t in v {
                match const_rational(t) {
                    Some(c) => scale *= c,
                    None if lin.is_none() => lin = Some(linear_form(t)?),
                    None => return None,
                }
            }
            let mut m = BTreeMap::new();
            add_into(&mut m, lin.unwrap_or_default(), &scale);
            m
        }
        Expr::Div(a, b) => {
            let d = const_rational(b)?;
            if d.is_zero() {
                return None;
            }
            let mut m = BTreeMap::new();
            add_into(&mut m, linear_form(a)?, &d.recip());
            m
        }
        _ => return None,
    };
    Some(out.into_iter().filter(|(_, v)| !v.is_zero()).collect())
}

/// Half-integer exponent `k/2` (k odd) of a power, if it is one.
fn half_power(e: &Expr) -> Option<i64> {
    let r = const_rational(e)?;
    (r.denom() == &BigInt::from(2))
        .then(|| r.numer().to_i64())
        .flatten()
}

#[derive(Default)]
struct Scan {
    /// symbol → lcm of the denominators of its coefficients in trig arguments
    trig_denoms: BTreeMap<String, BigInt>,
    /// trig arguments that are not linear forms (kernel angles), in order of appearance
    trig_kernels: Vec<Expr>,
    /// (func, argument) of exp/log/sqrt kernels, in order of appearance
    kernels: Vec<(Func, Expr)>,
    /// (y, x) of atan2 kernels, in order of appearance
    atan2s: Vec<(Expr, Expr)>,
}

impl Scan {
    fn expr(&mut self, e: &Expr) {
        e.visit(&mut |node| match node {
            Expr::Call(Func::Sin | Func::Cos | Func::Tan, arg) => match linear_form(arg) {
                Some(lin) => {
                    for (s, r) in lin {
                        let slot = self.trig_denoms.entry(s).or_insert_with(BigInt::one);
                        *slot = slot.lcm(r.denom());
                    }
                }
                None => self.trig_kernels.push((**arg).clone()),
            },
            Expr::Call(f @ (Func::Exp | Func::Log | Func::Sqrt | Func::Atan), arg) => {
                self.kernels.push((*f, (**arg).clone()))
            }
            Expr::Pow(b, x) if x.as_integer().is_none() && half_power(x).is_some() => {
                self.kernels.push((Func::Sqrt, (**b).clone()))
            }
            Expr::Atan2(y, x) => self.atan2s.push(((**y).clone(), (**x).clone())),
            _ => {}
        });
    }
}

struct Layout {
    kinds: Vec<VarKind>,
    angles: Vec<AngleVars>,
    coord_var: Vec<Option<usize>>,
    param_var: Vec<Option<usize>>,
    velocity_var: Vec<usize>,
    unknown_var: Vec<usize>,
    free_var: HashMap<(usize, Vec<u32>), usize>,
    free: Vec<(String, Vec<usize>)>,
}

impl Layout {
    fn push(&mut self, kind: VarKind) -> usize {
        self.kinds.push(kind);
        self.kinds.len() - 1
    }

    fn push_angle(&mut self, angle: Angle) -> usize {
        let a = self.angles.len();
        let sin = self.push(VarKind::Sin(a));
        let cos = self.push(VarKind::Cos(a));
        self.angles.push(AngleVars { angle, sin, cos });
        a
    }
}

/// All multi-indices of length `n` with total order ≤ `max`, in graded order.
fn multi_indices(n: usize, max: u32) -> Vec<Vec<u32>> {
    let mut out = vec![vec![0; n]];
    for _ in 0..max {
        let mut next = Vec::new();
        for m in &out {
            for j in 0..n {
                let mut m2 = m.clone();
                m2[j] += 1;
                if !out.contains(&m2) && !next.contains(&m2) {
                    next.push(m2);
                }
            }
        }
        out.extend(next);
    }
    out
}

fn base_layout(spec: &FieldSpec, scan: &Scan) -> Layout {
    let mut l = Layout {
        kinds: Vec::new(),
        angles: Vec::new(),
        coord_var: Vec::new(),
        param_var: Vec::new(),
        velocity_var: Vec::new(),
        unknown_var: Vec::new(),
        free_var: HashMap::new(),
        free: Vec::new(),
    };
    for (i, q) in spec.coordinates.iter().enumerate() {
        let v = l.push(VarKind::Coord(i));
        l.coord_var.push(Some(v));
        if let Some(d) = scan.trig_denoms.get(q) {
            let denom = d.to_u32().unwrap_or(1);
            l.push_angle(Angle::Symbol {
                sym: Sym::Coord(i),
                denom,
            });
        }
    }
    for i in 0..spec.coordinates.len() {
        let v = l.push(VarKind::Velocity(i));
        l.velocity_var.push(v);
    }
    for (i, p) in spec.parameters.iter().enumerate() {
        let v = l.push(VarKind::Param(i));
        l.param_var.push(Some(v));
        if let Some(d) = scan.trig_denoms.get(p) {
            let denom = d.to_u32().unwrap_or(1);
            l.push_angle(Angle::Symbol {
                sym: Sym::Param(i),
                denom,
            });
        }
    }
    for (fi, (name, args)) in spec.free_functions.iter().enumerate() {
        let idx: Vec<usize> = args
            .iter()
            .map(|a| {
                spec.coordinates
                    .iter()
                    .position(|c| c == a)
                    .expect("free function argument is a coordinate")
            })
            .collect();
        l.free.push((name.clone(), idx));
        for orders in multi_indices(args.len(), spec.free_order.max(1)) {
            let v = l.push(VarKind::Free {
                func: fi,
                orders: orders.clone(),
            });
            l.free_var.insert((fi, orders), v);
        }
    }
    for i in 0..spec.unknowns.len() {
        let v = l.push(VarKind::Unknown(i));
        l.unknown_var.push(v);
    }
    l
}

/// The zero polynomial of a ring of `n` variables named `{prefix}{i}`.
fn ring(prefix: &str, n: usize) -> Poly {
    let vars: Arc<Vec<PolyVariable>> = Arc::new(
        (0..n)
            .map(|i| symbol!(&format!("{prefix}{i}")).into())
            .collect(),
    );
    MultivariatePolynomial::new(&Z, None, vars)
}

/// A number no field of this process had before.
fn next_uid() -> u32 {
    static NEXT: std::sync::atomic::AtomicU32 = std::sync::atomic::AtomicU32::new(0);
    NEXT.fetch_add(1, std::sync::atomic::Ordering::Relaxed)
}

fn build(spec: &FieldSpec, layout: Layout) -> Field {
    let zero = ring("hamel_v", layout.kinds.len());
    let half = HalfRing::new(&layout.kinds, |n| ring("hamel_t", n));
    let inner = FieldInner {
        coordinates: spec.coordinates.clone(),
        parameters: spec.parameters.clone(),
        free: layout.free,
        unknowns: spec.unknowns.clone(),
        kinds: layout.kinds,
        angles: layout.angles,
        kernels: RefCell::new(Vec::new()),
        relations: RefCell::new(Vec::new()),
        zero,
        half,
        coord_var: layout.coord_var,
        param_var: layout.param_var,
        velocity_var: layout.velocity_var,
        unknown_var: layout.unknown_var,
        free_var: layout.free_var,
        kernel_var: Vec::new(),
        dvar: RefCell::new(HashMap::new()),
        uid: next_uid(),
    };
    let field = Field(Rc::new(inner));
    // sin(u)² = 1 − cos(u)² for every angle.
    let rels: Vec<(usize, Poly)> = field
        .inner()
        .angles
        .iter()
        .map(|a| {
            let c = field.inner().var_poly(a.cos);
            (a.sin, &field.inner().one() - &(&c * &c))
        })
        .collect();
    field.inner().relations.borrow_mut().extend(rels);
    field
}

impl Field {
    /// Build the field for the given symbols and expressions.
    pub fn new(spec: &FieldSpec) -> Result<Field, CasError> {
        let mut scan = Scan::default();
        for e in &spec.expressions {
            // sin, cos, tan of arctangents are algebraic (hamel_expr's `atan`): scanned as
            // `convert` converts them.
            scan.expr(&e.unfold_trig_of_atan());
        }
        // Phase A: the field without kernels, to put kernel arguments in normal form.
        let base = build(spec, base_layout(spec, &scan));
        let mut angle_args: Vec<(Poly, Poly)> = Vec::new();
        let mut kernel_args: Vec<(KernelFunc, Poly, Poly)> = Vec::new();
        for arg in &scan.trig_kernels {
            let a = base.convert(arg).map_err(nested)?;
            let seen = angle_args
                .iter()
                .any(|(n, d)| (&base.ex(n.clone(), d.clone()).expect("argument") - &a).is_zero());
            if !seen {
                angle_args.push((a.num, a.den));
            }
        }
        for (f, arg) in &scan.kernels {
            let a = base.convert(arg).map_err(nested)?;
            let (n, d) = if *f == Func::Sqrt {
                if a.is_number() || a.is_zero() {
                    continue; // handled exactly (or rejected) at conversion
                }
                // √(N/D) = √(N·D)/D: the kernel is the square root of the polynomial N·D.
                (base.inner().reduce(&a.num * &a.den), base.inner().one())
            } else {
                (a.num, a.den)
            };
            let this = base.ex(n.clone(), d.clone())?;
            let f = KernelFunc::Of(*f);
            let seen = kernel_args.iter().any(|(g, kn, kd)| {
                *g == f && (&base.ex(kn.clone(), kd.clone()).expect("argument") - &this).is_zero()
            });
            if !seen {
                kernel_args.push((f, n, d));
            }
        }
        for (y, x) in &scan.atan2s {
            let (y, x) = (
                base.convert(y).map_err(nested)?,
                base.convert(x).map_err(nested)?,
            );
            let (yn, xn) = base.atan2_arguments(&y, &x);
            let seen = kernel_args
                .iter()
                .any(|(g, ky, kx)| *g == KernelFunc::Atan2 && *ky == yn && *kx == xn);
            if !seen {
                kernel_args.push((KernelFunc::Atan2, yn, xn));
            }
        }
        if angle_args.is_empty() && kernel_args.is_empty() {
            return Ok(base);
        }
        // Phase B: the same variables plus one (sin/cos: two) per kernel.
        let mut layout = base_layout(spec, &scan);
        let nbase = layout.kinds.len();
        let mut angle_slots = Vec::new();
        for (k, (n, d)) in angle_args.iter().enumerate() {
            let a = layout.push_angle(Angle::Kernel {
                arg: (n.clone(), d.clone()),
            });
            angle_slots.push((k, a));
        }
        let mut kernel_vars = Vec::new();
        let mut kernels = Vec::new();
        for (k, (f, n, d)) in kernel_args.iter().enumerate() {
            let v = layout.push(VarKind::Kernel(k));
            kernel_vars.push(v);
            kernels.push((*f, n.clone(), d.clone()));
        }
        let field = build(spec, layout);
        // Re-embed the phase-A polynomials (a prefix of the variables) in the final field.
        let embed = |p: &Poly| -> Poly {
            let mut out = field.inner().zero.clone();
            let mut exps = vec![0u16; field.inner().nvars()];
            for t in p {
                exps[..nbase].copy_from_slice(t.exponents);
                out.append_monomial(t.coefficient.clone(), &exps);
            }
            out
        };
        let mut inner_angles = field.inner().angles.clone();
        for (k, a) in angle_slots {
            let (n, d) = &angle_args[k];
            if let Angle::Kernel { arg, .. } = &mut inner_angles[a].angle {
                *arg = (embed(n), embed(d));
            }
        }
        let mut kernel_list = Vec::new();
        let mut relations = Vec::new();
        for (k, (f, n, d)) in kernels.into_iter().enumerate() {
            let arg = (embed(&n), embed(&d));
            if f == KernelFunc::Of(Func::Sqrt) {
                relations.push((kernel_vars[k], arg.0.clone()));
            }
            kernel_list.push(Kernel { func: f, arg });
        }
        // Rebuild the inner with the kernel data filled in.
        let mut inner = Rc::try_unwrap(field.0)
            .ok()
            .expect("fresh field is not shared");
        inner.angles = inner_angles;
        inner.kernels = RefCell::new(kernel_list);
        inner.kernel_var = kernel_vars;
        inner.relations.borrow_mut().extend(relations);
        Ok(Field(Rc::new(inner)))
    }

    /// Convert an expression tree. Unknown names and unsupported forms are errors.
    pub fn convert(&self, e: &Expr) -> Result<Ex, CasError> {
        let f = self.inner();
        Ok(match e {
            Expr::Num(r) => self.rational(r.numer(), r.denom())?,
            Expr::Sym(s) => {
                if let Some(i) = f.coordinates.iter().position(|c| c == s) {
                    self.coord(i)
                } else if let Some(i) = f.parameters.iter().position(|c| c == s) {
                    self.param(i)
                } else if let Some(u) = self.unknown(s) {
                    u
                } else {
                    return Err(CasError::Unsupported(format!("unknown symbol `{s}`")));
                }
            }
            Expr::Der(q) => match f.coordinates.iter().position(|c| c == q) {
                Some(i) => self.velocity(i),
                None => {
                    return Err(CasError::Unsupported(format!(
                        "`der({q})` of a non-coordinate"
                    )));
                }
            },
            Expr::Free { name, orders, .. } => {
                let func = f.free.iter().position(|(n, _)| n == name).ok_or_else(|| {
                    CasError::Unsupported(format!("unknown free function `{name}`"))
                })?;
                let v = f.free_var.get(&(func, orders.clone())).ok_or_else(|| {
                    CasError::Unsupported(format!("derivative order of `{name}` too high"))
                })?;
                self.ex_poly(f.var_poly(*v))
            }
            Expr::Add(v) => {
                let mut acc = self.zero();
                for t in v {
                    acc = &acc + &self.convert(t)?;
                }
                acc
            }
            Expr::Mul(v) => {
                let mut acc = self.one();
                for t in v {
                    acc = &acc * &self.convert(t)?;
                }
                acc
            }
            Expr::Neg(x) => -self.convert(x)?,
            Expr::Div(a, b) => {
                let d = self.convert(b)?;
                if d.is_zero() {
                    return Err(CasError::Unsupported(format!(
                        "division by an expression that is identically zero: `{b}`"
                    )));
                }
                self.convert(a)?.div(&d)?
            }
            Expr::Pow(b, x) => {
                if let Some(n) = x.as_integer() {
                    let base = self.convert(b)?;
                    if n < 0 && base.is_zero() {
                        return Err(CasError::DivisionByZero);
                    }
                    base.pow(n)?
                } else if let Some(k) = half_power(x) {
                    self.sqrt(b)?.pow(k)?
                } else {
                    return Err(CasError::Unsupported(format!(
                        "`{e}`: only integer and half-integer exponents are supported"
                    )));
                }
            }
            Expr::Call(Func::Sin | Func::Cos | Func::Tan, arg) if arg.has_atan() => {
                let unfolded = e.unfold_trig_of_atan();
                if &unfolded == e {
                    return Err(CasError::Unsupported(format!(
                        "`{e}`: the sine, cosine or tangent of an angle with an arctangent is supported for angles a + k·atan(u) (k an integer) only"
                    )));
                }
                self.convert(&unfolded)?
            }
            Expr::Call(func, arg) => match func {
                Func::Sin | Func::Cos | Func::Tan => {
                    let (c, s) = self.cos_sin(arg)?;
                    match func {
                        Func::Sin => s,
                        Func::Cos => c,
                        _ => {
                            if c.is_zero() {
                                return Err(CasError::DivisionByZero);
                            }
                            s.div(&c)?
                        }
                    }
                }
                Func::Sqrt => self.sqrt(arg)?,
                Func::Exp | Func::Log | Func::Atan => {
                    let a = self.convert(arg)?;
                    if *func == Func::Exp && a.is_zero() {
                        return Ok(self.one());
                    }
                    if *func == Func::Atan && a.is_zero() {
                        return Ok(self.zero());
                    }
                    if *func == Func::Log && a.is_one() {
                        return Ok(self.zero());
                    }
                    self.kernel(*func, &a.num, &a.den)?
                }
            },
            Expr::Atan2(y, x) => {
                let (y, x) = (self.convert(y)?, self.convert(x)?);
                if y.is_zero() && x.is_zero() {
                    return Err(CasError::Unsupported(format!(
                        "`{e}`: atan2 of the origin (0, 0) has no angle"
                    )));
                }
                let (yn, xn) = self.atan2_arguments(&y, &x);
                let f = self.inner();
                let kernels = f.kernels.borrow();
                let k = (kernels.iter())
                    .position(|k| k.func == KernelFunc::Atan2 && k.arg == (yn.clone(), xn.clone()))
                    .ok_or_else(|| CasError::Undeclared("atan2(...)".into()))?;
                self.ex_poly(f.var_poly(f.kernel_var[k]))
            }
        })
    }

    /// atan2(y, x)'s kernel argument: (Y, X) = (Ny·Dy·Dx², Nx·Dx·Dy²) reduced, each divided
    /// by the positive integer gcd of their contents (the same angle: both are scaled by a
    /// positive factor), so that atan2 of proportional arguments with a positive rational
    /// ratio is one kernel.
    pub(crate) fn atan2_arguments(&self, y: &Ex, x: &Ex) -> (Poly, Poly) {
        let f = self.inner();
        let (dx2, dy2) = (&x.den * &x.den, &y.den * &y.den);
        let yn = f.reduce(&(&y.num * &y.den) * &dx2);
        let xn = f.reduce(&(&x.num * &x.den) * &dy2);
        let content = match (yn.is_zero(), xn.is_zero()) {
            (true, true) => return (yn, xn),
            (true, _) => xn.content(),
            (_, true) => yn.content(),
            _ => yn.content().gcd(&xn.content()),
        };
        let c = f.constant(content.abs());
        (yn.quot_rem(&c, false).0, xn.quot_rem(&c, false).0)
    }

    fn kernel(&self, func: Func, n: &Poly, d: &Poly) -> Result<Ex, CasError> {
        let f = self.inner();
        let kernels = f.kernels.borrow();
        let this = self.ex(n.clone(), d.clone())?;
        let k = kernels
            .iter()
            .position(|k| {
                k.func == KernelFunc::Of(func)
                    && (&self.ex(k.arg.0.clone(), k.arg.1.clone()).expect("argument") - &this)
                        .is_zero()
            })
            .ok_or_else(|| CasError::Undeclared(format!("{}(...)", func.name())))?;
        Ok(self.ex_poly(f.var_poly(f.kernel_var[k])))
    }

    fn sqrt(&self, arg: &Expr) -> Result<Ex, CasError> {
        let a = self.convert(arg)?;
        if a.is_zero() {
            return Ok(self.zero());
        }
        if a.is_number() {
            // Exact when the rational is a perfect square.
            let n = crate::field::integer_to_big(&a.num.lcoeff());
            let d = crate::field::integer_to_big(&a.den.lcoeff());
            if n.is_positive() {
                let (rn, rd) = (n.sqrt(), d.sqrt());
                if &rn * &rn == n && &rd * &rd == d {
                    return self.rational(&rn, &rd);
                }
            } else {
                return Err(CasError::Unsupported(format!(
                    "square root of the negative number `{arg}`"
                )));
            }
        }
        let g = self.inner().reduce(&a.num * &a.den);
        let r = self.kernel(Func::Sqrt, &g, &self.inner().one())?;
        r.div(&self.ex_poly(a.den.clone()))
    }

    /// (cos, sin) of an argument.
    fn cos_sin(&self, arg: &Expr) -> Result<(Ex, Ex), CasError> {
        let f = self.inner();
        match linear_form(arg) {
            Some(lin) => {
                let (mut c, mut s) = (self.one(), self.zero());
                for (name, r) in lin {
                    let sym = if let Some(i) = f.coordinates.iter().position(|x| *x == name) {
                        Sym::Coord(i)
                    } else if let Some(i) = f.parameters.iter().position(|x| *x == name) {
                        Sym::Param(i)
                    } else {
                        return Err(CasError::Unsupported(format!("unknown symbol `{name}`")));
                    };
                    let av = f
                        .angles
                        .iter()
                        .find(|a| matches!(a.angle, Angle::Symbol { sym: s2, .. } if s2 == sym))
                        .ok_or_else(|| CasError::Undeclared(format!("sin/cos of `{name}`")))?;
                    let Angle::Symbol { denom, .. } = av.angle else {
                        unreachable!()
                    };
                    let n = r * Rational::from_integer(BigInt::from(denom));
                    let n = n
                        .to_integer()
                        .to_i64()
                        .filter(|_| n.is_integer())
                        .ok_or_else(|| CasError::Internal("base angle denominator".into()))?;
                    let cu = self.ex_poly(f.var_poly(av.cos));
                    let su = self.ex_poly(f.var_poly(av.sin));
                    let su = if n < 0 { -su } else { su };
                    for _ in 0..n.unsigned_abs() {
                        let nc = &(&c * &cu) - &(&s * &su);
                        let ns = &(&s * &cu) + &(&c * &su);
                        c = nc;
                        s = ns;
                    }
                }
                Ok((c, s))
            }
            None => {
                let a = self.convert(arg)?;
                let av = f
                    .angles
                    .iter()
                    .find(|av| matches!(&av.angle, Angle::Kernel { arg } if (&self.ex(arg.0.clone(), arg.1.clone()).expect("argument") - &a).is_zero()))
                    .ok_or_else(|| CasError::Undeclared(format!("sin/cos({arg})")))?;
                Ok((
                    self.ex_poly(f.var_poly(av.cos)),
                    self.ex_poly(f.var_poly(av.sin)),
                ))
            }
        }
    }
}

fn nested(e: CasError) -> CasError {
    match e {
        CasError::Undeclared(_) => CasError::Unsupported(
            "nested transcendental functions (sqrt, exp, log, atan or sin/cos of a non-linear argument inside another one) are not supported".into(),
        ),
        other => other,
    }
}
