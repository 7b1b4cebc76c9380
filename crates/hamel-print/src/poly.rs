//! Sparse polynomials with rational coefficients in the atoms: the canonical form against
//! which a printed form is checked, and what collection works on.

use hamel_expr::{Canonical, Expr};
use num_traits::{Signed, ToPrimitive};

use smallvec::SmallVec;

use crate::atoms::Atoms;
pub use crate::mono::Mono;
use crate::q::Q;

/// A polynomial: its terms sorted by monomial, each monomial once, each coefficient nonzero
/// (a flat vector: sums merge sorted runs, products sort once).
#[derive(Clone, Debug, Default, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct Poly(Vec<(Mono, Q)>);

/// A quotient of polynomials, as canonical forms with a division come.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Fraction {
    /// Numerator.
    pub num: Poly,
    /// Denominator (the constant 1 for a polynomial).
    pub den: Poly,
}

/// Why an expression has no polynomial form.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum PolyError {
    /// A division by the zero polynomial.
    #[error("division by zero in the expression")]
    DivisionByZero,
    /// An exponent that is not a small integer, on a base that is not an atom.
    #[error("the exponent of `{0}` is not an integer")]
    Exponent(String),
    /// An exponent of 65,535 or more, or a sheet of 65,535 atoms or more
    /// ([`Mono::is_exact`]).
    #[error(
        "an exponent or a number of distinct subexpressions too large to print (65,535 or more)"
    )]
    TooLarge,
}

impl Poly {
    /// The constant `c`.
    pub fn constant(c: impl Into<Q>) -> Poly {
        Poly::term(Mono::default(), c)
    }

    /// `c · m`.
    pub fn term(m: Mono, c: impl Into<Q>) -> Poly {
        let c = c.into();
        if c.is_zero() {
            return Poly::default();
        }
        Poly(vec![(m, c)])
    }

    /// Whether every monomial is exact ([`Mono::is_exact`]: nothing saturated).
    pub fn is_exact(&self) -> bool {
        self.0.iter().all(|(m, _)| m.is_exact())
    }

    /// The polynomial with these terms, in any order, a monomial possibly repeated (the
    /// coefficients of equal monomials are added, zeros dropped).
    pub fn from_terms(mut terms: Vec<(Mono, Q)>) -> Poly {
        terms.sort_unstable_by(|a, b| a.0.cmp(&b.0));
        // Mostly the monomials are distinct already (an exported canonical form's are): then
        // the sorted terms are the polynomial, kept where they are.
        let distinct = terms.windows(2).all(|w| w[0].0 != w[1].0);
        if distinct && terms.iter().all(|(_, c)| !c.is_zero()) {
            return Poly(terms);
        }
        let mut out: Vec<(Mono, Q)> = Vec::with_capacity(terms.len());
        for (m, c) in terms {
            match out.last_mut() {
                Some((last, d)) if *last == m => *d = d.add(&c),
                _ => {
                    if out.last().is_some_and(|(_, d)| d.is_zero()) {
                        out.pop();
                    }
                    out.push((m, c));
                }
            }
        }
        if out.last().is_some_and(|(_, d)| d.is_zero()) {
            out.pop();
        }
        Poly(out)
    }

    /// The polynomial with these terms, given sorted by monomial, each monomial once, no
    /// coefficient zero.
    pub(crate) fn from_sorted(terms: Vec<(Mono, Q)>) -> Poly {
        debug_assert!(terms.windows(2).all(|w| w[0].0 < w[1].0));
        debug_assert!(terms.iter().all(|(_, c)| !c.is_zero()));
        Poly(terms)
    }

    /// The terms, in monomial order.
    pub fn terms(&self) -> impl ExactSizeIterator<Item = (&Mono, &Q)> + Clone {
        self.0.iter().map(|(m, c)| (m, c))
    }

    /// The monomials, in order.
    pub fn monomials(&self) -> impl Iterator<Item = &Mono> + Clone {
        self.0.iter().map(|(m, _)| m)
    }

    /// The coefficients, in monomial order.
    pub fn coefficients(&self) -> impl Iterator<Item = &Q> + Clone {
        self.0.iter().map(|(_, c)| c)
    }

    /// The number of terms.
    pub fn size(&self) -> usize {
        self.0.len()
    }

    /// Adds `c · m`, dropping the term if it cancels.
    pub fn add_term(&mut self, m: Mono, c: impl Into<Q>) {
        let c = c.into();
        if c.is_zero() {
            return;
        }
        match self.0.binary_search_by(|(n, _)| n.cmp(&m)) {
            Ok(k) => {
                let sum = self.0[k].1.add(&c);
                if sum.is_zero() {
                    self.0.remove(k);
                } else {
                    self.0[k].1 = sum;
                }
            }
            Err(k) => self.0.insert(k, (m, c)),
        }
    }

    /// Whether this is the zero polynomial.
    pub fn is_zero(&self) -> bool {
        self.0.is_empty()
    }

    /// `self += other` (a merge of the two sorted runs).
    pub fn add_assign(&mut self, other: &Poly) {
        if other.is_zero() {
            return;
        }
        let mine = std::mem::take(&mut self.0);
        let mut out = Vec::with_capacity(mine.len() + other.0.len());
        let mut theirs = other.0.iter().peekable();
        for (m, c) in mine {
            while let Some((n, d)) = theirs.next_if(|(n, _)| *n < m) {
                out.push((n.clone(), d.clone()));
            }
            match theirs.next_if(|(n, _)| *n == m) {
                Some((_, d)) => {
                    let sum = c.add(d);
                    if !sum.is_zero() {
                        out.push((m, sum));
                    }
                }
                None => out.push((m, c)),
            }
        }
        out.extend(theirs.cloned());
        self.0 = out;
    }

    /// `self · other`.
    pub fn mul(&self, other: &Poly) -> Poly {
        if let Some(c) = other.as_constant() {
            return self.scale(&c);
        }
        if let Some(c) = self.as_constant() {
            return other.scale(&c);
        }
        let mut out = Vec::with_capacity(self.0.len() * other.0.len());
        for (m, c) in &self.0 {
            for (n, d) in &other.0 {
                out.push((m.mul(n), c.mul(d)));
            }
        }
        Poly::from_terms(out)
    }

    /// `c · self`.
    pub fn scale(&self, c: &Q) -> Poly {
        if c.is_one() {
            return self.clone();
        }
        if c.is_zero() {
            return Poly::default();
        }
        Poly(self.0.iter().map(|(m, d)| (m.clone(), c.mul(d))).collect())
    }

    /// `self^n`.
    pub fn pow(&self, n: u32) -> Poly {
        match n {
            0 => Poly::constant(Q::one()),
            _ => (1..n).fold(self.clone(), |acc, _| acc.mul(self)),
        }
    }

    /// `c` with `self = c · other`, when there is one (`other` nonzero).
    pub fn ratio(&self, other: &Poly) -> Option<Q> {
        if self.0.len() != other.0.len() {
            return None;
        }
        let (_, a) = self.0.first()?;
        let (_, b) = other.0.first()?;
        let c = a.div(b);
        self.0
            .iter()
            .zip(&other.0)
            .all(|((m, x), (n, y))| m == n && *x == c.mul(y))
            .then_some(c)
    }

    /// Whether this is the constant 1.
    pub fn is_one(&self) -> bool {
        matches!(self.0.as_slice(), [(m, c)] if m.is_one() && c.is_one())
    }

    /// The constant value, if this is a constant.
    pub fn as_constant(&self) -> Option<Q> {
        match self.0.as_slice() {
            [] => Some(Q::zero()),
            [(m, c)] if m.is_one() => Some(c.clone()),
            _ => None,
        }
    }
}

impl From<Poly> for Fraction {
    /// The polynomial over 1.
    fn from(p: Poly) -> Fraction {
        Fraction::poly(p)
    }
}

impl Fraction {
    /// The constant `c`.
    pub fn constant(c: impl Into<Q>) -> Fraction {
        Fraction::poly(Poly::constant(c))
    }

    /// Atom `i` to the power `n`.
    pub fn atom(i: usize, n: u32) -> Fraction {
        Fraction::poly(Poly::term(Mono::from_pairs([(i, n)]), Q::one()))
    }

    /// `self / other`.
    pub fn over(&self, other: &Fraction) -> Fraction {
        self.times(&Fraction {
            num: other.den.clone(),
            den: other.num.clone(),
        })
    }

    fn poly(p: Poly) -> Fraction {
        Fraction {
            num: p,
            den: Poly::constant(Q::one()),
        }
    }

    /// The canonical expression `e` over the atoms: sums, products, integer powers and
    /// quotients are expanded; anything else (functions, non-integer powers) is an atom.
    pub fn from_expr(e: &Expr, atoms: &mut Atoms) -> Result<Fraction, PolyError> {
        let f = Fraction::read(e, atoms)?;
        if f.num.is_exact() && f.den.is_exact() {
            Ok(f)
        } else {
            Err(PolyError::TooLarge)
        }
    }

    /// [`Fraction::from_expr`] with the atoms numbered by `atoms` (a sheet's, or an entry's
    /// own while entries are read in parallel: `read.rs`).
    pub(crate) fn read(e: &Expr, atoms: &mut Atoms) -> Result<Fraction, PolyError> {
        Ok(match e {
            Expr::Num(r) => Fraction::poly(Poly::constant(r)),
            Expr::Add(v) => {
                // The monomial terms gathered and sorted once, the others added one by one.
                let mut monomials = Vec::with_capacity(v.len());
                let mut others = Vec::new();
                for t in v {
                    match monomial(t, atoms) {
                        Some((c, m)) => monomials.push((m, c)),
                        None => others.push(Fraction::read(t, atoms)?),
                    }
                }
                let sum = Fraction::poly(Poly::from_terms(monomials));
                if others.is_empty() {
                    return Ok(sum);
                }
                others.push(sum);
                Fraction::sum(others)
            }
            Expr::Mul(_) if let Some((c, m)) = monomial(e, atoms) => {
                Fraction::poly(Poly::term(m, c))
            }
            Expr::Mul(v) => {
                let mut acc = Fraction::poly(Poly::constant(Q::one()));
                for t in v {
                    acc = acc.times(&Fraction::read(t, atoms)?);
                }
                acc
            }
            Expr::Neg(a) => {
                let f = Fraction::read(a, atoms)?;
                Fraction {
                    num: f.num.scale(&Q::from(-1)),
                    den: f.den,
                }
            }
            Expr::Div(a, b) => {
                let (a, b) = (Fraction::read(a, atoms)?, Fraction::read(b, atoms)?);
                if b.num.is_zero() {
                    return Err(PolyError::DivisionByZero);
                }
                a.times(&Fraction {
                    num: b.den,
                    den: b.num,
                })
            }
            Expr::Pow(base, exp) => Fraction::power(base, exp, e, atoms)?,
            _ => Fraction::poly(Poly::term(Mono::atom(atoms.intern(e)), Q::one())),
        })
    }

    /// The number `atoms` gives each of `c`'s atoms, numbered in the order met
    /// (`Canonical::atoms_met`: the numerator's terms, then the factors', each term's atoms in
    /// order); the terms are read only until every atom is met.
    pub(crate) fn numbering(c: &Canonical, atoms: &mut Atoms) -> Vec<usize> {
        let mut map = Vec::new();
        Fraction::numbering_into(c, atoms, &mut map);
        map
    }

    /// [`Fraction::numbering`] appended to `out` (a sheet's entries' maps in one vector).
    pub(crate) fn numbering_into(c: &Canonical, atoms: &mut Atoms, out: &mut Vec<usize>) {
        let start = out.len();
        out.resize(start + c.atoms.len(), usize::MAX);
        let map = &mut out[start..];
        let mut left = c.atoms.len();
        let all = c.factors.iter().flat_map(|(t, _)| t);
        for t in c.num.iter().chain(all) {
            if left == 0 {
                break;
            }
            for &(a, _) in &t.powers {
                if map[a as usize] == usize::MAX {
                    let atom = &c.atoms[a as usize];
                    map[a as usize] = match c.ids.get(a as usize) {
                        Some(&id) => atoms.intern_numbered(id, atom),
                        None => atoms.intern(atom),
                    };
                    left -= 1;
                }
            }
        }
    }

    /// `base^exp`: expanded for a small integer exponent, an atom otherwise.
    fn power(
        base: &Expr,
        exp: &Expr,
        whole: &Expr,
        atoms: &mut Atoms,
    ) -> Result<Fraction, PolyError> {
        let Some(n) = exp.as_integer().filter(|n| n.abs() <= 64) else {
            if matches!(
                base,
                Expr::Sym(_) | Expr::Call(..) | Expr::Atan2(..) | Expr::Der(_)
            ) {
                let atom = atoms.intern(whole);
                return Ok(Fraction::poly(Poly::term(Mono::atom(atom), Q::one())));
            }
            return Err(PolyError::Exponent(base.to_string()));
        };
        let f = Fraction::read(base, atoms)?;
        let k = n.unsigned_abs().to_u32().unwrap_or(0);
        let (num, den) = (f.num.pow(k), f.den.pow(k));
        if n >= 0 {
            Ok(Fraction { num, den })
        } else if num.is_zero() {
            Err(PolyError::DivisionByZero)
        } else {
            Ok(Fraction { num: den, den: num })
        }
    }

    /// `self + other` (`self` taken, its numerator added to in place when the denominators
    /// agree).
    pub fn plus(mut self, other: &Fraction) -> Fraction {
        if self.den == other.den {
            self.num.add_assign(&other.num);
            return self;
        }
        let mut num = self.num.mul(&other.den);
        num.add_assign(&other.num.mul(&self.den));
        Fraction {
            num,
            den: self.den.mul(&other.den),
        }
    }

    /// The sum of `parts`: the polynomial ones gathered and sorted once (adding them one by
    /// one would merge the growing sum again at every step), the others added in turn.
    pub fn sum(parts: impl IntoIterator<Item = Fraction>) -> Fraction {
        let mut terms = Vec::new();
        let mut acc: Option<Fraction> = None;
        for f in parts {
            if f.den.is_one() {
                terms.extend(f.num.0);
            } else {
                acc = Some(
                    acc.unwrap_or_else(|| Fraction::poly(Poly::default()))
                        .plus(&f),
                );
            }
        }
        let polynomial = Fraction::poly(Poly::from_terms(terms));
        match acc {
            Some(acc) => acc.plus(&polynomial),
            None => polynomial,
        }
    }

    /// `self · other`.
    pub fn times(&self, other: &Fraction) -> Fraction {
        Fraction {
            num: self.num.mul(&other.num),
            den: self.den.mul(&other.den),
        }
    }

    /// Whether `self` and `other` are the same rational function: numerators compared
    /// directly when the denominators are equal up to a constant, cross-multiplied otherwise.
    pub fn same(&self, other: &Fraction) -> bool {
        match self.den.ratio(&other.den) {
            Some(c) => self.num == other.num.scale(&c),
            None => self.num.mul(&other.den) == other.num.mul(&self.den),
        }
    }

    /// A constant denominator folded into the numerator.
    pub fn normalised(self) -> Fraction {
        match self.den.as_constant() {
            Some(c) if !c.is_zero() && !c.is_one() => Fraction::poly(self.num.scale(&c.recip())),
            _ => self,
        }
    }
}

/// `e` as `c · m` when it is a monomial (a product of numbers, atoms and their natural
/// powers, possibly negated): the common shape of a canonical form's terms, read without
/// building a polynomial per factor. The atoms are those [`Fraction::from_expr`] makes.
fn monomial(e: &Expr, atoms: &mut Atoms) -> Option<(Q, Mono)> {
    let mut c = Q::one();
    let mut pairs = SmallVec::new();
    factors_of(e, 1, &mut c, &mut pairs, atoms)?;
    Some((c, Mono::from_packed(pairs)))
}

/// The factors of the monomial `e^k`: its number multiplied into `c`, its atoms' pairs
/// pushed (unsorted, an atom possibly twice); None if `e` is not a monomial.
fn factors_of(
    e: &Expr,
    k: u32,
    c: &mut Q,
    pairs: &mut SmallVec<[u32; 8]>,
    atoms: &mut Atoms,
) -> Option<()> {
    match e {
        Expr::Num(r) => {
            let r = Q::from(r);
            for _ in 0..k {
                *c = c.mul(&r);
            }
        }
        Expr::Neg(a) => {
            factors_of(a, k, c, pairs, atoms)?;
            if k % 2 == 1 {
                *c = c.neg();
            }
        }
        Expr::Mul(v) => {
            for t in v {
                factors_of(t, k, c, pairs, atoms)?;
            }
        }
        Expr::Pow(base, exp) => {
            let n = exp.as_integer()?;
            let n = u32::try_from(n).ok().filter(|n| (1..=64).contains(n))?;
            factors_of(base, k.checked_mul(n)?, c, pairs, atoms)?;
        }
        Expr::Add(_) | Expr::Div(..) => return None,
        _ => pairs.push(Mono::pack_pair(atoms.intern(e), k)),
    }
    Some(())
}

/// The sign of the first term in monomial order (for a deterministic sign convention).
pub(crate) fn leading_negative(p: &Poly) -> bool {
    p.0.first().is_some_and(|(_, c)| c.is_negative())
}
