//! Expressions over a common set of denominator factors, for large derivations.
//!
//! [`Ex`] keeps every value in lowest terms, which costs a gcd per operation; on the larger
//! models (a 6×6 Γ whose denominator δ has dozens of terms) sums of hundreds of products made
//! the derivation take minutes. An [`Over`] is instead N / (c · ∏ bᵢ^eᵢ) with N a reduced
//! polynomial, c a positive integer and bᵢ drawn from a shared list of irreducible polynomials
//! (the factors of the denominators that occur: δ, kernel radicands, …). Sums align the
//! exponents, products add them, derivatives use the quotient rule on the factors: no gcd is
//! ever needed. Zero is still decided exactly (N reduced is 0 iff the value is 0). [`Over::to_ex`]
//! brings a result back to lowest terms by trial division by the factors.

use std::cell::RefCell;
use std::collections::HashMap;
use std::rc::Rc;

use symbolica::prelude::Factorize;

use crate::field::{Ex, Field, Poly};
use crate::half::{HalfFactors, canonical_over_factored, half_factors, has_angles};

struct Inner {
    field: Field,
    /// Irreducible, pairwise distinct, positive leading coefficient.
    bases: RefCell<Vec<Poly>>,
    /// ∂b_j/∂q_i as an [`Over`] (memo).
    dbase: RefCell<HashMap<(usize, usize), Over>>,
    /// The half-angle factorisation of each base (memo; [`crate::half::half_factors`]).
    half: RefCell<HashMap<usize, Rc<HalfFactors>>>,
}

/// Numerator, exponents of the factors and integer denominator ([`Over::lowest_terms`]).
type Lowest = (Poly, Vec<u32>, Poly);

/// A value's canonical form: through the half-angle ring, or its plain lowest terms where the
/// half-angle ring is not needed.
enum Canonical {
    Half(Ex, HalfFactors),
    Plain(Lowest),
}

/// A shared list of denominator factors. Cheap to clone.
#[derive(Clone)]
pub struct Denominators(Rc<Inner>);

/// N / (c · ∏ bᵢ^eᵢ) over a [`Denominators`] list.
#[derive(Clone)]
pub struct Over {
    d: Rc<Inner>,
    num: Poly,
    exps: Vec<u32>,
    /// Positive integer constant (a constant polynomial).
    cden: Poly,
}

fn divides(p: &Poly, b: &Poly) -> Option<Poly> {
    let (q, r) = p.quot_rem(b, false);
    r.is_zero().then_some(q)
}

impl Denominators {
    /// A list seeded with the irreducible factors of the denominators of `seeds`.
    pub fn new(field: &Field, seeds: &[&Ex]) -> Denominators {
        let d = Denominators(Rc::new(Inner {
            field: field.clone(),
            bases: RefCell::new(Vec::new()),
            dbase: RefCell::new(HashMap::new()),
            half: RefCell::new(HashMap::new()),
        }));
        for e in seeds {
            d.add_factors_of(&e.den);
        }
        d
    }

    fn add_factors_of(&self, p: &Poly) {
        if p.is_constant() {
            return;
        }
        for (f, _) in p.factor() {
            if f.is_constant() {
                continue;
            }
            let f = if f.lcoeff().is_negative() { -f } else { f };
            let mut bases = self.0.bases.borrow_mut();
            if !bases.contains(&f) {
                bases.push(f);
            }
        }
    }

    /// Number of factors in the list.
    pub fn len(&self) -> usize {
        self.0.bases.borrow().len()
    }

    /// True when the list is empty.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Express `e` over the list (new factors of its denominator are added to the list).
    pub fn over(&self, e: &Ex) -> Over {
        let mut rest = e.den.clone();
        let mut exps = Vec::new();
        loop {
            let bases = self.0.bases.borrow().clone();
            exps.resize(bases.len(), 0);
            for (j, b) in bases.iter().enumerate() {
                while !rest.is_constant() {
                    match divides(&rest, b) {
                        Some(q) => {
                            rest = q;
                            exps[j] += 1;
                        }
                        None => break,
                    }
                }
            }
            if rest.is_constant() {
                break;
            }
            self.add_factors_of(&rest);
        }
        let (num, cden) = if rest.lcoeff().is_negative() {
            (-e.num.clone(), -rest)
        } else {
            (e.num.clone(), rest)
        };
        Over {
            d: self.0.clone(),
            num,
            exps,
            cden,
        }
    }

    /// The integer `n`.
    pub fn int(&self, n: i64) -> Over {
        self.over(&self.0.field.int(n))
    }
}

impl Over {
    fn inner(&self) -> &Inner {
        &self.d
    }

    fn base_pow(&self, j: usize, k: u32) -> Poly {
        let b = self.inner().bases.borrow()[j].clone();
        let mut out = self.inner().field.inner().one();
        for _ in 0..k {
            out = &out * &b;
        }
        out
    }

    fn padded(&self, n: usize) -> Vec<u32> {
        let mut e = self.exps.clone();
        e.resize(n, 0);
        e
    }

    /// True when the value is zero (exact).
    pub fn is_zero(&self) -> bool {
        self.num.is_zero()
    }

    /// Number of terms of the numerator (a size measure).
    pub fn size(&self) -> usize {
        self.num.nterms()
    }

    /// The value as a plain tree, in lowest terms, the denominator as a product of factors.
    pub fn to_expr(&self) -> hamel_expr::Expr {
        self.to_canonical().to_expr()
    }

    /// The value in lowest terms as polynomials over its atoms, the denominator as a product
    /// of factors; [`Over::to_expr`] is its tree.
    pub fn to_canonical(&self) -> hamel_expr::Canonical {
        match self.canonical_factored() {
            Canonical::Half(e, hf) => crate::export::to_canonical_with(&e, &hf),
            Canonical::Plain(lowest) => self.plain(lowest).to_canonical(),
        }
    }

    /// The value in normal form through the half-angle ring, with its denominator's half-angle
    /// factorisation; where the half-angle ring is not needed, the lowest terms of
    /// [`Over::lowest_terms`] instead.
    fn canonical_factored(&self) -> Canonical {
        let field = &self.inner().field;
        let fi = field.inner();
        let (num, exps, cden) = self.lowest_terms();
        let bases = self.inner().bases.borrow().clone();
        let used: Vec<usize> = (0..exps.len()).filter(|&j| exps[j] > 0).collect();
        if num.is_zero()
            || used.is_empty()
            || !(has_angles(fi, &num) || used.iter().any(|&j| has_angles(fi, &bases[j])))
        {
            return Canonical::Plain((num, exps, cden));
        }
        let factors: Vec<(Rc<HalfFactors>, u32)> = used
            .iter()
            .map(|&j| (self.base_half(j, &bases[j]), exps[j]))
            .collect();
        let refs: Vec<(&HalfFactors, u32)> =
            factors.iter().map(|(h, e)| (h.as_ref(), *e)).collect();
        let (num, den, hf) = canonical_over_factored(fi, &num, &cden, &refs);
        Canonical::Half(
            Ex {
                f: field.0.clone(),
                num,
                den,
            },
            hf,
        )
    }

    /// Numerator, exponents and integer denominator in lowest terms.
    fn lowest_terms(&self) -> Lowest {
        let fi = self.inner().field.inner();
        let bases = self.inner().bases.borrow().clone();
        let mut num = self.num.clone();
        let mut exps = self.padded(bases.len());
        if num.is_zero() {
            return (num, vec![0; bases.len()], fi.one());
        }
        for (j, b) in bases.iter().enumerate() {
            while exps[j] > 0 {
                match divides(&num, b) {
                    Some(q) => {
                        num = q;
                        exps[j] -= 1;
                    }
                    None => break,
                }
            }
        }
        // Factors are primitive with positive leading coefficients: only the integer content
        // of N and c can still be shared.
        let g = fi.constant(num.content()).gcd(&self.cden);
        if g.is_one() {
            (num, exps, self.cden.clone())
        } else {
            (
                num.quot_rem(&g, false).0,
                exps,
                self.cden.quot_rem(&g, false).0,
            )
        }
    }

    /// The value in normal form ([`crate::field`]): trial division of the numerator by the
    /// factors, then, when sin or cos occur in a fraction, lowest terms in the half-angle ring by
    /// trial division by the factors' (memoised) half-angle factorisations; otherwise the
    /// integer content.
    pub fn to_ex(&self) -> Ex {
        match self.canonical_factored() {
            Canonical::Half(e, _) => e,
            Canonical::Plain(lowest) => self.plain(lowest),
        }
    }

    /// Lowest terms without sin or cos in a fraction: the factors multiplied out (reduced when
    /// a square-root kernel is among them).
    fn plain(&self, (num, exps, cden): Lowest) -> Ex {
        let field = &self.inner().field;
        let fi = field.inner();
        let bases = self.inner().bases.borrow().clone();
        let mut den = cden;
        for (j, &e) in exps.iter().enumerate() {
            for _ in 0..e {
                den = &den * &bases[j];
            }
        }
        if fi
            .relations
            .borrow()
            .iter()
            .any(|(v, _)| den.degree(*v) > 0)
        {
            // A square-root kernel among the factors: r·r = G, so reduce and take lowest terms.
            return field.ex(num, den).expect("a nonzero denominator");
        }
        Ex {
            f: field.0.clone(),
            num,
            den,
        }
    }

    fn base_half(&self, j: usize, b: &Poly) -> Rc<HalfFactors> {
        let fi = self.inner().field.inner();
        self.inner()
            .half
            .borrow_mut()
            .entry(j)
            .or_insert_with(|| Rc::new(half_factors(fi, b)))
            .clone()
    }

    /// Product.
    pub fn mul(&self, o: &Over) -> Over {
        let fi = self.inner().field.inner();
        let n = self.exps.len().max(o.exps.len());
        let (a, b) = (self.padded(n), o.padded(n));
        Over {
            d: self.d.clone(),
            num: fi.reduce(&self.num * &o.num),
            exps: a.iter().zip(&b).map(|(x, y)| x + y).collect(),
            cden: &self.cden * &o.cden,
        }
    }

    /// Sum.
    pub fn add(&self, o: &Over) -> Over {
        if o.is_zero() {
            return self.clone();
        }
        if self.is_zero() {
            return o.clone();
        }
        let fi = self.inner().field.inner();
        let n = self.exps.len().max(o.exps.len());
        let (a, b) = (self.padded(n), o.padded(n));
        let target: Vec<u32> = a.iter().zip(&b).map(|(x, y)| *x.max(y)).collect();
        let g = self.cden.gcd(&o.cden);
        let ca = self.cden.quot_rem(&g, false).0; // cden_self / g
        let cb = o.cden.quot_rem(&g, false).0;
        let lift = |x: &Over, e: &[u32], scale: &Poly| -> Poly {
            let mut p = &x.num * scale;
            for j in 0..n {
                if target[j] > e[j] {
                    p = &p * &x.base_pow(j, target[j] - e[j]);
                }
            }
            p
        };
        let num = fi.reduce(&lift(self, &a, &cb) + &lift(o, &b, &ca));
        Over {
            d: self.d.clone(),
            num,
            exps: target,
            cden: &ca * &o.cden,
        }
    }

    /// Difference.
    pub fn sub(&self, o: &Over) -> Over {
        self.add(&o.neg())
    }

    /// Negation.
    pub fn neg(&self) -> Over {
        Over {
            d: self.d.clone(),
            num: -self.num.clone(),
            exps: self.exps.clone(),
            cden: self.cden.clone(),
        }
    }

    /// True when the value depends on coordinate q_i; exact, as [`Ex::depends_on`], and
    /// without bringing the value to lowest terms.
    pub fn depends_on(&self, i: usize) -> bool {
        let field = &self.inner().field;
        let bases = self.inner().bases.borrow();
        let mut den = self.cden.clone();
        let mut mentions = field.poly_mentions(&self.num, i);
        for (j, &e) in self.exps.iter().enumerate() {
            for _ in 0..e {
                den = &den * &bases[j];
            }
            mentions |= e > 0 && field.poly_mentions(&bases[j], i);
        }
        mentions && field.fraction_depends_on(&self.num, &den, i)
    }

    /// ∂/∂q_i. With w = 1/(c∏bⱼ^eⱼ): ∂(N w) = w (∂N − N Σⱼ eⱼ ∂bⱼ/bⱼ).
    pub fn diff(&self, i: usize) -> Over {
        let field = &self.inner().field;
        let den = Denominators(self.d.clone());
        if self.is_zero() {
            return den.int(0);
        }
        let poly = |p: &Poly| Over {
            d: self.d.clone(),
            num: p.clone(),
            exps: Vec::new(),
            cden: field.inner().one(),
        };
        let dn = den.over(&field.poly_diff(&self.num, i));
        let mut inner_sum = dn;
        for (j, &e) in self.exps.iter().enumerate() {
            if e == 0 {
                continue;
            }
            let db = self.dbase(j, i);
            if db.is_zero() {
                continue;
            }
            let mut term = poly(&self.num).mul(&db);
            term.exps.resize(term.exps.len().max(j + 1), 0);
            term.exps[j] += 1;
            let term = term.mul(&den.int(e as i64));
            inner_sum = inner_sum.sub(&term);
        }
        let w = Over {
            d: self.d.clone(),
            num: field.inner().one(),
            exps: self.exps.clone(),
            cden: self.cden.clone(),
        };
        inner_sum.mul(&w)
    }

    fn dbase(&self, j: usize, i: usize) -> Over {
        if let Some(hit) = self.inner().dbase.borrow().get(&(j, i)) {
            return hit.clone();
        }
        let b = self.inner().bases.borrow()[j].clone();
        let den = Denominators(self.d.clone());
        let d = den.over(&self.inner().field.poly_diff(&b, i));
        self.inner().dbase.borrow_mut().insert((j, i), d.clone());
        d
    }
}

/// Σ of terms (skipping zeros), starting from zero.
pub fn sum_over(den: &Denominators, terms: impl IntoIterator<Item = Over>) -> Over {
    terms
        .into_iter()
        .filter(|t| !t.is_zero())
        .fold(den.int(0), |acc, t| acc.add(&t))
}

/// A dense matrix of [`Over`] values, row-major.
#[derive(Clone)]
pub struct OMatrix {
    den: Denominators,
    rows: usize,
    cols: usize,
    data: Vec<Over>,
}

impl std::ops::Index<(usize, usize)> for OMatrix {
    type Output = Over;
    fn index(&self, (i, j): (usize, usize)) -> &Over {
        &self.data[i * self.cols + j]
    }
}

impl std::ops::IndexMut<(usize, usize)> for OMatrix {
    fn index_mut(&mut self, (i, j): (usize, usize)) -> &mut Over {
        &mut self.data[i * self.cols + j]
    }
}

impl OMatrix {
    /// Terms of the entries' numerators, in all (a size measure, [`Over::size`]).
    pub fn size(&self) -> usize {
        self.data.iter().map(Over::size).sum()
    }

    /// Build entry by entry.
    pub fn from_fn(
        den: &Denominators,
        rows: usize,
        cols: usize,
        mut f: impl FnMut(usize, usize) -> Over,
    ) -> OMatrix {
        let mut data = Vec::with_capacity(rows * cols);
        for i in 0..rows {
            for j in 0..cols {
                data.push(f(i, j));
            }
        }
        OMatrix {
            den: den.clone(),
            rows,
            cols,
            data,
        }
    }

    /// A [`crate::Matrix`] expressed over the denominators.
    pub fn from_matrix(den: &Denominators, m: &crate::Matrix) -> OMatrix {
        OMatrix::from_fn(den, m.rows(), m.cols(), |i, j| den.over(&m[(i, j)]))
    }

    /// The zero matrix.
    pub fn zeros(den: &Denominators, rows: usize, cols: usize) -> OMatrix {
        OMatrix::from_fn(den, rows, cols, |_, _| den.int(0))
    }

    /// Number of rows.
    pub fn rows(&self) -> usize {
        self.rows
    }

    /// Number of columns.
    pub fn cols(&self) -> usize {
        self.cols
    }

    /// The transpose.
    pub fn transpose(&self) -> OMatrix {
        OMatrix::from_fn(&self.den, self.cols, self.rows, |i, j| self[(j, i)].clone())
    }

    /// The product `self · other`.
    pub fn mul(&self, other: &OMatrix) -> OMatrix {
        assert_eq!(self.cols, other.rows, "matrix product dimensions");
        let den = &self.den;
        OMatrix::from_fn(den, self.rows, other.cols, |i, j| {
            sum_over(
                den,
                (0..self.cols)
                    .filter(|&k| !self[(i, k)].is_zero() && !other[(k, j)].is_zero())
                    .map(|k| self[(i, k)].mul(&other[(k, j)])),
            )
        })
    }

    /// The difference.
    pub fn sub(&self, other: &OMatrix) -> OMatrix {
        OMatrix::from_fn(&self.den, self.rows, self.cols, |i, j| {
            self[(i, j)].sub(&other[(i, j)])
        })
    }

    /// Entrywise derivative with respect to q_i.
    pub fn diff(&self, i: usize) -> OMatrix {
        OMatrix::from_fn(&self.den, self.rows, self.cols, |r, c| self[(r, c)].diff(i))
    }

    /// Every entry is zero (exact).
    pub fn is_zero(&self) -> bool {
        self.data.iter().all(Over::is_zero)
    }

    /// Back to a [`crate::Matrix`] in lowest terms.
    pub fn to_matrix(&self) -> crate::Matrix {
        crate::Matrix::from_fn(self.rows, self.cols, |i, j| self[(i, j)].to_ex())
    }
}
