//! Dormand–Prince 5(4) with Shampine's fourth-order continuous extension.
//!
//! Tableau, error coefficients and dense-output coefficients: J. R. Dormand and P. J. Prince,
//! "A family of embedded Runge–Kutta formulae", J. Comput. Appl. Math. 6 (1980); Hairer,
//! Nørsett & Wanner, "Solving ODEs I", Table II.5.2; dense output of Shampine (1986) as in
//! Hairer's dopri5.f (`D1`…`D7`). Controller parameters (safety 0.9, 0.2 ≤ h_new/h ≤ 10,
//! β = 0.04) are dopri5.f's defaults.

use crate::control::{Controller, Tolerances};
use crate::explicit::{Stages, Tableau, rows};
use crate::step::{AdaptiveStep, Interpolant};
use crate::system::{Evaluator, OdeSystem, StepFailure};

const TABLEAU: Tableau = Tableau {
    c: &[0.0, 1.0 / 5.0, 3.0 / 10.0, 4.0 / 5.0, 8.0 / 9.0, 1.0, 1.0],
    a: &[
        &[],
        &[1.0 / 5.0],
        &[3.0 / 40.0, 9.0 / 40.0],
        &[44.0 / 45.0, -56.0 / 15.0, 32.0 / 9.0],
        &[
            19372.0 / 6561.0,
            -25360.0 / 2187.0,
            64448.0 / 6561.0,
            -212.0 / 729.0,
        ],
        &[
            9017.0 / 3168.0,
            -355.0 / 33.0,
            46732.0 / 5247.0,
            49.0 / 176.0,
            -5103.0 / 18656.0,
        ],
        // The last row is also the fifth-order weights b (first same as last).
        &[
            35.0 / 384.0,
            0.0,
            500.0 / 1113.0,
            125.0 / 192.0,
            -2187.0 / 6784.0,
            11.0 / 84.0,
        ],
    ],
};

/// `b − b̂`: the difference between the fifth- and fourth-order weights.
const E: [f64; 7] = [
    71.0 / 57600.0,
    0.0,
    -71.0 / 16695.0,
    71.0 / 1920.0,
    -17253.0 / 339200.0,
    22.0 / 525.0,
    -1.0 / 40.0,
];

/// Shampine's dense-output coefficients (dopri5.f `D1`…`D7`).
const D: [f64; 7] = [
    -12715105075.0 / 11282082432.0,
    0.0,
    87487479700.0 / 32700410799.0,
    -10690763975.0 / 1880347072.0,
    701980252875.0 / 199316789632.0,
    -1453857185.0 / 822651844.0,
    69997945.0 / 29380423.0,
];

rows! {
    A1 = TABLEAU.a[1];
    A2 = TABLEAU.a[2];
    A3 = TABLEAU.a[3];
    A4 = TABLEAU.a[4];
    A5 = TABLEAU.a[5];
    /// The fifth-order weights (row 6: stage 7 is f at the new point).
    B_ROW = TABLEAU.a[6];
    E_ROW = &E;
    D_ROW = &D;
}

/// The DOPRI5 stepper: six evaluations per attempt (the seventh stage is the first of the
/// next step).
pub(crate) struct Dopri5 {
    stages: Stages,
    dense: Dense5,
    /// The error, or a dense-output sum, per component.
    scratch: Vec<f64>,
}

/// Continuous extension over the last accepted step (dopri5.f `CONTD5`).
struct Dense5 {
    /// The five coefficients `RCONT` of each component together.
    r: Vec<f64>,
}

impl Dopri5 {
    pub(crate) fn new(n: usize) -> Self {
        Dopri5 {
            stages: Stages::new(7, n),
            dense: Dense5 {
                r: vec![0.0; 5 * n],
            },
            scratch: vec![0.0; n],
        }
    }
}

impl AdaptiveStep for Dopri5 {
    fn order(&self) -> u32 {
        5
    }

    fn controller(&self, beta: Option<f64>, h_max: f64) -> Controller {
        let beta = beta.unwrap_or(0.04);
        Controller::new(0.9, 0.2, 10.0, beta, 0.2 - 0.75 * beta, h_max)
    }

    fn start(&mut self, f0: &[f64]) {
        self.stages.set(0, f0);
    }

    fn attempt<S: OdeSystem + ?Sized>(
        &mut self,
        ev: &mut Evaluator<'_, S>,
        tol: &Tolerances,
        t: f64,
        y: &[f64],
        h: f64,
        y_new: &mut [f64],
    ) -> Result<f64, StepFailure> {
        let (st, c) = (&mut self.stages, TABLEAU.c);
        st.stage(ev, (&A1, c[1]), t, y, h, 1)?;
        st.stage(ev, (&A2, c[2]), t, y, h, 2)?;
        st.stage(ev, (&A3, c[3]), t, y, h, 3)?;
        st.stage(ev, (&A4, c[4]), t, y, h, 4)?;
        st.stage(ev, (&A5, c[5]), t, y, h, 5)?;
        st.combine(y, h, &B_ROW, y_new);
        st.evaluate_at(ev, 6, t + h, y_new)?;
        st.sum(&E_ROW, &mut self.scratch);
        let err = self.scratch.iter().map(|e| h * e);
        Ok(tol.error_norm(err, y, y_new))
    }

    fn accept<S: OdeSystem + ?Sized>(
        &mut self,
        _ev: &mut Evaluator<'_, S>,
        _t: f64,
        y: &[f64],
        h: f64,
        y_new: &[f64],
        dense: bool,
    ) -> Result<(), StepFailure> {
        if dense {
            let st = &self.stages;
            st.sum(&D_ROW, &mut self.scratch);
            let (k0, k6) = (st.k(0), st.k(6));
            for (i, r) in self.dense.r.chunks_exact_mut(5).enumerate() {
                let ydiff = y_new[i] - y[i];
                let bspl = h * k0[i] - ydiff;
                r[0] = y[i];
                r[1] = ydiff;
                r[2] = bspl;
                r[3] = ydiff - h * k6[i] - bspl;
                r[4] = h * self.scratch[i];
            }
        }
        self.stages.copy(6, 0);
        Ok(())
    }

    fn interpolant(&self) -> Option<&dyn Interpolant> {
        Some(&self.dense)
    }
}

impl Interpolant for Dense5 {
    fn interpolate(&self, theta: f64, out: &mut [f64]) {
        let s1 = 1.0 - theta;
        for (o, r) in out.iter_mut().zip(self.r.chunks_exact(5)) {
            *o = r[0] + theta * (r[1] + s1 * (r[2] + theta * (r[3] + s1 * r[4])));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::{
        assert_order, dense_error_after_one_step, global_error_fixed, quadrature_defect,
        row_sum_defect,
    };

    #[test]
    fn tableau_rows_sum_to_nodes() {
        assert!(row_sum_defect(&TABLEAU) < 1e-15);
    }

    #[test]
    fn weights_satisfy_quadrature_conditions() {
        let b = TABLEAU.a[6];
        assert!(quadrature_defect(b, TABLEAU.c, 5) < 1e-15);
        let b_hat: Vec<f64> = b.iter().chain([&0.0]).zip(E).map(|(b, e)| b - e).collect();
        assert!(quadrature_defect(&b_hat, TABLEAU.c, 4) < 1e-15);
        assert!(
            quadrature_defect(&b_hat, TABLEAU.c, 5) > 1e-4,
            "the embedded pair is only order 4"
        );
    }

    /// DOPRI5's fifth-order error coefficients are small by design, so the sixth-order terms
    /// still show at these steps (observed ≈ 5.6 here, 5.3 at half these steps).
    #[test]
    fn fixed_step_order_is_five() {
        let e1 = global_error_fixed(&mut Dopri5::new(2), 0.05);
        let e2 = global_error_fixed(&mut Dopri5::new(2), 0.025);
        assert_order(e1, e2, 5.0, 0.7);
    }

    #[test]
    fn dense_output_has_local_order_five() {
        let e1 = dense_error_after_one_step(&mut Dopri5::new(2), 0.2, 0.4);
        let e2 = dense_error_after_one_step(&mut Dopri5::new(2), 0.1, 0.4);
        assert_order(e1, e2, 5.0, 0.4);
    }
}
