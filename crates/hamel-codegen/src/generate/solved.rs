//! The solved forms η̇ = A_Γ⁻¹ b: candidates by elimination, by blocks and by Cramer's rule on
//! the entries, written as trees for the generator to choose from.

#[allow(unused_imports)]
use super::*;

/// Names of the η inputs of the solved tape (not valid model names, so they cannot clash).
pub(super) fn eta_input(s: usize) -> String {
    format!("#eta{s}")
}

/// The tapes' η inputs as symbols, `#eta0..`.
pub(super) fn eta_syms(sigma: usize) -> Vec<Expr> {
    (0..sigma).map(|s| Expr::sym(&eta_input(s))).collect()
}

/// q̇ = Γη (6) from the closed form's Γ, each entry passed through `h` first.
pub(super) fn gamma_eta(
    gamma: &hamel_derive::Mat,
    eta: &[Expr],
    h: &dyn Fn(&Expr) -> Expr,
) -> Vec<Expr> {
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

/// A candidate solved form: outputs η̇ (σ), q̇ = Γη (ℓ, eq. (6)) and σ definiteness tests (the
/// pivots of A_Γ = L D Lᵀ, or the leading minors of its blocks); one ≤ 0 means A_Γ is not
/// positive definite there.
pub(super) struct Candidate {
    pub(super) name: &'static str,
    pub(super) exprs: Vec<Expr>,
}

/// Gaussian elimination without pivoting (stable for the symmetric positive definite A_Γ) on
/// trees, folding exact zeros and ones: the solution x of a x = b and the pivots. One
/// reciprocal per pivot, shared by its multipliers and its back substitution (a division costs
/// several multiplications).
pub(super) fn eliminate(mut a: Vec<Vec<Expr>>, mut b: Vec<Expr>) -> (Vec<Expr>, Vec<Expr>) {
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
pub(super) fn diagonal_blocks(a: &[Vec<Expr>]) -> Vec<Vec<usize>> {
    let g = a.len();
    let mut block_of: Vec<usize> = (0..g).collect();
    pub(super) fn root(b: &mut [usize], mut i: usize) -> usize {
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
pub(super) fn block_minors(a: &[Vec<Expr>]) -> Vec<Expr> {
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
pub(super) fn cramer_on_entries(a: &[Vec<Expr>], b: &[Expr]) -> (Vec<Expr>, Vec<Expr>) {
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
pub(super) fn solved_candidates(d: &Derivation) -> Vec<Candidate> {
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
