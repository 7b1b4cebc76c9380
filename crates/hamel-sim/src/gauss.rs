//! Gauss–Legendre collocation with s = 2 or 3 stages (orders 4 and 6): implicit, symmetric
//! and symplectic, so with a fixed step the energy error of a Hamiltonian system stays
//! bounded over long times instead of drifting.
//!
//! Coefficients: Hairer, Nørsett & Wanner, "Solving ODEs I", §II.7 (the Gauss methods of
//! order 4 of Hammer & Hollingsworth and of order 6 of Kuntzmann and Butcher). The stage
//! equations are solved by simplified Newton iteration with the Jacobian at the start of the
//! step, as in "Solving ODEs II", §IV.8, on the full `s·n` system (no eigen-decomposition
//! of the coefficient matrix), iterating to roundoff so the method's geometric properties
//! survive. The adaptive variant estimates the error by step doubling (Richardson,
//! "Solving ODEs I", §II.4) and propagates the two half steps, without extrapolation, which
//! would destroy the symmetry.

use nalgebra::{DMatrix, DVector, Dyn, LU};

use crate::control::{Controller, Tolerances};
use crate::step::{AdaptiveStep, FixedStep, Interpolant};
use crate::system::{Evaluator, OdeSystem, StepFailure};

/// Most Newton iterations per stage solve.
const MAX_NEWTON_ITERATIONS: usize = 20;

/// A Newton increment that no longer decreases has reached the iteration's noise floor if it
/// is at most this large in the tolerance-scaled norm (or below [`ROUNDOFF_FLOOR`] relative
/// to the state); a larger one means divergence.
const STALL_LIMIT: f64 = 1e-3;

/// Relative size of a Newton increment that is roundoff noise whatever the tolerances.
const ROUNDOFF_FLOOR: f64 = 1e4 * f64::EPSILON;

/// Nodes `c`, matrix `a` (row-major) and weights `b` of the `stages`-stage Gauss method, for
/// 2 or 3 stages.
fn butcher(stages: usize) -> Option<(Vec<f64>, Vec<f64>, Vec<f64>)> {
    match stages {
        2 => {
            let r = 3f64.sqrt() / 6.0;
            Some((
                vec![0.5 - r, 0.5 + r],
                vec![0.25, 0.25 - r, 0.25 + r, 0.25],
                vec![0.5, 0.5],
            ))
        }
        3 => {
            let r = 15f64.sqrt();
            #[rustfmt::skip]
            let a = vec![
                5.0 / 36.0,            2.0 / 9.0 - r / 15.0, 5.0 / 36.0 - r / 30.0,
                5.0 / 36.0 + r / 24.0, 2.0 / 9.0,            5.0 / 36.0 - r / 24.0,
                5.0 / 36.0 + r / 30.0, 2.0 / 9.0 + r / 15.0, 5.0 / 36.0,
            ];
            let c = vec![0.5 - r / 10.0, 0.5, 0.5 + r / 10.0];
            Some((c, a, vec![5.0 / 18.0, 4.0 / 9.0, 5.0 / 18.0]))
        }
        _ => None,
    }
}

/// What a step needs of a Gauss method: `c`, `a`, and `d = bᵀA⁻¹` in place of `b` (the new
/// state is `y + Σ d_i Z_i`, which needs no further evaluation of `f`).
struct Coefficients {
    s: usize,
    a: Vec<f64>,
    c: Vec<f64>,
    d: Vec<f64>,
}

impl Coefficients {
    fn new(stages: usize) -> Option<Self> {
        let (c, a, _) = butcher(stages)?;
        // The collocation polynomial u with u(0) = y, u(c_i) = y + Z_i ends at
        // u(1) = y + Σ_i Z_i ℓ_i(1)/c_i (ℓ_i: Lagrange basis on the nodes); for a collocation
        // method that is y + h Σ b_i f(Y_i), so d_i = ℓ_i(1)/c_i.
        let d = (0..stages)
            .map(|i| {
                let li: f64 = (0..stages)
                    .filter(|&j| j != i)
                    .map(|j| (1.0 - c[j]) / (c[i] - c[j]))
                    .product();
                li / c[i]
            })
            .collect();
        Some(Coefficients { s: stages, a, c, d })
    }

    fn order(&self) -> u32 {
        2 * self.s as u32
    }
}

/// The stage equations `Z_i = h Σ_j a_ij f(t + c_j h, y + Z_j)` of one step and their
/// simplified Newton solver.
struct Collocation {
    coef: Coefficients,
    tol: Tolerances,
    jac: Vec<f64>,
    /// LU factors of `I − h A⊗J` and the `h` they were made for.
    lu: Option<(f64, LU<f64, Dyn, Dyn>)>,
    z: Vec<f64>,
    f: Vec<f64>,
    stage: Vec<f64>,
    increment: DVector<f64>,
}

impl Collocation {
    fn new(coef: Coefficients, tol: Tolerances, n: usize) -> Self {
        let sn = coef.s * n;
        Collocation {
            coef,
            tol,
            jac: vec![0.0; n * n],
            lu: None,
            z: vec![0.0; sn],
            f: vec![0.0; sn],
            stage: vec![0.0; n],
            increment: DVector::zeros(sn),
        }
    }

    /// Evaluates the Jacobian used by the following solves at `(t, y)`, `f0 = f(t, y)`.
    fn set_jacobian<S: OdeSystem + ?Sized>(
        &mut self,
        ev: &mut Evaluator<'_, S>,
        t: f64,
        y: &[f64],
        f0: &[f64],
    ) -> Result<(), StepFailure> {
        self.lu = None;
        ev.jacobian(t, y, f0, &mut self.jac)
    }

    /// LU factors of `I − h A⊗J`, or None if the matrix is singular.
    fn factor(&self, h: f64) -> Option<(f64, LU<f64, Dyn, Dyn>)> {
        let (s, n) = (self.coef.s, self.stage.len());
        let (a, jac) = (&self.coef.a, &self.jac);
        let matrix = DMatrix::from_fn(s * n, s * n, |row, col| {
            let (i, p, j, q) = (row / n, row % n, col / n, col % n);
            let identity = if row == col { 1.0 } else { 0.0 };
            identity - h * a[i * s + j] * jac[p * n + q]
        });
        let lu = matrix.lu();
        lu.is_invertible().then_some((h, lu))
    }

    /// Solves the stage equations of the step of size `h` from `(t, y)`, starting from
    /// `Z_i = c_i h f_start` with `f_start = f(t, y)`, and writes the new state to `y_new`.
    ///
    /// The iteration runs until the scaled increment is at roundoff level or stops
    /// decreasing; it has failed if it stops decreasing (or runs out of iterations) with an
    /// increment above both [`STALL_LIMIT`] and the roundoff floor.
    fn solve<S: OdeSystem + ?Sized>(
        &mut self,
        ev: &mut Evaluator<'_, S>,
        t: f64,
        y: &[f64],
        f_start: &[f64],
        h: f64,
        y_new: &mut [f64],
    ) -> Result<(), StepFailure> {
        if !self.lu.as_ref().is_some_and(|(factored, _)| *factored == h) {
            self.lu = self.factor(h);
        }
        let Some((_, lu)) = &self.lu else {
            ev.stats.newton_failures += 1;
            return Err(StepFailure::Newton);
        };
        let (s, n) = (self.coef.s, y.len());
        let rtol = self.tol.rtol;
        let at_floor = |norm: f64| norm <= STALL_LIMIT || norm * rtol <= ROUNDOFF_FLOOR;
        for (i, zi) in self.z.chunks_exact_mut(n).enumerate() {
            for (z, &f) in zi.iter_mut().zip(f_start) {
                *z = self.coef.c[i] * h * f;
            }
        }
        let mut previous = f64::INFINITY;
        let mut converged = false;
        for _ in 0..MAX_NEWTON_ITERATIONS {
            for (i, (zi, fi)) in self
                .z
                .chunks_exact(n)
                .zip(self.f.chunks_exact_mut(n))
                .enumerate()
            {
                for ((stage, &yk), &zk) in self.stage.iter_mut().zip(y).zip(zi) {
                    *stage = yk + zk;
                }
                ev.rhs(t + self.coef.c[i] * h, &self.stage, fi)?;
            }
            for i in 0..s {
                for k in 0..n {
                    let quadrature: f64 = (0..s)
                        .map(|j| self.coef.a[i * s + j] * self.f[j * n + k])
                        .sum();
                    self.increment[i * n + k] = h * quadrature - self.z[i * n + k];
                }
            }
            lu.solve_mut(&mut self.increment);
            ev.stats.newton_iterations += 1;
            let mut sum = 0.0;
            for (m, (z, dz)) in self.z.iter_mut().zip(self.increment.iter()).enumerate() {
                *z += dz;
                let yk = y[m % n];
                sum += (dz / self.tol.scale(yk, yk)).powi(2);
            }
            let norm = (sum / (s * n) as f64).sqrt();
            if !norm.is_finite() {
                return Err(StepFailure::NonFinite);
            }
            if norm * rtol <= f64::EPSILON {
                converged = true;
                break;
            }
            if norm >= previous {
                converged = at_floor(norm);
                break;
            }
            previous = norm;
            converged = at_floor(norm);
        }
        if !converged {
            ev.stats.newton_failures += 1;
            return Err(StepFailure::Newton);
        }
        for (k, out) in y_new.iter_mut().enumerate() {
            *out = y[k]
                + (0..s)
                    .map(|i| self.coef.d[i] * self.z[i * n + k])
                    .sum::<f64>();
        }
        Ok(())
    }
}

/// A Gauss–Legendre stepper, for fixed steps ([`FixedStep`]) or step doubling
/// ([`AdaptiveStep`]). `f(t, y)` and the Jacobian are evaluated once per point the
/// integration starts a step from, and kept across rejected attempts.
pub(crate) struct Gauss {
    col: Collocation,
    f0: Vec<f64>,
    f0_valid: bool,
    jac_valid: bool,
    y_half: Vec<f64>,
    f_half: Vec<f64>,
    y_full: Vec<f64>,
}

impl Gauss {
    /// The `stages`-stage method (2 or 3) for a system of dimension `n`; `tol` scales the
    /// Newton increments (and is the error tolerance of the adaptive variant).
    pub(crate) fn new(stages: usize, n: usize, tol: Tolerances) -> Option<Self> {
        let coef = Coefficients::new(stages)?;
        Some(Gauss {
            col: Collocation::new(coef, tol, n),
            f0: vec![0.0; n],
            f0_valid: false,
            jac_valid: false,
            y_half: vec![0.0; n],
            f_half: vec![0.0; n],
            y_full: vec![0.0; n],
        })
    }

    /// Makes `f0` and the Jacobian current at `(t, y)`.
    fn prepare<S: OdeSystem + ?Sized>(
        &mut self,
        ev: &mut Evaluator<'_, S>,
        t: f64,
        y: &[f64],
    ) -> Result<(), StepFailure> {
        if !self.f0_valid {
            ev.rhs(t, y, &mut self.f0)?;
            self.f0_valid = true;
        }
        if !self.jac_valid {
            self.col.set_jacobian(ev, t, y, &self.f0)?;
            self.jac_valid = true;
        }
        Ok(())
    }

    /// Forgets `f0` and the Jacobian: the integration moved to a new point.
    fn moved(&mut self) {
        self.f0_valid = false;
        self.jac_valid = false;
    }
}

impl FixedStep for Gauss {
    fn step<S: OdeSystem + ?Sized>(
        &mut self,
        ev: &mut Evaluator<'_, S>,
        t: f64,
        y: &[f64],
        h: f64,
        y_new: &mut [f64],
    ) -> Result<(), StepFailure> {
        self.prepare(ev, t, y)?;
        self.col.solve(ev, t, y, &self.f0, h, y_new)?;
        self.moved();
        Ok(())
    }
}

impl AdaptiveStep for Gauss {
    fn order(&self) -> u32 {
        self.col.coef.order()
    }

    /// Hairer's controller without stabilisation, for an error estimate of order `p + 1`,
    /// with radau5.f's limits `0.2 ≤ h_new/h ≤ 8`; `beta` does not apply.
    fn controller(&self, _beta: Option<f64>, h_max: f64) -> Controller {
        Controller::new(0.9, 0.2, 8.0, 0.0, 1.0 / f64::from(self.order() + 1), h_max)
    }

    fn start(&mut self, f0: &[f64]) {
        self.f0.copy_from_slice(f0);
        self.f0_valid = true;
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
        self.prepare(ev, t, y)?;
        let half = 0.5 * h;
        self.col.solve(ev, t, y, &self.f0, half, &mut self.y_half)?;
        ev.rhs(t + half, &self.y_half, &mut self.f_half)?;
        self.col
            .solve(ev, t + half, &self.y_half, &self.f_half, half, y_new)?;
        self.col.solve(ev, t, y, &self.f0, h, &mut self.y_full)?;
        let richardson = 1.0 / (2f64.powi(self.order() as i32) - 1.0);
        let err = y_new
            .iter()
            .zip(&self.y_full)
            .map(|(two, one)| (two - one) * richardson);
        Ok(tol.error_norm(err, y, y_new))
    }

    fn accept<S: OdeSystem + ?Sized>(
        &mut self,
        _ev: &mut Evaluator<'_, S>,
        _t: f64,
        _y: &[f64],
        _h: f64,
        _y_new: &[f64],
        _dense: bool,
    ) -> Result<(), StepFailure> {
        self.moved();
        Ok(())
    }

    fn interpolant(&self) -> Option<&dyn Interpolant> {
        None
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::{Sample, assert_order, exact, quadrature_defect};

    #[test]
    fn coefficients_satisfy_simplifying_assumptions() {
        for s in [2, 3] {
            let (c, a, b) = butcher(s).unwrap();
            // B(2s): the weights are Gauss quadrature.
            assert!(quadrature_defect(&b, &c, 2 * s as i32) < 1e-15);
            assert!(quadrature_defect(&b, &c, 2 * s as i32 + 1) > 1e-4);
            // C(s): Σ_j a_ij c_j^(q−1) = c_i^q / q.
            for i in 0..s {
                for q in 1..=s as i32 {
                    let sum: f64 = (0..s).map(|j| a[i * s + j] * c[j].powi(q - 1)).sum();
                    assert!(
                        (sum - c[i].powi(q) / f64::from(q)).abs() < 1e-15,
                        "s={s} i={i} q={q}"
                    );
                }
            }
            // d = bᵀA⁻¹.
            let d = Coefficients::new(s).unwrap().d;
            for j in 0..s {
                let sum: f64 = (0..s).map(|i| d[i] * a[i * s + j]).sum();
                assert!((sum - b[j]).abs() < 1e-14, "s={s} j={j}");
            }
        }
        assert!(butcher(4).is_none());
    }

    /// The step-doubling estimate tracks the true local error of the two half steps.
    #[test]
    fn step_doubling_estimate_matches_local_error() {
        let tol = Tolerances {
            rtol: 1e-30,
            atol: 1.0,
        };
        for s in [2, 3] {
            let mut gauss = Gauss::new(
                s,
                2,
                Tolerances {
                    rtol: 1e-10,
                    atol: 1e-10,
                },
            )
            .unwrap();
            let mut ev = Evaluator::new(&Sample);
            let (y, mut y_new) = (vec![1.0, 1.0], vec![0.0; 2]);
            let h = 0.3;
            let estimate = gauss
                .attempt(&mut ev, &tol, 0.0, &y, h, &mut y_new)
                .unwrap();
            let e = exact(h);
            let actual =
                ((e[0] - y_new[0]).powi(2) + (e[1] - y_new[1]).powi(2)).sqrt() / 2f64.sqrt();
            let ratio = estimate / actual;
            assert!(
                (0.5..2.0).contains(&ratio),
                "s = {s}: estimate {estimate:e}, actual {actual:e}"
            );
        }
    }

    #[test]
    fn newton_with_finite_difference_jacobian_converges_to_roundoff() {
        let mut gauss = Gauss::new(
            3,
            2,
            Tolerances {
                rtol: 1e-6,
                atol: 1e-6,
            },
        )
        .unwrap();
        let mut ev = Evaluator::new(&Sample);
        let (y, mut y_new) = (vec![1.0, 1.0], vec![0.0; 2]);
        FixedStep::step(&mut gauss, &mut ev, 0.0, &y, 0.05, &mut y_new).unwrap();
        // Local error of an order-6 step of 0.05 is ~1e-13; roundoff-level convergence keeps
        // the Newton error well below that.
        let e = exact(0.05);
        assert!((e[0] - y_new[0]).abs() < 1e-12 && (e[1] - y_new[1]).abs() < 1e-12);
        assert!(
            ev.stats.newton_iterations <= 8,
            "{}",
            ev.stats.newton_iterations
        );
        assert_eq!(ev.stats.newton_failures, 0);
    }

    #[test]
    fn fixed_step_orders_are_four_and_six() {
        for (s, h, expected) in [(2, 0.1, 4.0), (3, 0.25, 6.0)] {
            let error = |h: f64| {
                let mut gauss = Gauss::new(
                    s,
                    2,
                    Tolerances {
                        rtol: 1e-10,
                        atol: 1e-10,
                    },
                )
                .unwrap();
                let mut ev = Evaluator::new(&Sample);
                let (mut y, mut y_new) = (vec![1.0, 1.0], vec![0.0; 2]);
                let steps = (1.0 / h).round() as usize;
                for k in 0..steps {
                    FixedStep::step(&mut gauss, &mut ev, k as f64 * h, &y, h, &mut y_new).unwrap();
                    std::mem::swap(&mut y, &mut y_new);
                }
                let e = exact(1.0);
                (e[0] - y[0]).abs().max((e[1] - y[1]).abs())
            };
            assert_order(error(h), error(h / 2.0), expected, 0.3);
        }
    }
}
