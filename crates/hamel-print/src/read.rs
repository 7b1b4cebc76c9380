//! Reading a sheet's entries: canonical expressions to fractions over the sheet's atoms, on
//! printing's pool.
//!
//! The atoms are numbered in the order they are first met, entry after entry, depth first
//! (the numbering decides the order of a polynomial's terms, and so which sign a sum is
//! printed with). The pool splits the entries into runs of consecutive entries; each run is
//! read with a numbering of its own that starts from the sheet's atoms ([`Local::seeded`]).
//! The sheet then numbers each entry's new atoms in turn, which is the order reading the
//! entries one after another would give: the first run's numbering is the sheet's, and only
//! the entries of the other runs are renumbered (in parallel, with their collection).

use std::hash::{Hash, Hasher};
use std::sync::Arc;
use std::sync::atomic::{AtomicUsize, Ordering};

use foldhash::HashMap;
use num_traits::ToPrimitive;

use hamel_expr::{Canonical, Expr};

use crate::atoms::{Atoms, Intern};
use crate::poly::{Fraction, PolyError};

/// What an entry is read from: its tree, or the polynomials the computer algebra wrote the
/// tree from (read alike, atoms met in the same order, without taking a tree apart).
#[derive(Clone, Copy)]
pub(crate) enum Source<'e> {
    /// A canonical tree.
    Tree(&'e Expr),
    /// An exported canonical form.
    Canonical(&'e Canonical),
}

/// The entries `es` (each with how often it is shown) read and numbered in the sheet's
/// `atoms`, which weigh them; on printing's pool when `parallel`.
///
/// # Errors
/// An entry with no rational form over its atoms (the first in order).
pub(crate) fn entries(
    es: &[(Source<'_>, usize)],
    parallel: bool,
    atoms: &mut Atoms,
) -> Result<Vec<Numbered>, PolyError> {
    let seeds: Vec<Expr> = (0..atoms.len())
        .map(|i| atoms.get(i).expr.clone())
        .collect();
    let read = crate::par::map_init(
        es,
        parallel,
        || Local::seeded(&seeds),
        |run, (e, _)| local(e, run),
    );
    let mut read = read.into_iter().collect::<Result<Vec<_>, _>>()?;
    if !in_order(&read, seeds.len()) {
        let mut run = Local::seeded(&seeds);
        read = es
            .iter()
            .map(|(e, _)| local(e, &mut run))
            .collect::<Result<Vec<_>, _>>()?;
    }
    let counts: Vec<usize> = es.iter().map(|(_, n)| *n).collect();
    Ok(number(read, &counts, atoms))
}

/// A run of entries' atoms, numbered in the order met after the sheet's own.
struct Local<'e> {
    index: HashMap<Key<'e>, usize>,
    list: Vec<&'e Expr>,
    /// Which run it numbers (each numbering made has its own).
    id: usize,
    /// Zeros, one per atom: where an entry's atoms are counted.
    counts: Vec<usize>,
}

impl<'e> Local<'e> {
    /// A numbering that starts from the sheet's atoms `seeds` (numbered as in the sheet).
    fn seeded(seeds: &'e [Expr]) -> Local<'e> {
        let mut local = Local {
            index: HashMap::default(),
            list: Vec::new(),
            id: RUNS.fetch_add(1, Ordering::Relaxed),
            counts: Vec::new(),
        };
        for e in seeds {
            local.intern(e);
        }
        local
    }
}

impl<'e> Intern<'e> for Local<'e> {
    fn intern(&mut self, expr: &'e Expr) -> usize {
        let next = self.list.len();
        *self.index.entry(Key(expr)).or_insert_with(|| {
            self.list.push(expr);
            next
        })
    }
}

/// An atom as a key: hashed by its [`fingerprint`], compared whole. (An atom occurs at
/// every term it is a factor of: hashing it whole, every name and argument, was a fifth of
/// reading.)
#[derive(Clone, Copy, PartialEq, Eq)]
struct Key<'e>(&'e Expr);

impl Hash for Key<'_> {
    fn hash<H: Hasher>(&self, state: &mut H) {
        state.write_u64(fingerprint(self.0));
    }
}

/// A hash of an atom from its shape and names, each name read by its length and its first
/// and last eight bytes (a function of the coordinates by its name and orders alone: its
/// arguments are the same wherever it occurs). Equal atoms have equal fingerprints.
fn fingerprint(e: &Expr) -> u64 {
    const K: u64 = 0x9e37_79b9_7f4a_7c15;
    let mix = |h: u64, x: u64| (h.rotate_left(5) ^ x).wrapping_mul(K);
    match e {
        Expr::Sym(s) => name(s),
        Expr::Der(s) => mix(name(s), 1),
        Expr::Num(r) => mix(r.numer().to_i64().unwrap_or(0) as u64, 2),
        Expr::Call(f, a) => mix(fingerprint(a), 3 + *f as u64),
        Expr::Free {
            name: n, orders, ..
        } => orders
            .iter()
            .fold(mix(name(n), 10), |h, &o| mix(h, u64::from(o))),
        Expr::Pow(b, x) => mix(mix(fingerprint(b), 11), fingerprint(x)),
        Expr::Neg(a) => mix(fingerprint(a), 12),
        Expr::Div(a, b) => mix(mix(fingerprint(a), 13), fingerprint(b)),
        Expr::Add(v) => v.iter().fold(14, |h, x| mix(h, fingerprint(x))),
        Expr::Mul(v) => v.iter().fold(15, |h, x| mix(h, fingerprint(x))),
    }
}

/// A name's length and its first and last eight bytes.
fn name(s: &str) -> u64 {
    let b = s.as_bytes();
    let word = |part: &[u8]| {
        let mut w = [0u8; 8];
        w[..part.len()].copy_from_slice(part);
        u64::from_le_bytes(w)
    };
    let head = word(&b[..b.len().min(8)]);
    let tail = word(&b[b.len().saturating_sub(8)..]);
    head ^ tail.rotate_left(29) ^ (b.len() as u64).wrapping_mul(0xff51_afd7_ed55_8ccd)
}

/// Numbers the runs' numberings (what tells the runs of a reading apart).
static RUNS: AtomicUsize = AtomicUsize::new(0);

/// An entry read in its run's numbering: its fraction, its run, the atoms it met first in its
/// run (numbered from `first` on), and in how many of its terms (numerator and denominator)
/// each of its atoms occurs.
struct Read<'e> {
    fraction: Fraction,
    run: usize,
    first: usize,
    new: Vec<&'e Expr>,
    weights: Vec<(usize, usize)>,
}

/// `e` read in `run`'s numbering.
///
/// # Errors
/// An expression with no rational form over its atoms.
fn local<'e>(e: &Source<'e>, run: &mut Local<'e>) -> Result<Read<'e>, PolyError> {
    let first = run.list.len();
    let fraction = match *e {
        Source::Tree(e) => Fraction::read(e, run)?,
        Source::Canonical(c) => Fraction::read_canonical(c, run),
    }
    .normalised();
    let counts = &mut run.counts;
    counts.resize(run.list.len(), 0);
    let mut weights = Vec::new();
    for m in fraction.num.monomials().chain(fraction.den.monomials()) {
        for i in m.atoms() {
            if counts[i] == 0 {
                weights.push((i, 0));
            }
            counts[i] += 1;
        }
    }
    for (i, w) in &mut weights {
        *w = std::mem::take(&mut counts[*i]);
    }
    Ok(Read {
        fraction,
        run: run.id,
        first,
        new: run.list[first..].to_vec(),
        weights,
    })
}

/// An entry whose atoms the sheet has numbered: its fraction and, unless already in the
/// sheet's numbering, the map from its run's numbering to the sheet's.
pub(crate) struct Numbered {
    fraction: Fraction,
    map: Option<Arc<Vec<usize>>>,
}

impl Numbered {
    /// The fraction in the sheet's numbering.
    pub(crate) fn into_fraction(mut self) -> Fraction {
        if let Some(map) = &self.map {
            self.fraction.renumber(map);
        }
        self.fraction
    }
}

/// Whether every run was read in order, from the sheet's atoms on: each entry read in the
/// numbering its run had after the entries before it in the sheet (the pool gives each run's
/// entries to one numbering, in order; this is checked, not assumed, and a reading that fails
/// it is done again on one thread).
fn in_order(read: &[Read<'_>], seeds: usize) -> bool {
    let mut at: Option<(usize, usize)> = None;
    for r in read {
        let expected = match at {
            Some((run, len)) if run == r.run => len,
            _ => seeds,
        };
        if r.first != expected {
            return false;
        }
        at = Some((r.run, r.first + r.new.len()));
    }
    let mut runs: Vec<usize> = read.iter().map(|r| r.run).collect();
    runs.dedup();
    let count = runs.len();
    runs.sort_unstable();
    runs.dedup();
    runs.len() == count
}

/// Numbers the entries' atoms in the sheet's `atoms`, entry after entry (an entry's new atoms
/// after those there, in the order it met them), and weighs them, each entry as often as it
/// is shown (`counts`). The entries were read in order ([`in_order`]).
fn number(read: Vec<Read<'_>>, counts: &[usize], atoms: &mut Atoms) -> Vec<Numbered> {
    let seeds = atoms.len();
    let mut run = RunMap::new(seeds);
    let mut current = None;
    let mut out = Vec::with_capacity(read.len());
    for (r, &count) in read.into_iter().zip(counts) {
        if current != Some(r.run) {
            run = RunMap::new(seeds);
            current = Some(r.run);
        }
        run.extend(&r.new, atoms);
        if !run.injective {
            // Two atoms of the run are one of the sheet's (equal text): merged now, and
            // weighed as merged.
            let mut fraction = r.fraction;
            fraction.renumber(&run.map);
            weigh_all(&fraction, count, atoms);
            out.push(Numbered {
                fraction,
                map: None,
            });
            continue;
        }
        for &(i, w) in &r.weights {
            atoms.weigh(run.map[i], w * count);
        }
        out.push(Numbered {
            fraction: r.fraction,
            map: run.shared(),
        });
    }
    out
}

/// A run's numbering in the sheet's: the map, kept with whether it is one-to-one and the
/// identity as the run's atoms are added.
struct RunMap {
    map: Vec<usize>,
    /// The sheet's numbers the map gives, by number.
    taken: Vec<bool>,
    injective: bool,
    identity: bool,
    /// The map as the run's entries share it (made again when the map grows).
    shared: Option<Arc<Vec<usize>>>,
}

impl RunMap {
    /// The map of a run that has met only the sheet's `seeds` atoms.
    fn new(seeds: usize) -> RunMap {
        RunMap {
            map: (0..seeds).collect(),
            taken: vec![true; seeds],
            injective: true,
            identity: true,
            shared: None,
        }
    }

    /// The run's `new` atoms numbered in the sheet (added there when not there yet).
    fn extend(&mut self, new: &[&Expr], atoms: &mut Atoms) {
        for e in new {
            let i = atoms.intern(e);
            self.identity &= i == self.map.len();
            if self.taken.len() <= i {
                self.taken.resize(i + 1, false);
            }
            self.injective &= !std::mem::replace(&mut self.taken[i], true);
            self.map.push(i);
            self.shared = None;
        }
    }

    /// The map for an entry of the run; None for the identity.
    fn shared(&mut self) -> Option<Arc<Vec<usize>>> {
        if self.identity {
            return None;
        }
        Some(
            self.shared
                .get_or_insert_with(|| Arc::new(self.map.clone()))
                .clone(),
        )
    }
}

/// Weighs every atom of `f`'s terms, `count` times.
fn weigh_all(f: &Fraction, count: usize, atoms: &mut Atoms) {
    for m in f.num.monomials().chain(f.den.monomials()) {
        for i in m.atoms() {
            atoms.weigh(i, count);
        }
    }
}

/// About how many terms `e` has (what decides whether reading it is worth the pool).
pub(crate) fn terms(e: &Source<'_>) -> usize {
    match e {
        Source::Tree(e) => tree_terms(e),
        Source::Canonical(c) => c.num.len() + c.factors.iter().map(|(t, _)| t.len()).sum::<usize>(),
    }
}

/// [`terms`] of a tree: as many as expanding it would make.
fn tree_terms(e: &Expr) -> usize {
    match e {
        Expr::Add(v) => v.len(),
        Expr::Div(a, b) => tree_terms(a) + tree_terms(b),
        Expr::Neg(a) => tree_terms(a),
        Expr::Mul(v) => v.iter().map(tree_terms).fold(1, usize::saturating_mul),
        Expr::Pow(b, _) => tree_terms(b),
        _ => 1,
    }
}

#[cfg(test)]
mod tests {
    use hamel_expr::parse;

    use super::*;
    use crate::atoms::Vocabulary;

    fn atoms() -> Atoms {
        let names = |v: &[&str]| v.iter().map(|s| s.to_string()).collect();
        Atoms::new(Vocabulary {
            parameters: names(&["a", "b", "m"]),
            coordinates: names(&["x", "y"]),
            velocities: names(&["eta1"]),
        })
    }

    /// Entries read in runs (as the pool splits them) and numbered entry after entry give
    /// the numbering, the fractions and the weights of reading them all in one run: the
    /// order a sheet's text depends on.
    #[test]
    fn runs_number_atoms_as_one_reading_does() {
        let texts = [
            "a*sin(x)*eta1 + b*cos(y)^2",
            "m*cos(y)*sin(x) - f(x, y)*a",
            "(b*x^(1/2) + m*eta1)/(a + cos(y))",
            "sin(x)^3*g(y) + b*m*f(x, y)",
            "eta1*x^(1/2)*cos(x) - 3/2*a*g(y)",
        ];
        let exprs: Vec<Expr> = texts.iter().map(|t| parse(t).unwrap().expr).collect();
        let counts = vec![1, 2, 1, 1, 3];
        let numbered = |cuts: &[usize]| {
            let mut sheet = atoms();
            sheet.intern(&parse("m").unwrap().expr);
            let seeds: Vec<Expr> = (0..sheet.len())
                .map(|i| sheet.get(i).expr.clone())
                .collect();
            let mut read = Vec::new();
            let mut run = Local::seeded(&seeds);
            for (k, e) in exprs.iter().enumerate() {
                if cuts.contains(&k) {
                    run = Local::seeded(&seeds);
                }
                read.push(local(&Source::Tree(e), &mut run).unwrap());
            }
            assert!(in_order(&read, seeds.len()));
            let fractions: Vec<Fraction> = number(read, &counts, &mut sheet)
                .into_iter()
                .map(Numbered::into_fraction)
                .collect();
            let order: Vec<String> = (0..sheet.len()).map(|i| sheet.get(i).key.clone()).collect();
            let weights: Vec<usize> = (0..sheet.len()).map(|i| sheet.weight(i)).collect();
            (fractions, order, weights)
        };
        let one = numbered(&[]);
        let mut sequential = atoms();
        sequential.intern(&parse("m").unwrap().expr);
        for (e, f) in exprs.iter().zip(&one.0) {
            assert_eq!(
                &Fraction::from_expr(e, &mut sequential)
                    .unwrap()
                    .normalised(),
                f
            );
        }
        for cuts in [&[1][..], &[2, 3], &[1, 2, 3, 4]] {
            assert_eq!(numbered(cuts), one, "runs cut before entries {cuts:?}");
        }
    }

    /// The entries `order` names (by index), each read with the first numbering or the
    /// second.
    fn read_in<'e>(
        exprs: &'e [Expr],
        order: &[(usize, bool)],
        runs: &mut [Local<'e>; 2],
    ) -> Vec<Read<'e>> {
        order
            .iter()
            .map(|&(k, first)| {
                local(&Source::Tree(&exprs[k]), &mut runs[usize::from(!first)]).unwrap()
            })
            .collect()
    }

    /// A run whose entries are not consecutive, or were not read in order, is found (and the
    /// sheet then reads again on one thread).
    #[test]
    fn a_run_read_out_of_order_is_found() {
        let exprs: Vec<Expr> = ["a*x", "b*y", "m*x*y", "a*b"]
            .iter()
            .map(|t| parse(t).unwrap().expr)
            .collect();
        let fresh = || [Local::seeded(&[]), Local::seeded(&[])];
        let runs = read_in(
            &exprs,
            &[(0, true), (1, true), (2, false), (3, false)],
            &mut fresh(),
        );
        assert!(in_order(&runs, 0));
        let resumed = read_in(
            &exprs,
            &[(0, true), (1, false), (2, true), (3, false)],
            &mut fresh(),
        );
        assert!(!in_order(&resumed, 0), "a run resumed after another");
        let mut swapped = read_in(&exprs, &[(0, true), (1, true), (2, false)], &mut fresh());
        swapped.swap(0, 1);
        assert!(!in_order(&swapped, 0), "a run's entries out of order");
    }
}
