//! Collection: a canonical polynomial written as a paper writes it.
//!
//! 1. The rational content and the common monomial come out in front.
//! 2. What is left is collected over the monomials in the state's atoms (the coordinates'
//!    functions and the velocities); each coefficient is a polynomial in the parameters.
//! 3. A coefficient is factored greedily: its own content out, then, while some parameter
//!    occurs in two terms or more, the one occurring most (ties: the one occurring in more
//!    terms of the whole sheet, then the model's order) is pulled out of the terms that have
//!    it: `m_f ρ₁ + m_r ρ₁ + m_r ρ₂` → `m_r(ρ₁ + ρ₂) + m_f ρ₁`.

use std::borrow::Cow;
use std::cell::RefCell;
use std::ops::Range;
use std::sync::{Arc, LazyLock};

use smallvec::SmallVec;

use crate::atoms::{Atoms, Kind};
use crate::factored::Factored;
use crate::form::{Factor, Factors, Form, factor_rank, is_zero};
use crate::memo::Memo;
use crate::poly::{Fraction, Mono, Poly, leading_negative};
use crate::q::Q;

/// What collection works with: the atoms, and the parameter polynomials factored so far (each
/// polynomial is factored once, whatever the number of groups it is the coefficient of).
pub(crate) struct Cx<'a> {
    atoms: &'a Atoms,
    memo: RefCell<Memo<Shared>>,
    /// The denominators' factors collected so far (a sheet's denominators are powers of a
    /// few: each is collected once).
    factors: RefCell<Memo<Shared>>,
    /// The equations' rate coefficients collected so far, as products (a sum one group):
    /// the true equations and the paper's have the same, A_Γ's rows.
    rates: RefCell<Memo<(Q, Factors)>>,
}

/// A polynomial's form as collection keeps it to use again: a sum behind one `Arc`, so that
/// every place it is used shares it (a coefficient or a denominator's factor that recurs is
/// one group, not copies: naming compares, and the check values, each once).
#[derive(Clone)]
enum Shared {
    Sum(Arc<Form>),
    Other(Form),
}

impl Shared {
    fn of(f: Form) -> Shared {
        match f {
            Form::Sum(_) => Shared::Sum(Arc::new(f)),
            other => Shared::Other(other),
        }
    }

    /// As a product `coef · factors` (a sum one group).
    fn factors(self) -> (Q, Factors) {
        match self {
            Shared::Other(Form::Product { coef, factors }) => (coef, factors),
            Shared::Sum(sum) => (Q::one(), smallvec::smallvec![Factor::Group(sum)]),
            Shared::Other(other) => (
                Q::one(),
                smallvec::smallvec![Factor::Group(Arc::new(other))],
            ),
        }
    }

    /// As a group (a product in parentheses too).
    fn group(self) -> Arc<Form> {
        match self {
            Shared::Sum(sum) => sum,
            Shared::Other(other) => Arc::new(other),
        }
    }

    /// As a form of its own.
    fn form(self) -> Form {
        match self {
            Shared::Sum(sum) => Arc::unwrap_or_clone(sum),
            Shared::Other(other) => other,
        }
    }
}

impl<'a> Cx<'a> {
    /// Nothing factored yet.
    pub(crate) fn new(atoms: &'a Atoms) -> Cx<'a> {
        Cx {
            atoms,
            memo: RefCell::default(),
            factors: RefCell::default(),
            rates: RefCell::default(),
        }
    }
}

impl std::ops::Deref for Cx<'_> {
    type Target = Atoms;

    fn deref(&self) -> &Atoms {
        self.atoms
    }
}

/// The printing form of a fraction: a polynomial, or a quotient of two, the sign out of the
/// denominator.
pub(crate) fn fraction(f: &Fraction, atoms: &Atoms) -> Form {
    let cx = Cx::new(atoms);
    match f.den.as_constant() {
        Some(c) if c.is_one() => poly_in(&f.num, &cx),
        _ => {
            let (mut num, mut den) = (poly_in(&f.num, &cx), poly_in(&f.den, &cx));
            if negative(&den) {
                negate(&mut num);
                negate(&mut den);
            }
            Form::Quotient(Box::new(num), Box::new(den))
        }
    }
}

/// The printing form of an entry whose denominator is kept in factors: each factor written
/// once and raised to its power (a group to a power is the group repeated, which rendering
/// writes as the power: `12 F₁(φ)²`), the sign out of the denominator. The parameter
/// polynomials are factored once in `cx` (the entries of a sheet share their coefficients:
/// the unicycle's 15,931 factorings are of 245 polynomials).
pub(crate) fn factored_in(f: &Factored, cx: &Cx<'_>) -> Form {
    if f.factors.is_empty() {
        return poly_over(&f.num, &f.scale, cx);
    }
    let mut coef = f.scale.clone();
    let mut factors = Factors::new();
    for (p, e) in &f.factors {
        let (hash, kept) = cx.factors.borrow().get(p.terms());
        let form = kept.unwrap_or_else(|| {
            let form = Shared::of(poly_in(p, cx));
            cx.factors
                .borrow_mut()
                .insert(hash, p.clone(), form.clone());
            form
        });
        raise(form, *e, &mut coef, &mut factors);
    }
    let (mut num, mut den) = (poly_in(&f.num, cx), sorted(coef, factors, cx));
    if negative(&den) {
        negate(&mut num);
        negate(&mut den);
    }
    Form::Quotient(Box::new(num), Box::new(den))
}

/// `form^e` multiplied into `coef · factors`.
fn raise(form: Shared, e: u32, coef: &mut Q, factors: &mut Factors) {
    match form {
        Shared::Other(Form::Product {
            coef: c,
            factors: more,
        }) => {
            for _ in 0..e {
                *coef = coef.mul(&c);
            }
            for x in more {
                match x {
                    Factor::Atom { index, power } => factors.push(Factor::Atom {
                        index,
                        power: power * e,
                    }),
                    other => factors.extend(std::iter::repeat_n(other, e as usize)),
                }
            }
        }
        sum => factors.extend(std::iter::repeat_n(Factor::Group(sum.group()), e as usize)),
    }
}

/// The printing form of a polynomial (step 1, then 2).
pub(crate) fn poly(p: &Poly, atoms: &Atoms) -> Form {
    poly_in(p, &Cx::new(atoms))
}

fn poly_in(p: &Poly, atoms: &Cx<'_>) -> Form {
    poly_over(p, &Q::one(), atoms)
}

/// The printing form of `p / scale` (`scale` rational, nonzero): `p`'s content divided by it.
fn poly_over(p: &Poly, scale: &Q, atoms: &Cx<'_>) -> Form {
    if p.is_zero() {
        return constant(Q::zero());
    }
    let (c, g) = content_of(p);
    // One term is c · g itself.
    let inner = (p.size() > 1).then(|| {
        by_state(
            &Divided {
                p,
                by: c.recip(),
                g: &g,
            },
            atoms,
        )
    });
    product(c.div(scale), &g, inner, atoms)
}

/// A polynomial's terms divided by `c · g` (its content, in [`poly_over`]), each made as it
/// is read: the quotient is not made as a polynomial of its own (collection splits its terms
/// anyway).
struct Divided<'p> {
    p: &'p Poly,
    /// `1/c`.
    by: Q,
    g: &'p Mono,
}

impl<'p> Divided<'p> {
    /// `p` itself.
    fn whole(p: &'p Poly) -> Divided<'p> {
        static ONE: LazyLock<Mono> = LazyLock::new(Mono::default);
        Divided {
            p,
            by: Q::one(),
            g: &ONE,
        }
    }

    /// The terms `(m/g, a/c)`, each monomial split into the atoms that `keep` holds for and
    /// the rest, in the order of `p`'s terms (which is monomial order when `g` is one:
    /// scaling keeps it; dividing may not).
    fn split_terms<'s>(
        &'s self,
        keep: impl Fn(usize) -> bool + Copy + 's,
    ) -> impl Iterator<Item = (Mono, Mono, Q)> + 's {
        self.p.terms().map(move |(m, a)| {
            let (kept, rest) = m.split_divided(self.g, keep);
            (kept, rest, a.mul(&self.by))
        })
    }

    /// How many terms.
    fn size(&self) -> usize {
        self.p.size()
    }

    /// Whether any term, divided, has an atom that `is`.
    fn any_atom(&self, is: impl Fn(usize) -> bool) -> bool {
        self.p
            .monomials()
            .any(|m| m.pairs().any(|(i, e)| is(i) && e > self.g.exponent(i)))
    }
}

/// [`content`] without `rest`: the rational content `c` (its sign that of the first term) and
/// the greatest common monomial `g` of `p = c · g · rest`.
fn content_of(p: &Poly) -> (Q, Mono) {
    if let Some((m, c)) = p.terms().next().filter(|_| p.size() == 1) {
        return (c.clone(), m.clone());
    }
    let mut monomials = p.monomials();
    let mut g = monomials.next().expect("a nonzero polynomial").clone();
    for m in monomials {
        if g.is_one() {
            break;
        }
        g.retain_common(m);
    }
    let mut c = Q::content(p.coefficients());
    if leading_negative(p) {
        c = c.neg();
    }
    (c, g)
}

/// `p = c · g · rest`: the rational content `c` (its sign that of the first term), the
/// greatest common monomial `g`.
pub(crate) fn content(p: &Poly) -> (Q, Mono, Cow<'_, Poly>) {
    let (c, g) = content_of(p);
    if p.size() == 1 {
        static ONE: LazyLock<Poly> = LazyLock::new(|| Poly::constant(Q::one()));
        return (c, g, Cow::Borrowed(&ONE));
    }
    let one = g.is_one();
    // Scaling keeps the terms' order; dividing by g may not, so those are sorted again.
    let rest = if one && c.is_one() {
        Cow::Borrowed(p)
    } else if one {
        Cow::Owned(p.scale(&c.recip()))
    } else {
        let r = c.recip();
        Cow::Owned(Poly::from_terms(
            p.terms()
                .map(|(m, d)| (m.div(&g).expect("g divides every term"), d.mul(&r)))
                .collect(),
        ))
    };
    (c, g, rest)
}

/// `c · g · (inner)`, factors in printing order; the sign taken out of a sum whose first printed
/// term is negative.
fn product(mut c: Q, g: &Mono, mut inner: Option<Form>, atoms: &Cx<'_>) -> Form {
    if let Some(Form::Sum(terms)) = &mut inner
        && terms.first().is_some_and(negative)
    {
        terms.iter_mut().for_each(negate);
        c = c.neg();
    }
    if c.is_one() && g.is_one() && matches!(inner, Some(Form::Sum(_))) {
        // The sum itself (what `sorted` makes of a lone group), not put in a group first.
        return inner.expect("a sum");
    }
    let mut factors = atoms_of(g);
    match inner {
        None => {}
        Some(Form::Product {
            coef,
            factors: more,
        }) => {
            factors.extend(more);
            return sorted(c.mul(&coef), factors, atoms);
        }
        Some(sum) => factors.push(Factor::Group(Arc::new(sum))),
    }
    sorted(c, factors, atoms)
}

fn sorted(coef: Q, mut factors: Factors, atoms: &Cx<'_>) -> Form {
    if coef.is_one()
        && matches!(factors.as_slice(), [Factor::Group(_)])
        && let Some(Factor::Group(sum)) = factors.pop()
    {
        return Arc::unwrap_or_clone(sum);
    }
    factors.sort_by_key(|x| factor_rank(x, atoms));
    Form::Product {
        coef,
        factors: merged(factors),
    }
}

/// Equal atoms next to each other (after sorting) merged into one power, in place.
fn merged(mut factors: Factors) -> Factors {
    factors.dedup_by(|x, kept| match (kept, x) {
        (Factor::Atom { index: i, power: p }, Factor::Atom { index: j, power: q }) if i == j => {
            *p += *q;
            true
        }
        _ => false,
    });
    factors
}

fn atoms_of(m: &Mono) -> Factors {
    atom_factors(m).collect()
}

/// The atoms of `m` as factors.
fn atom_factors(m: &Mono) -> impl Iterator<Item = Factor> + '_ {
    m.pairs()
        .map(|(index, power)| Factor::Atom { index, power })
}

pub(crate) fn negative(f: &Form) -> bool {
    match f {
        Form::Product { coef, .. } => coef.is_negative(),
        Form::Sum(terms) => terms.first().is_some_and(negative),
        Form::Quotient(num, _) => negative(num),
    }
}

pub(crate) fn negate(f: &mut Form) {
    match f {
        Form::Product { coef, .. } => *coef = coef.neg(),
        Form::Sum(terms) => terms.iter_mut().for_each(negate),
        Form::Quotient(num, _) => negate(num),
    }
}

fn constant(c: Q) -> Form {
    Form::Product {
        coef: c,
        factors: Factors::new(),
    }
}

/// Step 2: the terms grouped by their monomial in the state's atoms; a coefficient that every
/// group shares (up to a rational factor) comes out in front.
fn by_state(p: &Divided<'_>, atoms: &Cx<'_>) -> Form {
    if let Some(form) = by_rates(p, atoms) {
        return form;
    }
    let groups = Groups::of(p, atoms);
    if let Some((common, scales)) = groups.shared_coefficient() {
        let mut rest = Poly::default();
        for (r, c) in groups.runs.iter().zip(scales) {
            rest.add_term(groups.state(r).clone(), c);
        }
        let mut inner = by_state(&Divided::whole(&rest), atoms);
        let sign = if negative(&inner) {
            negate(&mut inner);
            Q::from(-1)
        } else {
            Q::one()
        };
        let common = parameters(common, atoms).group();
        return sorted(
            sign,
            smallvec::smallvec![Factor::Group(common), Factor::Group(Arc::new(inner))],
            atoms,
        );
    }
    groups.collected(atoms)
}

/// An equation as a paper writes it: the terms in the rates of the quasi-velocities collected
/// by rate, each coefficient (a function of the coordinates) in parentheses, `(…) η̇₁ + (…) η̇₂`,
/// then the other terms. None when `p` has no rate.
fn by_rates(p: &Divided<'_>, atoms: &Cx<'_>) -> Option<Form> {
    if !p.any_atom(|i| atoms.is_rate(i)) {
        return None;
    }
    // Each term split into its rates and the rest, sorted by rates then rest: each rate's
    // coefficient is a run, its terms in order (the monomials of `p` are distinct).
    let mut rest = Vec::with_capacity(p.size());
    let mut split: Vec<(Mono, Mono, Q)> = Vec::with_capacity(p.size());
    for (rate, coefficient, c) in p.split_terms(|i| atoms.is_rate(i)) {
        if rate.is_one() {
            rest.push((coefficient, c));
        } else {
            split.push((rate, coefficient, c));
        }
    }
    let mut by_rate: Vec<(SmallVec<[StateKey; 2]>, Mono, Poly)> = runs(split)
        .into_iter()
        .map(|(rate, coefficient)| (state_key(rate.pairs(), atoms), rate, coefficient))
        .collect();
    let rest = if p.g.is_one() {
        Poly::from_sorted(rest)
    } else {
        Poly::from_terms(rest)
    };
    if by_rate.is_empty() || (by_rate.len() == 1 && rest.is_zero()) {
        return None;
    }
    by_rate.sort_unstable_by(|a, b| a.0.cmp(&b.0));
    // A term for each rate, and at most one for each term of the rest.
    let mut terms: Vec<Form> = Vec::with_capacity(by_rate.len() + rest.size());
    terms.extend(by_rate.into_iter().map(|(_, rate, coefficient)| {
        let (coef, mut factors) = rate_coefficient(coefficient, atoms);
        factors.extend(atom_factors(&rate));
        sorted(coef, factors, atoms)
    }));
    if !rest.is_zero() {
        match by_state(&Divided::whole(&rest), atoms) {
            Form::Sum(more) => terms.extend(more),
            one => terms.push(one),
        }
    }
    Some(Form::Sum(terms))
}

/// A rate's coefficient `p` collected, as `coef · factors` (a sum one group); each polynomial
/// collected once for the sheet, its groups shared by every place it occurs.
fn rate_coefficient(p: Poly, atoms: &Cx<'_>) -> (Q, Factors) {
    let (hash, kept) = atoms.rates.borrow().get(p.terms());
    if let Some(kept) = kept {
        return kept;
    }
    let product = match poly_in(&p, atoms) {
        Form::Product { coef, factors } => (coef, factors),
        sum => (Q::one(), smallvec::smallvec![Factor::Group(Arc::new(sum))]),
    };
    atoms.rates.borrow_mut().insert(hash, p, product.clone());
    product
}

/// A state atom's place in the printing order ([`Atoms::rank`]), with its exponent.
type StateKey = (u32, u32);

/// The printing-order keys of a monomial's `(atom, exponent)` pairs.
fn state_key(pairs: impl Iterator<Item = (usize, u32)>, atoms: &Atoms) -> SmallVec<[StateKey; 2]> {
    pairs.map(|(i, e)| (atoms.rank(i), e)).collect()
}

/// A polynomial's terms grouped by their monomial in the state's atoms: each term split into
/// its state and parameter monomials, sorted by state then parameters, so that each group is
/// a run of terms, already in order (the monomials of the polynomial are distinct); the runs
/// in printing order. A group's coefficient is made a polynomial only where it has two terms
/// or more (most have one).
struct Groups {
    split: Vec<(Mono, Mono, Q)>,
    runs: Runs,
}

impl Groups {
    fn of(p: &Divided<'_>, atoms: &Atoms) -> Groups {
        let mut split: Vec<(Mono, Mono, Q)> = p
            .split_terms(|i| atoms.get(i).kind != Kind::Parameter)
            .collect();
        let mut runs = sorted_runs(&mut split);
        if runs.len() > 1 {
            sort_by_key_of(&mut runs, |r| group_order(&split[r.start].0, atoms));
        }
        Groups { split, runs }
    }

    /// The state monomial of the group `r`.
    fn state(&self, r: &Range<usize>) -> &Mono {
        &self.split[r.start].0
    }

    /// The parameter coefficient of the group `r`.
    fn coefficient(&self, r: &Range<usize>) -> Poly {
        let terms = self.split[r.clone()].iter();
        Poly::from_sorted(terms.map(|(_, m, c)| (m.clone(), c.clone())).collect())
    }

    /// When there are two groups or more and every coefficient is `c_i · P` for one
    /// polynomial `P` of two terms or more: `P` and the `c_i`.
    fn shared_coefficient(&self) -> Option<(Poly, Vec<Q>)> {
        // Equal polynomials up to a rational factor have as many terms: only those are
        // compared.
        let size = self.runs.first()?.len();
        if self.runs.len() < 2 || size < 2 || self.runs.iter().any(|r| r.len() != size) {
            return None;
        }
        let mut first: Option<Poly> = None;
        let mut scales = Vec::with_capacity(self.runs.len());
        for r in &self.runs {
            let coef = self.coefficient(r);
            let (c, g, rest) = content(&coef);
            match &first {
                _ if !g.is_one() => return None,
                None => first = Some(rest.into_owned()),
                Some(p) if *p == *rest => {}
                Some(_) => return None,
            }
            scales.push(c);
        }
        first.map(|p| (p, scales))
    }

    /// The collected sum of the groups.
    fn collected(&self, atoms: &Cx<'_>) -> Form {
        // At most a term for each term collected (a coefficient's terms do not multiply).
        let mut terms: Vec<Form> = Vec::with_capacity(self.split.len());
        for r in &self.runs {
            let coefficient = parameters_of_run(&self.split[r.clone()], atoms);
            let (coef, mut factors) = coefficient.factors();
            factors.extend(atom_factors(self.state(r)));
            match sorted(coef, factors, atoms) {
                t if is_zero(&t) => {}
                Form::Sum(inner) => terms.extend(inner),
                one => terms.push(one),
            }
        }
        if terms.len() == 1 {
            return terms.into_iter().next().expect("one term");
        }
        Form::Sum(terms)
    }
}

/// A group's place in a sum: the terms with rates of the quasi-velocities first (by those
/// rates: `η̇₁` before `η̇₂`), as an equation of motion is written, `A_Γ η̇ + …`; then the
/// state atoms in printing order.
fn group_order(
    m: &Mono,
    atoms: &Atoms,
) -> (bool, SmallVec<[StateKey; 2]>, SmallVec<[StateKey; 6]>) {
    let rates: SmallVec<[StateKey; 2]> = keys(m, true, atoms).collect();
    (rates.is_empty(), rates, keys(m, false, atoms).collect())
}

/// The printing-order keys of a monomial's pairs (its rates' alone when `rates`).
fn keys<'a>(m: &'a Mono, rates: bool, atoms: &'a Atoms) -> impl Iterator<Item = StateKey> + 'a {
    m.pairs()
        .filter(move |&(i, _)| !rates || atoms.is_rate(i))
        .map(move |(i, e)| (atoms.rank(i), e))
}

/// Terms `(key, rest, c)` (the products `key · rest` distinct) gathered by key: each key with
/// the polynomial of its rests, keys in order. The terms are sorted by key then rest, so that
/// each key's terms are a run, already in order; each run is measured first, so that every
/// vector is made at its size.
fn runs(mut split: Vec<(Mono, Mono, Q)>) -> Vec<(Mono, Poly)> {
    let ranges = sorted_runs(&mut split);
    let mut out = Vec::with_capacity(ranges.len());
    let mut terms = split.into_iter();
    for length in ranges.iter().map(Range::len) {
        let Some((key, rest, c)) = terms.next() else {
            break;
        };
        let mut run = Vec::with_capacity(length);
        run.push((rest, c));
        run.extend(terms.by_ref().take(length - 1).map(|(_, r, c)| (r, c)));
        out.push((key, Poly::from_sorted(run)));
    }
    out
}

/// Runs of a sorted vector: a sum has a few groups, held in place.
type Runs = SmallVec<[Range<usize>; 4]>;

/// Terms `(key, rest, c)` sorted by key then rest, and the runs of equal keys, in order.
fn sorted_runs(split: &mut [(Mono, Mono, Q)]) -> Runs {
    split.sort_unstable_by(|x, y| (&x.0, &x.1).cmp(&(&y.0, &y.1)));
    let mut runs = Runs::new();
    let mut start = 0;
    for k in 1..=split.len() {
        if k == split.len() || split[k].0 != split[start].0 {
            runs.push(start..k);
            start = k;
        }
    }
    runs
}

/// Step 3: a polynomial in the parameters, factored greedily (each polynomial once: what it
/// is factored into is shared by every place it occurs; a polynomial new to the memo is kept
/// there, not copied).
fn parameters(p: Poly, atoms: &Cx<'_>) -> Shared {
    // A monomial is written as it is: cheaper than looking it up.
    if let (1, Some((m, c))) = (p.size(), p.terms().next()) {
        return monomial(m, c, atoms);
    }
    let (hash, kept) = atoms.memo.borrow().get(p.terms());
    kept.unwrap_or_else(|| factored_new(hash, p, atoms))
}

/// [`parameters`] of the coefficient of a group, the run `run` of its terms `(state,
/// parameters, c)`: made a polynomial only when new to the memo.
fn parameters_of_run(run: &[(Mono, Mono, Q)], atoms: &Cx<'_>) -> Shared {
    let terms = run.iter().map(|(_, m, c)| (m, c));
    if let [(_, m, c)] = run {
        return monomial(m, c, atoms);
    }
    let (hash, kept) = atoms.memo.borrow().get(terms.clone());
    kept.unwrap_or_else(|| {
        let p = Poly::from_sorted(terms.map(|(m, c)| (m.clone(), c.clone())).collect());
        factored_new(hash, p, atoms)
    })
}

/// `p` (new to the memo, its terms hashing to `hash`) factored, and kept in the memo.
fn factored_new(hash: u64, p: Poly, atoms: &Cx<'_>) -> Shared {
    let f = Shared::of(factored(&p, atoms));
    atoms.memo.borrow_mut().insert(hash, p, f.clone());
    f
}

/// The monomial `c · m` in the parameters, as [`parameters`] writes it.
fn monomial(m: &Mono, c: &Q, atoms: &Cx<'_>) -> Shared {
    Shared::Other(sorted(c.clone(), atoms_of(m), atoms))
}

fn factored(p: &Poly, atoms: &Cx<'_>) -> Form {
    let (c, g, rest) = content(p);
    if rest.as_constant().is_some() {
        return product(c, &g, None, atoms);
    }
    product(c, &g, Some(greedy(&rest, atoms)), atoms)
}

/// A content-free polynomial in the parameters as a sum, the most frequent parameter pulled
/// out first.
fn greedy(p: &Poly, atoms: &Cx<'_>) -> Form {
    let Some(a) = most_frequent(p, atoms) else {
        let terms = p
            .terms()
            .map(|(m, c)| sorted(c.clone(), atoms_of(m), atoms))
            .collect();
        return in_order(terms, atoms);
    };
    // The terms without `a` keep their order; those divided by it may not.
    let (mut with, mut without) = (Vec::with_capacity(p.size()), Vec::with_capacity(p.size()));
    for (m, c) in p.terms() {
        match m.div(&Mono::atom(a)) {
            Some(q) => with.push((q, c.clone())),
            None => without.push((m.clone(), c.clone())),
        }
    }
    let (with, without) = (Poly::from_terms(with), Poly::from_sorted(without));
    // The sums the factoring makes are written with their first term positive (`product`):
    // `a · (with)` is the atom times the factors of `with`.
    let (coef, more) = parameters(with, atoms).factors();
    let mut factors: Factors = smallvec::smallvec![Factor::Atom { index: a, power: 1 }];
    factors.extend(more);
    let mut terms = Vec::with_capacity(1 + without.size());
    terms.push(sorted(coef, factors, atoms));
    if !without.is_zero() {
        match parameters(without, atoms).form() {
            Form::Sum(more) => terms.extend(more),
            one => terms.push(one),
        }
    }
    in_order(terms, atoms)
}

/// The terms of a sum in printing order: by their factors' ranks, the model's order first.
fn in_order(mut terms: Vec<Form>, atoms: &Cx<'_>) -> Form {
    if terms.len() < 2 {
        return Form::Sum(terms);
    }
    sort_by_key_of(&mut terms, |t| match t {
        Form::Product { factors, .. } => factors.iter().map(|x| factor_rank(x, atoms)).collect(),
        _ => SmallVec::<[_; 4]>::new(),
    });
    Form::Sum(terms)
}

/// `v` sorted by `key`: a few items by keys made at each comparison (most sums have a few
/// terms: no vector of keys is made), more by keys made once.
fn sort_by_key_of<T, K: Ord>(v: &mut [T], key: impl Fn(&T) -> K) {
    if v.len() <= 8 {
        v.sort_by_key(key);
    } else {
        v.sort_by_cached_key(key);
    }
}

/// The parameter atom occurring in the most terms (at least two); ties go to the one occurring
/// in more terms of the whole sheet, then to the model's order.
fn most_frequent(p: &Poly, atoms: &Atoms) -> Option<usize> {
    // A coefficient has a few parameters: counted in a list, not a map.
    let mut counts: SmallVec<[(usize, usize); 8]> = SmallVec::new();
    for m in p.monomials() {
        for i in m.atoms() {
            match counts.iter_mut().find(|(j, _)| *j == i) {
                Some((_, n)) => *n += 1,
                None => counts.push((i, 1)),
            }
        }
    }
    counts
        .into_iter()
        .filter(|&(_, n)| n >= 2)
        .max_by(|(i, n), (j, k)| {
            n.cmp(k)
                .then_with(|| atoms.weight(*i).cmp(&atoms.weight(*j)))
                .then_with(|| atoms.rank(*j).cmp(&atoms.rank(*i)))
        })
        .map(|(i, _)| i)
}
