//! Stage evaluation shared by the explicit Runge–Kutta methods.

use std::ops::Range;

use crate::system::{Evaluator, StepFailure};

/// An explicit Runge–Kutta tableau: the nodes `c` and the rows of the strictly lower
/// triangular matrix `a` (row `s` has `s` entries, zeros included), as printed in
/// Hairer–Nørsett–Wanner.
pub(crate) struct Tableau {
    pub(crate) c: &'static [f64],
    pub(crate) a: &'static [&'static [f64]],
}

/// The stage derivatives `k_s` of one step, with room for the stage state.
pub(crate) struct Stages {
    pub(crate) k: Vec<Vec<f64>>,
    state: Vec<f64>,
}

impl Stages {
    pub(crate) fn new(count: usize, n: usize) -> Self {
        Stages {
            k: vec![vec![0.0; n]; count],
            state: vec![0.0; n],
        }
    }

    /// Evaluates the stages `range` of `tableau`: `k_s = f(t + c_s h, y + h Σ_j a_sj k_j)`.
    /// The stages before `range.start` must already be in place.
    pub(crate) fn evaluate(
        &mut self,
        ev: &mut Evaluator<'_>,
        tableau: &Tableau,
        t: f64,
        y: &[f64],
        h: f64,
        range: Range<usize>,
    ) -> Result<(), StepFailure> {
        for s in range {
            let (done, rest) = self.k.split_at_mut(s);
            combine(y, h, tableau.a[s], done, &mut self.state);
            ev.rhs(t + tableau.c[s] * h, &self.state, &mut rest[0])?;
        }
        Ok(())
    }

    /// `out = y + h · Σ_j w_j k_j`.
    pub(crate) fn combine(&self, y: &[f64], h: f64, w: &[f64], out: &mut [f64]) {
        combine(y, h, w, &self.k, out);
    }

    /// `Σ_j w_j k_j[i]` for one component `i`.
    pub(crate) fn dot(&self, w: &[f64], i: usize) -> f64 {
        w.iter().zip(&self.k).map(|(&wj, kj)| wj * kj[i]).sum()
    }
}

/// `out = y + h · Σ_j w_j k_j` (zero weights skipped).
fn combine(y: &[f64], h: f64, w: &[f64], k: &[Vec<f64>], out: &mut [f64]) {
    out.fill(0.0);
    for (&wj, kj) in w.iter().zip(k) {
        if wj != 0.0 {
            for (o, &v) in out.iter_mut().zip(kj) {
                *o += wj * v;
            }
        }
    }
    for (o, &yi) in out.iter_mut().zip(y) {
        *o = yi + h * *o;
    }
}
