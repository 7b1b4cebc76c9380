//! A sheet: expressions printed together, sharing their atoms and a where-list of named
//! groups, as a paper names κ₁, κ₂ and F₁(θ, θ₁) once and uses them in every entry.

use std::collections::{BTreeMap, BTreeSet};
use std::sync::OnceLock;

use foldhash::HashMap;

use hamel_expr::Expr;

use crate::atoms::{Atoms, Kind, Vocabulary};
use crate::collect;
use crate::factored::Factored;
use crate::form::{
    Ctx, Definition, Factor, Form, Latex, Syntax, Text, argument, render, to_expr, write,
};
use crate::poly::{Fraction, Mono, Poly, PolyError};
use crate::q::Q;
use crate::read::Source;

/// Expressions printed together with their where-list.
#[derive(Clone, Debug)]
pub struct Sheet {
    pub(crate) atoms: Atoms,
    pub(crate) entries: Vec<(Form, Factored)>,
    /// How many times each entry is shown (equal entries are printed once and counted, so
    /// that a group in two equal entries recurs).
    pub(crate) counts: Vec<usize>,
    pub(crate) names: Vec<Definition>,
    /// The names the model gave ([`Sheet::abbreviate`]), by index.
    given: Vec<usize>,
    /// Whether a given name's definition is not written yet ([`Sheet::write_given`]).
    pub(crate) given_unwritten: bool,
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
            given_unwritten: false,
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
    /// m_d + m_f + m_r). Call before [`Sheet::name_groups`]: the name's definition is
    /// written when entries are added (with their factoring), else when the groups are
    /// named.
    ///
    /// # Errors
    /// An expression with no rational form over its atoms.
    pub fn abbreviate(&mut self, name: &str, e: &Expr) -> Result<(), PolyError> {
        let value = Fraction::from_expr(e, &mut self.atoms)?.normalised();
        self.given.push(self.names.len());
        let unwritten = Form::Sum(Vec::new());
        self.names.push(Definition::new(
            name.to_string(),
            Vec::new(),
            unwritten,
            true,
        ));
        self.values.push(OnceLock::from(value));
        self.given_unwritten = true;
        Ok(())
    }

    /// The model's abbreviations written with the factoring of the entries added so far.
    pub(crate) fn write_given(&mut self) {
        self.given_unwritten = false;
        for &j in &self.given {
            if let Some(v) = self.values[j].get() {
                self.names[j].form = collect::fraction(v, &self.atoms);
            }
        }
    }

    /// The forms in which the given names' groups appear, content-free as collection writes
    /// a group, with the factor from the form to the name's value: `(form, name, 1/c)`.
    pub(crate) fn given_forms(&self) -> Vec<(Form, usize, Q)> {
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
            Factored::terms,
            parallel,
            || (collect::Cx::new(atoms), check.residues()),
            |(cx, point), canonical| {
                let value = parallel.then(|| point.factored(&canonical));
                (collect::factored_in(&canonical, cx), canonical, value)
            },
        );
        self.entries.reserve(forms.len());
        self.at_check.reserve(forms.len());
        for (form, canonical, value) in forms {
            self.entries.push((form, canonical));
            self.at_check.push(value);
        }
        self.counts.extend(es.iter().map(|(_, n)| *n));
        self.write_given();
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

    /// [`Sheet::text`] appended to `out`.
    pub(crate) fn write_text(&self, i: usize, out: &mut String) {
        self.write_form(&self.entries[i].0, out);
    }

    /// A form of the sheet in the model syntax, named groups by name, appended to `out`.
    pub(crate) fn write_form(&self, f: &Form, out: &mut String) {
        write(f, self.ctx(), &Text, out);
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
        // Each entry walked once, however often it is shown.
        let mut ids = ids.to_vec();
        ids.sort_unstable();
        ids.dedup();
        let mut used = vec![false; self.names.len()];
        let mut todo: Vec<&Form> = ids.iter().map(|&i| &self.entries[i].0).collect();
        todo.extend(ids.iter().filter_map(|i| self.multipliers.get(i)));
        let mut found = Vec::new();
        while let Some(f) = todo.pop() {
            uses(f, &self.arguments, &mut found);
            for j in found.drain(..) {
                if !std::mem::replace(&mut used[j], true) {
                    todo.push(&self.names[j].form);
                }
            }
        }
        (0..used.len()).filter(|&j| used[j]).collect()
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
        // The forms stay as they are while they are checked: shared groups are valued once.
        let mut point = self.check.residues().keeping_groups();
        (0..self.entries.len()).find(|&i| {
            let (form, canonical) = &self.entries[i];
            let multiplier = self.multipliers.get(&i);
            let canonical = self.at_check[i].unwrap_or_else(|| point.factored(canonical));
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
        let canonical = &canonical.expanded();
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
}

/// A group's key: its polynomial without its rational content, the first term (in monomial
/// order) positive, so that groups equal up to a rational factor share it.
pub(crate) type Key = Poly;

/// A polynomial with a term for each atom marked in `found` (by index): what
/// [`Sheet::definition`] reads a name's kind and arguments from, and what tells a group's
/// velocities and parameters apart, when its value is not expanded.
pub(crate) fn atoms_key(found: &[bool]) -> Key {
    let mut terms = Vec::with_capacity(found.iter().filter(|&&f| f).count());
    let atoms = found.iter().enumerate().filter(|&(_, &f)| f);
    terms.extend(atoms.map(|(a, _)| (Mono::atom(a), Q::one())));
    Poly::from_sorted(terms)
}

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
                for x in factors {
                    if let Factor::Group(g) = x
                        && !memo.contains_key(&**g)
                    {
                        let v = self.fraction_of_in(g, memo);
                        memo.insert(g, v);
                    }
                }
                let parts = factors.iter().filter_map(|x| match x {
                    Factor::Atom { .. } => None,
                    Factor::Group(g) => Some(&memo[&**g]),
                    Factor::Name { index } => Some(self.value(*index)),
                });
                product(coef, factors, parts)
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

    /// Whether a velocity occurs in `key` (such groups are not named: the where-list holds
    /// parameter groups and functions of the coordinates).
    pub(crate) fn has_velocities(&self, key: &Key) -> bool {
        key.monomials()
            .any(|m| m.atoms().any(|i| self.atoms.get(i).kind == Kind::Velocity))
    }

    pub(crate) fn parameters_only(&self, key: &Key) -> bool {
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
            let mut name = String::with_capacity(stem.len() + 4);
            name.push_str(stem);
            push_decimal(&mut name, *counter);
            if !given.iter().any(|&j| self.names[j].name == name) {
                break name;
            }
        };
        Definition::new(name, args, form, false)
    }

    /// The coordinates `key` depends on, in the model's order.
    fn coordinates_in(&self, key: &Key) -> Vec<String> {
        let coordinates = &self.atoms.vocabulary().coordinates;
        let mut found = vec![false; coordinates.len()];
        let mut mark = |n: &String| {
            if let Some(k) = coordinates.iter().position(|c| c == n) {
                found[k] = true;
            }
        };
        let mut visited = vec![false; self.atoms.len()];
        for i in key.monomials().flat_map(Mono::atoms) {
            if std::mem::replace(&mut visited[i], true) {
                continue;
            }
            self.atoms.get(i).expr.visit(&mut |e| match e {
                Expr::Sym(n) | Expr::Der(n) => mark(n),
                Expr::Free { args, .. } => args.iter().for_each(&mut mark),
                _ => {}
            });
        }
        coordinates
            .iter()
            .zip(found)
            .filter(|&(_, f)| f)
            .map(|(c, _)| c.clone())
            .collect()
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

/// The value of a form's product `coef · factors`, given `parts`, the values of its groups and
/// names in order: the parts multiplied in order, then the monomial its atoms make (their
/// pairs gathered and sorted once).
pub(crate) fn product<'p>(
    coef: &Q,
    factors: &[Factor],
    parts: impl IntoIterator<Item = &'p Fraction>,
) -> Fraction {
    let monomial = Mono::from_unsorted(factors.iter().filter_map(|x| match x {
        Factor::Atom { index, power } => Some((*index, *power)),
        _ => None,
    }));
    let mut acc: Option<Fraction> = None;
    for v in parts {
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

/// `(content, key)` of a group's value that is a polynomial of two terms or more with no
/// common monomial.
pub(crate) fn key(f: &Fraction) -> Option<(Q, Key)> {
    let den = f.den.as_constant()?;
    if f.num.size() < 2 {
        return None;
    }
    let (c, m, rest) = collect::content(&f.num);
    m.is_one().then_some((c.div(&den), rest.into_owned()))
}

/// `n` in decimal appended to `out`.
fn push_decimal(out: &mut String, n: usize) {
    if n >= 10 {
        push_decimal(out, n / 10);
    }
    out.push(char::from(b'0' + (n % 10) as u8));
}

#[cfg(test)]
mod decimal_tests {
    /// The digits are those `to_string` writes, for one digit, several, and the largest.
    #[test]
    fn push_decimal_writes_the_digits() {
        for n in [0, 7, 10, 19, 123, 4_096, usize::MAX] {
            let mut out = String::from("kappa");
            super::push_decimal(&mut out, n);
            assert_eq!(out, format!("kappa{n}"));
        }
    }
}
