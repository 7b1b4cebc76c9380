//! Naming a sheet's groups ([`Sheet::name_groups`]): the groups that recur are counted by
//! kind, measured, and named once, parameter groups `κₙ`, then functions of the coordinates
//! `Fₙ(q…)`; every place of a named group is then written with its name.
//!
//! The groups are found by their places: every group of the entries, outer before inner,
//! entry after entry (`places.rs`). A group's inner groups are the places after its own, up
//! to its end, so a group is measured, compared and replaced by walking its form alongside
//! the place numbers, never by hashing or comparing forms whole. What naming needs of a
//! group's value (how many terms, which atoms, whether a monomial divides them all) is read
//! from its form ([`Shape`]): no group is expanded to be named; a name's value is expanded
//! when something asks for it (`Sheet::value`). On a large sheet, the entries'
//! groups are found and replaced on printing's pool, each entry from its own first place.

use std::sync::Arc;

use crate::atoms::Kind;
use crate::form::{Factor, Factors, Form};
use crate::places::{Keyed, Places, kinds};
use crate::poly::Mono;
use crate::q::Q;
use crate::sheet::{Key, Sheet, atoms_key, key};

impl Sheet {
    /// Names the groups that occur twice or more across the entries (the same form, or a
    /// rational multiple of a model's abbreviation): parameter groups `kappa1`, `kappa2`, …,
    /// then functions of the coordinates `F1`, `F2`, …, which may use the parameter names.
    /// Two passes over the groups, one to count, one to replace; no group is expanded. Then
    /// the groups still too wide for a line are named too
    /// ([`Sheet::name_wide`]).
    pub fn name_groups(&mut self) {
        if self.given_unwritten {
            self.write_given();
        }
        let (chosen, at, starts) = self.candidates();
        let at = &at;
        for (form, c) in chosen {
            let definition = self.definition(&c.atoms, form);
            self.push_name(definition, None);
        }
        // Each entry from its first place on (an entry that is a sum is a place itself).
        crate::par::for_each_mut(&mut self.entries, self.parallel, |i, (f, _)| {
            let mut next = starts[i];
            if matches!(f, Form::Sum(_)) {
                next += 1;
                if let Some(p) = &at.at[starts[i]] {
                    *f = named(p);
                    return;
                }
            }
            replace_at(f, &mut next, at);
        });
        self.name_wide();
    }

    /// The shape of the group `g` at place `*next` ([`Shape`]), kept in `memo` under the
    /// index its place has in `groups` (equal groups share it), computed if not there;
    /// returns that index, `next` moved past the group's inner places. None when the group
    /// holds a quotient or a name (its value is then expanded).
    fn group_shape(
        &self,
        g: &Form,
        next: &mut usize,
        groups: Groups<'_, '_>,
        memo: &mut [Option<Option<Shape>>],
    ) -> usize {
        let p = *next;
        let i = groups.at[p];
        if memo[i].is_none() {
            *next = p + 1;
            let v = self.shape_at(g, next, groups, memo);
            memo[i] = Some(v);
        }
        *next = groups.found[p].end;
        i
    }

    /// The shape of the form `f` (whose groups are the places from `*next` on, in the order
    /// of [`Places::hashed_groups`]), its groups' shapes taken by [`Sheet::group_shape`].
    fn shape_at(
        &self,
        f: &Form,
        next: &mut usize,
        groups: Groups<'_, '_>,
        memo: &mut [Option<Option<Shape>>],
    ) -> Option<Shape> {
        match f {
            Form::Product { factors, .. } => {
                let mut shape = Shape::of_atoms(factors, self.atoms.len());
                for x in factors {
                    match x {
                        Factor::Atom { .. } => {}
                        Factor::Group(g) => {
                            let i = self.group_shape(g, next, groups, memo);
                            shape.times(memo[i].as_ref().expect("shaped").as_ref()?);
                        }
                        Factor::Name { .. } => return None,
                    }
                }
                Some(shape)
            }
            Form::Sum(terms) => {
                let mut shapes = terms.iter().map(|t| self.shape_at(t, next, groups, memo));
                let mut sum = shapes.next()??;
                for t in shapes {
                    sum.plus(&t?);
                }
                Some(sum)
            }
            Form::Quotient(..) => None,
        }
    }

    /// The groups to name, in naming order: those occurring twice at least (the same form:
    /// collection writes a polynomial one way, so equal groups print alike and only these
    /// are expanded), free of velocities, of three terms or more if they hold parameters
    /// only (`ρ₁ + ρ₂` reads better than a name); parameter groups before functions of the
    /// coordinates, the more frequent first, then the larger, then the first met. Also, for
    /// each group of the entries by its place (outer before inner, entry after entry), the
    /// name it gets, if it gets one. Each group to name comes with its definition: its first
    /// occurrence, its inner groups named.
    fn candidates(&self) -> (Vec<(Form, Candidate)>, Named, Vec<usize>) {
        let given = self.given_forms();
        let (found, shown, starts) = self.places();
        let (at, firsts) = kinds_in_order(&found);
        let mut counted: Vec<(&Form, usize, usize)> =
            firsts.into_iter().map(|(f, place)| (f, place, 0)).collect();
        for (&i, n) in at.iter().zip(shown) {
            counted[i].2 += n;
        }
        let groups = Groups {
            found: &found,
            at: &at,
        };
        let mut chosen: Vec<(usize, Candidate)> = Vec::new();
        for (i, size, atoms) in self.recurring(&counted, groups, &given) {
            let (_, place, count) = counted[i];
            chosen.push((
                i,
                Candidate {
                    size,
                    atoms,
                    place,
                    count,
                },
            ));
        }
        chosen.sort_by_cached_key(|(i, c)| {
            let size = std::cmp::Reverse(c.size);
            (
                !self.parameters_only(&c.atoms),
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
        let at = Named {
            at: at.into_iter().map(|i| name_of[i].clone()).collect(),
            ends: found.iter().map(|k| k.end).collect(),
        };
        // A definition is its group's first occurrence, its inner groups (the places after
        // that one) named: copied so, never copying what a name replaces.
        let chosen = chosen
            .into_iter()
            .map(|(i, c)| (named_copy(counted[i].0, &mut (c.place + 1), &at), c))
            .collect();
        (chosen, at, starts)
    }

    /// The groups that may be named, by their index in `counted`, in its order, with the
    /// number of terms of their values and their atoms ([`Sheet::nameable`]): counted twice
    /// or more, free of velocities, not a given name's form, of three terms or more if they
    /// hold parameters only (`ρ₁ + ρ₂` reads better than a name). Outer groups come first:
    /// measuring them measures their inner groups, kept for the groups after.
    fn recurring(
        &self,
        counted: &[(&Form, usize, usize)],
        groups: Groups<'_, '_>,
        given: &[(Form, usize, Q)],
    ) -> Vec<(usize, usize, Key)> {
        let mut memo: Vec<Option<Option<Shape>>> = vec![None; counted.len()];
        let mut out = Vec::new();
        for (i, &(g, place, count)) in counted.iter().enumerate() {
            if count < 2 || groups.found[place].velocity || given.iter().any(|(f, _, _)| f == g) {
                continue;
            }
            self.group_shape(g, &mut { place }, groups, &mut memo);
            let shaped = memo[i].clone().expect("shaped");
            let Some((size, atoms)) = self.nameable(g, shaped) else {
                continue;
            };
            if !self.has_velocities(&atoms) && (size >= 3 || !self.parameters_only(&atoms)) {
                out.push((i, size, atoms));
            }
        }
        out
    }

    /// How many terms the value of the group `g` (of shape `shaped`, if known) has, and a
    /// polynomial with a term for each of its atoms; none unless the value is a polynomial of
    /// two terms or more with no common monomial (what [`key`] takes). A group holding a
    /// quotient or a name is expanded to tell.
    fn nameable(&self, g: &Form, shaped: Option<Shape>) -> Option<(usize, Key)> {
        let Some(shape) = shaped else {
            let (_, key) = key(&self.fraction_of(g))?;
            return Some((key.size(), key));
        };
        if shape.size < 2 || !shape.common.is_one() {
            return None;
        }
        Some((shape.size, atoms_key(&shape.atoms)))
    }

    /// Checks, for every kind of group of the sheet, that what its shape says (how many terms
    /// its value has, which atoms, whether it may be named) is what expanding it says; returns
    /// how many kinds it checked.
    #[cfg(test)]
    pub(crate) fn shapes_checked(&self) -> usize {
        let (found, _, _) = self.places();
        let (at, forms) = kinds_in_order(&found);
        let groups = Groups {
            found: &found,
            at: &at,
        };
        let mut memo = vec![None; forms.len()];
        let atoms = |(n, k): (usize, Key)| {
            (
                n,
                k.monomials()
                    .flat_map(Mono::atoms)
                    .collect::<std::collections::BTreeSet<_>>(),
            )
        };
        for (i, &(g, place)) in forms.iter().enumerate() {
            self.group_shape(g, &mut { place }, groups, &mut memo);
            let shaped = memo[i].clone().expect("shaped");
            assert!(shaped.is_some(), "a collected group has a shape");
            let by_shape = self.nameable(g, shaped).map(atoms);
            assert_eq!(by_shape, self.nameable(g, None).map(atoms));
        }
        forms.len()
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
        if !self.parallel {
            // One walk over the entries: a group they share is walked at its first place.
            // The seed models' sheets have two to four places an entry.
            let room = 4 * self.entries.len();
            let mut found = Places::new(&velocity);
            found.out.reserve(room);
            let mut starts = Vec::with_capacity(self.entries.len());
            let mut shown = Vec::with_capacity(room);
            for ((f, _), &n) in self.entries.iter().zip(&self.counts) {
                starts.push(found.out.len());
                found.entry(f);
                shown.resize(found.out.len(), n);
            }
            return (found.out, shown, starts);
        }
        let each = crate::par::map_ref(&self.entries, true, |(f, _)| {
            let mut found = Places::new(&velocity);
            found.entry(f);
            found.out
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
    /// ([`Places::hashed_groups`]).
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
}

/// Each place's kind numbered in the order the kinds are first met (outer before inner,
/// entry after entry), and each kind's first form and place.
fn kinds_in_order<'f>(found: &[Keyed<'f>]) -> (Vec<usize>, Vec<(&'f Form, usize)>) {
    let kinds = kinds(found);
    let mut number = vec![usize::MAX; found.len()];
    let (mut at, mut firsts) = (Vec::with_capacity(found.len()), Vec::new());
    for (place, k) in found.iter().enumerate() {
        let i = &mut number[kinds[place]];
        if *i == usize::MAX {
            *i = firsts.len();
            firsts.push((k.form, place));
        }
        at.push(*i);
    }
    (at, firsts)
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

/// A group that recurs: how many terms its value has, a polynomial with a term for each of
/// its atoms, its first place (outer before inner, entry after entry) and how often it occurs.
struct Candidate {
    size: usize,
    atoms: Key,
    place: usize,
    count: usize,
}

/// What naming reads of a group's value, from its form alone: how many terms it has, their
/// common monomial, and which atoms occur (by index). The terms of a collected form do not
/// cancel: each term of its expansion is one of the polynomial it was collected from, so a
/// sum has the terms of its summands, a product the products of its factors' terms.
#[derive(Clone)]
struct Shape {
    size: usize,
    common: Mono,
    atoms: Vec<bool>,
}

impl Shape {
    /// The shape of the product of the atoms among `factors`, over `n` atoms.
    fn of_atoms(factors: &[Factor], n: usize) -> Shape {
        let mut atoms = vec![false; n];
        let pairs = factors.iter().filter_map(|x| match x {
            Factor::Atom { index, power } => {
                atoms[*index] = true;
                Some((*index, *power))
            }
            _ => None,
        });
        Shape {
            size: 1,
            common: Mono::from_unsorted(pairs),
            atoms,
        }
    }

    /// This shape times `other`'s.
    fn times(&mut self, other: &Shape) {
        self.size = self.size.saturating_mul(other.size);
        if !other.common.is_one() {
            self.common = self.common.mul(&other.common);
        }
        self.or(other);
    }

    /// This shape plus `other`'s.
    fn plus(&mut self, other: &Shape) {
        self.size = self.size.saturating_add(other.size);
        if !self.common.is_one() {
            self.common.retain_common(&other.common);
        }
        self.or(other);
    }

    fn or(&mut self, other: &Shape) {
        for (a, b) in self.atoms.iter_mut().zip(&other.atoms) {
            *a |= *b;
        }
    }
}

/// A named group as a form: its factor times its name.
fn named(p: &Placed) -> Form {
    Form::Product {
        coef: p.factor.clone(),
        factors: smallvec::smallvec![Factor::Name { index: p.name }],
    }
}

/// The groups of `f` named where `at` says, by their places counted on from `next` (the
/// order of [`Places::hashed_groups`]). A group that is named is not looked into: its inner places are
/// counted and skipped.
fn replace_at(f: &mut Form, next: &mut usize, at: &Named) {
    match f {
        Form::Product { coef, factors } => {
            for x in factors.iter_mut() {
                let Factor::Group(g) = x else { continue };
                let place = *next;
                *next += 1;
                match &at.at[place] {
                    Some(p) => {
                        *next += p.inner;
                        *coef = coef.mul(&p.factor);
                        *x = Factor::Name { index: p.name };
                    }
                    // A group shared with other places is copied only to be changed.
                    None if at.inside(place) => replace_at(Arc::make_mut(g), next, at),
                    None => *next = at.ends[place],
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
            match place.and_then(|p| at.at[p].as_ref()) {
                Some(p) => {
                    *next += p.inner;
                    **b = named(p);
                }
                None => replace_at(b, next, at),
            }
        }
    }
}

/// A copy of `f` with its groups named where `at` says ([`replace_at`] of a copy), a named
/// group not copied.
fn named_copy(f: &Form, next: &mut usize, at: &Named) -> Form {
    match f {
        Form::Product { coef, factors } => {
            let mut coef = coef.clone();
            let mut copied = Factors::with_capacity(factors.len());
            for x in factors {
                let Factor::Group(g) = x else {
                    copied.push(x.clone());
                    continue;
                };
                let place = *next;
                *next += 1;
                copied.push(match &at.at[place] {
                    Some(p) => {
                        *next += p.inner;
                        coef = coef.mul(&p.factor);
                        Factor::Name { index: p.name }
                    }
                    None if at.inside(place) => Factor::Group(Arc::new(named_copy(g, next, at))),
                    None => {
                        *next = at.ends[place];
                        Factor::Group(Arc::clone(g))
                    }
                });
            }
            Form::Product {
                coef,
                factors: copied,
            }
        }
        Form::Sum(terms) => Form::Sum(terms.iter().map(|t| named_copy(t, next, at)).collect()),
        Form::Quotient(a, b) => {
            let a = named_copy(a, next, at);
            let place = matches!(**b, Form::Sum(_)).then(|| {
                *next += 1;
                *next - 1
            });
            let b = match place.and_then(|p| at.at[p].as_ref()) {
                Some(p) => {
                    *next += p.inner;
                    named(p)
                }
                None => named_copy(b, next, at),
            };
            Form::Quotient(Box::new(a), Box::new(b))
        }
    }
}

/// For each place of a sheet's groups (`places.rs`), the name it gets, if it gets one, and
/// where its inner places end.
struct Named {
    at: Vec<Option<Placed>>,
    ends: Vec<usize>,
}

impl Named {
    /// Whether a group inside the one at `place` gets a name.
    fn inside(&self, place: usize) -> bool {
        self.at[place + 1..self.ends[place]]
            .iter()
            .any(Option::is_some)
    }
}
