//! The planned state as an ODE system for `hamel-sim`, evaluated by the derivation's
//! structured evaluator (interpreted): y = (integrated and reconstructed coordinates, η).

use hamel_derive::Compiled;
use hamel_sim::{OdeSystem, SystemError};
use indexmap::IndexMap;

/// The planned state of a loaded scene as an ODE system.
pub(crate) struct System<'a> {
    pub(crate) compiled: &'a Compiled,
    pub(crate) params: IndexMap<String, f64>,
    /// The live parameters (the model's, in order) and what sets each at every evaluation.
    pub(crate) live: Vec<(String, hamel_sim::Live)>,
    pub(crate) names: &'a [String],
    pub(crate) ell: usize,
    pub(crate) sigma: usize,
    /// The coordinates in the state (integrated, then reconstructed), model indices.
    pub(crate) state: Vec<usize>,
    /// The value at which the dropped coordinates are held (the equations are free of them).
    pub(crate) reference: f64,
    /// Whether the energy and the constraint residual are computed (requested).
    pub(crate) energy: bool,
    pub(crate) residual: bool,
    /// δ = det[Z; α] at the start: a path that changes its sign crosses the singular set.
    pub(crate) delta0: f64,
    pub(crate) numeric: hamel_model::NumericModel<'a>,
    /// The largest condition number of [Z; α] met, and when: computed whenever |δ| has fallen
    /// below 1e-3 of its start (δ comes with every evaluation; the condition number costs an SVD).
    pub(crate) watch: std::cell::Cell<Option<(f64, f64)>>,
    /// The holonomic constraints, when the state holds every coordinate they depend on:
    /// projected onto after each step.
    pub(crate) holonomic: Option<&'a hamel_model::Completion>,
}

impl System<'_> {
    /// The full coordinates at state y: the state's, the dropped ones at the reference value.
    pub(crate) fn full_q<T: Copy>(&self, y: &[T], reference: T) -> Vec<T> {
        let mut q = vec![reference; self.ell];
        for (i, &k) in self.state.iter().enumerate() {
            q[k] = y[i];
        }
        q
    }

    /// The parameters at time `t`: the live ones set.
    pub(crate) fn params_at(
        &self,
        t: f64,
    ) -> Result<std::borrow::Cow<'_, IndexMap<String, f64>>, SystemError> {
        if self.live.is_empty() {
            return Ok(std::borrow::Cow::Borrowed(&self.params));
        }
        let mut p = self.params.clone();
        for (name, source) in &self.live {
            p[name] = source.at(t)?;
        }
        Ok(std::borrow::Cow::Owned(p))
    }

    pub(crate) fn at(&self, t: f64, y: &[f64]) -> Result<hamel_derive::Evaluation, SystemError> {
        let (qs, eta) = y.split_at(self.state.len());
        let q = self.full_q(qs, self.reference);
        let params = self.params_at(t)?;
        let result = self.compiled.evaluate(&q, eta, &params).and_then(|e| {
            if e.delta.signum() == self.delta0.signum() {
                Ok(e)
            } else {
                Err(hamel_derive::NumericError::CrossedSingularSet { delta: e.delta })
            }
        });
        result.map_err(|e| {
            let at: Vec<String> = self
                .state
                .iter()
                .zip(qs)
                .map(|(&k, v)| format!("{} = {v:.6}", self.names[k]))
                .chain(
                    eta.iter()
                        .enumerate()
                        .map(|(i, v)| format!("eta{} = {v:.6}", i + 1)),
                )
                .collect();
            SystemError::new(format!("{e} (state {})", at.join(", ")))
        })
    }
}

impl OdeSystem for System<'_> {
    fn dim(&self) -> usize {
        self.state.len() + self.sigma
    }
    fn rhs(&self, t: f64, y: &[f64], dy: &mut [f64]) -> Result<(), SystemError> {
        self.rhs_and_power(t, y, dy).map(|_| ())
    }
    /// With the energy requested, a model whose forces do work is integrated with their work
    /// beside the state (the energy balance E − W is then what is monitored).
    fn does_work(&self) -> bool {
        self.energy && self.compiled.has_forces()
    }
    fn power(&self, t: f64, y: &[f64]) -> Result<f64, SystemError> {
        Ok(self.at(t, y)?.power.unwrap_or(0.0))
    }
    fn rhs_and_power(&self, t: f64, y: &[f64], dy: &mut [f64]) -> Result<f64, SystemError> {
        let e = self.at(t, y)?;
        if e.delta.abs() < 1e-3 * self.delta0.abs() {
            let q = self.full_q(&y[..self.state.len()], self.reference);
            if let Ok(cond) = self.compiled.condition(&q, &self.params)
                && self.watch.get().is_none_or(|(c, _)| cond > c)
            {
                self.watch.set(Some((cond, t)));
            }
        }
        let n = self.state.len();
        for (i, &k) in self.state.iter().enumerate() {
            dy[i] = e.q_dot[k];
        }
        dy[n..].copy_from_slice(&e.eta_dot);
        Ok(e.power.unwrap_or(0.0))
    }
    fn energy(&self, t: f64, y: &[f64]) -> Option<f64> {
        if !self.energy {
            return None;
        }
        self.at(t, y).ok().map(|e| e.energy)
    }
    /// ‖α(q) q̇‖∞ with q̇ = Γη, from the model's own α (hamel-sim reports its maximum over the
    /// outputs as the constraint drift). Requested, it keeps every coordinate in the state.
    fn constraint_residual(&self, t: f64, y: &[f64]) -> Option<f64> {
        if !self.residual {
            return None;
        }
        let e = self.at(t, y).ok()?;
        let q = self.full_q(&y[..self.state.len()], self.reference);
        hamel_oracle::constraint_residual(&self.numeric, &q, &e.q_dot).ok()
    }
    /// Back onto h(q) = 0: the dependent coordinates by Newton, the others kept. The
    /// velocities need nothing: q̇ = Γη satisfies dh/dt = 0 at every q. Returns max |h| before.
    fn project(&self, _t: f64, y: &mut [f64]) -> Option<Result<f64, SystemError>> {
        let c = self.holonomic?;
        let n = self.state.len();
        let mut q = self.full_q(&y[..n], self.reference);
        let fail = |e: hamel_model::CompletionError| {
            SystemError::new(format!("projection onto the holonomic constraints: {e}"))
        };
        let residual = match c.residual(&q, &self.params) {
            Ok(r) => r,
            Err(e) => return Some(Err(fail(e))),
        };
        if residual == 0.0 {
            return Some(Ok(0.0));
        }
        if let Err(e) = c.complete(&mut q, &self.params) {
            return Some(Err(fail(e)));
        }
        for (i, &k) in self.state.iter().enumerate() {
            y[i] = q[k];
        }
        Some(Ok(residual))
    }

    /// The solution's series for the Taylor method: the structured right-hand side traced
    /// once, the recurrences run over it ([`hamel_runtime::taylor_by_trace`]). A system whose parameters
    /// change with time (live ones) has no series this way, and says so.
    fn taylor_coefficients(
        &self,
        t: f64,
        y: &[f64],
        order: usize,
        out: &mut Vec<f64>,
    ) -> Option<Result<(), SystemError>> {
        use hamel_runtime::{Scalar, SeriesFailure, Traced};
        if !self.live.is_empty() {
            return Some(Err(SystemError::new(
                "the Taylor method needs parameters constant in time; this scene sets some at every step",
            )));
        }
        let ns = self.state.len();
        let work = y.len() > self.dim();
        let series = hamel_runtime::taylor_by_trace(y, order, out, |x, dx| {
            let (qs, eta) = x.split_at(ns);
            let eta = &eta[..self.sigma];
            let q = self.full_q(qs, Traced::constant(self.reference));
            let r = self.compiled.rhs::<Traced>(&q, eta, &self.params)?;
            for (i, &k) in self.state.iter().enumerate() {
                dx[i] = r.q_dot[k];
            }
            dx[ns..ns + self.sigma].copy_from_slice(&r.eta_dot);
            if work {
                let forces = self.compiled.forces_at(&q, &r.q_dot, &self.params)?;
                let power = forces.iter().flatten().zip(&r.q_dot).map(|(f, v)| *f * *v);
                dx[ns + self.sigma] = power.fold(Traced::constant(0.0), |a, b| a + b);
            }
            Ok::<(), hamel_derive::NumericError>(())
        });
        Some(series.map_err(|e| match e {
            SeriesFailure::NonFinite => {
                SystemError::new(format!("at t = {t}: the Taylor series is not finite"))
            }
            SeriesFailure::System(e) => SystemError::new(format!("at t = {t}: {e}")),
        }))
    }

    /// Exact Jacobian: the structured right-hand side over dual numbers, one column per
    /// state component (used by the implicit Gauss–Legendre method).
    fn jacobian(&self, t: f64, y: &[f64], jac: &mut [f64]) -> Option<Result<(), SystemError>> {
        use hamel_expr::Dual;
        let n = y.len();
        let ns = self.state.len();
        let params = match self.params_at(t) {
            Ok(p) => p,
            Err(e) => return Some(Err(e)),
        };
        for j in 0..n {
            let yd: Vec<Dual> = y
                .iter()
                .enumerate()
                .map(|(i, &v)| Dual::new(v, if i == j { 1.0 } else { 0.0 }))
                .collect();
            let (qs, eta) = yd.split_at(ns);
            let q = self.full_q(qs, Dual::new(self.reference, 0.0));
            let r = match self.compiled.rhs::<Dual>(&q, eta, &params) {
                Ok(r) => r,
                Err(e) => return Some(Err(SystemError::new(format!("at t = {t}: {e}")))),
            };
            let rates = self.state.iter().map(|&k| &r.q_dot[k]);
            for (i, v) in rates.chain(&r.eta_dot).enumerate() {
                if !v.d.is_finite() {
                    return Some(Err(SystemError::new(format!(
                        "at t = {t}: the Jacobian is not finite"
                    ))));
                }
                jac[i * n + j] = v.d;
            }
        }
        Some(Ok(()))
    }
}
