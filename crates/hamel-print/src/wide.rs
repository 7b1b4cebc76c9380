//! Groups too wide for a line get names, as MotionGenesis's z variables and the paper's F₁
//! do: a long parameter coefficient becomes κₙ, a long function of the coordinates (a
//! denominator, a nested factor) Fₙ(q…), each defined once in the where-list, where its own
//! terms can be broken over lines.

use std::sync::Arc;

use crate::collect;
use crate::form::{Factor, Form, Latex, argument, render};
use crate::layout::{LINE, latex_width_upto, width, width_at_least};
use crate::poly::{Fraction, Poly};
use crate::sheet::Sheet;

/// The widest group left unnamed: half a line, so that a term holding one still fits beside
/// its coefficient and monomial.
pub const WIDE: usize = LINE / 2;

impl Sheet {
    /// Names every velocity-free group wider than `WIDE` (half a line) once rendered, inner
    /// groups first (so a name's definition is itself made of narrow groups), in the entries
    /// and then in the definitions (including those this adds). A group equal to a name's
    /// value takes that name.
    pub fn name_wide(&mut self) {
        let mut entries = std::mem::take(&mut self.entries);
        for (f, _) in &mut entries {
            self.name_wide_in(f);
        }
        self.entries = entries;
        let mut j = 0;
        while j < self.names.len() {
            let mut form = std::mem::replace(&mut self.names[j].form, Form::Sum(Vec::new()));
            self.name_wide_in_definition(&mut form);
            self.names[j].form = form;
            j += 1;
        }
    }

    /// A definition's own top level stays (it is what the where-list breaks over lines).
    fn name_wide_in_definition(&mut self, f: &mut Form) {
        match f {
            Form::Sum(terms) => terms.iter_mut().for_each(|t| self.name_wide_in(t)),
            other => self.name_wide_in(other),
        }
    }

    fn name_wide_in(&mut self, f: &mut Form) {
        match f {
            Form::Product { factors, .. } => {
                for x in factors.iter_mut() {
                    if let Factor::Atom { index, .. } = x {
                        self.name_wide_argument(*index);
                        continue;
                    }
                    let Factor::Group(g) = x else { continue };
                    // A group no wider than WIDE holds nothing wider (its atoms' arguments
                    // included), so nothing in it is named: it is left as it is (and, shared
                    // with other places, not copied).
                    if !self.wider_than_wide(g) {
                        continue;
                    }
                    self.name_wide_in(Arc::make_mut(g));
                    if self.wider_than_wide(g)
                        && let Some(index) = self.name_for(g)
                    {
                        *x = Factor::Name { index };
                    }
                }
            }
            Form::Sum(terms) => terms.iter_mut().for_each(|t| self.name_wide_in(t)),
            Form::Quotient(a, b) => {
                self.name_wide_in(a);
                self.name_wide_in(b);
                self.name_wide_denominator(b);
            }
        }
    }

    /// Whether `g` rendered in LaTeX is wider than [`WIDE`]: by the width of its pieces where
    /// they are known, else by a lower bound when it is over (a large group), else by
    /// rendering it.
    fn wider_than_wide(&self, g: &Form) -> bool {
        match latex_width_upto(g, self.ctx(), WIDE) {
            Some(w) => w > WIDE,
            None => width_at_least(g) > WIDE || width(&render(g, self.ctx(), &Latex)) > WIDE,
        }
    }

    /// A denominator that is a sum too wide for a line becomes a name (a fraction's
    /// denominator is not broken over lines).
    fn name_wide_denominator(&mut self, b: &mut Form) {
        if !matches!(b, Form::Sum(_)) || !self.wider_than_wide(b) {
            return;
        }
        if let Some(index) = self.name_for(b) {
            *b = Form::Product {
                coef: crate::Q::one(),
                factors: smallvec::smallvec![Factor::Name { index }],
            };
        }
    }

    /// A function or root of the coordinates too wide for a line gets its argument named
    /// (`\sqrt{F_7(θ)}`), when the argument has a rational form.
    fn name_wide_argument(&mut self, index: usize) {
        if self.examined.get(index).copied().unwrap_or(false) {
            return;
        }
        if self.examined.len() <= index {
            self.examined.resize(index + 1, false);
        }
        self.examined[index] = true;
        // The atom's LaTeX is measured already.
        let atom = self.atoms.get(index);
        if argument(&atom.expr).is_none() || atom.latex_width <= WIDE {
            return;
        }
        let atom = atom.expr.clone();
        let Some(arg) = argument(&atom) else { return };
        let Ok(value) = Fraction::from_expr(arg, &mut self.atoms) else {
            return;
        };
        let value = value.normalised();
        let form = collect::fraction(&value, &self.atoms);
        if let Some(name) = self.name_for(&form) {
            self.arguments.insert(index, name);
        }
    }

    /// The name whose value `g` is (a new one if none is), unless `g` holds a velocity. The
    /// names are told apart by their values at the sheet's random point, and only a name
    /// that agrees there is compared exactly (expanded); a new name's value is expanded when
    /// first needed.
    fn name_for(&mut self, g: &Form) -> Option<usize> {
        let atoms = self.atoms_in(g);
        if self.has_velocities(&atoms) {
            return None;
        }
        let here = self.point.form(g, &self.names);
        let mut value = None;
        for j in 0..self.names.len() {
            let there = self.point.name(j, &self.names);
            if let (Some(a), Some(b)) = (here, there)
                && !crate::modular::equal(a, b)
            {
                continue;
            }
            let v = value.get_or_insert_with(|| self.fraction_of(g));
            if self.value(j) == v {
                return Some(j);
            }
        }
        let index = self.names.len();
        let definition = self.definition(&atoms, g.clone());
        self.push_name(definition, value);
        Some(index)
    }

    /// A polynomial with a term for every atom of `f` (names expanded), which is every atom of
    /// its value: the terms of a collected form do not cancel, and a product of nonzero
    /// polynomials holds every atom of each factor. What [`Sheet::definition`] reads the kind
    /// and the arguments of a name from.
    fn atoms_in(&self, f: &Form) -> Poly {
        let mut found = vec![false; self.atoms.len()];
        let mut names = vec![false; self.names.len()];
        self.gather_atoms(f, &mut found, &mut names);
        crate::sheet::atoms_key(&found)
    }

    /// The atoms of `f` marked in `found` (by index), a name's definition read once
    /// (`names`: the names read already).
    fn gather_atoms(&self, f: &Form, found: &mut [bool], names: &mut [bool]) {
        match f {
            Form::Product { factors, .. } => {
                for x in factors {
                    match x {
                        Factor::Atom { index, .. } => found[*index] = true,
                        Factor::Group(g) => self.gather_atoms(g, found, names),
                        Factor::Name { index } => {
                            if !std::mem::replace(&mut names[*index], true) {
                                self.gather_atoms(&self.definitions()[*index].form, found, names);
                            }
                        }
                    }
                }
            }
            Form::Sum(terms) => terms
                .iter()
                .for_each(|t| self.gather_atoms(t, found, names)),
            Form::Quotient(a, b) => {
                self.gather_atoms(a, found, names);
                self.gather_atoms(b, found, names);
            }
        }
    }
}
