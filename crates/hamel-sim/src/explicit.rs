//! Stage evaluation shared by the explicit Runge–Kutta methods.

use crate::system::{Evaluator, OdeSystem, StepFailure};

/// An explicit Runge–Kutta tableau: the nodes `c` and the rows of the strictly lower
/// triangular matrix `a` (row `s` has `s` entries, zeros included), as printed in
/// Hairer–Nørsett–Wanner.
pub(crate) struct Tableau {
    pub(crate) c: &'static [f64],
    pub(crate) a: &'static [&'static [f64]],
}

/// The number of nonzero entries of `row` (the length of its [`Row`]).
pub(crate) const fn nonzeros(row: &[f64]) -> usize {
    let (mut count, mut j) = (0, 0);
    while j < row.len() {
        if row[j] != 0.0 {
            count += 1;
        }
        j += 1;
    }
    count
}

/// A row of weights `w_j` with its zeros left out, its length a constant: the sums
/// `Σ_j w_j k_j` are unrolled at compile time, as Hairer writes them out in dopri5.f and
/// dop853.f (a tableau's rows are half zeros). Declared with [`rows!`].
pub(crate) struct Row<const M: usize> {
    index: [usize; M],
    w: [f64; M],
}

impl<const M: usize> Row<M> {
    /// The nonzero entries of `row`; `M` must be [`nonzeros`]`(row)` (checked at compile time).
    pub(crate) const fn new(row: &[f64]) -> Self {
        assert!(nonzeros(row) == M, "M is not the number of nonzero weights");
        let mut out = Row {
            index: [0; M],
            w: [0.0; M],
        };
        let (mut m, mut j) = (0, 0);
        while j < row.len() {
            if row[j] != 0.0 {
                out.index[m] = j;
                out.w[m] = row[j];
                m += 1;
            }
            j += 1;
        }
        out
    }
}

/// Declares each `NAME = ROW` (a `&[f64]` known at compile time) as a constant [`Row`].
macro_rules! rows {
    ($($(#[$doc:meta])* $name:ident = $row:expr;)*) => {
        $($(#[$doc])* const $name: crate::explicit::Row<{ crate::explicit::nonzeros($row) }> =
            crate::explicit::Row::new($row);)*
    };
}
pub(crate) use rows;

/// The stage derivatives `k_s` of one step, stage after stage in one buffer, with room for
/// the stage state.
pub(crate) struct Stages {
    n: usize,
    k: Vec<f64>,
    state: Vec<f64>,
}

impl Stages {
    pub(crate) fn new(count: usize, n: usize) -> Self {
        Stages {
            n,
            k: vec![0.0; count * n],
            state: vec![0.0; n],
        }
    }

    /// `k_s`.
    #[inline]
    pub(crate) fn k(&self, s: usize) -> &[f64] {
        &self.k[s * self.n..(s + 1) * self.n]
    }

    /// `k_s = v`.
    #[inline]
    pub(crate) fn set(&mut self, s: usize, v: &[f64]) {
        self.k[s * self.n..(s + 1) * self.n].copy_from_slice(v);
    }

    /// `k_to = k_from` (the last stage of a step is the first of the next).
    #[inline]
    pub(crate) fn copy(&mut self, from: usize, to: usize) {
        let n = self.n;
        self.k.copy_within(from * n..(from + 1) * n, to * n);
    }

    /// `k_s = f(t, y)`.
    pub(crate) fn evaluate_at<S: OdeSystem + ?Sized>(
        &mut self,
        ev: &mut Evaluator<'_, S>,
        s: usize,
        t: f64,
        y: &[f64],
    ) -> Result<(), StepFailure> {
        let n = self.n;
        ev.rhs(t, y, &mut self.k[s * n..(s + 1) * n])
    }

    /// Stage `s`: `k_s = f(t + c h, y + h Σ_j a_j k_j)` with `a` row `s` of the tableau and `c`
    /// its node. The stages `a` reads must be in place.
    #[allow(clippy::too_many_arguments, reason = "one stage of a Runge–Kutta step")]
    pub(crate) fn stage<S: OdeSystem + ?Sized, const M: usize>(
        &mut self,
        ev: &mut Evaluator<'_, S>,
        (a, c): (&Row<M>, f64),
        t: f64,
        y: &[f64],
        h: f64,
        s: usize,
    ) -> Result<(), StepFailure> {
        let mut state = std::mem::take(&mut self.state);
        self.combine(y, h, a, &mut state);
        let result = self.evaluate_at(ev, s, t + c * h, &state);
        self.state = state;
        result
    }

    /// `out = y + h · Σ_j w_j k_j`.
    pub(crate) fn combine<const M: usize>(&self, y: &[f64], h: f64, w: &Row<M>, out: &mut [f64]) {
        let (y, out) = (&y[..self.n], &mut out[..self.n]);
        self.sums(w, |i, sum| out[i] = y[i] + h * sum);
    }

    /// `out[i] = Σ_j w_j k_j[i]`.
    pub(crate) fn sum<const M: usize>(&self, w: &Row<M>, out: &mut [f64]) {
        let out = &mut out[..self.n];
        self.sums(w, |i, sum| out[i] = sum);
    }

    /// `out[i] = Σ_j w_j (k_j[i] − k_base[i])`: for weights that sum to zero or one, the
    /// differences of nearby stages keep their large coefficients from amplifying the
    /// rounding of the stages themselves (a continuous extension in monomial form).
    pub(crate) fn sum_relative<const M: usize>(&self, w: &Row<M>, base: usize, out: &mut [f64]) {
        let out = &mut out[..self.n];
        let ks: [&[f64]; M] = std::array::from_fn(|m| self.k(w.index[m]));
        let kb = self.k(base);
        for i in 0..self.n {
            let mut sum = 0.0;
            for m in 0..M {
                sum += w.w[m] * (ks[m][i] - kb[i]);
            }
            out[i] = sum;
        }
    }

    /// `put(i, Σ_j w_j k_j[i])` for every component `i`, in order. Small systems (the
    /// reduced equations of a mechanism have a handful of states) take a kernel whose
    /// dimension is a constant: no bounds checks, the loops unrolled and vectorised. The sums
    /// are the same, term by term in the same order, so the results are identical bit for bit.
    #[inline(always)]
    fn sums<const M: usize>(&self, w: &Row<M>, put: impl FnMut(usize, f64)) {
        macro_rules! dispatch {
            ($($n:literal)*) => {
                match self.n {
                    $($n => self.sums_fixed::<$n, M>(w, put),)*
                    _ => self.sums_any(w, put),
                }
            };
        }
        dispatch!(1 2 3 4 5 6 7 8 9 10 11 12)
    }

    /// [`Stages::sums`] for `n = N`.
    #[inline]
    fn sums_fixed<const N: usize, const M: usize>(
        &self,
        w: &Row<M>,
        mut put: impl FnMut(usize, f64),
    ) {
        let ks: [&[f64; N]; M] = std::array::from_fn(|m| {
            self.k(w.index[m])
                .try_into()
                .expect("a stage has n = N components")
        });
        let mut sums = [0.0; N];
        for m in 0..M {
            for i in 0..N {
                sums[i] += w.w[m] * ks[m][i];
            }
        }
        for (i, sum) in sums.into_iter().enumerate() {
            put(i, sum);
        }
    }

    /// [`Stages::sums`] for any `n`.
    #[inline]
    fn sums_any<const M: usize>(&self, w: &Row<M>, mut put: impl FnMut(usize, f64)) {
        let ks: [&[f64]; M] = std::array::from_fn(|m| self.k(w.index[m]));
        for i in 0..self.n {
            let mut sum = 0.0;
            for m in 0..M {
                sum += w.w[m] * ks[m][i];
            }
            put(i, sum);
        }
    }
}
