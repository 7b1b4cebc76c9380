//! A sheet: expressions printed together, sharing their atoms and a where-list of named
//! groups, as a paper names κ₁, κ₂ and F₁(θ, θ₁) once and uses them in every entry.

use std::collections::BTreeSet;

use hamel_expr::{Expr, Rational};
use num_traits::{One, Signed};

use crate::atoms::{Atoms, Kind, Vocabulary};
use crate::collect;
use crate::form::{Ctx, Definition, Factor, Form, Latex, Text, render, to_expr};
use crate::poly::{Fraction, Poly, PolyError};

/// Expressions printed together with their where-list.
#[derive(Clone, Debug)]
pub struct Sheet {
    atoms: Atoms,
    entries: Vec<(Form, Fraction)>,
    names: Vec<Definition>,
}

impl Sheet {
    /// An empty sheet for a model's names.
    pub fn new(vocabulary: &Vocabulary) -> Sheet {
        Sheet {
            atoms: Atoms::new(vocabulary.clone()),
            entries: Vec::new(),
            names: Vec::new(),
        }
    }

    /// Adds the canonical expression `e`; returns its index.
    ///
    /// # Errors
    /// An expression with no rational form over its atoms.
    pub fn add(&mut self, e: &Expr) -> Result<usize, PolyError> {
        let canonical = Fraction::from_expr(e, &mut self.atoms)?.normalised();
        let form = collect::fraction(&canonical, &self.atoms);
        self.entries.push((form, canonical));
        Ok(self.entries.len() - 1)
    }

    /// The printing form of entry `i`.
    pub fn form(&self, i: usize) -> &Form {
        &self.entries[i].0
    }

    pub(crate) fn ctx(&self) -> Ctx<'_> {
        Ctx {
            atoms: &self.atoms,
            names: &self.names,
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
        self.definitions(&Text)
    }

    /// The where-list in LaTeX.
    pub fn definitions_latex(&self) -> Vec<(String, String)> {
        self.definitions(&Latex)
    }

    fn definitions(&self, s: &dyn crate::form::Syntax) -> Vec<(String, String)> {
        self.names
            .iter()
            .map(|d| (s.name(d), render(&d.form, self.ctx(), s)))
            .collect()
    }

    /// Entry `i` as an expression, names expanded (for evaluation and checks).
    pub fn to_expr(&self, i: usize) -> Expr {
        to_expr(&self.entries[i].0, self.ctx())
    }

    /// Whether entry `i`, its names expanded, is exactly its canonical form.
    pub fn check(&self, i: usize) -> bool {
        let mut atoms = self.atoms.clone();
        let e = self.to_expr(i);
        Fraction::from_expr(&e, &mut atoms).is_ok_and(|f| f.same(&self.entries[i].1))
    }

    /// Names the groups that occur twice or more (up to a rational factor) across the
    /// entries: parameter groups `kappa1`, `kappa2`, …, then functions of the coordinates
    /// `F1`, `F2`, …, which may use the parameter names ([`Sheet::candidates`] says which and
    /// in what order). Two passes over the groups: one to count, one to replace.
    pub fn name_groups(&mut self) {
        let chosen = self.candidates();
        for (key, form) in &chosen {
            let index = self.names.len();
            let definition = self.definition(key, form.clone(), index);
            self.names.push(definition);
        }
        let keys: Vec<Key> = chosen.into_iter().map(|(k, _)| k).collect();
        let orientation: Vec<Rational> = (0..keys.len()).map(|i| self.orientation(i)).collect();
        let mut entries = std::mem::take(&mut self.entries);
        for (f, _) in &mut entries {
            self.replace(f, &keys, &orientation, None);
        }
        self.entries = entries;
        for j in 0..self.names.len() {
            let mut form = self.names[j].form.clone();
            self.replace(&mut form, &keys, &orientation, Some(j));
            self.names[j].form = form;
        }
    }
}

/// A group's key: its polynomial without its rational content, the first term (in monomial
/// order) positive, so that groups equal up to a rational factor share it.
type Key = Poly;

impl Sheet {
    /// The form as a fraction over the sheet's atoms, names expanded.
    fn fraction_of(&self, f: &Form) -> Fraction {
        match f {
            Form::Product { coef, factors } => {
                let mut acc = Fraction::constant(coef.clone());
                for x in factors {
                    let part = match x {
                        Factor::Atom { index, power } => Fraction::atom(*index, *power),
                        Factor::Group(g) => self.fraction_of(g),
                        Factor::Name { index } => self.fraction_of(&self.names[*index].form),
                    };
                    acc = acc.times(&part);
                }
                acc
            }
            Form::Sum(terms) => terms.iter().fold(
                Fraction::constant(Rational::from_integer(0.into())),
                |acc, t| acc.plus(&self.fraction_of(t)),
            ),
            Form::Quotient(a, b) => self.fraction_of(a).over(&self.fraction_of(b)),
        }
    }

    /// `(content, key)` of a group that is a polynomial with no common monomial.
    fn key_of(&self, g: &Form) -> Option<(Rational, Key)> {
        let f = self.fraction_of(g);
        if f.den.as_constant().is_none() || f.num.0.len() < 2 {
            return None;
        }
        let (c, m, rest) = collect::content(&f.num);
        let scale = c / f.den.as_constant().expect("checked");
        m.0.is_empty().then_some((scale, rest))
    }

    /// Every unnamed group of a form, outer before inner.
    fn groups<'a>(f: &'a Form, out: &mut Vec<&'a Form>) {
        match f {
            Form::Product { factors, .. } => {
                for x in factors {
                    if let Factor::Group(g) = x {
                        out.push(g);
                        Sheet::groups(g, out);
                    }
                }
            }
            Form::Sum(terms) => terms.iter().for_each(|t| Sheet::groups(t, out)),
            Form::Quotient(a, b) => {
                Sheet::groups(a, out);
                Sheet::groups(b, out);
            }
        }
    }

    /// The groups to name, in naming order: those occurring twice at least, free of
    /// velocities, of three terms or more if they hold parameters only (`ρ₁ + ρ₂` reads better
    /// than a name); parameter groups before functions of the coordinates, the more frequent
    /// first, then the larger, then the first met. Their forms are scaled to the key.
    fn candidates(&self) -> Vec<(Key, Form)> {
        let mut found: Vec<&Form> = Vec::new();
        for (f, _) in &self.entries {
            Sheet::groups(f, &mut found);
        }
        let mut counted: Vec<(Key, Form, usize)> = Vec::new();
        for g in found {
            let Some((c, key)) = self.key_of(g) else {
                continue;
            };
            match counted.iter_mut().find(|(k, _, _)| *k == key) {
                Some(entry) => entry.2 += 1,
                None => counted.push((key, positive(scaled(g, &c.recip())), 1)),
            }
        }
        let mut chosen: Vec<(usize, (Key, Form, usize))> = counted
            .into_iter()
            .enumerate()
            .filter(|(_, (key, _, n))| {
                *n >= 2
                    && !self.has_velocities(key)
                    && (key.0.len() >= 3 || !self.parameters_only(key))
            })
            .collect();
        chosen.sort_by_key(|(i, (key, _, n))| {
            let size = std::cmp::Reverse(key.0.len());
            (!self.parameters_only(key), std::cmp::Reverse(*n), size, *i)
        });
        chosen.into_iter().map(|(_, (k, f, _))| (k, f)).collect()
    }

    /// Whether a velocity occurs in `key` (such groups are not named: the where-list holds
    /// parameter groups and functions of the coordinates).
    fn has_velocities(&self, key: &Key) -> bool {
        key.0.keys().any(|m| {
            m.0.iter()
                .any(|&(i, _)| self.atoms.get(i).kind == Kind::Velocity)
        })
    }

    fn parameters_only(&self, key: &Key) -> bool {
        key.0.keys().all(|m| {
            m.0.iter()
                .all(|&(i, _)| self.atoms.get(i).kind == Kind::Parameter)
        })
    }

    /// The definition of the group `key` (printed as `form`), the `index`-th name.
    fn definition(&self, key: &Key, form: Form, index: usize) -> Definition {
        let parameter = self.parameters_only(key);
        let same_kind = self.names[..index]
            .iter()
            .filter(|d| d.args.is_empty() == parameter)
            .count();
        let args = if parameter {
            Vec::new()
        } else {
            self.coordinates_in(key)
        };
        let name = if parameter {
            format!("kappa{}", same_kind + 1)
        } else {
            format!("F{}", same_kind + 1)
        };
        Definition { name, args, form }
    }

    /// The coordinates `key` depends on, in the model's order.
    fn coordinates_in(&self, key: &Key) -> Vec<String> {
        let mut seen = BTreeSet::new();
        for m in key.0.keys() {
            for &(i, _) in &m.0 {
                self.atoms.get(i).expr.visit(&mut |e| {
                    if let Expr::Sym(n) = e {
                        seen.insert(n.clone());
                    }
                });
            }
        }
        self.atoms
            .vocabulary()
            .coordinates
            .iter()
            .filter(|c| seen.contains(*c))
            .cloned()
            .collect()
    }

    /// Every group of `f` whose key is a name's becomes that name (not `skip`: a definition
    /// does not name itself).
    fn replace(&self, f: &mut Form, keys: &[Key], orientation: &[Rational], skip: Option<usize>) {
        match f {
            Form::Product { coef, factors } => {
                for x in factors.iter_mut() {
                    let Factor::Group(g) = x else { continue };
                    let named = self.key_of(g).and_then(|(c, k)| {
                        let index = keys.iter().position(|key| *key == k)?;
                        (Some(index) != skip).then_some((c, index))
                    });
                    match named {
                        Some((c, index)) => {
                            *coef = &*coef * c * &orientation[index];
                            *x = Factor::Name { index };
                        }
                        None => self.replace(g, keys, orientation, skip),
                    }
                }
            }
            Form::Sum(terms) => terms
                .iter_mut()
                .for_each(|t| self.replace(t, keys, orientation, skip)),
            Form::Quotient(a, b) => {
                self.replace(a, keys, orientation, skip);
                self.replace(b, keys, orientation, skip);
            }
        }
    }
}

impl Sheet {
    /// ±1: the definition `index` as printed over its key (whose first term in monomial order
    /// is positive).
    fn orientation(&self, index: usize) -> Rational {
        let printed = self.fraction_of(&self.names[index].form);
        let (c, _, _) = collect::content(&printed.num);
        if c.is_negative() {
            -Rational::one()
        } else {
            Rational::one()
        }
    }
}

fn positive(mut f: Form) -> Form {
    if collect::negative(&f) {
        collect::negate(&mut f);
    }
    f
}

/// `r · f`, the factor put into the coefficients.
fn scaled(f: &Form, r: &Rational) -> Form {
    match f {
        Form::Product { coef, factors } => Form::Product {
            coef: coef * r,
            factors: factors.clone(),
        },
        Form::Sum(terms) => Form::Sum(terms.iter().map(|t| scaled(t, r)).collect()),
        Form::Quotient(a, b) => Form::Quotient(Box::new(scaled(a, r)), b.clone()),
    }
}
