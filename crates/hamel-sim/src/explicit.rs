//! Stage evaluation shared by the explicit Runge–Kutta methods.

use std::ops::Range;

use crate::system::{Evaluator, OdeSystem, StepFailure};

/// An explicit Runge–Kutta tableau: the nodes `c` and the rows of the strictly lower
/// triangular matrix `a` (row `s` has `s` entries, zeros included), as printed in
/// Hairer–Nørsett–Wanner.
pub(crate) struct Tableau {
    pub(crate) c: &'static [f64],
    pub(crate) a: &'static [&'static [f64]],
}

/// The most stages of a method here (DOP853 with its continuous extension).
const MAX_STAGES: usize = 16;

/// A row of weights `w_j` with its zeros left out (a tableau's rows are half zeros), for the
/// sums `Σ_j w_j k_j`; built at compile time.
#[derive(Clone, Copy)]
pub(crate) struct Weights {
    len: usize,
    index: [usize; MAX_STAGES],
    w: [f64; MAX_STAGES],
}

impl Weights {
    const EMPTY: Weights = Weights {
        len: 0,
        index: [0; MAX_STAGES],
        w: [0.0; MAX_STAGES],
    };

    /// The nonzero entries of `row`.
    pub(crate) const fn new(row: &[f64]) -> Weights {
        let mut out = Weights::EMPTY;
        let mut j = 0;
        while j < row.len() {
            if row[j] != 0.0 {
                out.index[out.len] = j;
                out.w[out.len] = row[j];
                out.len += 1;
            }
            j += 1;
        }
        out
    }

    /// The rows of `tableau`'s matrix.
    pub(crate) const fn rows<const N: usize>(tableau: &Tableau) -> [Weights; N] {
        let mut out = [Weights::EMPTY; N];
        let mut s = 0;
        while s < N {
            out[s] = Weights::new(tableau.a[s]);
            s += 1;
        }
        out
    }

    /// `Σ_j w_j k[j]`, in two independent partial sums (one sequential sum would make every
    /// term wait for the one before).
    #[inline]
    fn dot(&self, k: &[f64]) -> f64 {
        let (mut even, mut odd) = (0.0, 0.0);
        let mut m = 0;
        while m + 1 < self.len {
            even += self.w[m] * k[self.index[m]];
            odd += self.w[m + 1] * k[self.index[m + 1]];
            m += 2;
        }
        if m < self.len {
            even += self.w[m] * k[self.index[m]];
        }
        even + odd
    }
}

/// The stage derivatives `k_s` of one step, component-major in one buffer (`k_s[i]` at
/// `i·count + s`), so that every combination `Σ_j w_j k_j[i]` reads one contiguous run; with
/// room for the stage state and one evaluation.
pub(crate) struct Stages {
    count: usize,
    k: Vec<f64>,
    state: Vec<f64>,
    f: Vec<f64>,
}

impl Stages {
    pub(crate) fn new(count: usize, n: usize) -> Self {
        Stages {
            count,
            k: vec![0.0; count * n],
            state: vec![0.0; n],
            f: vec![0.0; n],
        }
    }

    /// `k_s[i]`.
    #[inline]
    pub(crate) fn get(&self, s: usize, i: usize) -> f64 {
        self.k[i * self.count + s]
    }

    /// `k_s = v`.
    pub(crate) fn set(&mut self, s: usize, v: &[f64]) {
        for (row, &x) in self.k.chunks_exact_mut(self.count).zip(v) {
            row[s] = x;
        }
    }

    /// `k_to = k_from` (the last stage of a step is the first of the next).
    pub(crate) fn copy(&mut self, from: usize, to: usize) {
        for row in self.k.chunks_exact_mut(self.count) {
            row[to] = row[from];
        }
    }

    /// `k_s = f(t, y)`.
    pub(crate) fn evaluate_at<S: OdeSystem + ?Sized>(
        &mut self,
        ev: &mut Evaluator<'_, S>,
        s: usize,
        t: f64,
        y: &[f64],
    ) -> Result<(), StepFailure> {
        let mut f = std::mem::take(&mut self.f);
        let result = ev.rhs(t, y, &mut f);
        if result.is_ok() {
            self.set(s, &f);
        }
        self.f = f;
        result
    }

    /// Evaluates the stages `range` of `tableau`: `k_s = f(t + c_s h, y + h Σ_j a_sj k_j)`.
    /// The stages before `range.start` must already be in place.
    pub(crate) fn evaluate<S: OdeSystem + ?Sized>(
        &mut self,
        ev: &mut Evaluator<'_, S>,
        (a, c): (&[Weights], &[f64]),
        t: f64,
        y: &[f64],
        h: f64,
        range: Range<usize>,
    ) -> Result<(), StepFailure> {
        for s in range {
            let mut state = std::mem::take(&mut self.state);
            self.combine(y, h, &a[s], &mut state);
            let result = self.evaluate_at(ev, s, t + c[s] * h, &state);
            self.state = state;
            result?;
        }
        Ok(())
    }

    /// `out = y + h · Σ_j w_j k_j`.
    pub(crate) fn combine(&self, y: &[f64], h: f64, w: &Weights, out: &mut [f64]) {
        for ((o, &yi), row) in out.iter_mut().zip(y).zip(self.k.chunks_exact(self.count)) {
            *o = yi + h * w.dot(row);
        }
    }

    /// `Σ_j w_j k_j[i]` for one component `i`.
    #[inline]
    pub(crate) fn dot(&self, w: &Weights, i: usize) -> f64 {
        w.dot(&self.k[i * self.count..(i + 1) * self.count])
    }
}
