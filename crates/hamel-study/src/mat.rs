//! Matrices as rows (the serialised form) and back.

use nalgebra::DMatrix;

/// A matrix as rows.
pub(crate) fn rows(m: &DMatrix<f64>) -> Vec<Vec<f64>> {
    (0..m.nrows())
        .map(|i| m.row(i).iter().copied().collect())
        .collect()
}

/// Rows as a matrix.
pub(crate) fn matrix(rows: &[Vec<f64>]) -> DMatrix<f64> {
    let cols = rows.first().map_or(0, Vec::len);
    DMatrix::from_fn(rows.len(), cols, |i, k| rows[i][k])
}
