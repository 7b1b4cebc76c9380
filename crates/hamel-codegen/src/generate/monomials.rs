//! The series program's products with the pairs of factors they share computed once (issue 63).
//!
//! In the Taylor recurrences a product of two series is the costly operation (k + 1
//! multiply–adds for coefficient k, against one for a sum or a scale), so the program should
//! hold as few as the rates allow. The tape shares whole subexpressions, not parts of products:
//! the rolling disk's rates hold cos θ·ψ̇ inside cos²θ·ψ̇, cos θ·ψ̇² and φ̇·cos θ·ψ̇, five
//! products and a square as the tape writes them, four once cos θ·ψ̇ is one node.
//!
//! Each product of the program is taken as the multiset of its factors that depend on the
//! state (a small integer power of one, where only products use it, counting as that many
//! factors); then, greedily, the pair of factors found in the most products (at least two;
//! ties to the smallest pair, so the result is deterministic) becomes a factor of its own in
//! all of them, until no pair is shared (Re-Pair, as in the greedy multiplication-count
//! optimisers of FORM and of SymPy's `cse`). Every product keeps its value; only the
//! association of its factors changes, so its coefficients agree with the tape's to rounding.

use std::collections::{BTreeMap, BTreeSet, HashMap};

use hamel_expr::Op;

/// A factor of a product after sharing.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub(super) enum Factor {
    /// A tape operation's value.
    Op(usize),
    /// A shared pair ([`Monomials::pairs`]).
    Pair(usize),
}

/// The products of the program after sharing.
#[derive(Debug, Default)]
pub(super) struct Monomials {
    /// A product operation of the tape → its factors that depend on the state (its fixed
    /// operands stay the operation's).
    pub(super) of: HashMap<usize, Vec<Factor>>,
    /// A product operation → its operands fixed over the step.
    pub(super) fixed: HashMap<usize, Vec<usize>>,
    /// The shared pairs' two factors.
    pub(super) pairs: Vec<(Factor, Factor)>,
}

/// The largest integer power taken apart into factors (a higher one is squarings).
const SPLIT_POWER: i32 = 4;

impl Monomials {
    /// The products among the `needed` operations that depend on the state (`varying`), their
    /// pairs shared. `keep`: operations that must stay values of their own (the rates).
    pub(super) fn new(ops: &[Op], needed: &[bool], varying: &[bool], keep: &[usize]) -> Self {
        let split = split_powers(ops, needed, varying, keep);
        let mut m = Monomials::default();
        for (k, op) in ops.iter().enumerate() {
            let Op::Mul(list) = op else { continue };
            if !(needed[k] && varying[k]) {
                continue;
            }
            let mut factors = Vec::new();
            for &a in list.iter().filter(|&&a| varying[a]) {
                match &ops[a] {
                    Op::PowI(b, e) if split[a] => {
                        factors.extend(std::iter::repeat_n(Factor::Op(*b), *e as usize))
                    }
                    _ => factors.push(Factor::Op(a)),
                }
            }
            m.of.insert(k, factors);
            m.fixed
                .insert(k, list.iter().copied().filter(|&a| !varying[a]).collect());
        }
        m.share();
        m
    }

    /// The tape operations a product now reads: its fixed operands and its factors' atoms.
    pub(super) fn operands(&self, k: usize) -> Vec<usize> {
        let mut out = self.fixed[&k].clone();
        let mut stack = self.of[&k].clone();
        while let Some(f) = stack.pop() {
            match f {
                Factor::Op(a) => out.push(a),
                Factor::Pair(p) => stack.extend([self.pairs[p].0, self.pairs[p].1]),
            }
        }
        out
    }

    /// Re-Pair: the pair in the most products becomes a factor, until none is shared.
    fn share(&mut self) {
        let mut keys: Vec<usize> = self.of.keys().copied().collect();
        keys.sort_unstable();
        loop {
            let mut count: BTreeMap<(Factor, Factor), usize> = BTreeMap::new();
            for k in &keys {
                for pair in pairs_in(&self.of[k]) {
                    *count.entry(pair).or_default() += 1;
                }
            }
            let best = (count.iter().filter(|(_, n)| **n >= 2))
                .max_by_key(|(pair, n)| (**n, std::cmp::Reverse(**pair)));
            let Some((&(x, y), _)) = best else { return };
            let pair = Factor::Pair(self.pairs.len());
            self.pairs.push((x, y));
            for k in &keys {
                let factors = self.of.get_mut(k).expect("a key");
                if let Some(mut rest) = without(factors, x, y) {
                    rest.push(pair);
                    *factors = rest;
                }
            }
        }
    }
}

/// Which integer powers are taken apart: 2 ≤ e ≤ [`SPLIT_POWER`] of a varying base, needed,
/// used by products only and not to be kept.
fn split_powers(ops: &[Op], needed: &[bool], varying: &[bool], keep: &[usize]) -> Vec<bool> {
    let mut other_use = vec![false; ops.len()];
    keep.iter().for_each(|&k| other_use[k] = true);
    for (k, op) in ops.iter().enumerate().filter(|(k, _)| needed[*k]) {
        if !matches!(op, Op::Mul(_)) || !varying[k] {
            op.for_each_operand(|a| other_use[a] = true);
        }
    }
    (ops.iter().enumerate())
        .map(|(k, op)| match op {
            Op::PowI(b, e) => {
                needed[k] && varying[*b] && (2..=SPLIT_POWER).contains(e) && !other_use[k]
            }
            _ => false,
        })
        .collect()
}

/// The distinct unordered pairs of a multiset of factors (a factor with itself where it is
/// there twice).
fn pairs_in(f: &[Factor]) -> BTreeSet<(Factor, Factor)> {
    let mut out = BTreeSet::new();
    for i in 0..f.len() {
        for j in i + 1..f.len() {
            out.insert((f[i].min(f[j]), f[i].max(f[j])));
        }
    }
    out
}

/// The factors without one x and one y, if they hold both.
fn without(f: &[Factor], x: Factor, y: Factor) -> Option<Vec<Factor>> {
    let mut rest = f.to_vec();
    for z in [x, y] {
        let at = rest.iter().position(|&g| g == z)?;
        rest.remove(at);
    }
    Some(rest)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The rolling disk's products: cos²·ψ̇, cos·ψ̇², φ̇·cos·ψ̇ share cos·ψ̇, and the squares,
    /// used by products only, are taken apart.
    #[test]
    fn the_pair_in_most_products_is_computed_once() {
        let exprs: Vec<hamel_expr::Expr> = ["c^2*w", "c*w^2", "f*c*w", "f*s"]
            .iter()
            .map(|s| hamel_expr::parse(s).unwrap().expr)
            .collect();
        let inputs: Vec<String> = ["c", "w", "f", "s"].map(String::from).to_vec();
        let tape = hamel_expr::Tape::compile(&exprs.iter().collect::<Vec<_>>(), &inputs).unwrap();
        let ops = tape.ops();
        let (needed, varying) = (vec![true; ops.len()], vec![true; ops.len()]);
        let m = Monomials::new(ops, &needed, &varying, tape.outputs());
        let input = |i: usize| {
            let at = ops
                .iter()
                .position(|op| matches!(op, Op::Input(j) if *j == i));
            Factor::Op(at.unwrap())
        };
        let (c, w) = (input(0), input(1));
        assert_eq!(m.pairs, vec![(c.min(w), c.max(w))], "{m:?}");
        let mut sizes: Vec<usize> = m.of.values().map(Vec::len).collect();
        sizes.sort();
        assert_eq!(sizes, vec![2, 2, 2, 2], "{m:?}");
    }
}
