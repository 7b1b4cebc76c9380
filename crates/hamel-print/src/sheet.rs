//! A sheet: expressions printed together, sharing their atoms and a where-list of named
//! groups, as a paper names κ₁, κ₂ and F₁(θ, θ₁) once and uses them in every entry.

use std::borrow::Cow;
use std::collections::{BTreeMap, BTreeSet};
use std::sync::OnceLock;

use foldhash::HashMap;

use hamel_expr::Expr;

use crate::atoms::{Atoms, Kind, Vocabulary};
use crate::collect;
use crate::form::{Ctx, Definition, Factor, Form, Latex, Syntax, Text, argument, render, to_expr};
use crate::places::{Keyed, hashed_groups, kinds, place};
use crate::poly::{Fraction, Mono, Poly, PolyError};
use crate::q::Q;
use crate::read::Source;

/// Expressions printed together with their where-list.
#[derive(Clone, Debug)]
pub struct Sheet {
    pub(crate) atoms: Atoms,
    pub(crate) entries: Vec<(Form, Fraction)>,
    /// How many times each entry is shown (equal entries are printed once and counted, so
    /// that a group in two equal entries recurs).
    counts: Vec<usize>,
    pub(crate) names: Vec<Definition>,
    /// The names the model gave ([`Sheet::abbreviate`]), by index.
    given: Vec<usize>,
    /// Each name's value, its definition expanded (computed once, when first needed: a
    /// name is told apart from the others by its value at [`Sheet::point`]).
    values: Vec<OnceLock<Fraction>>,
    /// A random point at which names' values are compared before they are expanded
    /// (`modular.rs`).
    pub(crate) point: crate::modular::Point,
    /// Another, at which each printed form is checked against its canonical form
    /// ([`Sheet::first_mismatch`]).
    check: crate::modular::Point,
    /// Each entry's canonical form's value at [`Sheet::check`] (none at a pole), taken as it
    /// is read on printing's pool; none for an entry read on the calling thread (its value
    /// is taken when it is checked).
    at_check: Vec<Option<Option<crate::modular::V>>>,
    /// The last number given to a parameter group (`kappaN`) and to a function (`FN`).
    numbers: [usize; 2],
    /// Atoms whose argument is printed by name (atom ↦ name; the name's value is the
    /// argument, checked by [`Sheet::check_arguments`]).
    pub(crate) arguments: BTreeMap<usize, usize>,
    /// Equations multiplied through by a denominator proved positive (entry ↦ that
    /// denominator): the entry's form is then the numerator, and its canonical form times the
    /// multiplier ([`Sheet::multiply_through`]).
    pub(crate) multipliers: BTreeMap<usize, Form>,
    /// The atoms whose argument [`Sheet::name_wide`] has looked at (each once), by index.
    pub(crate) examined: Vec<bool>,
    /// Whether the entries are many enough to be worked on printing's pool.
    pub(crate) parallel: bool,
}

impl Sheet {
    /// An empty sheet for a model's names.
    pub fn new(vocabulary: &Vocabulary) -> Sheet {
        Sheet::of(vocabulary.clone())
    }

    /// [`Sheet::new`], taking the names.
    pub(crate) fn of(vocabulary: Vocabulary) -> Sheet {
        Sheet {
            atoms: Atoms::new(vocabulary),
            entries: Vec::new(),
            counts: Vec::new(),
            names: Vec::new(),
            given: Vec::new(),
            values: Vec::new(),
            point: crate::modular::Point::random(),
            check: crate::modular::Point::random(),
            at_check: Vec::new(),
            arguments: BTreeMap::new(),
            numbers: [0, 0],
            multipliers: BTreeMap::new(),
            examined: Vec::new(),
            parallel: false,
        }
    }

    /// Adds the canonical expression `e`; returns its index.
    ///
    /// # Errors
    /// An expression with no rational form over its atoms.
    pub fn add(&mut self, e: &Expr) -> Result<usize, PolyError> {
        Ok(self.add_all([e])?[0])
    }

    /// Names the parameter expression `e` `name` (a model's `[abbreviations]`): wherever
    /// printing meets a group that is a rational multiple of it, it writes the name (`m` for
    /// m_d + m_f + m_r). Call before [`Sheet::name_groups`].
    ///
    /// # Errors
    /// An expression with no rational form over its atoms.
    pub fn abbreviate(&mut self, name: &str, e: &Expr) -> Result<(), PolyError> {
        let value = Fraction::from_expr(e, &mut self.atoms)?.normalised();
        let form = collect::fraction(&value, &self.atoms);
        self.given.push(self.names.len());
        self.names
            .push(Definition::new(name.to_string(), Vec::new(), form, true));
        self.values.push(OnceLock::from(value));
        Ok(())
    }

    /// The forms in which the given names' groups appear, content-free as collection writes
    /// a group, with the factor from the form to the name's value: `(form, name, 1/c)`.
    fn given_forms(&self) -> Vec<(Form, usize, Q)> {
        let mut out = Vec::new();
        for (j, _) in self.names.iter().enumerate().filter(|(_, d)| d.given) {
            if let Some((c, rest)) = key(self.value(j)) {
                out.push((collect::poly(&rest, &self.atoms), j, c.recip()));
            }
        }
        out
    }

    /// Adds the canonical expressions `es` together; returns their indices. Where the
    /// factoring of a coefficient could pull out either of two parameters, it pulls out the
    /// one that occurs in more terms across all of them (so that equal groups recur and the
    /// entries are factored alike: `m_r(ρ₁ + ρ₂)` wherever the rider's mass multiplies both).
    ///
    /// # Errors
    /// An expression with no rational form over its atoms (nothing is added then).
    pub fn add_all<'a>(
        &mut self,
        es: impl IntoIterator<Item = &'a Expr>,
    ) -> Result<Vec<usize>, PolyError> {
        self.add_counted(es.into_iter().map(|e| (Source::Tree(e), 1)))
    }

    /// [`Sheet::add_all`], each expression with the number of times it is shown. The entries
    /// are read and collected on printing's pool when they are large enough (`read.rs`).
    pub(crate) fn add_counted<'a>(
        &mut self,
        es: impl IntoIterator<Item = (Source<'a>, usize)>,
    ) -> Result<Vec<usize>, PolyError> {
        let es: Vec<(Source<'a>, usize)> = es.into_iter().collect();
        let parallel = crate::par::worth_it(es.iter().map(|(e, _)| crate::read::terms(e)));
        self.parallel |= parallel;
        let read = crate::read::entries(&es, parallel, &mut self.atoms)?;
        let first = self.entries.len();
        let (atoms, check) = (&self.atoms, &self.check);
        let forms = crate::par::map_init_owned(
            read,
            parallel,
            || (collect::Cx::new(atoms), check.residues()),
            |(cx, point), canonical| {
                let value = parallel.then(|| point.fraction(&canonical));
                (collect::fraction_in(&canonical, cx), canonical, value)
            },
        );
        for (form, canonical, value) in forms {
            self.entries.push((form, canonical));
            self.at_check.push(value);
        }
        self.counts.extend(es.iter().map(|(_, n)| *n));
        // The model's abbreviations written with the same factoring.
        for (d, v) in self.names.iter_mut().zip(&self.values) {
            if let Some(v) = v.get().filter(|_| d.given) {
                d.form = collect::fraction(v, &self.atoms);
            }
        }
        Ok((first..self.entries.len()).collect())
    }

    /// How many of the entries shown are entry `i` (equal entries are printed once).
    pub(crate) fn shown(&self, i: usize) -> usize {
        self.counts[i]
    }

    /// The printing form of entry `i`.
    pub fn form(&self, i: usize) -> &Form {
        &self.entries[i].0
    }

    pub(crate) fn ctx(&self) -> Ctx<'_> {
        Ctx {
            atoms: &self.atoms,
            names: &self.names,
            arguments: &self.arguments,
        }
    }

    /// Entry `i` in the model syntax, named groups by name.
    pub fn text(&self, i: usize) -> String {
        render(&self.entries[i].0, self.ctx(), &Text)
    }

    /// Entry `i` in LaTeX.
    pub fn latex(&self, i: usize) -> String {
        render(&self.entries[i].0, self.ctx(), &Latex)
    }

    /// The where-list: `(name with arguments, definition)` in text.
    pub fn definitions_text(&self) -> Vec<(String, String)> {
        (0..self.names.len())
            .map(|j| self.definition_text(j))
            .collect()
    }

    /// Name `j` (with its arguments) and its definition in the model syntax.
    pub fn definition_text(&self, j: usize) -> (String, String) {
        let d = &self.names[j];
        (Text.name(d).to_string(), render(&d.form, self.ctx(), &Text))
    }

    /// Name `j` with its arguments, in LaTeX.
    pub fn name_latex(&self, j: usize) -> String {
        Latex.name(&self.names[j]).to_string()
    }

    /// The where-list's definitions, in order.
    pub fn definitions(&self) -> &[Definition] {
        &self.names
    }

    /// The names that entries `ids` use, directly, inside other names or as the argument of
    /// an atom.
    pub fn names_used(&self, ids: &[usize]) -> BTreeSet<usize> {
        let mut used = BTreeSet::new();
        let mut todo: Vec<&Form> = ids.iter().map(|&i| &self.entries[i].0).collect();
        todo.extend(ids.iter().filter_map(|i| self.multipliers.get(i)));
        while let Some(f) = todo.pop() {
            let mut found = Vec::new();
            uses(f, &self.arguments, &mut found);
            for j in found {
                if used.insert(j) {
                    todo.push(&self.names[j].form);
                }
            }
        }
        used
    }

    /// Entry `i` as an expression, names expanded (for evaluation and checks).
    pub fn to_expr(&self, i: usize) -> Expr {
        to_expr(&self.entries[i].0, self.ctx())
    }

    /// The first entry (by index) whose printed form is not its canonical form, if any:
    /// both evaluated at a random point modulo a prime (`modular.rs`: a disagreement is
    /// certain, an agreement wrong with probability below 10⁻¹⁶; the canonical forms'
    /// values are taken as they are read), and expanded exactly ([`Sheet::check`]) where the
    /// point is a pole.
    pub fn first_mismatch(&self) -> Option<usize> {
        let mut point = self.check.residues();
        (0..self.entries.len()).find(|&i| {
            let (form, canonical) = &self.entries[i];
            let multiplier = self.multipliers.get(&i);
            let canonical = self.at_check[i].unwrap_or_else(|| point.fraction(canonical));
            match crate::modular::agrees(&mut point, &self.names, form, multiplier, canonical) {
                Some(same) => !same,
                None => !self.check(i),
            }
        })
    }

    /// Name `j`'s value, its definition expanded (once).
    pub(crate) fn value(&self, j: usize) -> &Fraction {
        self.values[j].get_or_init(|| self.fraction_of(&self.names[j].form))
    }

    /// Adds the definition of a name whose value, `value` when known, is its form expanded.
    pub(crate) fn push_name(&mut self, d: Definition, value: Option<Fraction>) {
        self.names.push(d);
        self.values
            .push(value.map(OnceLock::from).unwrap_or_default());
    }

    /// Whether entry `i`, its names expanded, is exactly its canonical form.
    pub fn check(&self, i: usize) -> bool {
        let (form, canonical) = &self.entries[i];
        match self.multipliers.get(&i) {
            Some(d) => self
                .fraction_of(form)
                .same(&canonical.times(&self.fraction_of(d))),
            None => self.fraction_of(form).same(canonical),
        }
    }

    /// Writes equation `i` (an entry set to zero) multiplied through by its denominator, when
    /// the denominator's sign is proved on the whole domain from the parameters declared
    /// `positive` (`positive.rs`); by minus it when negative, so that the multiplier is
    /// positive. Returns whether it did. Call after [`Sheet::name_groups`].
    pub fn multiply_through(&mut self, i: usize, positive: &BTreeSet<String>) -> bool {
        let Form::Quotient(num, den) = &self.entries[i].0 else {
            return false;
        };
        let Some(sign) = crate::positive::sign(den, self.ctx(), positive) else {
            return false;
        };
        let (mut num, mut den) = ((**num).clone(), (**den).clone());
        if sign == crate::positive::Sign::NonPositive {
            collect::negate(&mut num);
            collect::negate(&mut den);
        }
        self.entries[i].0 = num;
        self.multipliers.insert(i, den);
        true
    }

    /// The positive multiplier of equation `i` in the model syntax, if it was multiplied
    /// through ([`Sheet::multiply_through`]).
    pub fn multiplier_text(&self, i: usize) -> Option<String> {
        self.multipliers
            .get(&i)
            .map(|d| render(d, self.ctx(), &Text))
    }

    /// The same in LaTeX.
    pub fn multiplier_latex(&self, i: usize) -> Option<String> {
        self.multipliers
            .get(&i)
            .map(|d| render(d, self.ctx(), &Latex))
    }

    /// Whether every atom printed with a named argument has that name's value as its
    /// argument, exactly.
    pub fn check_arguments(&self) -> bool {
        self.arguments.iter().all(|(&atom, &name)| {
            let mut atoms = self.atoms.clone();
            argument(&self.atoms.get(atom).expr)
                .and_then(|a| Fraction::from_expr(a, &mut atoms).ok())
                .is_some_and(|f| f.same(self.value(name)))
        })
    }

    /// Names the groups that occur twice or more across the entries (the same form, or a
    /// rational multiple of a model's abbreviation): parameter groups `kappa1`, `kappa2`, …,
    /// then functions of the coordinates `F1`, `F2`, …, which may use the parameter names.
    /// Two passes over the groups, one to count, one to replace; only the recurring groups are
    /// expanded. Then the groups still too wide for a line are named too
    /// ([`Sheet::name_wide`]).
    pub fn name_groups(&mut self) {
        let (chosen, at, starts) = self.candidates();
        let first = self.names.len();
        let mut places = Vec::new();
        for c in chosen {
            let definition = self.definition(&c.key, c.form);
            self.push_name(definition, Some(c.value));
            places.push(c.place);
        }
        // Each entry from its first place on (an entry that is a sum is a place itself).
        crate::par::for_each_mut(&mut self.entries, self.parallel, |i, (f, _)| {
            let mut next = starts[i];
            if matches!(f, Form::Sum(_)) {
                next += 1;
                if let Some(p) = &at[starts[i]] {
                    *f = named(p);
                    return;
                }
            }
            replace_at(f, &mut next, &at);
        });
        // A definition is its group's first occurrence: its inner groups are the places
        // after that one.
        crate::par::for_each_mut(&mut self.names[first..], self.parallel, |k, d| {
            replace_at(&mut d.form, &mut (places[k] + 1), &at);
        });
        self.name_wide();
    }
}

/// The name a group's place gets, the factor from the group to the name's value, and how
/// many places lie inside the group (skipped when it is replaced).
#[derive(Clone)]
struct Placed {
    name: usize,
    factor: Q,
    inner: usize,
}

/// The places of a sheet's groups ([`Sheet::places`]) and, for each, the index of its kind
/// (equal groups share one).
#[derive(Clone, Copy)]
struct Groups<'p, 'f> {
    found: &'p [Keyed<'f>],
    at: &'p [usize],
}

/// A group that recurs: its form, its value and key, its first place (outer before inner,
/// entry after entry) and how often it occurs.
struct Candidate {
    form: Form,
    value: Fraction,
    key: Key,
    place: usize,
    count: usize,
}

/// A group's key: its polynomial without its rational content, the first term (in monomial
/// order) positive, so that groups equal up to a rational factor share it.
type Key = Poly;

impl Sheet {
    /// The form as a fraction over the sheet's atoms, names expanded.
    pub(crate) fn fraction_of(&self, f: &Form) -> Fraction {
        self.fraction_of_in(f, &mut HashMap::default())
    }

    /// [`Sheet::fraction_of`], each group's value taken from `memo` when it is there (equal
    /// groups recur across a sheet), and added to it.
    fn fraction_of_in<'f>(&self, f: &'f Form, memo: &mut HashMap<&'f Form, Fraction>) -> Fraction {
        match f {
            Form::Product { coef, factors } => {
                // The atoms make one monomial; only groups and names are multiplied in.
                let mut monomial = Mono::default();
                let mut acc: Option<Fraction> = None;
                for x in factors {
                    let part = match x {
                        Factor::Atom { index, power } => {
                            monomial = monomial.mul(&Mono::from_pairs([(*index, *power)]));
                            continue;
                        }
                        Factor::Group(g) => {
                            if !memo.contains_key(g) {
                                let v = self.fraction_of_in(g, memo);
                                memo.insert(g, v);
                            }
                            Cow::Borrowed(&memo[g])
                        }
                        Factor::Name { index } => Cow::Borrowed(self.value(*index)),
                    };
                    acc = Some(match acc {
                        Some(a) => a.times(&part),
                        None => part.into_owned(),
                    });
                }
                let front = Fraction::from(Poly::term(monomial, coef.clone()));
                match acc {
                    Some(rest) => rest.times(&front),
                    None => front,
                }
            }
            Form::Sum(terms) => {
                let parts: Vec<Fraction> =
                    terms.iter().map(|t| self.fraction_of_in(t, memo)).collect();
                Fraction::sum(parts)
            }
            Form::Quotient(a, b) => {
                let a = self.fraction_of_in(a, memo);
                a.over(&self.fraction_of_in(b, memo))
            }
        }
    }

    /// The value of the group `g` at place `*next` ([`Sheet::fraction_of_in`]), kept in
    /// `memo` under the index its place has in `groups` (equal groups share it), computed if
    /// not there; returns that index, `next` moved past the group's inner places. The inner
    /// groups are valued alike, by their places, so no form is hashed or compared.
    fn group_at(
        &self,
        g: &Form,
        next: &mut usize,
        groups: Groups<'_, '_>,
        memo: &mut [Option<Fraction>],
    ) -> usize {
        let p = *next;
        let i = groups.at[p];
        if memo[i].is_none() {
            *next = p + 1;
            let v = self.fraction_at(g, next, groups, memo);
            memo[i] = Some(v);
        }
        *next = groups.found[p].end;
        i
    }

    /// The form `f` (whose groups are the places from `*next` on, in the order of
    /// [`hashed_groups`]) as a fraction, names expanded, groups valued by [`Sheet::group_at`].
    fn fraction_at(
        &self,
        f: &Form,
        next: &mut usize,
        groups: Groups<'_, '_>,
        memo: &mut [Option<Fraction>],
    ) -> Fraction {
        match f {
            Form::Product { coef, factors } => {
                // The atoms make one monomial; only groups and names are multiplied in.
                let mut monomial = Mono::default();
                let mut parts: Vec<Result<usize, usize>> = Vec::new();
                for x in factors {
                    match x {
                        Factor::Atom { index, power } => {
                            monomial = monomial.mul(&Mono::from_pairs([(*index, *power)]));
                        }
                        Factor::Group(g) => parts.push(Ok(self.group_at(g, next, groups, memo))),
                        Factor::Name { index } => parts.push(Err(*index)),
                    }
                }
                let mut acc: Option<Fraction> = None;
                for part in parts {
                    let v = match part {
                        Ok(i) => memo[i].as_ref().expect("valued"),
                        Err(j) => self.value(j),
                    };
                    acc = Some(match acc {
                        Some(a) => a.times(v),
                        None => v.clone(),
                    });
                }
                let front = Fraction::from(Poly::term(monomial, coef.clone()));
                match acc {
                    Some(rest) => rest.times(&front),
                    None => front,
                }
            }
            Form::Sum(terms) => {
                let parts: Vec<Fraction> = terms
                    .iter()
                    .map(|t| self.fraction_at(t, next, groups, memo))
                    .collect();
                Fraction::sum(parts)
            }
            Form::Quotient(a, b) => {
                let a = self.fraction_at(a, next, groups, memo);
                if matches!(**b, Form::Sum(_)) {
                    let i = self.group_at(b, next, groups, memo);
                    a.over(memo[i].as_ref().expect("valued"))
                } else {
                    a.over(&self.fraction_at(b, next, groups, memo))
                }
            }
        }
    }

    /// The groups to name, in naming order: those occurring twice at least (the same form:
    /// collection writes a polynomial one way, so equal groups print alike and only these
    /// are expanded), free of velocities, of three terms or more if they hold parameters
    /// only (`ρ₁ + ρ₂` reads better than a name); parameter groups before functions of the
    /// coordinates, the more frequent first, then the larger, then the first met. Also, for
    /// each group of the entries by its place (outer before inner, entry after entry), the
    /// name it gets, if it gets one.
    fn candidates(&self) -> (Vec<Candidate>, Vec<Option<Placed>>, Vec<usize>) {
        let given = self.given_forms();
        let (found, shown, starts) = self.places();
        let kinds = kinds(&found);
        let mut counted: Vec<(&Form, usize, usize)> = Vec::new();
        let mut of_kind = vec![usize::MAX; found.len()];
        let mut at: Vec<usize> = Vec::with_capacity(found.len());
        for (place, (k, n)) in found.iter().zip(shown).enumerate() {
            let i = &mut of_kind[kinds[place]];
            if *i == usize::MAX {
                *i = counted.len();
                counted.push((k.form, place, 0));
            }
            counted[*i].2 += n;
            at.push(*i);
        }
        let groups = Groups {
            found: &found,
            at: &at,
        };
        let mut chosen: Vec<(usize, Candidate)> = Vec::new();
        for (i, value, key) in self.recurring(&counted, groups, &given) {
            let (g, place, count) = counted[i];
            chosen.push((
                i,
                Candidate {
                    form: g.clone(),
                    value,
                    key,
                    place,
                    count,
                },
            ));
        }
        chosen.sort_by_cached_key(|(i, c)| {
            let size = std::cmp::Reverse(c.key.size());
            (
                !self.parameters_only(&c.key),
                std::cmp::Reverse(c.count),
                size,
                *i,
            )
        });
        let first = self.names.len();
        // Equal groups have as many inner places as the first of them.
        let inner = |i: usize| found[counted[i].1].end - counted[i].1 - 1;
        let mut name_of: Vec<Option<Placed>> = vec![None; counted.len()];
        for (name, (i, _)) in chosen.iter().enumerate() {
            name_of[*i] = Some(Placed {
                name: first + name,
                factor: Q::one(),
                inner: inner(*i),
            });
        }
        for (i, &(g, _, _)) in counted.iter().enumerate() {
            if let Some((_, name, factor)) = given.iter().find(|(f, _, _)| f == g) {
                name_of[i] = Some(Placed {
                    name: *name,
                    factor: factor.clone(),
                    inner: inner(i),
                });
            }
        }
        let at = at.into_iter().map(|i| name_of[i].clone()).collect();
        (chosen.into_iter().map(|(_, c)| c).collect(), at, starts)
    }

    /// The groups that may be named, by their index in `counted`, in its order, with their
    /// values and keys: counted twice or more, free of velocities, not a given name's form,
    /// of three terms or more if they hold parameters only (`ρ₁ + ρ₂` reads better than a
    /// name). Outer groups come first: valuing them values their inner groups, kept for the
    /// groups after. (Dealt to two workers, each valuing inner groups anew, this was slower
    /// on the unicycle's momenta.)
    fn recurring(
        &self,
        counted: &[(&Form, usize, usize)],
        groups: Groups<'_, '_>,
        given: &[(Form, usize, Q)],
    ) -> Vec<(usize, Fraction, Key)> {
        let mut memo: Vec<Option<Fraction>> = vec![None; counted.len()];
        let mut out = Vec::new();
        for (i, &(g, place, count)) in counted.iter().enumerate() {
            if count < 2 || groups.found[place].velocity || given.iter().any(|(f, _, _)| f == g) {
                continue;
            }
            self.group_at(g, &mut { place }, groups, &mut memo);
            let value = memo[i].clone().expect("valued");
            let Some((_, key)) = key(&value) else {
                continue;
            };
            if !self.has_velocities(&key) && (key.size() >= 3 || !self.parameters_only(&key)) {
                out.push((i, value, key));
            }
        }
        out
    }

    /// Every group of the entries by its place (outer before inner, entry after entry, an
    /// entry that is a sum a place too), with how often its entry is shown, and each entry's
    /// first place. Each entry's groups are hashed on printing's pool when the sheet is large.
    fn places(&self) -> (Vec<Keyed<'_>>, Vec<usize>, Vec<usize>) {
        let velocity = |x: &Factor| match x {
            Factor::Atom { index, .. } => self.atoms.get(*index).kind == Kind::Velocity,
            Factor::Name { index } => self.mentions_velocity(&self.names[*index].form),
            Factor::Group(_) => false,
        };
        let each = crate::par::map_ref(&self.entries, self.parallel, |(f, _)| {
            let mut found = Vec::new();
            if matches!(f, Form::Sum(_)) {
                place(f, &mut found, &velocity);
            } else {
                hashed_groups(f, &mut found, &velocity);
            }
            found
        });
        let total = each.iter().map(Vec::len).sum();
        let (mut found, mut shown) = (Vec::with_capacity(total), Vec::with_capacity(total));
        let mut starts = Vec::with_capacity(each.len());
        for (places, &n) in each.into_iter().zip(&self.counts) {
            let offset = found.len();
            starts.push(offset);
            found.extend(places.into_iter().map(|k| Keyed {
                end: k.end + offset,
                ..k
            }));
            shown.resize(found.len(), n);
        }
        (found, shown, starts)
    }

    /// Whether a velocity occurs in the form `f` (read from its factors, without expanding
    /// it: a collected form's terms do not cancel); a group's is found as its place is
    /// ([`hashed_groups`]).
    fn mentions_velocity(&self, f: &Form) -> bool {
        match f {
            Form::Product { factors, .. } => factors.iter().any(|x| match x {
                Factor::Atom { index, .. } => self.atoms.get(*index).kind == Kind::Velocity,
                Factor::Group(g) => self.mentions_velocity(g),
                Factor::Name { index } => self.mentions_velocity(&self.names[*index].form),
            }),
            Form::Sum(terms) => terms.iter().any(|t| self.mentions_velocity(t)),
            Form::Quotient(a, b) => self.mentions_velocity(a) || self.mentions_velocity(b),
        }
    }

    /// Whether a velocity occurs in `key` (such groups are not named: the where-list holds
    /// parameter groups and functions of the coordinates).
    pub(crate) fn has_velocities(&self, key: &Key) -> bool {
        key.monomials()
            .any(|m| m.atoms().any(|i| self.atoms.get(i).kind == Kind::Velocity))
    }

    fn parameters_only(&self, key: &Key) -> bool {
        key.monomials()
            .all(|m| m.atoms().all(|i| self.atoms.get(i).kind == Kind::Parameter))
    }

    /// The definition of the group `key` (printed as `form`), the `index`-th name.
    pub(crate) fn definition(&mut self, key: &Key, form: Form) -> Definition {
        let parameter = self.parameters_only(key);
        let args = if parameter {
            Vec::new()
        } else {
            self.coordinates_in(key)
        };
        let stem = if parameter { "kappa" } else { "F" };
        // The next number of this kind whose name the model's abbreviations do not take.
        let counter = &mut self.numbers[usize::from(!parameter)];
        let given = &self.given;
        let name = loop {
            *counter += 1;
            let name = format!("{stem}{counter}");
            if !given.iter().any(|&j| self.names[j].name == name) {
                break name;
            }
        };
        Definition::new(name, args, form, false)
    }

    /// The coordinates `key` depends on, in the model's order.
    fn coordinates_in(&self, key: &Key) -> Vec<String> {
        let atoms: BTreeSet<usize> = key.monomials().flat_map(Mono::atoms).collect();
        let mut seen: BTreeSet<String> = BTreeSet::new();
        for i in atoms {
            self.atoms.get(i).expr.visit(&mut |e| match e {
                Expr::Sym(n) | Expr::Der(n) => {
                    seen.insert(n.clone());
                }
                Expr::Free { args, .. } => seen.extend(args.iter().cloned()),
                _ => {}
            });
        }
        self.atoms
            .vocabulary()
            .coordinates
            .iter()
            .filter(|c| seen.contains(*c))
            .cloned()
            .collect()
    }
}

/// A named group as a form: its factor times its name.
fn named(p: &Placed) -> Form {
    Form::Product {
        coef: p.factor.clone(),
        factors: vec![Factor::Name { index: p.name }],
    }
}

/// The groups of `f` named where `at` says, by their places counted on from `next` (the
/// order of [`hashed_groups`]). A group that is named is not looked into: its inner places are
/// counted and skipped.
fn replace_at(f: &mut Form, next: &mut usize, at: &[Option<Placed>]) {
    match f {
        Form::Product { coef, factors } => {
            for x in factors.iter_mut() {
                let Factor::Group(g) = x else { continue };
                let place = *next;
                *next += 1;
                match &at[place] {
                    Some(p) => {
                        *next += p.inner;
                        *coef = coef.mul(&p.factor);
                        *x = Factor::Name { index: p.name };
                    }
                    None => replace_at(g, next, at),
                }
            }
        }
        Form::Sum(terms) => terms.iter_mut().for_each(|t| replace_at(t, next, at)),
        Form::Quotient(a, b) => {
            replace_at(a, next, at);
            let place = matches!(**b, Form::Sum(_)).then(|| {
                *next += 1;
                *next - 1
            });
            match place.and_then(|p| at[p].as_ref()) {
                Some(p) => {
                    *next += p.inner;
                    **b = named(p);
                }
                None => replace_at(b, next, at),
            }
        }
    }
}

/// The names `f` uses directly (its named groups and its atoms' named arguments).
fn uses(f: &Form, arguments: &BTreeMap<usize, usize>, out: &mut Vec<usize>) {
    match f {
        Form::Product { factors, .. } => {
            for x in factors {
                match x {
                    Factor::Name { index } => out.push(*index),
                    Factor::Group(g) => uses(g, arguments, out),
                    Factor::Atom { index, .. } => out.extend(arguments.get(index)),
                }
            }
        }
        Form::Sum(terms) => terms.iter().for_each(|t| uses(t, arguments, out)),
        Form::Quotient(a, b) => {
            uses(a, arguments, out);
            uses(b, arguments, out);
        }
    }
}

/// `(content, key)` of a group's value that is a polynomial of two terms or more with no
/// common monomial.
fn key(f: &Fraction) -> Option<(Q, Key)> {
    let den = f.den.as_constant()?;
    if f.num.size() < 2 {
        return None;
    }
    let (c, m, rest) = collect::content(&f.num);
    m.is_one().then_some((c.div(&den), rest.into_owned()))
}
