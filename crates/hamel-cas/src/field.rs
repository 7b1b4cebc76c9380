//! The field of expressions and its normal form.
//!
//! An expression is a quotient N/D of polynomials with integer coefficients in the *field
//! variables*: coordinates q, parameters, velocities der(q), sin and cos of base angles, free
//! functions and their partial derivatives, kernels (log, exp, sqrt of non-trivial arguments) and
//! plain unknowns. Some variables satisfy a quadratic relation v² = G (G a polynomial in earlier
//! variables): every sin(u) satisfies sin(u)² = 1 − cos(u)², every square-root kernel r = √G
//! satisfies r² = G. The relations {v² − G} are a Gröbner basis (their leading terms v² are
//! coprime), so every polynomial has a unique *reduced* representative, of degree ≤ 1 in each
//! related variable.
//!
//! **Normal form**, kept after every operation: N and D reduced, in lowest terms, D with a
//! positive leading coefficient. The ring of reduced polynomials in sin and cos is not a unique
//! factorisation domain (sin·sin = (1 − cos)(1 + cos)), so lowest terms are computed where it
//! is one: in the half-angle parametrisation t = tan(u/2), then mapped back to sin and cos by a
//! fixed rule ([`crate::half`]). Without square-root kernels the form is therefore *canonical*:
//! equal values have identical N and D (s/(1 + c) and (1 − c)/s are one form). Consequences,
//! all exact:
//! * an expression is zero iff its reduced numerator is the zero polynomial (the reduced form of
//!   an element of the ideal is 0), so `a == b` is decided by `(a − b).is_zero()`;
//! * if no variable depending on a coordinate q occurs in N or D the expression is free of q;
//!   when one occurs, the expression is free of q iff its total derivative ∂/∂q is zero
//!   ([`Ex::depends_on`] does both). (With a canonical form a value free of q never mentions
//!   q's sin or cos; the derivative test is kept for free functions and kernels.)
//!
//! Arithmetic on large derivations runs without lowest terms ([`crate::over`]); the half-angle
//! ring is used only to bring results to this normal form.

use std::fmt;
use std::rc::Rc;

use hamel_expr::{Expr, Func};
use num_bigint::BigInt;
use symbolica::prelude::*;

use crate::CasError;
use crate::vars::int;
pub(crate) use crate::vars::{
    Angle, AngleVars, FieldInner, Kernel, KernelFunc, Poly, Sym, VarKind, big_to_integer,
    integer_to_big,
};

/// What an expression depends on: the input to [`Field::new`].
#[derive(Clone, Debug, Default)]
pub struct FieldSpec {
    /// Coordinates, in order.
    pub coordinates: Vec<String>,
    /// Parameters, in order.
    pub parameters: Vec<String>,
    /// Free functions: name and coordinate arguments.
    pub free_functions: Vec<(String, Vec<String>)>,
    /// Highest total order of derivatives of free functions that may be needed.
    pub free_order: u32,
    /// Extra plain symbols (unknown coefficients, η₁…η_σ, …).
    pub unknowns: Vec<String>,
    /// Every expression that will be converted into the field (scanned for sin/cos arguments
    /// and kernels).
    pub expressions: Vec<Expr>,
}

/// A field of expressions over a fixed set of variables. Cheap to clone (shared).
#[derive(Clone)]
pub struct Field(pub(crate) Rc<FieldInner>);

/// An element of a [`Field`], always in normal form. Not `Send`: it lives on the
/// computer-algebra thread.
#[derive(Clone)]
pub struct Ex {
    pub(crate) f: Rc<FieldInner>,
    pub(crate) num: Poly,
    pub(crate) den: Poly,
}

impl FieldInner {
    pub fn nvars(&self) -> usize {
        self.kinds.len()
    }

    /// The exported atom of variable `v`'s number ([`hamel_expr::Canonical::ids`]): the
    /// field's and the variable's, so that equal numbers are one variable of one field, whose
    /// tree ([`crate::export::var_expr`]) never changes.
    pub fn atom_id(&self, v: usize) -> u64 {
        (u64::from(self.uid) << 32) | v as u64
    }

    pub fn var_poly(&self, v: usize) -> Poly {
        let mut e = vec![0u16; self.nvars()];
        e[v] = 1;
        self.zero.monomial(int(1), e)
    }

    pub fn constant(&self, n: Integer) -> Poly {
        self.zero.constant(n)
    }

    pub fn one(&self) -> Poly {
        self.zero.one()
    }

    /// The coordinates a variable depends on.
    pub fn deps(&self, v: usize) -> Vec<usize> {
        match &self.kinds[v] {
            VarKind::Coord(i) => vec![*i],
            VarKind::Sin(a) | VarKind::Cos(a) => match &self.angles[*a].angle {
                Angle::Symbol {
                    sym: Sym::Coord(i), ..
                } => vec![*i],
                Angle::Symbol { .. } => vec![],
                Angle::Kernel { arg, .. } => self.deps_of(&arg.0, &arg.1),
            },
            VarKind::Free { func, .. } => self.free[*func].1.clone(),
            VarKind::Kernel(k) => {
                let kernels = self.kernels.borrow();
                let arg = &kernels[*k].arg;
                self.deps_of(&arg.0, &arg.1)
            }
            VarKind::Param(_) | VarKind::Velocity(_) | VarKind::Unknown(_) => vec![],
        }
    }

    fn deps_of(&self, n: &Poly, d: &Poly) -> Vec<usize> {
        let mut out = Vec::new();
        for v in 0..self.nvars() {
            if n.degree(v) > 0 || d.degree(v) > 0 {
                for q in self.deps(v) {
                    if !out.contains(&q) {
                        out.push(q);
                    }
                }
            }
        }
        out.sort();
        out
    }

    /// Split `p` by powers of variable `v`: `p = Σ_k parts[k] v^k`, parts free of `v`.
    /// N/D with variable v set to a/b: both multiplied by b^K (K the larger degree in v), so
    /// the pair stays polynomial and the ratio is exact.
    pub fn substitute_pair(&self, n: Poly, d: Poly, v: usize, a: i64, b: i64) -> (Poly, Poly) {
        let deg = n.degree(v).max(d.degree(v)) as usize;
        if deg == 0 {
            return (n, d);
        }
        let sub = |p: &Poly| {
            let mut acc = self.zero.clone();
            for (j, part) in self.split(p, v).into_iter().enumerate() {
                if part.is_zero() {
                    continue;
                }
                let c = Integer::from(a).pow(j as u64) * Integer::from(b).pow((deg - j) as u64);
                acc = &acc + &part.mul_coeff(c);
            }
            acc
        };
        (sub(&n), sub(&d))
    }

    pub fn split(&self, p: &Poly, v: usize) -> Vec<Poly> {
        let deg = p.degree(v) as usize;
        let mut parts = vec![self.zero.clone(); deg + 1];
        let mut exps = vec![0u16; self.nvars()];
        for t in p {
            exps.copy_from_slice(t.exponents);
            let k = exps[v] as usize;
            exps[v] = 0;
            parts[k].append_monomial(t.coefficient.clone(), &exps);
        }
        parts
    }

    /// Reduce `p` modulo every relation (degree ≤ 1 in each related variable).
    pub fn reduce(&self, p: Poly) -> Poly {
        let relations = self.relations.borrow();
        let mut p = p;
        for (v, g) in relations.iter().rev() {
            if p.degree(*v) < 2 {
                continue;
            }
            let parts = self.split(&p, *v);
            let mut even = self.zero.clone();
            let mut odd = self.zero.clone();
            let mut gpow = self.one();
            for (k, part) in parts.into_iter().enumerate() {
                if k >= 2 && k % 2 == 0 {
                    gpow = &gpow * g;
                }
                if part.is_zero() {
                    continue;
                }
                let term = &part * &gpow;
                if k % 2 == 0 {
                    even = &even + &term;
                } else {
                    odd = &odd + &term;
                }
            }
            p = &even + &(&odd * &self.var_poly(*v));
        }
        p
    }

    /// Bring N/D to normal form: reduce both modulo the relations, then divide by the gcd.
    pub fn normalize(&self, num: Poly, den: Poly) -> Result<(Poly, Poly), CasError> {
        let n = self.reduce(num);
        let d = self.reduce(den);
        self.finish(n, d)
    }

    /// Lowest terms and the sign, for N/D that are already reduced: through the half-angle ring
    /// when a sin or cos occurs ([`crate::half::canonical`]), by a gcd otherwise.
    pub fn finish(&self, n: Poly, d: Poly) -> Result<(Poly, Poly), CasError> {
        if d.is_zero() {
            return Err(CasError::DivisionByZero);
        }
        if n.is_zero() {
            return Ok((n, self.one()));
        }
        // A reduced polynomial over an integer is already canonical up to the integer content
        // (its half-angle image comes back as itself), so only fractions go through t.
        if !d.is_constant()
            && (crate::half::has_angles(self, &n) || crate::half::has_angles(self, &d))
        {
            let (n, d) = crate::half::canonical(self, &n, &d);
            return Ok(self.cancel_related_factors(n, d));
        }
        let (mut n, mut d) = if d.is_constant() && d.lcoeff() == int(1) {
            (n, d)
        } else {
            let g = n.gcd(&d);
            if g.is_one() {
                (n, d)
            } else {
                (n.quot_rem(&g, false).0, d.quot_rem(&g, false).0)
            }
        };
        (n, d) = self.cancel_related_factors(n, d);
        if d.lcoeff().is_negative() {
            n = -n;
            d = -d;
        }
        Ok((n, d))
    }

    /// When a square-root kernel r (r² = G) divides D, N/D = N·r/(D·r) with D·r reduced by
    /// r² = G may cancel further: G/r becomes r. The rewritten pair is kept only when it has
    /// fewer terms, so the form stays deterministic and this costs one gcd only where a bare r
    /// divides a denominator. (sin u is handled exactly by the half-angle ring.)
    pub(crate) fn cancel_related_factors(&self, mut n: Poly, mut d: Poly) -> (Poly, Poly) {
        let relations: Vec<usize> = self
            .relations
            .borrow()
            .iter()
            .map(|(v, _)| *v)
            .filter(|&v| matches!(self.kinds[v], VarKind::Kernel(_)))
            .collect();
        for v in relations {
            if d.degree(v) == 0 || d.into_iter().any(|t| t.exponents[v] == 0) {
                continue;
            }
            let x = self.var_poly(v);
            let n2 = self.reduce(&n * &x);
            let d2 = self.reduce(&d * &x);
            let g = n2.gcd(&d2);
            if g.is_one() {
                continue;
            }
            let (n2, d2) = (n2.quot_rem(&g, false).0, d2.quot_rem(&g, false).0);
            if n2.nterms() + d2.nterms() < n.nterms() + d.nterms() {
                (n, d) = (n2, d2);
            }
        }
        (n, d)
    }
}

impl Field {
    pub(crate) fn inner(&self) -> &FieldInner {
        &self.0
    }

    pub(crate) fn ex(&self, num: Poly, den: Poly) -> Result<Ex, CasError> {
        let (num, den) = self.0.normalize(num, den)?;
        Ok(Ex {
            f: self.0.clone(),
            num,
            den,
        })
    }

    pub(crate) fn ex_poly(&self, num: Poly) -> Ex {
        let num = self.0.reduce(num);
        Ex {
            f: self.0.clone(),
            den: self.0.one(),
            num,
        }
    }

    /// The integer `n`.
    pub fn int(&self, n: i64) -> Ex {
        self.ex_poly(self.0.constant(int(n)))
    }

    /// The rational `p/q` (q ≠ 0).
    pub fn rational(&self, p: &BigInt, q: &BigInt) -> Result<Ex, CasError> {
        self.ex(
            self.0.constant(big_to_integer(p)),
            self.0.constant(big_to_integer(q)),
        )
    }

    /// Zero.
    pub fn zero(&self) -> Ex {
        self.int(0)
    }

    /// One.
    pub fn one(&self) -> Ex {
        self.int(1)
    }

    fn var(&self, v: usize) -> Ex {
        self.ex_poly(self.0.var_poly(v))
    }

    /// The coordinate `q_i` itself.
    pub fn coord(&self, i: usize) -> Ex {
        match self.0.coord_var[i] {
            Some(v) => self.var(v),
            None => panic!(
                "coordinate {} has no polynomial variable",
                self.0.coordinates[i]
            ),
        }
    }

    /// The velocity der(q_i).
    pub fn velocity(&self, i: usize) -> Ex {
        self.var(self.0.velocity_var[i])
    }

    /// The parameter with this index.
    pub fn param(&self, i: usize) -> Ex {
        match self.0.param_var[i] {
            Some(v) => self.var(v),
            None => panic!(
                "parameter {} has no polynomial variable",
                self.0.parameters[i]
            ),
        }
    }

    /// The unknown symbol with this name.
    pub fn unknown(&self, name: &str) -> Option<Ex> {
        let i = self.0.unknowns.iter().position(|u| u == name)?;
        Some(self.var(self.0.unknown_var[i]))
    }

    /// Number of coordinates.
    pub fn ncoords(&self) -> usize {
        self.0.coordinates.len()
    }

    /// Coordinate names.
    pub fn coordinates(&self) -> &[String] {
        &self.0.coordinates
    }

    /// Parameter names.
    pub fn parameters(&self) -> &[String] {
        &self.0.parameters
    }

    /// Index of a coordinate by name.
    pub fn coord_index(&self, name: &str) -> Option<usize> {
        self.0.coordinates.iter().position(|c| c == name)
    }

    /// Number of field variables (a measure of the problem size).
    pub fn nvars(&self) -> usize {
        self.0.nvars()
    }
}

impl Ex {
    pub(crate) fn field(&self) -> Field {
        Field(self.f.clone())
    }

    fn same_field(&self, other: &Ex) {
        debug_assert!(
            Rc::ptr_eq(&self.f, &other.f),
            "expressions of different fields"
        );
    }

    /// True when the expression is identically zero (exact).
    pub fn is_zero(&self) -> bool {
        self.num.is_zero()
    }

    /// True when the expression is the number 1.
    pub fn is_one(&self) -> bool {
        self.num.is_one() && self.den.is_one()
    }

    /// True when the expression is a number.
    pub fn is_number(&self) -> bool {
        self.num.is_constant() && self.den.is_constant()
    }

    /// Number of terms of numerator plus denominator (a size measure).
    pub fn size(&self) -> usize {
        self.num.nterms() + self.den.nterms()
    }

    /// The reciprocal.
    pub fn inv(&self) -> Result<Ex, CasError> {
        self.field().ex(self.den.clone(), self.num.clone())
    }

    /// Quotient (error when `other` is zero).
    pub fn div(&self, other: &Ex) -> Result<Ex, CasError> {
        self.same_field(other);
        if other.is_zero() {
            return Err(CasError::DivisionByZero);
        }
        Ok(self * &other.inv()?)
    }

    /// Integer power (error for a negative power of zero).
    pub fn pow(&self, n: i64) -> Result<Ex, CasError> {
        if n < 0 {
            return self.inv()?.pow(-n);
        }
        let mut result = self.field().one();
        let mut base = self.clone();
        let mut k = n as u64;
        while k > 0 {
            if k & 1 == 1 {
                result = &result * &base;
            }
            k >>= 1;
            if k > 0 {
                base = &base * &base;
            }
        }
        Ok(result)
    }

    /// The numerator as an expression.
    pub fn numerator(&self) -> Ex {
        Ex {
            f: self.f.clone(),
            num: self.num.clone(),
            den: self.f.one(),
        }
    }

    /// The denominator as an expression.
    pub fn denominator(&self) -> Ex {
        Ex {
            f: self.f.clone(),
            num: self.den.clone(),
            den: self.f.one(),
        }
    }

    /// The distinct non-constant irreducible factors of the numerator, each with a positive
    /// leading coefficient, sorted by their text: for a polynomial in sin and cos, the factors
    /// of [`crate::half::trig_factors`] (from the unique factorisation in the half-angle ring,
    /// regrouped into polynomials in sin and cos, with 1 + cos u for a zero at u = π); otherwise
    /// factored over the integers with the field variables independent.
    pub fn numerator_factors(&self) -> Vec<Ex> {
        self.poly_factors(&self.num)
    }

    /// The distinct non-constant irreducible factors of the denominator, as for
    /// [`Ex::numerator_factors`].
    pub fn denominator_factors(&self) -> Vec<Ex> {
        self.poly_factors(&self.den)
    }

    fn poly_factors(&self, p: &Poly) -> Vec<Ex> {
        if p.is_constant() {
            return Vec::new();
        }
        let factors: Vec<(Poly, usize)> = match crate::half::trig_factors(&self.f, p) {
            Some((_, fs)) => fs.into_iter().map(|(t, e)| (t, e as usize)).collect(),
            None => p.factor(),
        };
        let mut out: Vec<Ex> = factors
            .into_iter()
            .filter(|(f, _)| !f.is_constant())
            .map(|(f, _)| {
                let f = if f.lcoeff().is_negative() { -f } else { f };
                Ex {
                    f: self.f.clone(),
                    num: f,
                    den: self.f.one(),
                }
            })
            .collect();
        out.sort_by_cached_key(|e| e.to_string());
        out.dedup();
        out
    }

    /// True when the expression depends on coordinate `q_i`. Exact: when no variable depending
    /// on `q_i` occurs it is free of `q_i`; otherwise it depends on `q_i` iff its total
    /// derivative with respect to `q_i` is not zero.
    pub fn depends_on(&self, i: usize) -> bool {
        self.mentions(i) && self.field().fraction_depends_on(&self.num, &self.den, i)
    }

    /// True when a variable depending on `q_i` occurs (syntactic; may be true for an
    /// expression that is free of `q_i`, never false for one that depends on it).
    pub fn mentions(&self, i: usize) -> bool {
        (0..self.f.nvars()).any(|v| {
            (self.num.degree(v) > 0 || self.den.degree(v) > 0) && self.f.deps(v).contains(&i)
        })
    }

    /// The same value written without q_k, for an expression that does not depend on q_k
    /// (decided exactly by [`Ex::depends_on`]): its canonical form may still mention q_k, as in
    /// (1 − cos²θ)/sin θ, so q_k is given a value at which the denominator does not vanish
    /// (0, 1, 2, … where q_k occurs as itself; for sin and cos the rational points
    /// (4/5, 3/5), (5/13, 12/13), … of the unit circle). `None` when the expression depends
    /// on q_k, or q_k occurs inside a free function or kernel, or under two related angles.
    pub fn without_coordinate(&self, k: usize) -> Option<Ex> {
        if !self.mentions(k) {
            return Some(self.clone());
        }
        if self.depends_on(k) {
            return None;
        }
        let fi = &self.f;
        let mut coord = None;
        let mut angle = None;
        for v in 0..fi.nvars() {
            if (self.num.degree(v) == 0 && self.den.degree(v) == 0) || !fi.deps(v).contains(&k) {
                continue;
            }
            match fi.kinds[v] {
                VarKind::Coord(i) if i == k => coord = Some(v),
                VarKind::Sin(a) | VarKind::Cos(a) => match angle {
                    None => angle = Some(a),
                    Some(b) if b == a => {}
                    Some(_) => return None,
                },
                _ => return None,
            }
        }
        let points: [(i64, i64, i64); 6] = [
            (4, 3, 5),
            (5, 12, 13),
            (8, 15, 17),
            (3, 4, 5),
            (12, 5, 13),
            (20, 21, 29),
        ];
        for (t, &(ps, pc, h)) in points.iter().enumerate() {
            let (mut n, mut d) = (self.num.clone(), self.den.clone());
            if let Some(v) = coord {
                (n, d) = fi.substitute_pair(n, d, v, t as i64, 1);
            }
            if let Some(a) = angle {
                let av = &fi.angles[a];
                (n, d) = fi.substitute_pair(n, d, av.sin, ps, h);
                (n, d) = fi.substitute_pair(n, d, av.cos, pc, h);
            }
            if d.is_zero() {
                continue;
            }
            return self.field().ex(n, d).ok();
        }
        None
    }

    /// The conditions for the expression to be free of q_k, as equations `c = 0`: the
    /// coefficients of the reduced N'·D − N·D' (the numerator of the total derivative) in the
    /// monomials of the variables that depend on q_k (sin, cos of angles in q_k, q_k itself),
    /// each made primitive with a positive leading coefficient, and each once.
    /// Reduced monomials are linearly independent over the other variables, so the expression
    /// is free of q_k iff every condition holds; conditions that are identically zero are
    /// left out (none are returned when the expression is free of q_k). Free functions of q_k
    /// count as variables depending on q_k, so for them the conditions are sufficient only.
    pub fn dependence_conditions(&self, k: usize) -> Vec<Ex> {
        if !self.mentions(k) {
            return Vec::new();
        }
        let field = self.field();
        let fi = &self.f;
        let test = field.derivative_test(&self.num, &self.den, k);
        let on_k: Vec<usize> = (0..fi.nvars())
            .filter(|&v| test.degree(v) > 0 && fi.deps(v).contains(&k))
            .collect();
        let mut parts: Vec<(Vec<u16>, Poly)> = Vec::new();
        let mut exps = vec![0u16; fi.nvars()];
        for t in &test {
            exps.copy_from_slice(t.exponents);
            let key: Vec<u16> = on_k.iter().map(|&v| exps[v]).collect();
            for &v in &on_k {
                exps[v] = 0;
            }
            match parts.iter_mut().find(|(k2, _)| *k2 == key) {
                Some((_, p)) => p.append_monomial(t.coefficient.clone(), &exps),
                None => {
                    let mut p = fi.zero.clone();
                    p.append_monomial(t.coefficient.clone(), &exps);
                    parts.push((key, p));
                }
            }
        }
        parts.sort_by(|x, y| x.0.cmp(&y.0));
        // Each condition primitive with a positive leading coefficient, each once.
        let mut out: Vec<Ex> = Vec::new();
        for (_, p) in parts.into_iter().filter(|(_, p)| !p.is_zero()) {
            let p = p.quot_rem(&fi.constant(p.content()), false).0;
            let c = field.ex_poly(if p.lcoeff().is_negative() { -p } else { p });
            if !out.contains(&c) {
                out.push(c);
            }
        }
        out
    }

    /// Solve `self = 0` for the value of the free function `name`: when the numerator is of
    /// degree one in that value, P₀ + P₁·f with P₁ ≠ 0, and no derivative of any free function
    /// occurs, the solution f = −P₀/P₁ (a closed form in the other variables). `None` otherwise.
    pub fn solve_for_free(&self, name: &str) -> Option<Ex> {
        let fi = &self.f;
        let func = fi.free.iter().position(|(n, _)| n == name)?;
        let nargs = fi.free[func].1.len();
        let v = *fi.free_var.get(&(func, vec![0; nargs]))?;
        if self.num.degree(v) != 1 {
            return None;
        }
        let derivative_occurs = fi
            .free_var
            .iter()
            .any(|((_, orders), &w)| orders.iter().any(|&o| o > 0) && self.num.degree(w) > 0);
        if derivative_occurs {
            return None;
        }
        let parts = fi.split(&self.num, v);
        if parts[1].is_zero() {
            return None;
        }
        self.field().ex(-parts[0].clone(), parts[1].clone()).ok()
    }

    /// The coordinates the expression depends on (indices, sorted), decided as in
    /// [`Ex::depends_on`].
    pub fn coordinate_dependence(&self) -> Vec<usize> {
        self.f
            .deps_of(&self.num, &self.den)
            .into_iter()
            .filter(|&i| self.depends_on(i))
            .collect()
    }

    /// True when some velocity der(q) occurs.
    pub fn has_velocities(&self) -> bool {
        self.f
            .velocity_var
            .iter()
            .any(|&v| self.num.degree(v) > 0 || self.den.degree(v) > 0)
    }

    /// True when the unknown symbol occurs.
    pub fn has_unknown(&self, name: &str) -> bool {
        match self.f.unknowns.iter().position(|u| u == name) {
            Some(i) => {
                let v = self.f.unknown_var[i];
                self.num.degree(v) > 0 || self.den.degree(v) > 0
            }
            None => false,
        }
    }

    /// True when a free function (or a derivative of it) occurs.
    pub fn has_free_function(&self, name: &str) -> bool {
        self.f.free_var.iter().any(|((func, _), &v)| {
            self.f.free[*func].0 == name && (self.num.degree(v) > 0 || self.den.degree(v) > 0)
        })
    }

    /// The partial derivative with respect to der(q_j), the velocities being independent
    /// variables (the other velocities and all coordinates held fixed).
    pub fn diff_velocity(&self, j: usize) -> Ex {
        let v = self.f.velocity_var[j];
        self.partial_var(v)
    }

    /// The partial derivative with respect to the unknown symbol `name`.
    pub fn diff_unknown(&self, name: &str) -> Option<Ex> {
        let i = self.f.unknowns.iter().position(|u| u == name)?;
        Some(self.partial_var(self.f.unknown_var[i]))
    }

    /// ∂/∂v for a variable with no relation and no dependants.
    fn partial_var(&self, v: usize) -> Ex {
        let field = self.field();
        let dn = field.ex_poly(self.num.derivative(v));
        if self.den.degree(v) == 0 {
            return &dn
                * &field
                    .ex(field.0.one(), self.den.clone())
                    .expect("nonzero denominator");
        }
        let dd = field.ex_poly(self.den.derivative(v));
        let n = field.ex_poly(self.num.clone());
        let d = field.ex_poly(self.den.clone());
        (&(&dn * &d) - &(&n * &dd))
            .div(&(&d * &d))
            .expect("nonzero denominator")
    }

    /// The total derivative with respect to coordinate `q_i` (through sin, cos, free functions
    /// and kernels of `q_i`; velocities and other coordinates held fixed).
    pub fn diff(&self, i: usize) -> Ex {
        let field = self.field();
        let dn = field.poly_diff(&self.num, i);
        if self.den.is_constant() {
            return &dn
                * &field
                    .ex(field.0.one(), self.den.clone())
                    .expect("nonzero denominator");
        }
        let dd = field.poly_diff(&self.den, i);
        let n = field.ex_poly(self.num.clone());
        let d = field.ex_poly(self.den.clone());
        (&(&dn * &d) - &(&n * &dd))
            .div(&(&d * &d))
            .expect("nonzero denominator")
    }
}

impl Field {
    /// d(field variable v)/dq_i as a quotient of polynomials, or None if zero.
    fn dvar(&self, v: usize, i: usize) -> Option<(Poly, Poly)> {
        if let Some(hit) = self.0.dvar.borrow().get(&(v, i)) {
            return hit.clone();
        }
        let f = &self.0;
        let one = f.one();
        let result: Option<(Poly, Poly)> = match &f.kinds[v] {
            VarKind::Coord(k) => (*k == i).then(|| (one.clone(), one.clone())),
            VarKind::Sin(a) | VarKind::Cos(a) => {
                let av = &f.angles[*a];
                let is_sin = matches!(f.kinds[v], VarKind::Sin(_));
                let (other, sign) = if is_sin { (av.cos, 1) } else { (av.sin, -1) };
                let other = &f.var_poly(other) * &f.constant(int(sign));
                match &av.angle {
                    Angle::Symbol {
                        sym: Sym::Coord(k),
                        denom,
                    } if *k == i => Some((other, f.constant(int(*denom as i64)))),
                    Angle::Symbol { .. } => None,
                    Angle::Kernel { arg, .. } => {
                        let arg = self
                            .ex(arg.0.clone(), arg.1.clone())
                            .expect("kernel argument");
                        let d = arg.diff(i);
                        if d.is_zero() {
                            None
                        } else {
                            let r = &self.ex_poly(other) * &d;
                            Some((r.num, r.den))
                        }
                    }
                }
            }
            VarKind::Free { func, orders } => {
                let args = &f.free[*func].1;
                args.iter().position(|&a| a == i).map(|j| {
                    let mut o = orders.clone();
                    o[j] += 1;
                    let w = *f.free_var.get(&(*func, o.clone())).unwrap_or_else(|| {
                        panic!(
                            "derivative of free function `{}` beyond the supported order",
                            f.free[*func].0
                        )
                    });
                    (f.var_poly(w), one.clone())
                })
            }
            VarKind::Kernel(k) => {
                let kernel = f.kernels.borrow()[*k].clone();
                match kernel.func {
                    KernelFunc::Atan2 => self.atan2_derivative(&kernel, i),
                    KernelFunc::Of(func) => self.unary_kernel_derivative(v, func, &kernel, i),
                }
            }
            VarKind::Param(_) | VarKind::Velocity(_) | VarKind::Unknown(_) => None,
        };
        self.0.dvar.borrow_mut().insert((v, i), result.clone());
        result
    }

    /// d f(u)/dq_i for the kernel `v` = f(u), f = exp, log, atan or sqrt.
    fn unary_kernel_derivative(
        &self,
        v: usize,
        func: Func,
        kernel: &Kernel,
        i: usize,
    ) -> Option<(Poly, Poly)> {
        {
            {
                let arg = self
                    .ex(kernel.arg.0.clone(), kernel.arg.1.clone())
                    .expect("kernel argument");
                let da = arg.diff(i);
                if da.is_zero() {
                    None
                } else {
                    let me = self.var(v);
                    let r = match func {
                        Func::Exp => &me * &da,
                        Func::Log => da.div(&arg).expect("log of zero"),
                        // d atan(u) = u'/(1 + u²)
                        Func::Atan => da
                            .div(&(&self.one() + &(&arg * &arg)))
                            .expect("1 + u² is not zero"),
                        // r = √G: dr = G' r / (2 G)
                        Func::Sqrt => (&da * &me)
                            .div(&(&arg * &self.int(2)))
                            .expect("sqrt of zero"),
                        _ => unreachable!("kernel function"),
                    };
                    Some((r.num, r.den))
                }
            }
        }
    }

    /// d atan2(Y, X)/dq_i = (X·Y' − Y·X')/(X² + Y²).
    fn atan2_derivative(&self, kernel: &Kernel, i: usize) -> Option<(Poly, Poly)> {
        let (y, x) = (
            self.ex_poly(kernel.arg.0.clone()),
            self.ex_poly(kernel.arg.1.clone()),
        );
        let top = &(&x * &y.diff(i)) - &(&y * &x.diff(i));
        if top.is_zero() {
            return None;
        }
        let r = top
            .div(&(&(&x * &x) + &(&y * &y)))
            .expect("X² + Y² is not zero");
        Some((r.num, r.den))
    }

    /// Total derivative of a polynomial with respect to q_i.
    /// Whether N/D (D ≠ 0) depends on q_i, exactly and without gcds: d(N/D)/dq_i = 0 iff
    /// N'·D − N·D' = 0; with N' = a/da and D' = b/db, iff a·db·D − N·b·da reduces to zero.
    pub(crate) fn fraction_depends_on(&self, num: &Poly, den: &Poly, i: usize) -> bool {
        !self.derivative_test(num, den, i).is_zero()
    }

    /// a·db·D − N·b·da reduced, with N' = a/da and D' = b/db: zero iff d(N/D)/dq_i = 0, and
    /// otherwise a nonzero multiple of the derivative's numerator.
    pub(crate) fn derivative_test(&self, num: &Poly, den: &Poly, i: usize) -> Poly {
        let (a, da) = self.poly_diff_frac(num, i);
        let test = if den.is_constant() {
            a
        } else {
            let (b, db) = self.poly_diff_frac(den, i);
            &(&(&a * &db) * den) - &(&(num * &b) * &da)
        };
        self.0.reduce(test)
    }

    /// True when a variable of `p` depends on q_i (syntactic).
    pub(crate) fn poly_mentions(&self, p: &Poly, i: usize) -> bool {
        (0..self.0.nvars()).any(|v| p.degree(v) > 0 && self.0.deps(v).contains(&i))
    }

    /// dp/dq_i as a fraction (numerator, denominator) gathered by cross-multiplication, without
    /// gcds: for exact zero tests, where lowest terms are not needed.
    pub(crate) fn poly_diff_frac(&self, p: &Poly, i: usize) -> (Poly, Poly) {
        let mut num = self.0.zero.clone();
        let mut den = self.0.one();
        for v in 0..self.0.nvars() {
            if p.degree(v) == 0 {
                continue;
            }
            let Some((dn, dd)) = self.dvar(v, i) else {
                continue;
            };
            let t = &p.derivative(v) * &dn;
            if dd == den {
                num = &num + &t;
            } else if dd.is_one() {
                num = &num + &(&t * &den);
            } else {
                num = &(&num * &dd) + &(&t * &den);
                den = &den * &dd;
            }
        }
        (num, den)
    }

    pub(crate) fn poly_diff(&self, p: &Poly, i: usize) -> Ex {
        let mut acc = self.zero();
        for v in 0..self.0.nvars() {
            if p.degree(v) == 0 {
                continue;
            }
            let Some((dn, dd)) = self.dvar(v, i) else {
                continue;
            };
            let pv = p.derivative(v);
            let term = if dd.is_one() {
                self.ex_poly(&pv * &dn)
            } else {
                self.ex(&pv * &dn, dd).expect("nonzero denominator")
            };
            acc = &acc + &term;
        }
        acc
    }
}

impl PartialEq for Ex {
    fn eq(&self, other: &Ex) -> bool {
        self.num == other.num && self.den == other.den
    }
}

impl fmt::Debug for Ex {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "Ex({self})")
    }
}

// Arithmetic. The normal form of a sum or product is rebuilt from the operands' normal forms.
impl std::ops::Add for &Ex {
    type Output = Ex;
    fn add(self, o: &Ex) -> Ex {
        self.same_field(o);
        let f = &self.f;
        if o.is_zero() {
            return self.clone();
        }
        if self.is_zero() {
            return o.clone();
        }
        let (n, d) = if self.den == o.den {
            (&self.num + &o.num, self.den.clone())
        } else if self.den.is_one() {
            (f.reduce(&(&self.num * &o.den) + &o.num), o.den.clone())
        } else if o.den.is_one() {
            (
                f.reduce(&self.num + &(&o.num * &self.den)),
                self.den.clone(),
            )
        } else {
            let g = self.den.gcd(&o.den);
            let a = self.den.quot_rem(&g, false).0;
            let b = o.den.quot_rem(&g, false).0;
            (
                f.reduce(&(&self.num * &b) + &(&o.num * &a)),
                f.reduce(&a * &o.den),
            )
        };
        let (num, den) = f.finish(n, d).expect("nonzero denominator");
        Ex {
            f: f.clone(),
            num,
            den,
        }
    }
}

impl std::ops::Neg for &Ex {
    type Output = Ex;
    fn neg(self) -> Ex {
        Ex {
            f: self.f.clone(),
            num: -self.num.clone(),
            den: self.den.clone(),
        }
    }
}

impl std::ops::Sub for &Ex {
    type Output = Ex;
    fn sub(self, o: &Ex) -> Ex {
        self + &(-o)
    }
}

impl std::ops::Mul for &Ex {
    type Output = Ex;
    fn mul(self, o: &Ex) -> Ex {
        self.same_field(o);
        let f = &self.f;
        if self.is_zero() || o.is_zero() {
            return Field(f.clone()).zero();
        }
        // Cross-cancel first to keep the product small.
        let (n1, d2) = cancel(&self.num, &o.den);
        let (n2, d1) = cancel(&o.num, &self.den);
        let prod = &n1 * &n2;
        let den = &d1 * &d2;
        let needs_reduction = f
            .relations
            .borrow()
            .iter()
            .any(|(v, _)| prod.degree(*v) >= 2 || den.degree(*v) >= 2);
        // Without reduction and without sin or cos the cross-cancelled product is already in
        // lowest terms.
        let needs_reduction = needs_reduction
            || crate::half::has_angles(f, &prod)
            || crate::half::has_angles(f, &den);
        let (num, den) = if needs_reduction {
            f.finish(f.reduce(prod), f.reduce(den))
        } else {
            let (mut n, mut d) = f.cancel_related_factors(prod, den);
            if d.lcoeff().is_negative() {
                n = -n;
                d = -d;
            }
            Ok((n, d))
        }
        .expect("nonzero denominator");
        Ex {
            f: f.clone(),
            num,
            den,
        }
    }
}

fn cancel(n: &Poly, d: &Poly) -> (Poly, Poly) {
    if d.is_one() || n.is_one() {
        return (n.clone(), d.clone());
    }
    let g = n.gcd(d);
    if g.is_one() {
        (n.clone(), d.clone())
    } else {
        (n.quot_rem(&g, false).0, d.quot_rem(&g, false).0)
    }
}

/// Owned-operand conveniences.
macro_rules! owned_ops {
    ($tr:ident, $m:ident) => {
        impl std::ops::$tr<Ex> for Ex {
            type Output = Ex;
            fn $m(self, o: Ex) -> Ex {
                (&self).$m(&o)
            }
        }
        impl std::ops::$tr<&Ex> for Ex {
            type Output = Ex;
            fn $m(self, o: &Ex) -> Ex {
                (&self).$m(o)
            }
        }
        impl std::ops::$tr<Ex> for &Ex {
            type Output = Ex;
            fn $m(self, o: Ex) -> Ex {
                self.$m(&o)
            }
        }
    };
}
owned_ops!(Add, add);
owned_ops!(Sub, sub);
owned_ops!(Mul, mul);

impl std::ops::Neg for Ex {
    type Output = Ex;
    fn neg(self) -> Ex {
        -&self
    }
}
