//! The hypotheses of Proposition 2.1 (H0–H5, Talamucci 2015 §2.3) and H6, the one the paper
//! lacks for the term it drops. Each check runs on the CAS thread, decides exactly, and returns
//! a witness (object, indices, coordinate, entry) for a failure.
//!
//! Indices: `p` are the coordinates to eliminate; [`Blocks`] is the structure (17) of Z with
//! the coordinates in the model's order (block 1: the μ + v coordinates whose velocities are
//! not quasi-velocities; block 2: those with η_i = q̇_j).

use hamel_cas::{Ex, Matrix, Over};
use hamel_derive::Symbolic;

use crate::report::{Hypothesis, Witness};

pub use crate::report::HypothesisId as Id;
pub use crate::report::HypothesisId::*;

/// The block structure (17) of Z, as indices.
#[derive(Clone, Debug)]
pub struct Blocks {
    /// Rows of Z that are not unit rows (the v "true" quasi-velocities), in order.
    pub rows1: Vec<usize>,
    /// Unit rows of Z, in order.
    pub rows2: Vec<usize>,
    /// Coordinates of block 1 (μ + v), in model order.
    pub j1: Vec<usize>,
    /// Coordinates of block 2 (σ − v): j2[k] is the coordinate of unit row rows2[k].
    pub j2: Vec<usize>,
}

impl Blocks {
    /// Find (17): every row of Z equal to a unit vector e_j is a plain velocity η_i = q̇_j.
    pub fn of(z: &Matrix) -> Blocks {
        let (mut rows1, mut rows2, mut j2) = (Vec::new(), Vec::new(), Vec::new());
        for i in 0..z.rows() {
            let nonzero: Vec<usize> = (0..z.cols()).filter(|&j| !z[(i, j)].is_zero()).collect();
            match nonzero.as_slice() {
                [j] if z[(i, *j)].is_one() && !j2.contains(j) => {
                    rows2.push(i);
                    j2.push(*j);
                }
                _ => rows1.push(i),
            }
        }
        let j1 = (0..z.cols()).filter(|j| !j2.contains(j)).collect();
        Blocks {
            rows1,
            rows2,
            j1,
            j2,
        }
    }

    /// v of (17).
    pub fn v(&self) -> usize {
        self.rows1.len()
    }

    /// The submatrix of `m` with the given rows and columns.
    pub fn sub(m: &Matrix, rows: &[usize], cols: &[usize]) -> Matrix {
        Matrix::from_fn(rows.len(), cols.len(), |r, c| m[(rows[r], cols[c])].clone())
    }
}

/// A value to test: an [`Ex`] (lowest terms) or an [`Over`] (common denominators; tested
/// without a gcd).
#[derive(Clone)]
pub enum Val {
    /// In lowest terms.
    Ex(Ex),
    /// Over the derivation's denominators.
    Over(Over),
}

impl Val {
    /// Exact dependence on q_k.
    pub fn depends_on(&self, k: usize) -> bool {
        match self {
            Val::Ex(e) => e.depends_on(k),
            Val::Over(o) => o.depends_on(k),
        }
    }

    /// The coordinates it depends on, among `0..ell`.
    pub fn dependence(&self, ell: usize) -> Vec<usize> {
        (0..ell).filter(|&k| self.depends_on(k)).collect()
    }

    fn text(&self) -> String {
        match self {
            Val::Ex(e) => e.to_expr().to_string(),
            Val::Over(o) => o.to_expr().to_string(),
        }
    }
}

/// The first coordinate of `p` that `e` depends on (exactly).
pub fn first_dependence(e: &Val, p: &[usize]) -> Option<usize> {
    p.iter().copied().find(|&k| e.depends_on(k))
}

/// A witness for entry `e` of `object` at 1-based `index`.
pub fn witness(
    s: &Symbolic,
    object: &str,
    index: Vec<usize>,
    coordinate: Option<usize>,
    e: &Val,
    note: String,
) -> Witness {
    Witness {
        object: object.to_string(),
        index,
        coordinate: coordinate.map(|k| s.field.coordinates()[k].clone()),
        expression: e.text(),
        note,
    }
}

/// Scan entries (object name, 1-based index, value) for the first one depending on a
/// coordinate of `p`.
pub fn scan(
    s: &Symbolic,
    p: &[usize],
    entries: impl IntoIterator<Item = (String, Vec<usize>, Val)>,
    what: &str,
) -> Option<Witness> {
    scan_names(s.field.coordinates(), p, entries, what)
}

/// [`scan`] with the coordinates' names.
pub fn scan_names(
    names: &[String],
    p: &[usize],
    entries: impl IntoIterator<Item = (String, Vec<usize>, Val)>,
    what: &str,
) -> Option<Witness> {
    for (object, index, e) in entries {
        if let Some(k) = first_dependence(&e, p) {
            let name = &names[k];
            let note = format!("{object}{index:?} contains `{name}`: {what}");
            return Some(Witness {
                object: object.clone(),
                index,
                coordinate: Some(name.clone()),
                expression: e.text(),
                note,
            });
        }
    }
    None
}

fn verdict(statement: &str, witness: Option<Witness>) -> Hypothesis {
    Hypothesis {
        statement: statement.to_string(),
        holds: witness.is_none(),
        witness,
    }
}

fn idx(v: &[usize]) -> Vec<usize> {
    v.iter().map(|i| i + 1).collect()
}

/// (H0): Γ splits as (32)–(33), i.e. the rows of Γ of the kept coordinates are free of
/// q₁..q_p, and Γᵀ∇U is free of q₁..q_p.
pub fn h0(s: &Symbolic, p: &[usize]) -> Hypothesis {
    let ell = s.gamma.rows();
    let sigma = s.gamma.cols();
    let gamma_rows = (0..ell)
        .filter(|k| !p.contains(k))
        .flat_map(|k| (0..sigma).map(move |r| (k, r)))
        .map(|(k, r)| {
            (
                "Gamma".to_string(),
                idx(&[k, r]),
                Val::Ex(s.gamma[(k, r)].clone()),
            )
        });
    let forcing = s.forcing.iter().enumerate().map(|(i, f)| {
        (
            "Gamma^T grad U".to_string(),
            vec![i + 1],
            Val::Over(f.clone()),
        )
    });
    verdict(
        "(H0) Γ splits as (32)–(33): the rows of Γ of the kept coordinates are free of the \
         eliminated ones; and Γᵀ∇U is free of them",
        scan(
            s,
            p,
            gamma_rows.chain(forcing),
            "(33) or the forcing term of (11) fails",
        ),
    )
}

/// (H1): (Z₂; α₂) = 0, (17) and (23).
pub fn h1(s: &Symbolic, b: &Blocks) -> Hypothesis {
    let statement = "(H1) (Z₂; α₂) = 0: the v quasi-velocities and the constraints do not \
                     involve the velocities of block 2";
    for (r, &i) in b.rows1.iter().enumerate() {
        for (c, &j) in b.j2.iter().enumerate() {
            let e = &s.z[(i, j)];
            if !e.is_zero() {
                let name = &s.field.coordinates()[j];
                let note = format!("η{} involves der({name}), a block-2 velocity", i + 1);
                return verdict(
                    statement,
                    Some(witness(
                        s,
                        "Z2",
                        vec![r + 1, c + 1],
                        None,
                        &Val::Ex(e.clone()),
                        note,
                    )),
                );
            }
        }
    }
    for m in 0..s.alpha.rows() {
        for (c, &j) in b.j2.iter().enumerate() {
            let e = &s.alpha[(m, j)];
            if !e.is_zero() {
                let name = &s.field.coordinates()[j];
                let note = format!(
                    "constraint {} involves der({name}), a block-2 velocity",
                    m + 1
                );
                return verdict(
                    statement,
                    Some(witness(
                        s,
                        "alpha2",
                        vec![m + 1, c + 1],
                        None,
                        &Val::Ex(e.clone()),
                        note,
                    )),
                );
            }
        }
    }
    verdict(statement, None)
}

/// (H2): the columns of A⁽¹'²⁾ are combinations of the rows of α₁ (exact rank test); the
/// witness is the column that is not, with the entry of Γ₁ᵀA⁽¹'²⁾ (27) that does not vanish.
pub fn h2(s: &Symbolic, b: &Blocks) -> Result<Hypothesis, hamel_cas::CasError> {
    let statement = "(H2) the columns of A⁽¹'²⁾ are combinations of the rows of α₁";
    let alpha1 = Blocks::sub(&s.alpha, &(0..s.alpha.rows()).collect::<Vec<_>>(), &b.j1);
    let a12 = Blocks::sub(&s.a, &b.j1, &b.j2);
    let gamma1 = Blocks::sub(&s.gamma, &b.j1, &b.rows1);
    let base = if alpha1.rows() == 0 {
        0
    } else {
        alpha1.rank()?
    };
    for c in 0..b.j2.len() {
        let col = Matrix::from_fn(1, b.j1.len(), |_, h| a12[(h, c)].clone());
        let stacked = if alpha1.rows() == 0 {
            col.clone()
        } else {
            alpha1.vstack(&col)
        };
        if stacked.rank()? > base {
            let name = &s.field.coordinates()[b.j2[c]];
            let g = gamma1
                .transpose()
                .mul(&Matrix::from_fn(b.j1.len(), 1, |h, _| a12[(h, c)].clone()));
            let r = (0..g.rows()).find(|&r| !g[(r, 0)].is_zero()).unwrap_or(0);
            let e = if g.rows() > 0 {
                g[(r, 0)].clone()
            } else {
                s.field.zero()
            };
            let note = format!(
                "the column of A(1,2) for `{name}` is not a combination of the rows of α₁: \
                 (Γ₁ᵀA⁽¹'²⁾)[{}, {}] ≠ 0 (Property 2.2)",
                r + 1,
                c + 1
            );
            return Ok(verdict(
                statement,
                Some(witness(
                    s,
                    "Gamma1^T A12",
                    vec![r + 1, c + 1],
                    None,
                    &Val::Ex(e),
                    note,
                )),
            ));
        }
    }
    Ok(verdict(statement, None))
}

/// b = Γ₁ᵀA⁽¹'¹⁾Γ₁, the entries (22).
pub fn b_matrix(s: &Symbolic, b: &Blocks) -> Matrix {
    let gamma1 = Blocks::sub(&s.gamma, &b.j1, &b.rows1);
    let a11 = Blocks::sub(&s.a, &b.j1, &b.j1);
    gamma1.transpose().mul(&a11).mul(&gamma1)
}

/// (H3): the expressions (22) are free of q₁..q_p.
pub fn h3(s: &Symbolic, b: &Blocks, p: &[usize]) -> Hypothesis {
    let bm = b_matrix(s, b);
    let v = bm.rows();
    let entries = (0..v)
        .flat_map(|r| (r..v).map(move |c| (r, c)))
        .map(|(r, c)| {
            (
                "b".to_string(),
                vec![r + 1, c + 1],
                Val::Ex(bm[(r, c)].clone()),
            )
        });
    verdict(
        "(H3) the entries b_rs (22) of Γ₁ᵀA⁽¹'¹⁾Γ₁ are free of the eliminated coordinates",
        scan(s, p, entries, "(22) fails"),
    )
}

/// (H4): A⁽²'²⁾ is free of q₁..q_p.
pub fn h4(s: &Symbolic, b: &Blocks, p: &[usize]) -> Hypothesis {
    let a22 = Blocks::sub(&s.a, &b.j2, &b.j2);
    let n = a22.rows();
    let entries = (0..n)
        .flat_map(|r| (r..n).map(move |c| (r, c)))
        .map(|(r, c)| {
            (
                "A22".to_string(),
                vec![r + 1, c + 1],
                Val::Ex(a22[(r, c)].clone()),
            )
        });
    verdict(
        "(H4) A⁽²'²⁾ is free of the eliminated coordinates",
        scan(s, p, entries, "(H4) fails"),
    )
}

/// The expressions (35): first line for i ≤ v, r < s ≤ v, then the second line for r ≤ v and
/// the block-2 coordinates; as (label, 1-based indices, value).
pub fn expressions_35(s: &Symbolic, b: &Blocks) -> Vec<(String, Vec<usize>, Val)> {
    let f = &s.field;
    let v = b.v();
    let g = |h: usize, r: usize| &s.gamma[(b.j1[h], b.rows1[r])];
    let dz = |i: usize, h: usize, k: usize| s.z[(b.rows1[i], b.j1[h])].diff(k);
    let n1 = b.j1.len();
    let mut out = Vec::new();
    for i in 0..v {
        for r in 0..v {
            for s_ in r + 1..v {
                let mut acc = f.zero();
                for h in 0..n1 {
                    for k in 0..n1 {
                        let d = dz(i, h, b.j1[k]);
                        if d.is_zero() {
                            continue;
                        }
                        let c = &(g(h, r) * g(k, s_)) - &(g(h, s_) * g(k, r));
                        acc = &acc + &(&c * &d);
                    }
                }
                out.push((
                    "(35) first line".to_string(),
                    vec![i + 1, r + 1, s_ + 1],
                    Val::Ex(acc),
                ));
            }
        }
        for r in 0..v {
            for (c, &q) in b.j2.iter().enumerate() {
                let mut acc = f.zero();
                for h in 0..n1 {
                    let d = dz(i, h, q);
                    if !d.is_zero() {
                        acc = &acc + &(g(h, r) * &d);
                    }
                }
                out.push((
                    "(35) second line".to_string(),
                    vec![i + 1, r + 1, v + c + 1],
                    Val::Ex(acc),
                ));
            }
        }
    }
    out
}

/// (H5): the expressions (35) are free of q₁..q_p.
pub fn h5(s: &Symbolic, b: &Blocks, p: &[usize]) -> Hypothesis {
    verdict(
        "(H5) the expressions (35) are free of the eliminated coordinates",
        scan(s, p, expressions_35(s, b), "(35) fails"),
    )
}

/// (H6): the correction Σ_m ν_m ΓᵀV_mΓη (the term the paper drops; zero when ΘᵀAΓ = 0) is free
/// of q₁..q_p, coefficient by coefficient.
pub fn h6(s: &Symbolic, p: &[usize]) -> Hypothesis {
    let sigma = s.q_correction.len();
    let entries = (0..sigma).flat_map(|i| {
        (0..sigma).flat_map(move |r| {
            (r..sigma).map(move |c| {
                (
                    format!("Q_correction({})", i + 1),
                    vec![r + 1, c + 1],
                    Val::Over(s.q_correction[i][(r, c)].clone()),
                )
            })
        })
    });
    verdict(
        "(H6) the correction Σ_m ν_m ΓᵀV_mΓη that the paper's (10)–(15) drop is free of the \
         eliminated coordinates (it vanishes when ΘᵀAΓ = 0)",
        scan(
            s,
            p,
            entries,
            "the paper's equations miss a term that contains it",
        ),
    )
}
