//! Test problems and measurements shared by the unit tests.

use crate::control::Tolerances;
use crate::explicit::Tableau;
use crate::step::AdaptiveStep;
use crate::system::{Evaluator, OdeSystem, SystemError};

/// `y1' = y1 cos t`, `y2' = −y2²`, `y(0) = (1, 1)`: non-autonomous and nonlinear, with the exact
/// solution `(exp(sin t), 1/(1 + t))`.
pub(crate) struct Sample;

impl OdeSystem for Sample {
    fn dim(&self) -> usize {
        2
    }
    fn rhs(&self, t: f64, y: &[f64], dy: &mut [f64]) -> Result<(), SystemError> {
        dy[0] = y[0] * t.cos();
        dy[1] = -y[1] * y[1];
        Ok(())
    }
}

pub(crate) fn exact(t: f64) -> [f64; 2] {
    [t.sin().exp(), 1.0 / (1.0 + t)]
}

fn max_error(t: f64, y: &[f64]) -> f64 {
    exact(t)
        .iter()
        .zip(y)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f64::max)
}

/// `max_s |Σ_j a_sj − c_s|`.
pub(crate) fn row_sum_defect(tableau: &Tableau) -> f64 {
    tableau
        .a
        .iter()
        .zip(tableau.c)
        .map(|(row, c)| (row.iter().sum::<f64>() - c).abs())
        .fold(0.0, f64::max)
}

/// `max_{q < order} |Σ_i b_i c_i^q − 1/(q+1)|`: zero iff the weights integrate polynomials of
/// degree below `order` exactly.
pub(crate) fn quadrature_defect(b: &[f64], c: &[f64], order: i32) -> f64 {
    (0..order)
        .map(|q| {
            let sum: f64 = b.iter().zip(c).map(|(b, c)| b * c.powi(q)).sum();
            (sum - 1.0 / f64::from(q + 1)).abs()
        })
        .fold(0.0, f64::max)
}

const TOL: Tolerances = Tolerances {
    rtol: 1e-6,
    atol: 1e-6,
};

/// Error at t = 1 of [`Sample`] integrated with the constant step `h` (every step accepted).
pub(crate) fn global_error_fixed(stepper: &mut impl AdaptiveStep, h: f64) -> f64 {
    let mut ev = Evaluator::new(&Sample);
    let mut y = vec![1.0, 1.0];
    let mut y_new = vec![0.0; 2];
    let mut f0 = vec![0.0; 2];
    ev.rhs(0.0, &y, &mut f0).unwrap();
    stepper.start(&f0);
    let steps = (1.0 / h).round() as usize;
    for k in 0..steps {
        let t = k as f64 * h;
        stepper
            .attempt(&mut ev, &TOL, t, &y, h, &mut y_new)
            .unwrap();
        stepper.accept(&mut ev, t, &y, h, &y_new, false).unwrap();
        std::mem::swap(&mut y, &mut y_new);
    }
    max_error(1.0, &y)
}

/// Error of the continuous extension at `θ·h` after one step of size `h` from the exact `y(0)`.
pub(crate) fn dense_error_after_one_step(
    stepper: &mut impl AdaptiveStep,
    h: f64,
    theta: f64,
) -> f64 {
    let mut ev = Evaluator::new(&Sample);
    let y = vec![1.0, 1.0];
    let mut y_new = vec![0.0; 2];
    let mut f0 = vec![0.0; 2];
    ev.rhs(0.0, &y, &mut f0).unwrap();
    stepper.start(&f0);
    stepper
        .attempt(&mut ev, &TOL, 0.0, &y, h, &mut y_new)
        .unwrap();
    stepper.accept(&mut ev, 0.0, &y, h, &y_new, true).unwrap();
    let mut out = vec![0.0; 2];
    stepper
        .interpolant()
        .expect("method has dense output")
        .interpolate(theta, &mut out);
    max_error(theta * h, &out)
}

/// Asserts that errors `e1` at step `h` and `e2` at `h/2` show order `expected ± slack`.
pub(crate) fn assert_order(e1: f64, e2: f64, expected: f64, slack: f64) {
    let observed = (e1 / e2).log2();
    assert!(
        (observed - expected).abs() <= slack,
        "observed order {observed:.3} (errors {e1:.3e}, {e2:.3e}), expected {expected}"
    );
}
