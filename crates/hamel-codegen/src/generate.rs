//! The generator proper: a derivation into the files of a crate (feature `derive`).

use std::fmt::Write;

use hamel_derive::Derivation;
use hamel_derive::conditioning::STATED_MULTIPLE;
use hamel_expr::{Expr, Func, Op, Tape};

use crate::{CodegenError, RUNTIME_SOURCES, escape, manifest};

mod contact;

/// A generated crate.
#[derive(Clone, Debug)]
pub struct Generated {
    /// Files, relative paths with their text.
    pub files: Vec<(String, String)>,
    /// Arithmetic operations of the ingredients written as separate trees.
    pub ops_trees: usize,
    /// The same after sharing common subexpressions.
    pub ops_shared: usize,
    /// The solved form written into `solved` (used by `fast` or not).
    pub solved: SolvedForm,
}

/// A solved form as plain trees (for comparisons with other evaluators).
#[derive(Clone, Debug)]
pub struct SolvedForm {
    /// The candidate's name (`Cramer's rule on block entries`, …).
    pub name: &'static str,
    /// Whether `fast` uses it (else the structured path).
    pub used: bool,
    /// η̇ (σ), then q̇ (ℓ).
    pub exprs: Vec<Expr>,
    /// Their inputs, in order: the coordinates, the parameters, then η (named `#eta0`, …).
    pub inputs: Vec<String>,
}

/// Which path the generated `fast` takes, and why.
struct PathChoice {
    solved: bool,
    doc: String,
}

/// States at which the paths are compared: a fixed pseudo-random sequence (deterministic) of
/// (q, η, parameter factors): q in [-3, 3] (every third in [-0.1, 0.1]), η in [-2, 2]; every
/// other state has each parameter scaled by a factor in [0.5, 2] (the others use the defaults).
fn sample_states(
    ell: usize,
    sigma: usize,
    npar: usize,
    n: usize,
) -> Vec<(Vec<f64>, Vec<f64>, Vec<f64>)> {
    let mut x: u64 = 0x9e37_79b9_7f4a_7c15;
    let mut next = || {
        x ^= x << 13;
        x ^= x >> 7;
        x ^= x << 17;
        (x >> 11) as f64 / (1u64 << 53) as f64
    };
    (0..n)
        .map(|k| {
            // Every third state near q = 0 (where mechanisms often sit upright, and terms of
            // expanded forms cancel).
            let spread = if k % 3 == 2 { 0.1 } else { 3.0 };
            let q = (0..ell).map(|_| spread * (2.0 * next() - 1.0)).collect();
            let eta = (0..sigma).map(|_| -2.0 + 4.0 * next()).collect();
            let factors = (0..npar)
                .map(|_| {
                    let f = 0.5 * 4.0_f64.powf(next());
                    if k % 2 == 1 { f } else { 1.0 }
                })
                .collect();
            (q, eta, factors)
        })
        .collect()
}

/// Floating-point errors at up to 200 sample states ([`sample_states`]: half of them at other
/// parameters) with [Z; α] well conditioned and A_Γ positive definite, relative (max |Δ| / max(1, max |·|) over η̇ and q̇), against the
/// structured evaluation in double-double arithmetic (about 32 digits): the largest error of
/// the solved tape in f64, the largest error of the structured evaluation in f64, and the
/// number of states used. The reference also checks that the candidate is the same function.
fn deviation(
    d: &Derivation,
    compiled: &hamel_derive::Compiled,
    solved: &Tape,
) -> (f64, f64, usize) {
    use hamel_expr::{DD, Scalar};
    let (ell, sigma) = (d.ell, d.sigma);
    let (mut worst, mut worst_structured) = (0.0_f64, 0.0_f64);
    let mut used = 0;
    for (q, eta, factors) in sample_states(ell, sigma, d.parameters.len(), 400) {
        let mut params = d.parameters.clone();
        for (v, f) in params.values_mut().zip(&factors) {
            *v *= f;
        }
        if used == 200 {
            break;
        }
        if compiled.condition(&q, &params).map_or(true, |c| c > 1e6) {
            continue;
        }
        let dd = |v: &[f64]| v.iter().map(|&x| DD::constant(x)).collect::<Vec<_>>();
        let (Ok(r), Ok(s)) = (
            compiled.rhs::<DD>(&dd(&q), &dd(&eta), &params),
            compiled.rhs::<f64>(&q, &eta, &params),
        ) else {
            continue;
        };
        let Some(out) = solved_at(solved, &q, &params, &eta, ell + sigma) else {
            continue;
        };
        let (eta_dot, q_dot) = out.split_at(sigma);
        let exact: Vec<f64> = r
            .eta_dot
            .iter()
            .chain(&r.q_dot)
            .map(|x| x.value())
            .collect();
        let scale = exact.iter().fold(1.0_f64, |m, x| m.max(x.abs()));
        let error = |v: Vec<f64>| {
            v.iter()
                .zip(&exact)
                .map(|(a, b)| (a - b).abs())
                .fold(0.0, f64::max)
                / scale
        };
        worst = worst.max(error(eta_dot.iter().chain(q_dot).copied().collect()));
        worst_structured =
            worst_structured.max(error(s.eta_dot.iter().chain(&s.q_dot).copied().collect()));
        used += 1;
    }
    (worst, worst_structured, used)
}

/// The solved tape in f64 at (q, η): η̇ then q̇ (`n` = σ + ℓ values), or `None` where it fails
/// or a definiteness pivot after them is not positive.
fn solved_at(
    solved: &Tape,
    q: &[f64],
    params: &indexmap::IndexMap<String, f64>,
    eta: &[f64],
    n: usize,
) -> Option<Vec<f64>> {
    let inputs: Vec<f64> = q
        .iter()
        .chain(params.values())
        .chain(eta)
        .copied()
        .collect();
    let mut out = solved.eval::<f64>(&inputs).ok()?;
    if out[n..].iter().any(|&p| p <= 0.0) {
        return None;
    }
    out.truncate(n);
    Some(out)
}

/// A configuration approaching the singular set, with what any candidate is compared against:
/// (q, η) and η̇ in double-double, its largest magnitude, and κ.
struct NearSingular {
    q: Vec<f64>,
    eta_dot: Vec<hamel_expr::DD>,
    scale: f64,
    kappa: f64,
}

/// Configurations approaching each factor of δ that depends on the coordinates (distances
/// 1e-2 … 1e-7 on both sides, default parameters), with the structured evaluation in
/// double-double and the problem's own condition number κ ([`hamel_derive::conditioning`]) at
/// each: computed once, for every candidate; with the η they share.
fn near_singular_states(
    d: &Derivation,
    compiled: &hamel_derive::Compiled,
) -> (Vec<NearSingular>, Vec<f64>) {
    use hamel_derive::conditioning::{problem_condition, singular_points};
    use hamel_expr::DD;
    let params = &d.parameters;
    let eta: Vec<f64> = (0..d.sigma)
        .map(|i| [0.8, -1.3, 0.4][i % 3] / (1 + i / 3) as f64)
        .collect();
    let dd = |v: &[f64]| v.iter().map(|&x| DD::from_f64(x)).collect::<Vec<_>>();
    let states = singular_points(d, params, 1)
        .iter()
        .flat_map(|point| point.approach(2..=7))
        .filter_map(|q| {
            let r = compiled.rhs::<DD>(&dd(&q), &dd(&eta), params).ok()?;
            let kappa = problem_condition(compiled, &q, &eta, params).ok()?;
            let scale = r
                .eta_dot
                .iter()
                .fold(0.0_f64, |m, x| m.max(x.to_f64().abs()));
            kappa.is_finite().then_some(NearSingular {
                q,
                eta_dot: r.eta_dot,
                scale,
                kappa,
            })
        })
        .collect();
    (states, eta)
}

/// The worst relative error of η̇ from the solved tape in f64 at `states`, as a multiple of
/// (κ + 1)·ε, and the number of states used. Where the solved form divides by the factors of δ
/// it keeps the digits the problem has; where its expanded numerators cancel it may not.
fn near_singular_set(
    d: &Derivation,
    (states, eta): &(Vec<NearSingular>, Vec<f64>),
    solved: &Tape,
) -> (f64, usize) {
    use hamel_expr::DD;
    let (mut worst, mut used) = (0.0_f64, 0);
    for s in states {
        let Some(out) = solved_at(solved, &s.q, &d.parameters, eta, d.ell + d.sigma) else {
            continue;
        };
        let error = out[..d.sigma]
            .iter()
            .zip(&s.eta_dot)
            .map(|(a, b)| (DD::from_f64(*a) - *b).to_f64().abs())
            .fold(0.0, f64::max)
            / s.scale.max(f64::MIN_POSITIVE);
        worst = worst.max(error / ((s.kappa + 1.0) * f64::EPSILON));
        used += 1;
    }
    (worst, used)
}

/// The path of the generated `fast`: the candidate solved forms are tried from the fewest
/// operations at run time with fixed parameters ([`Tape::varying_operation_count`]; total
/// operations break ties). One is used when its shared operation count is at most the
/// structured path's estimate (the ingredients' plus ℓ³ + σ²ℓ², a lower estimate of what the
/// structured runtime adds: the LU of [Z; α] and the contractions of (11)) and it agrees with
/// a double-double reference at 200 sample states at least as well as the structured path, or
/// to 1e-12 ([`deviation`]), and within [`STATED_MULTIPLE`] (κ + 1)·ε approaching the singular
/// set ([`near_singular_states`], [`near_singular_set`]). Its expanded forms
/// can cancel badly in floating point (derivation.md §4), hence the check; the decision only
/// selects a code path, exactness is not at stake. Returns the choice and the candidate used
/// (the cheapest one when the structured path is taken) with its tape; no candidate for a
/// structured derivation, which has no closed form to solve.
fn choose_path(
    d: &Derivation,
    ingredients: &Tape,
    candidates: Vec<Candidate>,
    inputs: &[String],
    slots: &Slots,
) -> Result<(PathChoice, Option<(Candidate, Tape)>), String> {
    let ell = d.ell;
    if candidates.is_empty() {
        let doc = format!(
            "structured (the derivation is in structured form, docs/derivation.md §6: no closed form to solve; estimate: {} operations = ingredients + ℓ³ + σ²ℓ²)",
            ingredients.operation_count() + ell.pow(3) + d.sigma.pow(2) * ell.pow(2)
        );
        return Ok((PathChoice { solved: false, doc }, None));
    }
    let mut tried: Vec<(usize, usize, Candidate, Tape)> = candidates
        .into_iter()
        .map(|c| {
            let tape = Tape::compile(&c.exprs.iter().collect::<Vec<_>>(), inputs)
                .map_err(|e| e.to_string())?;
            Ok((
                tape.varying_operation_count(|i| slots.varying(i)),
                tape.operation_count(),
                c,
                tape,
            ))
        })
        .collect::<Result<_, String>>()?;
    tried.sort_by_key(|t| (t.0, t.1));
    let ops_s = ingredients.operation_count() + ell.pow(3) + d.sigma.pow(2) * ell.pow(2);
    let compiled = d.compile().map_err(|e| e.to_string())?;
    let near_states = near_singular_states(d, &compiled);
    let mut notes = Vec::new();
    let mut pick = None;
    for (k, (run, ops, c, tape)) in tried.iter().enumerate() {
        if *ops > ops_s {
            notes.push(format!("`{}` ({ops} operations) is more than that", c.name));
            continue;
        }
        let (worst, structured, used) = deviation(d, &compiled, tape);
        let (near, near_used) = near_singular_set(d, &near_states, tape);
        if used >= 100 && worst <= structured.max(1e-12) && near <= STATED_MULTIPLE {
            let near = if near_used == 0 {
                String::new()
            } else {
                format!(
                    "; at {near_used} states approaching the singular set, at most {near:.1e} (κ + 1)·ε"
                )
            };
            pick = Some((
                k,
                format!(
                    "solved form (`{}`): {ops} operations, {run} of them at run time with fixed parameters, against the structured path's {ops_s} (ingredients + ℓ³ + σ²ℓ²); at {used} sample states its relative error in f64 is at most {worst:.1e} (structured path: {structured:.1e}; reference: double-double){near}",
                    c.name
                ),
            ));
            break;
        }
        if near > STATED_MULTIPLE {
            notes.push(format!(
                "`{}` loses digits approaching the singular set: relative error {near:.1e} (κ + 1)·ε, above {STATED_MULTIPLE}",
                c.name
            ));
            continue;
        }
        notes.push(format!(
            "`{}` has relative error {worst:.1e} at {used} sample states, above max(1e-12, the structured path's {structured:.1e}), or too few states",
            c.name
        ));
    }
    let (solved, k, mut doc) = match pick {
        Some((k, doc)) => (true, k, doc),
        None => (
            false,
            0,
            format!("structured (estimate: {ops_s} operations = ingredients + ℓ³ + σ²ℓ²)"),
        ),
    };
    if !notes.is_empty() {
        doc += &format!("; not used: {}", notes.join("; "));
    }
    doc += &format!(
        ". Candidates (operations at run time / in all): {}.",
        list(
            tried
                .iter()
                .map(|(run, ops, c, _)| format!("`{}` {run}/{ops}", c.name))
        )
    );
    let (_, _, c, tape) = tried.swap_remove(k);
    Ok((PathChoice { solved, doc }, Some((c, tape))))
}

/// Names of the η inputs of the solved tape (not valid model names, so they cannot clash).
fn eta_input(s: usize) -> String {
    format!("#eta{s}")
}

/// The tapes' η inputs as symbols, `#eta0..`.
fn eta_syms(sigma: usize) -> Vec<Expr> {
    (0..sigma).map(|s| Expr::sym(&eta_input(s))).collect()
}

/// q̇ = Γη (6) from the closed form's Γ, each entry passed through `h` first.
fn gamma_eta(gamma: &hamel_derive::Mat, eta: &[Expr], h: &dyn Fn(&Expr) -> Expr) -> Vec<Expr> {
    use fold::*;
    gamma
        .entries
        .iter()
        .map(|row| {
            row.iter().zip(eta).fold(Expr::int(0), |acc, (e, x)| {
                add(acc, mul(h(&e.expr), x.clone()))
            })
        })
        .collect()
}

/// Expression builders that fold exact zeros and ones, so that structural zeros of Γ, A_Γ and
/// Q⁽ⁱ⁾ vanish from the solved form (in floating point 0·x is not 0 for every x, so the
/// compiler could not do this).
use hamel_expr::build as fold;

/// A candidate solved form: outputs η̇ (σ), q̇ = Γη (ℓ, eq. (6)) and σ definiteness tests (the
/// pivots of A_Γ = L D Lᵀ, or the leading minors of its blocks); one ≤ 0 means A_Γ is not
/// positive definite there.
struct Candidate {
    name: &'static str,
    exprs: Vec<Expr>,
}

/// Gaussian elimination without pivoting (stable for the symmetric positive definite A_Γ) on
/// trees, folding exact zeros and ones: the solution x of a x = b and the pivots. One
/// reciprocal per pivot, shared by its multipliers and its back substitution (a division costs
/// several multiplications).
fn eliminate(mut a: Vec<Vec<Expr>>, mut b: Vec<Expr>) -> (Vec<Expr>, Vec<Expr>) {
    use fold::*;
    let g = b.len();
    let inverse: Vec<Expr> = (0..g)
        .map(|k| {
            for i in k + 1..g {
                let f = mul(a[i][k].clone(), div(Expr::int(1), a[k][k].clone()));
                if f.is_zero_literal() {
                    continue;
                }
                for j in k + 1..g {
                    a[i][j] = sub(a[i][j].clone(), mul(f.clone(), a[k][j].clone()));
                }
                b[i] = sub(b[i].clone(), mul(f, b[k].clone()));
            }
            div(Expr::int(1), a[k][k].clone())
        })
        .collect();
    let mut x = vec![Expr::int(0); g];
    for k in (0..g).rev() {
        let mut r = b[k].clone();
        for j in k + 1..g {
            r = sub(r, mul(a[k][j].clone(), x[j].clone()));
        }
        x[k] = mul(r, inverse[k].clone());
    }
    (x, (0..g).map(|k| a[k][k].clone()).collect())
}

/// The diagonal blocks of a matrix (connected components of its nonzero pattern; exact zeros
/// are zero literals), each as its sorted rows, in order of first row.
fn diagonal_blocks(a: &[Vec<Expr>]) -> Vec<Vec<usize>> {
    let g = a.len();
    let mut block_of: Vec<usize> = (0..g).collect();
    fn root(b: &mut [usize], mut i: usize) -> usize {
        while b[i] != i {
            b[i] = b[b[i]];
            i = b[i];
        }
        i
    }
    for r in 0..g {
        for s in 0..g {
            if !a[r][s].is_zero_literal() {
                let (x, y) = (root(&mut block_of, r), root(&mut block_of, s));
                block_of[x.max(y)] = x.min(y);
            }
        }
    }
    let mut blocks: Vec<Vec<usize>> = Vec::new();
    for r in 0..g {
        let k = root(&mut block_of, r);
        match blocks.iter_mut().find(|b| b[0] == k) {
            Some(b) => b.push(r),
            None => blocks.push(vec![r]),
        }
    }
    blocks
}

/// The definiteness tests of a symmetric matrix without divisions where it can: for each
/// diagonal block ([`diagonal_blocks`]) of at most 3 rows its leading principal minors (all
/// positive iff the block is positive definite, Sylvester's criterion), for a larger one the
/// pivots of its elimination.
fn block_minors(a: &[Vec<Expr>]) -> Vec<Expr> {
    use fold::*;
    let mut tests = Vec::new();
    for rows in diagonal_blocks(a) {
        let m = |i: usize, j: usize| a[rows[i]][rows[j]].clone();
        let minor2 = |i: usize, j: usize, k: usize, l: usize| {
            sub(mul(m(i, k), m(j, l)), mul(m(i, l), m(j, k)))
        };
        match rows.len() {
            1 => tests.push(m(0, 0)),
            2 => tests.extend([m(0, 0), minor2(0, 1, 0, 1)]),
            3 => {
                // Expanded along the first row.
                let det = add(
                    sub(
                        mul(m(0, 0), minor2(1, 2, 1, 2)),
                        mul(m(0, 1), minor2(1, 2, 0, 2)),
                    ),
                    mul(m(0, 2), minor2(1, 2, 0, 1)),
                );
                tests.extend([m(0, 0), minor2(0, 1, 0, 1), det]);
            }
            n => {
                let sub_a: Vec<Vec<Expr>> =
                    (0..n).map(|i| (0..n).map(|j| m(i, j)).collect()).collect();
                tests.extend(eliminate(sub_a, vec![Expr::int(0); n]).1);
            }
        }
    }
    tests
}

/// a x = b block by block ([`diagonal_blocks`]): Cramer's rule on the entries for blocks of at
/// most 3 rows (the determinant and adjugate as products of entries, not expanded; one
/// reciprocal of the determinant per block), elimination for larger ones. Returns x and the
/// definiteness tests: each block's leading principal minors (Sylvester's criterion), or its
/// pivots.
fn cramer_on_entries(a: &[Vec<Expr>], b: &[Expr]) -> (Vec<Expr>, Vec<Expr>) {
    use fold::*;
    let mut x = vec![Expr::int(0); b.len()];
    let mut tests = Vec::new();
    for rows in diagonal_blocks(a) {
        let m = |i: usize, j: usize| a[rows[i]][rows[j]].clone();
        let minor2 = |i: usize, j: usize, k: usize, l: usize| {
            sub(mul(m(i, k), m(j, l)), mul(m(i, l), m(j, k)))
        };
        // adj[i][j]: the cofactor of entry (j, i).
        let (adj, det, minors): (Vec<Vec<Expr>>, Expr, Vec<Expr>) = match rows.len() {
            1 => (vec![vec![Expr::int(1)]], m(0, 0), vec![m(0, 0)]),
            2 => {
                let det = minor2(0, 1, 0, 1);
                let neg = |e: Expr| Expr::Neg(Box::new(e)).tidy();
                (
                    vec![vec![m(1, 1), neg(m(0, 1))], vec![neg(m(1, 0)), m(0, 0)]],
                    det.clone(),
                    vec![m(0, 0), det],
                )
            }
            3 => {
                let cof = |i: usize, j: usize| {
                    let (r0, r1) = match i {
                        0 => (1, 2),
                        1 => (0, 2),
                        _ => (0, 1),
                    };
                    let (c0, c1) = match j {
                        0 => (1, 2),
                        1 => (0, 2),
                        _ => (0, 1),
                    };
                    let c = minor2(r0, r1, c0, c1);
                    if (i + j) % 2 == 1 {
                        Expr::Neg(Box::new(c)).tidy()
                    } else {
                        c
                    }
                };
                let adj: Vec<Vec<Expr>> = (0..3)
                    .map(|i| (0..3).map(|j| cof(j, i)).collect())
                    .collect();
                let det = (0..3).fold(Expr::int(0), |acc, j| {
                    add(acc, mul(m(0, j), adj[j][0].clone()))
                });
                (adj, det.clone(), vec![m(0, 0), minor2(0, 1, 0, 1), det])
            }
            _ => {
                let sub_a: Vec<Vec<Expr>> = (0..rows.len())
                    .map(|i| (0..rows.len()).map(|j| m(i, j)).collect())
                    .collect();
                let (y, pivots) = eliminate(sub_a, rows.iter().map(|&r| b[r].clone()).collect());
                for (&r, y) in rows.iter().zip(y) {
                    x[r] = y;
                }
                tests.extend(pivots);
                continue;
            }
        };
        let inverse = div(Expr::int(1), det);
        for (i, &r) in rows.iter().enumerate() {
            let num = rows.iter().enumerate().fold(Expr::int(0), |acc, (j, &c)| {
                add(acc, mul(adj[i][j].clone(), b[c].clone()))
            });
            x[r] = mul(num, inverse.clone());
        }
        tests.extend(minors);
    }
    (x, tests)
}

/// The candidate solved forms of A_Γ η̇ = Γᵀ∇U − Σ_rs Q⁽ⁱ⁾_rs η_r η_s (eq. (11) with the true Q
/// of derivation.md), η as inputs:
/// * `elimination`: elimination on the trees of A_Γ, Γᵀ∇U and Q⁽ⁱ⁾ as derived;
/// * `elimination of normal forms`: the same on the normal form of each right-hand side b_i
///   (like terms of Q collected by the CAS), all in Horner form;
/// * `Cramer's rule on blocks`: for each diagonal block of A_Γ (at most 3 rows), η̇ = adj(A) b /
///   det A with the adjugate and the determinant as exact normal forms (no cancellation in
///   the determinant); instead of pivots, the block's leading principal minors (all > 0 iff
///   the block is positive definite, Sylvester's criterion);
/// * `Cramer's rule on block entries`: the same with the determinant and adjugate written as
///   products of the (Horner-form) entries of A_Γ, not expanded, and blocks of any size
///   (elimination beyond 3 rows) found from A_Γ's exact zeros;
/// * `normal form`: η̇ = A_Γ⁻¹ b as one exact normal form per component (when the CAS kept it
///   small), in Horner form; the pivots still come from eliminating A_Γ.
///
/// Horner forms take out the state (q, η) first, so that the coefficients left are
/// polynomials in the parameters alone (hoisted out of loops with fixed parameters).
fn solved_candidates(d: &Derivation) -> Vec<Candidate> {
    use fold::*;
    // A structured derivation has no closed form to solve: the structured path only.
    let Some(c) = d.closed() else {
        return Vec::new();
    };
    let g = d.sigma;
    let params: Vec<&String> = d.parameters.keys().collect();
    let late = |f: &Expr| {
        !f.any(&mut |e| match e {
            Expr::Sym(n) => !params.contains(&n),
            Expr::Der(_) | Expr::Free { .. } => true,
            _ => false,
        })
    };
    let hor = |e: &Expr| e.horner_by(&late);
    // The CAS names η `eta1..`; the tapes take them as `#eta0..`.
    let rename = |e: &Expr| {
        e.map(&mut |x| match x {
            Expr::Sym(n) => match n.strip_prefix("eta").and_then(|k| k.parse::<usize>().ok()) {
                Some(k) if (1..=g).contains(&k) && !params.iter().any(|p| **p == n) => {
                    Expr::sym(&eta_input(k - 1))
                }
                _ => Expr::Sym(n),
            },
            other => other,
        })
    };
    let eta = eta_syms(g);
    let q_dot = |h: &dyn Fn(&Expr) -> Expr| gamma_eta(&c.gamma, &eta, h);
    let a_gamma = |h: &dyn Fn(&Expr) -> Expr| -> Vec<Vec<Expr>> {
        (0..g)
            .map(|r| (0..g).map(|s| h(&c.a_gamma.entries[r][s].expr)).collect())
            .collect()
    };
    let assemble = |name, x: Vec<Expr>, q_dot: Vec<Expr>, pivots: Vec<Expr>| Candidate {
        name,
        exprs: x.into_iter().chain(q_dot).chain(pivots).collect(),
    };
    let mut out = Vec::new();

    let b_trees: Vec<Expr> = (0..g)
        .map(|i| {
            let mut x = rename(&c.forcing[i].expr);
            for r in 0..g {
                let row = (0..g).fold(Expr::int(0), |acc, s| {
                    add(acc, mul(c.q[i].entries[r][s].expr.clone(), eta[s].clone()))
                });
                x = sub(x, mul(row, eta[r].clone()));
            }
            x
        })
        .collect();
    let (x, pivots) = eliminate(a_gamma(&|e| e.clone()), b_trees);
    out.push(assemble("elimination", x, q_dot(&|e| e.clone()), pivots));

    let ing = &d.ingredients;
    let a_hor = a_gamma(&hor);
    // The normal forms of b (empty unless the derivation was made for code generation).
    let b: Vec<Expr> = ing.eta_rhs.iter().map(|e| hor(&rename(&e.expr))).collect();
    if b.len() == g {
        let (x, pivots) = eliminate(a_hor.clone(), b.clone());
        out.push(assemble(
            "elimination of normal forms",
            x,
            q_dot(&hor),
            pivots,
        ));
    }
    if let (Some(blocks), true) = (&ing.blocks, b.len() == g) {
        let mut x = vec![Expr::int(0); g];
        let mut minors = Vec::new();
        for blk in blocks {
            let det = hor(&blk.det.expr);
            for (i, &r) in blk.rows.iter().enumerate() {
                let num = blk
                    .rows
                    .iter()
                    .enumerate()
                    .fold(Expr::int(0), |acc, (j, &c)| {
                        add(acc, mul(hor(&blk.adj[i][j].expr), b[c].clone()))
                    });
                x[r] = div(num, det.clone());
            }
            minors.extend(blk.minors.iter().map(|m| hor(&m.expr)));
        }
        out.push(assemble("Cramer's rule on blocks", x, q_dot(&hor), minors));
    }
    if b.len() == g {
        let (x, minors) = cramer_on_entries(&a_hor, &b);
        out.push(assemble(
            "Cramer's rule on block entries",
            x,
            q_dot(&hor),
            minors,
        ));
    }
    if let Some(eta_dot) = &ing.eta_dot {
        let x: Vec<Expr> = eta_dot.iter().map(|e| hor(&rename(&e.expr))).collect();
        out.push(assemble(
            "normal form",
            x,
            q_dot(&hor),
            block_minors(&a_hor),
        ));
    }
    out
}

fn ident(name: &str) -> String {
    let s: String = name
        .chars()
        .map(|c| if c.is_ascii_alphanumeric() { c } else { '_' })
        .collect();
    if s.chars().next().is_some_and(|c| c.is_ascii_digit()) || s == "self" || s == "type" {
        format!("p_{s}")
    } else {
        s
    }
}

fn lit(x: f64) -> String {
    let s = format!("{x:?}");
    if s.contains('.') || s.contains('e') || s.contains("inf") || s.contains("NaN") {
        s
    } else {
        format!("{s}.0")
    }
}

/// One `let` per shared operation of `tape`, its inputs taken from `slots`.
/// A sine and a cosine of the same argument are computed together (`sin_cos`). In sums and
/// products the operands that do not depend on the state come first, so that with fixed
/// parameters their part is loop-invariant (left-to-right evaluation).
///
/// With a [`Hoist`] plan, `part` selects the fixed half (the lets of `Prepared::new`, plus one
/// `f{k}` per combination of fixed operands) or the varying half (the fixed values it needs
/// read from the prepared array `c`).
fn lets(tape: &Tape, slots: &Slots, part: Part) -> String {
    let ops = tape.ops();
    let varying = tape.varying(|i| slots.varying(i));
    let ordered = |k: usize, v: &[usize], sep: &str| -> String {
        let (fixed, moving): (Vec<usize>, Vec<usize>) = v.iter().partition(|&&k| !varying[k]);
        let fixed: Vec<String> = match part {
            Part::Varying(h) if h.part.contains_key(&k) => {
                vec![format!("S::constant(c[{}])", h.part[&k])]
            }
            _ => fixed.iter().map(|k| format!("t{k}")).collect(),
        };
        fixed
            .into_iter()
            .chain(moving.iter().map(|k| format!("t{k}")))
            .collect::<Vec<_>>()
            .join(sep)
    };
    // For each sin(a), the index of cos(a) if the tape has it (and the other way round).
    let mut partner: Vec<Option<usize>> = vec![None; ops.len()];
    {
        let mut cos_of = std::collections::HashMap::new();
        for (k, op) in ops.iter().enumerate() {
            if let Op::Call(Func::Cos, a) = op {
                cos_of.insert(*a, k);
            }
        }
        for (k, op) in ops.iter().enumerate() {
            if let Op::Call(Func::Sin, a) = op
                && let Some(&c) = cos_of.get(a)
            {
                partner[k] = Some(c);
                partner[c] = Some(k);
            }
        }
    }
    let mut paired = vec![false; ops.len()];
    let mut o = String::new();
    for (k, op) in ops.iter().enumerate() {
        if paired[k] {
            continue;
        }
        match part {
            Part::All => {}
            Part::Fixed(h) => {
                if let (Some(_), Op::Add(v) | Op::Mul(v)) = (h.part.get(&k), op) {
                    let sep = if matches!(op, Op::Add(_)) {
                        " + "
                    } else {
                        " * "
                    };
                    let fixed: Vec<String> = v
                        .iter()
                        .filter(|&&a| !varying[a])
                        .map(|a| format!("t{a}"))
                        .collect();
                    let _ = writeln!(o, "    let f{k} = {};", fixed.join(sep));
                }
                if varying[k] {
                    continue;
                }
            }
            Part::Varying(h) if !varying[k] => {
                if let Some(j) = h.op.get(&k) {
                    let _ = writeln!(o, "    let t{k} = S::constant(c[{j}]);");
                    continue;
                } else if !h.consts.contains(&k) {
                    continue;
                }
            }
            Part::Varying(_) => {}
        }
        let rhs = match op {
            Op::Input(i) => slots.text(*i),
            Op::Const(r) => format!("S::constant({})", lit(Expr::rational_to_f64(r))),
            Op::Add(v) => ordered(k, v, " + "),
            Op::Mul(v) => ordered(k, v, " * "),
            Op::Neg(a) => format!("-t{a}"),
            // A constant divisor: a multiplication by its reciprocal, rounded once (a division
            // costs several multiplications; the quotient moves by at most an ulp).
            Op::Div(a, b) => match &ops[*b] {
                Op::Const(r) if *r.numer() != 0.into() => {
                    let recip = Expr::rational_to_f64(&r.recip());
                    format!("t{a} * S::constant({})", lit(recip))
                }
                _ => format!("t{a} / t{b}"),
            },
            Op::PowI(a, n) => format!("t{a}.powi({n})"),
            Op::PowF(a, b) => format!("t{a}.powf(t{b})"),
            Op::Call(f, a) if partner[k].is_some() => {
                let other = partner[k].unwrap();
                paired[other] = true;
                let (sin, cos) = if *f == Func::Sin {
                    (k, other)
                } else {
                    (other, k)
                };
                let _ = writeln!(o, "    let (t{sin}, t{cos}) = t{a}.sin_cos();");
                continue;
            }
            Op::Call(f, a) => {
                let name = match f {
                    Func::Sin => "sin",
                    Func::Cos => "cos",
                    Func::Tan => "tan",
                    Func::Sqrt => "sqrt",
                    Func::Exp => "exp",
                    Func::Log => "ln",
                    Func::Atan => "atan",
                };
                format!("t{a}.{name}()")
            }
            Op::Atan2(y, x) => format!("t{y}.atan2(t{x})"),
        };
        let _ = writeln!(o, "    let t{k} = {rhs};");
    }
    o
}

/// Which operations of a tape [`lets`] writes.
#[derive(Clone, Copy)]
enum Part<'a> {
    /// All of them, in one function.
    All,
    /// Those that do not depend on the state, and the hoisted values (`Prepared::new`).
    Fixed(&'a Hoist),
    /// Those that depend on the state, reading the hoisted values from `c`.
    Varying(&'a Hoist),
}

/// The values of a solved tape computed once per parameter set (`Prepared`): the fixed
/// (parameter-only) operations used by a varying one or as a result, and for each varying sum
/// or product with two or more fixed operands, their combination (`f{k}`, left to right, as
/// the unsplit code evaluates it, so the results are unchanged bit for bit). Constants that
/// the varying half uses stay inline there.
struct Hoist {
    /// Fixed operation → index in the prepared array.
    op: std::collections::HashMap<usize, usize>,
    /// Varying sum or product → index of its fixed operands' combination.
    part: std::collections::HashMap<usize, usize>,
    /// Constants used by the varying half.
    consts: std::collections::HashSet<usize>,
    /// The names of the prepared array's entries, in order (`t{k}` or `f{k}`).
    names: Vec<String>,
    /// The definiteness tests that depend on the parameters alone (checked once).
    fixed_tests: Vec<usize>,
    /// The others (checked at every state).
    varying_tests: Vec<usize>,
}

impl Hoist {
    /// The plan for `tape` whose outputs are σ + `n_rates` results, then the tests.
    fn new(tape: &Tape, slots: &Slots, n_results: usize) -> Hoist {
        let varying = tape.varying(|i| slots.varying(i));
        let ops = tape.ops();
        let mut h = Hoist {
            op: Default::default(),
            part: Default::default(),
            consts: Default::default(),
            names: Vec::new(),
            fixed_tests: Vec::new(),
            varying_tests: Vec::new(),
        };
        let use_fixed = |h: &mut Hoist, a: usize| {
            if !varying[a] && matches!(ops[a], Op::Const(_)) {
                h.consts.insert(a);
            } else if !varying[a] && !h.op.contains_key(&a) {
                h.op.insert(a, h.names.len());
                h.names.push(format!("t{a}"));
            }
        };
        for (k, op) in ops.iter().enumerate() {
            if !varying[k] {
                continue;
            }
            match op {
                Op::Add(v) | Op::Mul(v) => {
                    let fixed: Vec<usize> = v.iter().copied().filter(|&a| !varying[a]).collect();
                    if fixed.len() >= 2 {
                        h.part.insert(k, h.names.len());
                        h.names.push(format!("f{k}"));
                    } else {
                        fixed.into_iter().for_each(|a| use_fixed(&mut h, a));
                    }
                }
                Op::Neg(a) | Op::PowI(a, _) | Op::Call(_, a) => use_fixed(&mut h, *a),
                Op::Div(a, b) | Op::PowF(a, b) | Op::Atan2(a, b) => {
                    use_fixed(&mut h, *a);
                    use_fixed(&mut h, *b);
                }
                Op::Input(_) | Op::Const(_) => {}
            }
        }
        let out = tape.outputs();
        for &o in &out[..n_results] {
            use_fixed(&mut h, o);
        }
        for &o in &out[n_results..] {
            if varying[o] {
                h.varying_tests.push(o);
            } else {
                h.fixed_tests.push(o);
            }
        }
        h
    }
}

/// The error text of a failed definiteness test.
const NOT_DEFINITE: &str = "A_Γ is not positive definite (a pivot of its L D Lᵀ factorisation, or a leading minor of a block, is not > 0)";

/// `if !(tests > 0) { return Err(…) }` for the given tape entries (nothing if none).
fn definiteness_check(tests: &[usize], place: &str) -> String {
    if tests.is_empty() {
        return String::new();
    }
    format!(
        "    if !({}) {{\n        return Err(runtime::cold_error(\"{NOT_DEFINITE} {place}\"));\n    }}\n",
        tests
            .iter()
            .map(|i| format!("t{i}.value() > 0.0"))
            .collect::<Vec<_>>()
            .join(" && ")
    )
}

/// Where a tape's inputs come from in the generated function: slots are `n` coordinates
/// (`coords[0..n]`), the parameters, then η (`eta[eta_at..]`).
#[derive(Clone, Copy)]
struct Slots<'a> {
    coords: &'a str,
    n: usize,
    params: &'a [String],
    /// The parameters set at every evaluation ([`Derivation::live`]): varying, like the state.
    live: &'a [String],
    eta: &'a str,
    eta_at: usize,
}

impl Slots<'_> {
    /// Whether input slot `i` is part of the state (not a parameter).
    fn varying(&self, i: usize) -> bool {
        i < self.n
            || i >= self.n + self.params.len()
            || self.live.contains(&self.params[i - self.n])
    }

    /// The Rust text of input slot `i`.
    fn text(&self, i: usize) -> String {
        let np = self.params.len();
        if i < self.n {
            format!("{}[{i}]", self.coords)
        } else if i < self.n + np {
            format!("S::constant(p.{})", ident(&self.params[i - self.n]))
        } else {
            format!("{}[{}]", self.eta, self.eta_at + i - self.n - np)
        }
    }
}

/// The straight-line body of `ingredients`: the lets, then `out[j] = …`.
fn straight_line(tape: &Tape, slots: &Slots) -> String {
    let mut o = lets(tape, slots, Part::All);
    for (j, i) in tape.outputs().iter().enumerate() {
        let _ = writeln!(o, "    out[{j}] = t{i};");
    }
    o
}

/// The two halves of a solved-form function. The tape's outputs are η̇ (σ), rates
/// (`n_rates`), then the definiteness tests; `ret` writes the result from the texts of η̇ and
/// of the rates. Returns (the body of `prepare_*`, which checks the parameter-only tests and
/// returns the prepared array, the body of `*_from`, which reads that array as `c`, the
/// array's length). Without `hoist` (a form not on the fast path, which is then never compiled
/// unless called), nothing is prepared and the body does it all.
fn solved_body(
    tape: &Tape,
    slots: &Slots,
    hoist: bool,
    sigma: usize,
    n_rates: usize,
    ret: impl Fn(String, String) -> String,
) -> (String, String, usize) {
    let h = Hoist::new(tape, slots, sigma + n_rates);
    let (fixed, mut body) = if hoist {
        let mut fixed = lets(tape, slots, Part::Fixed(&h));
        fixed += &definiteness_check(&h.fixed_tests, "for these parameters");
        let _ = writeln!(fixed, "    Ok([{}])", list(h.names.iter().cloned()));
        let mut body = lets(tape, slots, Part::Varying(&h));
        body += &definiteness_check(&h.varying_tests, "here");
        (fixed, body)
    } else {
        let mut body = lets(tape, slots, Part::All);
        let tests = [h.fixed_tests.as_slice(), &h.varying_tests].concat();
        body.push_str(&definiteness_check(&tests, "here"));
        ("    Ok([])\n".to_string(), body)
    };
    let out = tape.outputs();
    let t = |i: &usize| format!("t{i}");
    let _ = writeln!(
        body,
        "    Ok({})",
        ret(
            list(out[..sigma].iter().map(t)),
            list(out[sigma..sigma + n_rates].iter().map(t))
        )
    );
    (fixed, body, if hoist { h.names.len() } else { 0 })
}

fn list(items: impl IntoIterator<Item = String>) -> String {
    items.into_iter().collect::<Vec<_>>().join(", ")
}

/// Generate the crate for a derivation; `eliminated` are coordinate indices proven absent from
/// the true equations and from the kinematics still needed (`hamel reduce`'s reduced system).
/// `command` is the command line that regenerates it (written into the files).
pub fn generate(
    d: &Derivation,
    eliminated: &[usize],
    command: &str,
) -> Result<Generated, CodegenError> {
    check_names(d)?;
    let code = Code::new(d, eliminated)?;
    let model = fill(MODEL_TEMPLATE, &code.fields(d, eliminated, command))?;
    let lib = "//! A numeric core generated by hamel (see `model.rs`). Engine-free: it needs no computer\n\
               //! algebra at run time; its arithmetic is the vendored `hamel-runtime`.\n\n\
               pub mod model;\n\npub use hamel_runtime as runtime;\npub use model::*;\n";
    let cargo = manifest::generated(&escape::package_name(&[
        "hamel-model",
        &d.model,
        &d.eta_name,
    ]));
    let mut files: Vec<(String, String)> = vec![
        ("Cargo.toml".into(), cargo),
        ("src/lib.rs".into(), lib.into()),
        ("src/model.rs".into(), model),
        ("src/bin/eval.rs".into(), EVAL_BIN.into()),
        (
            "vendor/hamel-runtime/Cargo.toml".into(),
            manifest::runtime(),
        ),
    ];
    files.extend(
        RUNTIME_SOURCES
            .iter()
            .map(|(path, text)| (path.to_string(), text.to_string())),
    );
    Ok(Generated {
        files,
        ops_trees: code.ops_trees,
        ops_shared: code.ops_shared,
        solved: match code.candidate {
            Some(c) => SolvedForm {
                name: c.name,
                used: code.choice.solved,
                exprs: c.exprs[..d.sigma + d.ell].to_vec(),
                inputs: code.solved_inputs,
            },
            None => SolvedForm {
                name: "none (structured derivation)",
                used: false,
                exprs: Vec::new(),
                inputs: code.solved_inputs,
            },
        },
    })
}

/// Names become code (fields, match arms): they must be identifiers. Free text (the command,
/// the model's and choice's names in comments and strings) is escaped where it lands
/// (`escape`). Free functions must be defined first.
fn check_names(d: &Derivation) -> Result<(), CodegenError> {
    for name in d.coordinates.iter().chain(d.parameters.keys()) {
        escape::rust_ident(name)?;
    }
    if !d.free_functions.is_empty() {
        return Err(CodegenError::FreeFunctions(d.free_functions.join(", ")));
    }
    Ok(())
}

/// `model.rs` as text with `@name@` placeholders ([`fill`]).
const MODEL_TEMPLATE: &str = include_str!("../templates/model.rs.in");

/// `template` with every `@name@` replaced by its value in `fields`. Errors: a placeholder
/// without a value, or a value without a placeholder (the template and the generator disagree).
fn fill(template: &str, fields: &[(&str, String)]) -> Result<String, CodegenError> {
    let mut out = String::with_capacity(template.len() * 2);
    let mut used = vec![false; fields.len()];
    let mut rest = template;
    while let Some(at) = rest.find('@') {
        out.push_str(&rest[..at]);
        let after = &rest[at + 1..];
        let end = after
            .find('@')
            .ok_or_else(|| CodegenError::Internal("an unclosed @ in the model template".into()))?;
        let name = &after[..end];
        let k = fields.iter().position(|(n, _)| *n == name).ok_or_else(|| {
            CodegenError::Internal(format!("no value for @{name}@ of the model template"))
        })?;
        used[k] = true;
        out.push_str(&fields[k].1);
        rest = &after[end + 1..];
    }
    out.push_str(rest);
    match used.iter().position(|u| !u) {
        Some(k) => Err(CodegenError::Internal(format!(
            "the model template has no @{}@",
            fields[k].0
        ))),
        None => Ok(out),
    }
}

/// The generated code's pieces: the ingredients' tape, the solved form chosen for the full
/// system and, when it compiles without the eliminated coordinates, for the reduced one.
struct Code {
    tape: Tape,
    /// α(q) alone (the constraint residual needs nothing else).
    alpha: Tape,
    /// The body of `energy_from`, and what it computes, for the docs.
    energy_part: (String, &'static str),
    /// The body of `residual_from`, and what it computes.
    residual_part: (String, &'static str),
    /// Whether `energy_from` and `residual_from` are straight-line code (a closed form), so
    /// that `energy_many` and `residual_max_many` evaluate them four states at a time.
    monitors_in_lanes: bool,
    /// h(q) of the holonomic constraints.
    holonomic: Tape,
    /// F(q, q̇) of the model's forces (zeros without): inputs the coordinates, the
    /// parameters, then the velocities.
    forces: Tape,
    ops_trees: usize,
    ops_shared: usize,
    params: Vec<String>,
    kept: Vec<usize>,
    solved_inputs: Vec<String>,
    choice: PathChoice,
    candidate: Option<Candidate>,
    solved_ops: usize,
    reduced_solved: bool,
    /// (prepare, body, number of parameter-only values) of `solved_from` and `reduced_from`.
    solved_part: (String, String, usize),
    reduced_part: (String, String, usize),
    /// The placeholders of the constraint forces ([`contact::fields`]).
    contact_fields: [(&'static str, String); 5],
}

impl Code {
    fn new(d: &Derivation, eliminated: &[usize]) -> Result<Code, CodegenError> {
        let exprs = d
            .ingredient_exprs()
            .map_err(|e| CodegenError::Ingredients(e.to_string()))?;
        let params: Vec<String> = d.parameters.keys().cloned().collect();
        let inputs: Vec<String> = d
            .coordinates
            .iter()
            .cloned()
            .chain(params.clone())
            .collect();
        let tape = Tape::compile(&exprs, &inputs)?;
        // Where α and U lie in the ingredients (the runtime's `Layout`: Z, α, A, U, …).
        let rho = d.dims().rho();
        let alpha_at = d.sigma * d.ell;
        let u_at = alpha_at + rho * d.ell + d.ell * d.ell;
        let alpha_exprs = &exprs[alpha_at..alpha_at + rho * d.ell];
        let alpha = Tape::compile(alpha_exprs, &inputs)?;
        let h: Vec<&Expr> = d.holonomic.iter().map(|c| &c.h.expr).collect();
        let holonomic = Tape::compile(&h, &inputs)?;
        let forces = forces_tape(d, &inputs)?;
        let kept: Vec<usize> = (0..d.ell).filter(|k| !eliminated.contains(k)).collect();
        let solved_inputs: Vec<String> = inputs
            .iter()
            .cloned()
            .chain((0..d.sigma).map(eta_input))
            .collect();
        let full_slots = Slots {
            coords: "q",
            n: d.ell,
            params: &params,
            live: &d.live,
            eta: "eta",
            eta_at: 0,
        };
        let (choice, solved) =
            choose_path(d, &tape, solved_candidates(d), &solved_inputs, &full_slots)
                .map_err(CodegenError::Path)?;
        let reduced_tape = solved.as_ref().and_then(|(candidate, _)| {
            // Also with nothing eliminated: the reduced form is then the solved form itself,
            // with its parameter-only values prepared once (evaluating `fast` at each call
            // would prepare them every time).
            choice
                .solved
                .then(|| reduced_tape(d, &candidate.exprs, &kept, &params))
                .flatten()
        });
        let solved_part = match &solved {
            Some((_, solved_tape)) => solved_body(
                solved_tape,
                &full_slots,
                choice.solved,
                d.sigma,
                d.ell,
                |e, q| format!("([{e}], [{q}])"),
            ),
            // No closed form: `solved` is the structured path.
            None => (
                "    Ok([])\n".to_string(),
                "    let _ = c;\n    let r = rhs_fixed(q, eta, p, false)?;\n    Ok((r.eta_dot, r.q_dot))\n".to_string(),
                0,
            ),
        };
        let reduced_part = match &reduced_tape {
            Some(t) => solved_body(
                t,
                &Slots {
                    coords: "x",
                    n: kept.len(),
                    params: &params,
                    live: &d.live,
                    eta: "x",
                    eta_at: kept.len(),
                },
                true,
                d.sigma,
                kept.len(),
                |e, q| format!("[{}]", list([q, e].into_iter().filter(|s| !s.is_empty()))),
            ),
            None => ("    Ok([])\n".into(), REDUCED_AT_REFERENCE.into(), 0),
        };
        let energy_part = energy_part(d, exprs[u_at], &solved_inputs, &full_slots)?;
        let residual_part = residual_part(d, alpha_exprs, &solved_inputs, &full_slots)?;
        let contact_fields = contact::fields(d, full_slots)?;
        Ok(Code {
            contact_fields,
            alpha,
            energy_part,
            residual_part,
            monitors_in_lanes: d.closed().is_some(),
            ops_trees: exprs.iter().map(|e| e.tree_operations()).sum(),
            ops_shared: tape.operation_count(),
            solved_ops: solved.as_ref().map_or(0, |(_, t)| t.operation_count()),
            reduced_solved: reduced_tape.is_some(),
            tape,
            holonomic,
            forces,
            params,
            kept,
            solved_inputs,
            choice,
            candidate: solved.map(|(c, _)| c),
            solved_part,
            reduced_part,
        })
    }

    /// The values of the model template's placeholders.
    fn fields(
        &self,
        d: &Derivation,
        eliminated: &[usize],
        command: &str,
    ) -> Vec<(&'static str, String)> {
        let names = |ix: &[usize]| list(ix.iter().map(|&k| escape::rust_str(&d.coordinates[k])));
        let reduced_state: Vec<String> = self
            .kept
            .iter()
            .map(|&k| d.coordinates[k].clone())
            .chain((1..=d.sigma).map(|i| format!("eta{i}")))
            .collect();
        let full_slots = Slots {
            coords: "q",
            n: d.ell,
            params: &self.params,
            live: &d.live,
            eta: "eta",
            eta_at: 0,
        };
        let mut f = vec![
            (
                "head",
                escape::doc_comment(
                    "//!",
                    &format!(
                        "The numeric core of model `{}` with quasi-velocities `{}`, generated by hamel.",
                        d.model, d.eta_name
                    ),
                ),
            ),
            ("command", escape::doc_comment("//!", command)),
            ("model", escape::rust_str(&d.model)),
            ("eta", escape::rust_str(&d.eta_name)),
            (
                "eta_doc",
                d.eta
                    .iter()
                    .enumerate()
                    .map(|(i, e)| escape::doc_comment("//! *", &format!("eta{} = {e}", i + 1)))
                    .collect::<String>(),
            ),
            ("coords", d.coordinates.join(", ")),
            ("sigma", d.sigma.to_string()),
            ("ell", d.ell.to_string()),
            ("mu", d.mu.to_string()),
            ("dependent", d.dims().dependent.to_string()),
            ("reduced", reduced_state.join(", ")),
            (
                "elim",
                eliminated
                    .iter()
                    .map(|&k| d.coordinates[k].clone())
                    .collect::<Vec<_>>()
                    .join(", "),
            ),
            ("coord_list", names(&(0..d.ell).collect::<Vec<_>>())),
            ("np", eliminated.len().to_string()),
            ("elim_ix", list(eliminated.iter().map(|k| k.to_string()))),
            ("nk", self.kept.len().to_string()),
            ("kept_ix", list(self.kept.iter().map(|k| k.to_string()))),
            ("nr", reduced_state.len().to_string()),
            (
                "reduced_list",
                list(reduced_state.iter().map(|s| escape::rust_str(s))),
            ),
            ("ops_trees", self.ops_trees.to_string()),
            ("ops_shared", self.ops_shared.to_string()),
            ("solved_ops", self.solved_ops.to_string()),
            ("body", straight_line(&self.tape, &full_slots)),
            ("alpha_body", straight_line(&self.alpha, &full_slots)),
            ("energy_body", self.energy_part.0.clone()),
            ("energy_doc", self.energy_part.1.to_string()),
            ("residual_body", self.residual_part.0.clone()),
            ("residual_doc", self.residual_part.1.to_string()),
            ("many_doc", many_doc(self.monitors_in_lanes).into()),
            (
                "energy_many_body",
                many_body(self.monitors_in_lanes, Monitor::Energy),
            ),
            (
                "residual_many_body",
                many_body(self.monitors_in_lanes, Monitor::Residual),
            ),
            (
                "holonomic_body",
                straight_line(&self.holonomic, &full_slots),
            ),
            ("nh", d.holonomic.len().to_string()),
            (
                "holonomic_uses",
                list(
                    (0..d.ell)
                        .filter(|&k| {
                            d.holonomic
                                .iter()
                                .any(|c| c.h.expr.mentions(&d.coordinates[k]))
                        })
                        .map(|k| k.to_string()),
                ),
            ),
            (
                "dependent_ix",
                list(d.holonomic.iter().map(|c| c.dependent.to_string())),
            ),
            ("solved_body", self.solved_part.1.clone()),
            ("prepare_full", self.solved_part.0.clone()),
            ("n_full", self.solved_part.2.to_string()),
            ("reduced_solved", self.reduced_solved.to_string()),
            ("reduced_body", self.reduced_part.1.clone()),
            ("prepare_reduced", self.reduced_part.0.clone()),
            ("n_reduced", self.reduced_part.2.to_string()),
            ("solved", self.choice.solved.to_string()),
            ("wide", wide_type(self.ops_shared, "runtime::DD")),
            ("jet", wide_type(self.ops_shared, "DualN<REDUCED_DIM>")),
            (
                "wide_doc",
                format!(
                    "{}, as the ingredients have {} shared operations (the threshold is {COLD_ABOVE}).",
                    if self.ops_shared > COLD_ABOVE {
                        "behind [`runtime::Cold`] (never inlined)"
                    } else {
                        "inlined"
                    },
                    self.ops_shared
                ),
            ),
            (
                "path_doc",
                escape::doc_comment(
                    "//!",
                    &format!(
                        "**Path of [`fast`]** (used by [`full_into`], [`reduced`], the Jacobian): {}",
                        self.choice.doc
                    ),
                ),
            ),
        ];
        f.extend(parameter_fields(d));
        f.extend(self.force_fields(d, full_slots));
        f.extend(self.contact_fields.clone());
        f
    }

    /// The placeholders of the forces: `forces()`'s body (inputs q, the parameters, q̇) and the
    /// flags of whether there are forces and whether they depend on the velocities.
    fn force_fields(&self, d: &Derivation, slots: Slots) -> [(&'static str, String); 3] {
        let velocities = Slots { eta: "qd", ..slots };
        [
            ("forces_body", straight_line(&self.forces, &velocities)),
            ("velocity_forces", d.ingredients.velocity_forces.to_string()),
            ("has_forces", d.ingredients.forces.is_some().to_string()),
        ]
    }
}

/// The model's forces F(q, q̇) ([`Derivation::forces_tape`]); without forces, ℓ zeros on the
/// same inputs.
fn forces_tape(d: &Derivation, inputs: &[String]) -> Result<Tape, CodegenError> {
    if let Some(tape) = d.forces_tape(inputs)? {
        return Ok(tape);
    }
    let zeros = vec![Expr::int(0); d.ell];
    let mut with_velocities = inputs.to_vec();
    with_velocities.extend(d.coordinates.iter().map(|q| format!("der({q})")));
    Ok(Tape::compile(
        &zeros.iter().collect::<Vec<_>>(),
        &with_velocities,
    )?)
}

/// The body of the generated `energy_from`: with a closed form, straight-line code of
/// E = ½ηᵀA_Γη − U from A_Γ's canonical entries (a few operations, where the structured
/// evaluation solves [Z; α] and forms A_Γ); without, the structured
/// evaluation unchecked (no error estimate, no paper's form). `u` is U's expression.
fn energy_part(
    d: &Derivation,
    u: &Expr,
    solved_inputs: &[String],
    slots: &Slots,
) -> Result<(String, &'static str), CodegenError> {
    use fold::*;
    let Some(c) = d.closed() else {
        let body = "    Ok(structured_unchecked(q, eta, p, false)?.energy)\n";
        return Ok((body.into(), "the structured evaluation, unchecked"));
    };
    let g = d.sigma;
    let eta = eta_syms(g);
    let a = |r: usize, s: usize| c.a_gamma.entries[r][s].expr.clone();
    // ½ηᵀA_Γη = Σ_r η_r (½ A_rr η_r + Σ_{s>r} A_rs η_s), A_Γ symmetric.
    let kinetic = (0..g).fold(Expr::int(0), |acc, r| {
        let row = (r + 1..g).fold(div(mul(a(r, r), eta[r].clone()), Expr::int(2)), |row, s| {
            add(row, mul(a(r, s), eta[s].clone()))
        });
        add(acc, mul(eta[r].clone(), row))
    });
    let energy = sub(kinetic, u.clone());
    let tape = Tape::compile(&[&energy], solved_inputs)?;
    let mut body = "    let _ = (q, eta, p);\n".to_string();
    body += &lets(&tape, slots, Part::All);
    let _ = writeln!(body, "    Ok(t{})", tape.outputs()[0]);
    Ok((body, "straight-line code of the closed form"))
}

/// The body of the generated `residual_from`, r = α(q)Γ(q)η (the constraint residual of the
/// velocities q̇ = Γη): with a closed form, one tape of r from α's and Γ's entries (sharing
/// their trigonometry, no η̇ computed); without, α times the structured evaluation's q̇.
fn residual_part(
    d: &Derivation,
    alpha: &[&Expr],
    solved_inputs: &[String],
    slots: &Slots,
) -> Result<(String, &'static str), CodegenError> {
    use fold::*;
    let Some(c) = d.closed() else {
        let body = "    let r = structured_unchecked(q, eta, p, false)?;\n    \
                    let mut a = [S::constant(0.0); DIMS.rho() * DIMS.ell];\n    \
                    alpha(q, p, &mut a);\n    \
                    for m in 0..DIMS.rho() {\n        \
                    out[m] = (0..DIMS.ell).fold(S::constant(0.0), |acc, j| acc + a[m * DIMS.ell + j] * r.q_dot[j]);\n    \
                    }\n    Ok(())\n";
        return Ok((body.into(), "α times the structured evaluation's q̇"));
    };
    let l = d.ell;
    let q_dot = gamma_eta(&c.gamma, &eta_syms(d.sigma), &|e| e.clone());
    let r: Vec<Expr> = (0..d.dims().rho())
        .map(|m| {
            (0..l).fold(Expr::int(0), |acc, j| {
                add(acc, mul(alpha[m * l + j].clone(), q_dot[j].clone()))
            })
        })
        .collect();
    let refs: Vec<&Expr> = r.iter().collect();
    let tape = Tape::compile(&refs, solved_inputs)?;
    let mut body = "    let _ = (q, eta, p, &out);\n".to_string();
    body += &lets(&tape, slots, Part::All);
    for (m, i) in tape.outputs().iter().enumerate() {
        let _ = writeln!(body, "    out[{m}] = t{i};");
    }
    body += "    Ok(())\n";
    Ok((body, "straight-line code of α(q)Γ(q)η from the closed form"))
}

/// A monitor the generated code evaluates at many states at once.
#[derive(Clone, Copy)]
enum Monitor {
    /// `energy_from`: E = ½ηᵀA_Γη − U.
    Energy,
    /// `residual_from`: ‖α(q)Γ(q)η‖∞.
    Residual,
}

/// How `energy_many` and `residual_max_many` evaluate, for their docs.
fn many_doc(lanes: bool) -> &'static str {
    if lanes {
        "the closed form four states at a time (`runtime::over_rows`: vector instructions, \
         AVX2 where the CPU has it, the same bits as one by one)"
    } else {
        "one state at a time (no closed form: the structured evaluation pivots on each \
         state's own values)"
    }
}

/// The body of `energy_many` or `residual_max_many`: with a closed form, the straight-line
/// code over `runtime::Lanes` (a [`hamel_runtime::LaneFn`] defined in the body); without, the
/// f64 function row by row.
fn many_body(lanes: bool, monitor: Monitor) -> String {
    let name = match monitor {
        Monitor::Energy => "energy",
        Monitor::Residual => "residual_max",
    };
    let one = |p: &str| format!("{name}(&y[..DIMS.ell], &y[DIMS.ell..], {p}).ok()");
    if !lanes {
        return format!(
            "    let w = DIMS.ell + DIMS.sigma;\n    \
             for (o, y) in out.iter_mut().zip(rows.chunks_exact(w)) {{\n        \
             *o = {}.filter(|v| v.is_finite());\n    }}\n",
            one("p")
        );
    }
    let at = match monitor {
        Monitor::Energy => "energy_from(&x[..DIMS.ell], &x[DIMS.ell..], self.0)",
        Monitor::Residual => {
            "let mut r = [runtime::Lanes::default(); DIMS.rho()];\n            \
             residual_from(&x[..DIMS.ell], &x[DIMS.ell..], self.0, &mut r)?;\n            \
             Ok(runtime::abs_max(&r))"
        }
    };
    format!(
        "    struct Monitor<'a>(&'a Parameters);\n    \
         impl runtime::LaneFn for Monitor<'_> {{\n        \
         #[inline(always)]\n        \
         fn at(&self, x: &[runtime::Lanes]) -> Result<runtime::Lanes, EvalError> {{\n            \
         {at}\n        }}\n        \
         fn one(&self, y: &[f64]) -> Option<f64> {{\n            {}\n        }}\n    \
         }}\n    \
         runtime::over_rows::<{{ DIMS.ell + DIMS.sigma }}, _>(&Monitor(p), rows, out);\n",
        one("self.0")
    )
}

/// Above this many shared operations of the ingredients, the generated code wraps its wide
/// scalar types (double-double, the Jacobian's duals) in `hamel_runtime::Cold`: inlined, they
/// make the compiler take minutes over the straight-line code (the bicycle's 4,700 operations:
/// 4 min 8 s inlined, 20 s cold). The bundled models other than the bicycle have at most 130.
pub const COLD_ABOVE: usize = 1000;

/// `ty`, wrapped in `runtime::Cold` when the ingredients have more than [`COLD_ABOVE`] shared
/// operations.
fn wide_type(ops_shared: usize, ty: &str) -> String {
    if ops_shared > COLD_ABOVE {
        format!("runtime::Cold<{ty}>")
    } else {
        ty.to_string()
    }
}

/// The reduced solved form: η̇ and the kept rates as code of (kept q, η) alone. The eliminated
/// coordinates are proven absent from A_Γ, Γᵀ∇U, Q⁽ⁱ⁾ and the kept rows of Γ, so the tape
/// compiles without them as inputs; if it did not (`None`), `reduced` keeps evaluating the full
/// form at reference values.
fn reduced_tape(
    d: &Derivation,
    solved: &[Expr],
    kept: &[usize],
    params: &[String],
) -> Option<Tape> {
    let kept_solved: Vec<&Expr> = solved[..d.sigma]
        .iter()
        .chain(kept.iter().map(|&k| &solved[d.sigma + k]))
        .chain(&solved[d.sigma + d.ell..])
        .collect();
    let kept_inputs: Vec<String> = kept
        .iter()
        .map(|&k| d.coordinates[k].clone())
        .chain(params.iter().cloned())
        .chain((0..d.sigma).map(eta_input))
        .collect();
    Tape::compile(&kept_solved, &kept_inputs).ok()
}

/// The placeholders of the `Parameters` struct: names, fields, defaults, setter arms.
fn parameter_fields(d: &Derivation) -> Vec<(&'static str, String)> {
    vec![
        ("npar", d.parameters.len().to_string()),
        (
            "param_names",
            list(d.parameters.keys().map(|s| escape::rust_str(s))),
        ),
        (
            "param_fields",
            d.parameters
                .keys()
                .map(|k| {
                    format!(
                        "{}    pub {}: f64,\n",
                        escape::doc_comment("    ///", &format!("`{k}`")),
                        ident(k)
                    )
                })
                .collect::<String>(),
        ),
        (
            "param_defaults",
            d.parameters
                .iter()
                .map(|(k, v)| format!("            {}: {},\n", ident(k), lit(*v)))
                .collect::<String>(),
        ),
        (
            "param_set",
            d.parameters
                .keys()
                .map(|k| {
                    format!(
                        "            {} => Some(&mut self.{}),\n",
                        escape::rust_str(k),
                        ident(k)
                    )
                })
                .collect::<String>(),
        ),
        ("nlive", d.live.len().to_string()),
        (
            "live_list",
            list(d.live.iter().map(|s| escape::rust_str(s))),
        ),
        (
            "live_set",
            (d.live.iter().enumerate())
                .map(|(i, k)| format!("        self.{} = values[{i}];\n", ident(k)))
                .collect::<String>(),
        ),
    ]
}

/// The body of `reduced` without a reduced solved form: the full right-hand side with the
/// eliminated coordinates at the first `REFERENCE` value where it evaluates.
const REDUCED_AT_REFERENCE: &str = "    let eta = &x[KEPT.len()..];
    let mut last = None;
    for r in REFERENCE {
        let mut q = [S::constant(r); ELL];
        for (i, &k) in KEPT.iter().enumerate() {
            q[k] = x[i];
        }
        match fast(&q, eta, p) {
            Ok((eta_dot, q_dot)) => {
                let mut v = [S::constant(0.0); REDUCED_DIM];
                for (i, &k) in KEPT.iter().enumerate() {
                    v[i] = q_dot[k];
                }
                v[KEPT.len()..].copy_from_slice(&eta_dot);
                return Ok(v);
            }
            Err(e) => last = Some(e),
        }
    }
    Err(last.expect(\"REFERENCE is not empty\"))
";

/// The `eval` binary: the same `--state` JSON as `hamel eval`, the same JSON out.
pub const EVAL_BIN: &str = include_str!("../bins/eval.rs");

/// The `simulate` binary (with [`with_simulator`]).
pub const SIMULATE_BIN: &str = include_str!("../bins/simulate.rs");

/// The `scene` binary (the integration job of `hamel simulate` on a compiled core).
pub const SCENE_BIN: &str = include_str!("../bins/scene.rs");

/// The integrators (`crates/hamel-sim/src/*.rs`, listed by `build.rs`), vendored into a
/// generated crate by [`with_simulator`]: (path inside the crate, text).
const SIM_SOURCES: &[(&str, &str)] = include!(concat!(env!("OUT_DIR"), "/sim_sources.rs"));

/// Add the `simulate` and `scene` binaries to a generated crate: the integrators of `crates/hamel-sim` are
/// vendored as a path dependency inside the crate (they need nalgebra, serde and thiserror),
/// so the crate still builds on its own.
pub fn with_simulator(mut g: Generated) -> Result<Generated, CodegenError> {
    g.edit_manifest(|doc| manifest::add_path_dependency(doc, "hamel-sim", "vendor/hamel-sim"))?;
    g.files
        .push(("vendor/hamel-sim/Cargo.toml".into(), manifest::simulator()));
    for (path, text) in SIM_SOURCES {
        g.files.push((path.to_string(), text.to_string()));
    }
    g.files
        .push(("src/bin/simulate.rs".into(), SIMULATE_BIN.into()));
    g.files.push(("src/bin/scene.rs".into(), SCENE_BIN.into()));
    Ok(g)
}

impl Generated {
    /// Edit the crate's manifest with a TOML writer ([`manifest::edit`]).
    pub fn edit_manifest(
        &mut self,
        edit: impl FnOnce(&mut toml_edit::DocumentMut),
    ) -> Result<(), CodegenError> {
        let (_, text) = self
            .files
            .iter_mut()
            .find(|(path, _)| path == "Cargo.toml")
            .ok_or_else(|| CodegenError::Internal("a generated crate without Cargo.toml".into()))?;
        *text = manifest::edit(text, edit)?;
        Ok(())
    }
}
