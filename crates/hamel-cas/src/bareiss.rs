//! The exact inverse of [Z; α] (4)–(5) by fraction-free Gauss–Jordan elimination (Bareiss) in
//! the half-angle ring.
//!
//! Gauss–Jordan over the field of expressions takes lowest terms (a gcd) after every one of its
//! O(n³) operations. Here each row is instead cleared of denominators once, in Z[…, t, …] (a
//! polynomial ring, so every exact division is a plain division), and the elimination
//! keeps polynomial entries: with prev the previous pivot, every update
//! a_ij ← (a_kk a_ij − a_ik a_kj)/prev is an exact division, and every entry is a minor of the
//! matrix, so nothing grows beyond the size of the determinant (Bareiss 1968; the Gauss–Jordan
//! form of Nakos, Turner and Williams 1997). At the end [A | I] has become [d·I | d·A⁻¹] with
//! d = ±det A, and only the n² entries of the inverse and the determinant are brought to lowest
//! terms, each by one gcd.
//!
//! Fields with square-root kernels keep Gauss–Jordan in the field (their relations r² = G are
//! not those of a polynomial ring).

use crate::half::{lowest_terms, to_half};
use crate::vars::{FieldInner, Poly};

/// The largest minor (in terms of the half-angle ring) the elimination lets grow before it
/// gives way to Gauss–Jordan in the field. Minors are determinants, and a determinant that is
/// compact in (sin, cos) can be large in t (each cos is (1 − t²)/(1 + t²)): the unicycle's
/// momenta choice, whose rows carry the mass matrix, reaches it, the other bundled choices do
/// not (docs/derivation.md).
const MINOR_TERMS: usize = 300;

/// A matrix of half-angle-ring polynomials, row-major, with its n columns and the n columns of
/// the identity beside them.
struct Augmented {
    n: usize,
    a: Vec<Vec<Poly>>,
}

fn pow(p: &Poly, k: usize) -> Poly {
    crate::half::pow(p, k, &p.one())
}

/// One row (N_j/D_j) of the matrix over one denominator: the row multiplied by
/// R = lcm_j(g_j)·∏_a h_a^(E_a), where N_j/D_j = f_j h^(m_Dj − m_Nj)/g_j in the half-angle ring,
/// so that every entry is a polynomial. Returns the row and R.
fn clear_row(fi: &FieldInner, row: &[(&Poly, &Poly)]) -> (Vec<Poly>, Poly) {
    let angles = fi.angles.len();
    let images: Vec<(Poly, Poly, Vec<i64>)> = row
        .iter()
        .map(|(n, d)| {
            let ((fn_, mn), (gd, md)) = (to_half(fi, n), to_half(fi, d));
            let e = (0..angles).map(|a| md[a] as i64 - mn[a] as i64).collect();
            (fn_, gd, e)
        })
        .collect();
    let lcm = images.iter().fold(fi.half.zero.one(), |l, (f, g, _)| {
        if f.is_zero() {
            return l;
        }
        let gcd = l.gcd(g);
        &l * &g.quot_rem(&gcd, false).0
    });
    let big_e: Vec<i64> = (0..angles)
        .map(|a| {
            images
                .iter()
                .filter(|(f, _, _)| !f.is_zero())
                .map(|(_, _, e)| -e[a])
                .max()
                .unwrap_or(0)
                .max(0)
        })
        .collect();
    let hs: Vec<Poly> = (0..angles).map(|a| fi.half.h(a)).collect();
    let cleared = images
        .iter()
        .map(|(f, g, e)| {
            if f.is_zero() {
                return f.clone();
            }
            let mut p = f * &lcm.quot_rem(g, false).0;
            for a in 0..angles {
                p = &p * &pow(&hs[a], (big_e[a] + e[a]) as usize);
            }
            p
        })
        .collect();
    let r = (0..angles).fold(lcm, |r, a| &r * &pow(&hs[a], big_e[a] as usize));
    (cleared, r)
}

impl Augmented {
    /// Fraction-free Gauss–Jordan on [A | I]; `None` when A is singular, `Err` when a division
    /// meant to be exact is not (not expected: the caller then falls back).
    fn eliminate(&mut self) -> Result<Option<(Poly, bool)>, ()> {
        let n = self.n;
        let mut prev = self.a[0][0].one();
        let mut swapped = false;
        for k in 0..n {
            let pivot = (k..n)
                .filter(|&r| !self.a[r][k].is_zero())
                .min_by_key(|&r| self.a[r][k].nterms());
            let Some(p) = pivot else {
                return Ok(None);
            };
            if p != k {
                self.a.swap(p, k);
                swapped = !swapped;
            }
            for i in (0..n).filter(|&i| i != k) {
                let aik = self.a[i][k].clone();
                for j in (0..2 * n).filter(|&j| j != k) {
                    let t = &(&self.a[k][k] * &self.a[i][j]) - &(&aik * &self.a[k][j]);
                    self.a[i][j] = crate::half::exact_quotient(&t, &prev).ok_or(())?;
                    if self.a[i][j].nterms() > MINOR_TERMS {
                        return Err(());
                    }
                }
                self.a[i][k] = aik.zero();
            }
            prev = self.a[k][k].clone();
        }
        Ok(Some((prev, swapped)))
    }
}

/// The inverse and the determinant of the n×n matrix of field values N_ij/D_ij (row-major), as
/// canonical (N, D) pairs; `Ok(None)` when it is singular, `Err(())` when this method does
/// not apply (square-root kernels) or a division meant to be exact was not.
pub(crate) type Inverse = (Vec<(Poly, Poly)>, (Poly, Poly));

pub(crate) fn inverse(
    fi: &FieldInner,
    n: usize,
    entries: &[(&Poly, &Poly)],
) -> Result<Option<Inverse>, ()> {
    let relations = fi.relations.borrow();
    if relations.iter().any(|(v, _)| fi.kernel_var.contains(v)) {
        return Err(());
    }
    drop(relations);
    let zero = fi.half.zero.clone();
    let mut rows = Vec::with_capacity(n);
    let mut scales = Vec::with_capacity(n);
    for i in 0..n {
        let (mut row, r) = clear_row(fi, &entries[i * n..(i + 1) * n]);
        row.extend((0..n).map(|j| if i == j { zero.one() } else { zero.clone() }));
        rows.push(row);
        scales.push(r);
    }
    let mut aug = Augmented { n, a: rows };
    let Some((d, swapped)) = aug.eliminate()? else {
        return Ok(None);
    };
    // R·A = A', A'·X = d·I with X the right half: A⁻¹ = X·R/d; det A = ±d/∏R.
    let inv = (0..n)
        .flat_map(|i| (0..n).map(move |j| (i, j)))
        .map(|(i, j)| lowest_terms(fi, &(&aug.a[i][n + j] * &scales[j]), &d))
        .collect();
    let prod = scales.iter().fold(zero.one(), |acc, r| &acc * r);
    let det = if swapped { -d.clone() } else { d.clone() };
    Ok(Some((inv, lowest_terms(fi, &det, &prod))))
}
