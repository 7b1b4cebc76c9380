//! LU factorisation with partial pivoting over any [`Scalar`], in caller-owned storage: the
//! n×n matrix row-major in a slice, the permutation in another. [`Lu`] owns its storage for
//! callers that do not count allocations.

use crate::scalar::Scalar;

/// When a pivot counts as zero: relative to the largest entry of the matrix.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Pivot {
    /// Only an exact zero (references and oracles: every nonzero pivot is used).
    Exact,
    /// Below this multiple of the largest |entry| (the evaluators: a numerically singular
    /// [Z; α] is reported, not solved).
    Relative(f64),
}

/// The threshold the evaluators use: 1e-14 of the largest entry.
pub const EVALUATOR_PIVOT: Pivot = Pivot::Relative(1e-14);

/// Factor the n×n matrix `a` (row-major) in place, L below the diagonal (unit diagonal
/// implied), U on and above; `perm[i]` is the original row of row i. Pivots are chosen by the
/// magnitude of their f64 value, the first largest on ties. `false` when a pivot counts as zero
/// (see [`Pivot`]) or an entry is not finite.
#[inline(always)]
pub fn factor<S: Scalar>(n: usize, a: &mut [S], perm: &mut [usize], pivot: Pivot) -> bool {
    factor_rows(n, n, a, perm, pivot)
}

/// [`factor`] for a matrix of `rows` ≥ n rows and n columns (row-major, `perm` `rows` long):
/// each pivot is chosen among all the rows left, so the first n rows of the result are the LU
/// factors of the n rows the pivoting selected (`perm[..n]`), and [`solve`] with them solves
/// the selected equations of a consistent system (a matrix whose extra rows depend on the
/// others: constraints of rank below their number).
#[inline(always)]
pub fn factor_rows<S: Scalar>(
    rows: usize,
    n: usize,
    a: &mut [S],
    perm: &mut [usize],
    pivot: Pivot,
) -> bool {
    let (a, perm) = (&mut a[..rows * n], &mut perm[..rows]);
    let mut scale = 0.0_f64;
    for x in a.iter() {
        let v = x.value().abs();
        if !v.is_finite() {
            return false;
        }
        scale = scale.max(v);
    }
    if scale == 0.0 && n > 0 {
        return false;
    }
    let floor = match pivot {
        Pivot::Exact => 0.0,
        Pivot::Relative(r) => r * scale,
    };
    for (i, p) in perm.iter_mut().enumerate() {
        *p = i;
    }
    let entries: Vec<S> = if S::RECORDS_DECISIONS {
        a.to_vec()
    } else {
        Vec::new()
    };
    for k in 0..n {
        let mut p = k;
        for i in k + 1..rows {
            if a[i * n + k].value().abs() > a[p * n + k].value().abs() {
                p = i;
            }
        }
        if a[p * n + k].value().abs() <= floor {
            if S::RECORDS_DECISIONS {
                S::undecidable();
            }
            return false;
        }
        if S::RECORDS_DECISIONS {
            record_pivot(rows, n, a, k, p, pivot, &entries);
        }
        if p != k {
            for j in 0..n {
                a.swap(k * n + j, p * n + j);
            }
            perm.swap(k, p);
        }
        eliminate(n, a, k);
    }
    true
}

/// How far below the largest candidate of its column a pivot chosen at a tracing point may fall
/// at another state before a tracer's record of the path is left for the pivoting evaluation:
/// threshold pivoting's u (a growth of at most 1 + 1/u per step, where partial pivoting's is 2).
pub const TRACED_PIVOT_THRESHOLD: f64 = 0.5;

/// For a tracer ([`Scalar::RECORDS_DECISIONS`]): pivot (`p`, k) was chosen, so the path holds
/// where it stays above [`TRACED_PIVOT_THRESHOLD`] of the other candidates of column k, and
/// above the floor of `pivot` but at least [`EVALUATOR_PIVOT`]'s (a multiple of the largest of
/// `entries`, the matrix as given): a record of an exact-pivot computation is left where the
/// evaluators would call the matrix numerically singular, as they then report it.
#[cold]
fn record_pivot<S: Scalar>(
    rows: usize,
    n: usize,
    a: &[S],
    k: usize,
    p: usize,
    pivot: Pivot,
    entries: &[S],
) {
    let chosen = a[p * n + k];
    let others: Vec<S> = (k..rows)
        .filter(|&i| i != p)
        .map(|i| a[i * n + k])
        .collect();
    S::decided(chosen, TRACED_PIVOT_THRESHOLD, &others);
    let floor = match (pivot, EVALUATOR_PIVOT) {
        (Pivot::Relative(r), Pivot::Relative(e)) => r.max(e),
        (_, Pivot::Relative(e)) => e,
        (_, Pivot::Exact) => 0.0,
    };
    S::decided(chosen, floor, entries);
}

/// One step of elimination below pivot (k, k).
#[inline(always)]
fn eliminate<S: Scalar>(n: usize, a: &mut [S], k: usize) {
    let (top, below) = a.split_at_mut((k + 1) * n);
    let pivot_row = &top[k * n..];
    let pivot = pivot_row[k];
    for row in below.chunks_exact_mut(n) {
        let f = row[k] / pivot;
        row[k] = f;
        for (x, &t) in row[k + 1..].iter_mut().zip(&pivot_row[k + 1..]) {
            *x = *x - f * t;
        }
    }
}

/// Solve with factors from [`factor`]: `b` (length n) is overwritten by x with M x = b.
/// `tmp` holds n values. With factors from [`factor_rows`], `b` has `rows` entries (those of
/// the rows not selected are not read) and x is written to its first n.
#[inline(always)]
pub fn solve<S: Scalar>(n: usize, lu: &[S], perm: &[usize], b: &mut [S], tmp: &mut [S]) {
    for i in 0..n {
        tmp[i] = b[perm[i]];
    }
    for i in 0..n {
        let mut x = tmp[i];
        for j in 0..i {
            x = x - lu[i * n + j] * tmp[j];
        }
        tmp[i] = x;
    }
    for i in (0..n).rev() {
        let mut x = tmp[i];
        for j in i + 1..n {
            x = x - lu[i * n + j] * tmp[j];
        }
        tmp[i] = x / lu[i * n + i];
    }
    b[..n].copy_from_slice(&tmp[..n]);
}

/// Solve the transposed system with factors from [`factor`] or [`factor_rows`]: y with
/// Mᵀ y = b for the n rows of M the pivoting selected, written to `y` by M's row (`rows`
/// entries; those of the rows not selected 0). With P M = L U (`perm`), Uᵀ z = b forward,
/// Lᵀ w = z backward, y[perm[i]] = wᵢ. `tmp` holds n values.
#[inline(always)]
pub fn solve_transposed<S: Scalar>(
    n: usize,
    lu: &[S],
    perm: &[usize],
    b: &[S],
    y: &mut [S],
    tmp: &mut [S],
) {
    for i in 0..n {
        let mut x = b[i];
        for j in 0..i {
            x = x - lu[j * n + i] * tmp[j];
        }
        tmp[i] = x / lu[i * n + i];
    }
    for i in (0..n).rev() {
        let mut x = tmp[i];
        for j in i + 1..n {
            x = x - lu[j * n + i] * tmp[j];
        }
        tmp[i] = x;
    }
    y.fill(S::constant(0.0));
    for i in 0..n {
        y[perm[i]] = tmp[i];
    }
}

/// The determinant from factors of [`factor`] (the product of the pivots, signed by the
/// permutation's parity).
pub fn determinant<S: Scalar>(n: usize, lu: &[S], perm: &[usize]) -> S {
    let mut det = S::constant(1.0);
    for i in 0..n {
        det = det * lu[i * n + i];
    }
    let mut seen = vec![false; n];
    let mut odd = false;
    for start in 0..n {
        let (mut i, mut len) = (start, 0);
        while !seen[i] {
            seen[i] = true;
            i = perm[i];
            len += 1;
        }
        odd ^= len > 0 && len % 2 == 0;
    }
    if odd { -det } else { det }
}

/// LU factors that own their storage.
#[derive(Clone, Debug)]
pub struct Lu<S> {
    n: usize,
    lu: Vec<S>,
    perm: Vec<usize>,
}

impl<S: Scalar> Lu<S> {
    /// Factor a square matrix given by rows; `None` when a pivot is exactly zero.
    pub fn new(rows: Vec<Vec<S>>) -> Option<Lu<S>> {
        let n = rows.len();
        Lu::from_row_major(n, rows.into_iter().flatten().collect(), Pivot::Exact)
    }

    /// Factor the n×n row-major `a`; `None` when a pivot counts as zero ([`Pivot`]).
    pub fn from_row_major(n: usize, mut a: Vec<S>, pivot: Pivot) -> Option<Lu<S>> {
        if a.len() != n * n {
            return None;
        }
        let mut perm = vec![0; n];
        factor(n, &mut a, &mut perm, pivot).then_some(Lu { n, lu: a, perm })
    }

    /// Solve `M x = b`.
    pub fn solve(&self, b: &[S]) -> Vec<S> {
        let mut x = b.to_vec();
        let mut tmp = b.to_vec();
        solve(self.n, &self.lu, &self.perm, &mut x, &mut tmp);
        x
    }

    /// det M.
    pub fn determinant(&self) -> S {
        determinant(self.n, &self.lu, &self.perm)
    }
}

/// Solve the square system `a x = b` (LU with partial pivoting); `None` when singular.
pub fn solve_system<S: Scalar>(a: Vec<Vec<S>>, b: Vec<S>) -> Option<Vec<S>> {
    Lu::new(a).map(|lu| lu.solve(&b))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn solves_with_pivoting_and_signs_the_determinant() {
        let a = vec![
            vec![0.0, 2.0, 1.0],
            vec![1.0, 1.0, 0.0],
            vec![3.0, 0.0, 1.0],
        ];
        let x = [1.0, -2.0, 0.5];
        let b: Vec<f64> = a
            .iter()
            .map(|r| r.iter().zip(&x).map(|(p, q)| p * q).sum())
            .collect();
        let lu = Lu::new(a).unwrap();
        for (g, e) in lu.solve(&b).iter().zip(&x) {
            assert!((g - e).abs() < 1e-14);
        }
        // det = 0·(1·1 − 0·0) − 2·(1·1 − 0·3) + 1·(1·0 − 1·3) = −5
        assert!((lu.determinant() + 5.0).abs() < 1e-14);
        assert!(solve_system(vec![vec![1.0, 2.0], vec![2.0, 4.0]], vec![1.0, 2.0]).is_none());
    }

    /// Four rows of rank 3 in three unknowns, the third the sum of the first two: the
    /// pivoting selects independent rows among all four and solves the consistent system;
    /// the first three alone are singular.
    #[test]
    fn factor_rows_selects_independent_rows_of_a_consistent_tall_system() {
        let a = [
            [1.0, 2.0, 0.0],
            [0.0, 1.0, 1.0],
            [1.0, 3.0, 1.0],
            [2.0, 0.0, 1.0],
        ];
        let x = [0.5, -1.0, 2.0];
        let mut b: Vec<f64> = a
            .iter()
            .map(|r| r.iter().zip(&x).map(|(p, q)| p * q).sum())
            .collect();
        let mut m: Vec<f64> = a.iter().flatten().copied().collect();
        let mut square = m[..9].to_vec();
        let mut perm = [0; 4];
        assert!(!factor(3, &mut square, &mut perm, Pivot::Relative(1e-14)));
        assert!(factor_rows(4, 3, &mut m, &mut perm, Pivot::Relative(1e-14)));
        let mut sorted = perm[..3].to_vec();
        sorted.sort_unstable();
        assert!(sorted.contains(&3), "the fourth row is needed: {perm:?}");
        let mut tmp = [0.0; 3];
        solve(3, &m, &perm, &mut b, &mut tmp);
        for (g, e) in b.iter().zip(&x) {
            assert!((g - e).abs() < 1e-14, "{g} vs {e}");
        }
    }

    #[test]
    fn a_relative_pivot_floor_reports_numerical_singularity() {
        let a = vec![1.0, 1.0, 1.0, 1.0 + 1e-15];
        assert!(Lu::from_row_major(2, a.clone(), Pivot::Exact).is_some());
        assert!(Lu::from_row_major(2, a, EVALUATOR_PIVOT).is_none());
        assert!(Lu::from_row_major(2, vec![f64::NAN, 0.0, 0.0, 1.0], Pivot::Exact).is_none());
    }
}
