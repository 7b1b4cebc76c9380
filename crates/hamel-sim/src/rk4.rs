//! The classical fourth-order Runge–Kutta method (Kutta 1901), with a fixed step.
//!
//! Tableau: Hairer, Nørsett & Wanner, "Solving ODEs I", Table II.1.2 (left).

use crate::explicit::{Stages, Tableau, rows};
use crate::step::FixedStep;
use crate::system::{Evaluator, OdeSystem, StepFailure};

const TABLEAU: Tableau = Tableau {
    c: &[0.0, 0.5, 0.5, 1.0],
    a: &[&[], &[0.5], &[0.0, 0.5], &[0.0, 0.0, 1.0]],
};
const B: [f64; 4] = [1.0 / 6.0, 1.0 / 3.0, 1.0 / 3.0, 1.0 / 6.0];

rows! {
    A1 = TABLEAU.a[1];
    A2 = TABLEAU.a[2];
    A3 = TABLEAU.a[3];
    B_ROW = &B;
}

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
        let (st, c) = (&mut self.stages, TABLEAU.c);
        st.evaluate_at(ev, 0, t, y)?;
        st.stage(ev, (&A1, c[1]), t, y, h, 1)?;
        st.stage(ev, (&A2, c[2]), t, y, h, 2)?;
        st.stage(ev, (&A3, c[3]), t, y, h, 3)?;
        st.combine(y, h, &B_ROW, y_new);
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
