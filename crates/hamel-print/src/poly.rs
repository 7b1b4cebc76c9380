//! Sparse polynomials with rational coefficients in the atoms: the canonical form against
//! which a printed form is checked, and what collection works on.

use hamel_expr::{Canonical, Expr};
use num_traits::{Signed, ToPrimitive};

use smallvec::SmallVec;

use crate::atoms::Atoms;
use crate::q::Q;

/// A monomial: `(atom, exponent)` pairs, sorted by atom index, exponents ≥ 1; a few pairs
/// held inline (most monomials of a derivation have four atoms or fewer), more on the heap.
/// Each pair is packed in one word, the atom in the high half (`pack`): the words order as
/// the pairs do, and compare, hash and test equal as one slice of machine integers.
#[derive(Debug, Default, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct Mono(Pairs);

impl Clone for Mono {
    /// The pairs copied whole (smallvec's own clone pushes them one at a time: a monomial
    /// is cloned for every term that collection moves).
    fn clone(&self) -> Mono {
        Mono(Pairs::from_slice(&self.0))
    }
}

/// A monomial's pairs, packed.
type Pairs = SmallVec<[u64; 8]>;

/// The pair `(i, e)` in one word: `i` high, `e` low, so that words order as pairs do.
fn pack(i: u32, e: u32) -> u64 {
    (u64::from(i) << 32) | u64::from(e)
}

/// A packed pair's atom.
fn atom_of(p: u64) -> u32 {
    (p >> 32) as u32
}

/// A packed pair's exponent.
fn exponent_of(p: u64) -> u32 {
    p as u32
}

/// A packed pair `(i, e)` as `(i, e)`.
fn unpack(p: u64) -> (u32, u32) {
    (atom_of(p), exponent_of(p))
}

/// An atom's index as a monomial stores it. A sheet's atoms are distinct subexpressions of
/// what it prints, far fewer than 2³².
fn stored(i: usize) -> u32 {
    u32::try_from(i).expect("fewer than 2^32 atoms")
}

impl Mono {
    /// The atom `i` to the first power.
    pub fn atom(i: usize) -> Mono {
        Mono::from_pairs([(i, 1)])
    }

    /// The monomial with these `(atom, exponent)` pairs, given sorted by atom, each atom
    /// once, exponents ≥ 1.
    pub fn from_pairs(pairs: impl IntoIterator<Item = (usize, u32)>) -> Mono {
        Mono(pairs.into_iter().map(|(i, e)| pack(stored(i), e)).collect())
    }

    /// The monomial with these `(atom, exponent)` pairs, in any order, an atom possibly more
    /// than once (its exponents added).
    pub(crate) fn from_unsorted(pairs: impl IntoIterator<Item = (usize, u32)>) -> Mono {
        let mut pairs: Pairs = pairs.into_iter().map(|(i, e)| pack(stored(i), e)).collect();
        sort_pairs(&mut pairs);
        Mono(pairs)
    }

    /// The `(atom, exponent)` pairs, sorted by atom.
    pub fn pairs(&self) -> impl ExactSizeIterator<Item = (usize, u32)> + Clone + '_ {
        self.0
            .iter()
            .map(|&p| (atom_of(p) as usize, exponent_of(p)))
    }

    /// The atoms, in order.
    pub fn atoms(&self) -> impl ExactSizeIterator<Item = usize> + Clone + '_ {
        self.0.iter().map(|&p| atom_of(p) as usize)
    }

    /// Whether this is the monomial 1 (no atom).
    pub fn is_one(&self) -> bool {
        self.0.is_empty()
    }

    /// The product of two monomials (a merge of the sorted pairs).
    pub fn mul(&self, other: &Mono) -> Mono {
        let (a, b) = (&self.0, &other.0);
        let mut out = Pairs::with_capacity(a.len() + b.len());
        let (mut i, mut j) = (0, 0);
        while i < a.len() && j < b.len() {
            match atom_of(a[i]).cmp(&atom_of(b[j])) {
                std::cmp::Ordering::Less => {
                    out.push(a[i]);
                    i += 1;
                }
                std::cmp::Ordering::Greater => {
                    out.push(b[j]);
                    j += 1;
                }
                std::cmp::Ordering::Equal => {
                    out.push(pack(atom_of(a[i]), exponent_of(a[i]) + exponent_of(b[j])));
                    i += 1;
                    j += 1;
                }
            }
        }
        out.extend_from_slice(&a[i..]);
        out.extend_from_slice(&b[j..]);
        Mono(out)
    }

    /// `self / other`, when `other` divides `self`.
    pub fn div(&self, other: &Mono) -> Option<Mono> {
        let mut out = Pairs::with_capacity(self.0.len());
        let mut theirs = other.0.iter().map(|&p| unpack(p)).peekable();
        for (i, e) in self.0.iter().map(|&p| unpack(p)) {
            let f = match theirs.peek() {
                Some(&(k, f)) if k == i => {
                    theirs.next();
                    f
                }
                Some(&(k, _)) if k < i => return None,
                _ => 0,
            };
            let left = e.checked_sub(f)?;
            if left > 0 {
                out.push(pack(i, left));
            }
        }
        theirs.next().is_none().then_some(Mono(out))
    }

    /// `self` made the greatest common divisor of itself and `other`, in place.
    pub(crate) fn retain_common(&mut self, other: &Mono) {
        let mut theirs = other.0.iter().map(|&p| unpack(p)).peekable();
        let mut kept = 0;
        for k in 0..self.0.len() {
            let (i, e) = unpack(self.0[k]);
            while theirs.next_if(|&(j, _)| j < i).is_some() {}
            if let Some((_, f)) = theirs.next_if(|&(j, _)| j == i) {
                self.0[kept] = pack(i, e.min(f));
                kept += 1;
            }
        }
        self.0.truncate(kept);
    }

    /// The exponent of atom `i`.
    pub fn exponent(&self, i: usize) -> u32 {
        self.pairs().find(|&(a, _)| a == i).map_or(0, |(_, e)| e)
    }

    /// [`Mono::split`] of `self / g` (`g` divides `self`), without making the quotient.
    pub(crate) fn split_divided(&self, g: &Mono, keep: impl Fn(usize) -> bool) -> (Mono, Mono) {
        if g.is_one() {
            return self.split(keep);
        }
        let (mut kept, mut rest) = (Pairs::new(), Pairs::new());
        let mut theirs = g.0.iter().map(|&p| unpack(p)).peekable();
        for (i, e) in self.0.iter().map(|&p| unpack(p)) {
            let f = theirs.next_if(|&(k, _)| k == i).map_or(0, |(_, f)| f);
            let left = e - f;
            if left == 0 {
                continue;
            }
            if keep(i as usize) {
                kept.push(pack(i, left));
            } else {
                rest.push(pack(i, left));
            }
        }
        (Mono(kept), Mono(rest))
    }

    /// The part made of atoms for which `keep` holds, and the rest (their product is
    /// `self`).
    pub(crate) fn split(&self, keep: impl Fn(usize) -> bool) -> (Mono, Mono) {
        let (mut kept, mut rest) = (Pairs::new(), Pairs::new());
        for &p in &self.0 {
            if keep(atom_of(p) as usize) {
                kept.push(p);
            } else {
                rest.push(p);
            }
        }
        (Mono(kept), Mono(rest))
    }
}

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
        Fraction::read(e, atoms)
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
            if matches!(base, Expr::Sym(_) | Expr::Call(..) | Expr::Der(_)) {
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
    let mut pairs = Pairs::new();
    factors_of(e, 1, &mut c, &mut pairs, atoms)?;
    sort_pairs(&mut pairs);
    Some((c, Mono(pairs)))
}

/// Pairs sorted by atom, an atom's pairs merged into one (exponents added): a monomial's
/// pairs from factors met in any order.
fn sort_pairs(pairs: &mut Pairs) {
    pairs.sort_unstable_by_key(|&p| atom_of(p));
    pairs.dedup_by(|later, earlier| {
        let same = atom_of(*later) == atom_of(*earlier);
        if same {
            *earlier = pack(
                atom_of(*earlier),
                exponent_of(*earlier) + exponent_of(*later),
            );
        }
        same
    });
}

/// The factors of the monomial `e^k`: its number multiplied into `c`, its atoms' pairs
/// pushed (unsorted, an atom possibly twice); None if `e` is not a monomial.
fn factors_of(e: &Expr, k: u32, c: &mut Q, pairs: &mut Pairs, atoms: &mut Atoms) -> Option<()> {
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
        _ => pairs.push(pack(stored(atoms.intern(e)), k)),
    }
    Some(())
}

/// The sign of the first term in monomial order (for a deterministic sign convention).
pub(crate) fn leading_negative(p: &Poly) -> bool {
    p.0.first().is_some_and(|(_, c)| c.is_negative())
}

#[cfg(test)]
mod tests {
    use super::{pack, unpack};

    /// Packed pairs order as the pairs do (what keeps a polynomial's terms, and so the
    /// printed forms, in the order they had), and unpack to themselves.
    #[test]
    fn packed_pairs_order_as_pairs() {
        let values = [0, 1, 2, 7, 255, 65_536, u32::MAX - 1, u32::MAX];
        let pairs: Vec<(u32, u32)> = values
            .iter()
            .flat_map(|&i| values.iter().map(move |&e| (i, e)))
            .collect();
        for &a in &pairs {
            assert_eq!(unpack(pack(a.0, a.1)), a);
            for &b in &pairs {
                assert_eq!(
                    pack(a.0, a.1).cmp(&pack(b.0, b.1)),
                    a.cmp(&b),
                    "{a:?} {b:?}"
                );
            }
        }
    }
}
