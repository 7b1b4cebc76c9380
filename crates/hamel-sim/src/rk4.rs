//! The classical fourth-order Runge–Kutta method (Kutta 1901), with a fixed step.
//!
//! Tableau: Hairer, Nørsett & Wanner, "Solving ODEs I", Table II.1.2 (left).

use crate::explicit::{Stages, Tableau, Weights};
use crate::step::FixedStep;
use crate::system::{Evaluator, OdeSystem, StepFailure};

const TABLEAU: Tableau = Tableau {
    c: &[0.0, 0.5, 0.5, 1.0],
    a: &[&[], &[0.5], &[0.0, 0.5], &[0.0, 0.0, 1.0]],
};
const B: [f64; 4] = [1.0 / 6.0, 1.0 / 3.0, 1.0 / 3.0, 1.0 / 6.0];
/// The tableau's rows and [`B`], zeros left out.
const A: [Weights; 4] = Weights::rows(&TABLEAU);
const B_W: Weights = Weights::new(&B);

/// Classical RK4: four right-hand side evaluations per step.
pub(crate) struct Rk4 {
    stages: Stages,
}

impl Rk4 {
    pub(crate) fn new(n: usize) -> Self {
        Rk4 {
            stages: Stages::new(4, n),
        }
    }
}

impl FixedStep for Rk4 {
    fn step<S: OdeSystem + ?Sized>(
        &mut self,
        ev: &mut Evaluator<'_, S>,
        t: f64,
        y: &[f64],
        h: f64,
        y_new: &mut [f64],
    ) -> Result<(), StepFailure> {
        self.stages.evaluate_at(ev, 0, t, y)?;
        self.stages.evaluate(ev, (&A, TABLEAU.c), t, y, h, 1..4)?;
        self.stages.combine(y, h, &B_W, y_new);
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tableau_satisfies_the_order_four_quadrature_conditions() {
        for (s, row) in TABLEAU.a.iter().enumerate() {
            assert_eq!(row.iter().sum::<f64>(), TABLEAU.c[s]);
        }
        for q in 0..4 {
            let sum: f64 = B.iter().zip(TABLEAU.c).map(|(b, c)| b * c.powi(q)).sum();
            assert!((sum - 1.0 / f64::from(q + 1)).abs() < 1e-15, "q = {q}");
        }
    }
}
