//! The energy balance of a system whose forces do work (dampers, motors): W = ∫ P dt, the work
//! of the forces, integrated as one more state beside y, so that E − W is the invariant the
//! integration monitors (exactly conserved by the true motion) and W is reported at each
//! output ([`Solution::work`]).

use crate::solution::{IntegrationError, Solution};
use crate::states::States;
use crate::system::{OdeSystem, SystemError};

/// `inner` with W appended to its state: dW/dt = P(t, y), invariant E − W.
pub(crate) struct WithWork<'a, S: ?Sized> {
    inner: &'a S,
}

impl<S: OdeSystem + ?Sized> WithWork<'_, S> {
    fn n(&self) -> usize {
        self.inner.dim()
    }

    /// The rows of `rows` (each n + 1 long) without their W.
    fn states(&self, rows: &[f64]) -> Vec<f64> {
        rows.chunks_exact(self.n() + 1)
            .flat_map(|y| y[..self.n()].iter().copied())
            .collect()
    }
}

impl<S: OdeSystem + ?Sized> OdeSystem for WithWork<'_, S> {
    fn dim(&self) -> usize {
        self.n() + 1
    }

    fn rhs(&self, t: f64, y: &[f64], dy: &mut [f64]) -> Result<(), SystemError> {
        let n = self.n();
        dy[n] = self.inner.rhs_and_power(t, &y[..n], &mut dy[..n])?;
        Ok(())
    }

    fn energy(&self, t: f64, y: &[f64]) -> Option<f64> {
        let n = self.n();
        self.inner.energy(t, &y[..n]).map(|e| e - y[n])
    }

    fn energies(&self, t: &[f64], rows: &[f64], out: &mut [Option<f64>]) {
        let n = self.n();
        self.inner.energies(t, &self.states(rows), out);
        for (o, y) in out.iter_mut().zip(rows.chunks_exact(n + 1)) {
            *o = o.map(|e| e - y[n]);
        }
    }

    fn constraint_residual(&self, t: f64, y: &[f64]) -> Option<f64> {
        self.inner.constraint_residual(t, &y[..self.n()])
    }

    fn constraint_residuals(&self, t: &[f64], rows: &[f64], out: &mut [Option<f64>]) {
        self.inner.constraint_residuals(t, &self.states(rows), out);
    }

    fn project(&self, t: f64, y: &mut [f64]) -> Option<Result<f64, SystemError>> {
        let n = self.n();
        self.inner.project(t, &mut y[..n])
    }

    /// The state's series and the work's (W' = the power), from the inner system asked with
    /// W appended ([`OdeSystem::taylor_coefficients`]).
    fn taylor_coefficients(
        &self,
        t: f64,
        y: &[f64],
        order: usize,
        out: &mut Vec<f64>,
    ) -> Option<Result<(), SystemError>> {
        self.inner.taylor_coefficients(t, y, order, out)
    }
}

/// The system with its work appended.
pub(crate) fn with_work<S: OdeSystem + ?Sized>(inner: &S) -> WithWork<'_, S> {
    WithWork { inner }
}

/// The result of integrating [`with_work`] from y0 with W(t0) = 0, back as the system's own:
/// states of dimension `n`, energies E and the work W apart.
pub(crate) fn split_result(
    result: Result<Solution, IntegrationError>,
    n: usize,
) -> Result<Solution, IntegrationError> {
    match result {
        Ok(s) => Ok(split(s, n)),
        Err(mut e) => {
            e.partial = Box::new(split(*e.partial, n));
            if e.state.len() == n + 1 {
                e.state.pop();
            }
            Err(e)
        }
    }
}

/// The augmented solution as the system's own: states of dimension `n`, W apart, E = (E − W)
/// + W at each output.
fn split(mut s: Solution, n: usize) -> Solution {
    if s.y.dim() != n + 1 {
        return s;
    }
    let mut states = States::with_capacity(n, s.y.len());
    let mut work = Vec::with_capacity(s.y.len());
    for y in s.y.iter() {
        states.push(&y[..n]);
        work.push(y[n]);
    }
    for (e, w) in s.energy.iter_mut().zip(&work) {
        *e = e.map(|balance| balance + w);
    }
    s.y = states;
    s.work = work;
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A damped oscillator x'' = −x − c x': E = ½(x'² + x²) falls, E − W stays at E(0) to the
    /// integration's accuracy, and W matches the closed form's E(t) − E(0).
    struct Damped {
        c: f64,
    }

    impl OdeSystem for Damped {
        fn dim(&self) -> usize {
            2
        }
        fn rhs(&self, _t: f64, y: &[f64], dy: &mut [f64]) -> Result<(), SystemError> {
            dy[0] = y[1];
            dy[1] = -y[0] - self.c * y[1];
            Ok(())
        }
        fn energy(&self, _t: f64, y: &[f64]) -> Option<f64> {
            Some(0.5 * (y[0] * y[0] + y[1] * y[1]))
        }
        fn does_work(&self) -> bool {
            true
        }
        fn power(&self, _t: f64, y: &[f64]) -> Result<f64, SystemError> {
            Ok(-self.c * y[1] * y[1])
        }
    }

    #[test]
    fn the_balance_holds_and_the_work_is_reported() {
        let system = Damped { c: 0.3 };
        let times: Vec<f64> = (0..=20).map(|i| i as f64 * 0.5).collect();
        let options = crate::Options {
            rtol: 1e-12,
            atol: 1e-12,
            ..crate::Options::default()
        };
        let s = crate::integrate(
            &system,
            crate::Method::Dop853,
            0.0,
            &[1.0, 0.0],
            &times,
            &options,
        )
        .unwrap();
        assert_eq!(s.y.dim(), 2);
        assert_eq!(s.work.len(), times.len());
        let e0 = 0.5;
        let e_end = s.energy.last().unwrap().unwrap();
        assert!(e_end < 0.1 * e0, "the damper takes the energy: {e_end}");
        let drift = s.stats.energy_drift.unwrap();
        assert!(drift < 1e-10, "E − W drifts by {drift}");
        for (e, w) in s.energy.iter().zip(&s.work) {
            assert!((e.unwrap() - w - e0).abs() < 1e-10);
        }
    }
}
