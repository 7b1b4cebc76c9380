//! Test systems with known solutions or invariants.
#![allow(dead_code)]

use hamel_sim::{OdeSystem, SystemError};

/// `y1' = y1 cos t`, `y2' = −y2²`, `y(0) = (1, 1)`: non-autonomous and nonlinear, exact
/// solution `(exp(sin t), 1/(1 + t))`.
pub struct Sample;

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

pub fn sample_exact(t: f64) -> Vec<f64> {
    vec![t.sin().exp(), 1.0 / (1.0 + t)]
}

/// Largest componentwise difference of two states.
pub fn distance(a: &[f64], b: &[f64]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f64::max)
}

/// The Kepler problem `q'' = −q/|q|³` in the plane, state `(q1, q2, p1, p2)`, period 2π.
/// Energy `|p|²/2 − 1/|q|`; the "constraint residual" is the drift of the angular momentum.
pub struct Kepler {
    pub analytic_jacobian: bool,
    pub angular_momentum: f64,
}

impl Kepler {
    /// Initial state at perihelion for eccentricity `e` (semi-major axis 1).
    pub fn new(e: f64, analytic_jacobian: bool) -> (Self, Vec<f64>) {
        let y0 = vec![1.0 - e, 0.0, 0.0, ((1.0 + e) / (1.0 - e)).sqrt()];
        let angular_momentum = y0[0] * y0[3] - y0[1] * y0[2];
        (
            Kepler {
                analytic_jacobian,
                angular_momentum,
            },
            y0,
        )
    }
}

impl OdeSystem for Kepler {
    fn dim(&self) -> usize {
        4
    }
    fn rhs(&self, _t: f64, y: &[f64], dy: &mut [f64]) -> Result<(), SystemError> {
        let r2 = y[0] * y[0] + y[1] * y[1];
        if r2 == 0.0 {
            return Err(SystemError::new("collision: q = 0"));
        }
        let r3 = r2 * r2.sqrt();
        dy[0] = y[2];
        dy[1] = y[3];
        dy[2] = -y[0] / r3;
        dy[3] = -y[1] / r3;
        Ok(())
    }
    fn jacobian(&self, _t: f64, y: &[f64], jac: &mut [f64]) -> Option<Result<(), SystemError>> {
        if !self.analytic_jacobian {
            return None;
        }
        let r2 = y[0] * y[0] + y[1] * y[1];
        let r3 = r2 * r2.sqrt();
        let r5 = r3 * r2;
        jac.fill(0.0);
        jac[2] = 1.0; // dq1'/dp1
        jac[4 + 3] = 1.0; // dq2'/dp2
        jac[8] = -1.0 / r3 + 3.0 * y[0] * y[0] / r5;
        jac[8 + 1] = 3.0 * y[0] * y[1] / r5;
        jac[12] = 3.0 * y[1] * y[0] / r5;
        jac[12 + 1] = -1.0 / r3 + 3.0 * y[1] * y[1] / r5;
        Some(Ok(()))
    }
    fn energy(&self, _t: f64, y: &[f64]) -> Option<f64> {
        Some(0.5 * (y[2] * y[2] + y[3] * y[3]) - 1.0 / (y[0] * y[0] + y[1] * y[1]).sqrt())
    }
    fn constraint_residual(&self, _t: f64, y: &[f64]) -> Option<f64> {
        Some(y[0] * y[3] - y[1] * y[2] - self.angular_momentum)
    }
}

/// `y' = −y`, but the right-hand side refuses every `t ≥ wall`.
pub struct Wall {
    pub wall: f64,
}

impl OdeSystem for Wall {
    fn dim(&self) -> usize {
        1
    }
    fn rhs(&self, t: f64, y: &[f64], dy: &mut [f64]) -> Result<(), SystemError> {
        if t >= self.wall {
            return Err(SystemError::new(format!(
                "singular at t = {t} (wall at {})",
                self.wall
            )));
        }
        dy[0] = -y[0];
        Ok(())
    }
}

/// `y' = y²`, `y(0) = 1`: blows up at t = 1 (`y = 1/(1 − t)`).
pub struct BlowUp;

impl OdeSystem for BlowUp {
    fn dim(&self) -> usize {
        1
    }
    fn rhs(&self, _t: f64, y: &[f64], dy: &mut [f64]) -> Result<(), SystemError> {
        dy[0] = y[0] * y[0];
        Ok(())
    }
}

/// `y' = −y` until `t = 0.3`, NaN afterwards (a system that fails without saying so).
pub struct SilentNan;

impl OdeSystem for SilentNan {
    fn dim(&self) -> usize {
        1
    }
    fn rhs(&self, t: f64, y: &[f64], dy: &mut [f64]) -> Result<(), SystemError> {
        dy[0] = if t > 0.3 { f64::NAN } else { -y[0] };
        Ok(())
    }
}
