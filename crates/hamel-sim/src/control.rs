//! Step-size control shared by the adaptive methods, after Hairer's dopri5.f and dop853.f
//! (E. Hairer, S. P. Nørsett, G. Wanner, "Solving Ordinary Differential Equations I", 2nd ed.,
//! Springer 1993, §II.4; Lund stabilisation: Hairer & Wanner, "Solving ODEs II", §IV.2).

use crate::system::{Evaluator, OdeSystem};

/// Scalar relative and absolute tolerances.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Tolerances {
    pub(crate) rtol: f64,
    pub(crate) atol: f64,
}

impl Tolerances {
    /// Hairer's weight `sk = atol + rtol · max(|y|, |y_new|)`.
    #[inline]
    pub(crate) fn scale(&self, y: f64, y_new: f64) -> f64 {
        self.atol + self.rtol * y.abs().max(y_new.abs())
    }

    /// Root-mean-square norm of `err` in the weights of [`Tolerances::scale`].
    #[inline]
    pub(crate) fn error_norm(
        &self,
        err: impl Iterator<Item = f64>,
        y: &[f64],
        y_new: &[f64],
    ) -> f64 {
        let sum: f64 = err
            .zip(y.iter().zip(y_new))
            .map(|(e, (&a, &b))| (e / self.scale(a, b)).powi(2))
            .sum();
        (sum / y.len() as f64).sqrt()
    }
}

/// The controller's verdict on an error estimate.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum Verdict {
    /// Keep the step; continue with the given step size.
    Accept(f64),
    /// Repeat the step with the given step size.
    Reject(f64),
}

/// Hairer's step-size controller with Lund stabilisation ("COMPUTATION OF HNEW" in
/// dopri5.f/dop853.f): `h_new = h / clamp(err^expo / err_old^beta / safe, 1/fac_max, 1/fac_min)`.
#[derive(Clone, Debug)]
pub(crate) struct Controller {
    safe: f64,
    fac_min: f64,
    fac_max: f64,
    beta: f64,
    expo: f64,
    fac_old: f64,
    h_max: f64,
}

impl Controller {
    /// `expo` is the exponent applied to the error (1/(q+1) for an error estimate of order q,
    /// minus Hairer's Lund correction); `fac_min ≤ h_new/h ≤ fac_max`.
    pub(crate) fn new(
        safe: f64,
        fac_min: f64,
        fac_max: f64,
        beta: f64,
        expo: f64,
        h_max: f64,
    ) -> Self {
        Controller {
            safe,
            fac_min,
            fac_max,
            beta,
            expo,
            fac_old: 1e-4,
            h_max,
        }
    }

    /// Factor by which the step shrinks after a failed attempt (a system error, non-finite
    /// values, a Newton failure): the largest decrease the controller allows.
    #[inline]
    pub(crate) fn shrink(&self) -> f64 {
        self.fac_min
    }

    /// The verdict on a step of size `h` with scaled error `err`; after a rejection an accepted
    /// step may not grow (Hairer's `REJECT` flag).
    #[inline]
    pub(crate) fn verdict(&self, h: f64, err: f64, after_reject: bool) -> Verdict {
        // err^(1/8) (DOP853 without Lund stabilisation) by three square roots, each
        // correctly rounded: a third of the time of `powf`, within two ulps of it.
        let fac11 = if self.expo == 0.125 {
            err.sqrt().sqrt().sqrt()
        } else {
            err.powf(self.expo)
        };
        if err <= 1.0 {
            // β = 0 (DOP853's default): no Lund stabilisation, and no power to compute.
            let lund = if self.beta == 0.0 {
                1.0
            } else {
                self.fac_old.powf(self.beta)
            };
            let fac = (fac11 / lund / self.safe).clamp(1.0 / self.fac_max, 1.0 / self.fac_min);
            let mut h_new = (h / fac).abs().min(self.h_max);
            if after_reject {
                h_new = h_new.min(h.abs());
            }
            Verdict::Accept(h_new.copysign(h))
        } else {
            Verdict::Reject(h / (fac11 / self.safe).min(1.0 / self.fac_min))
        }
    }

    /// Records the error of an accepted step (the memory of the Lund stabilisation).
    #[inline]
    pub(crate) fn accepted(&mut self, err: f64) {
        self.fac_old = err.max(1e-4);
    }
}

/// Hairer's initial step heuristic (function HINIT of dopri5.f/dop853.f) for a method of
/// order `order`: an explicit Euler step probes the second derivative, and `h` is chosen so
/// that `h^order · max(‖f0‖, ‖f''‖) = 0.01`. If the probe fails (a system error or non-finite
/// values), the first guess is returned; the step loop then shrinks it as needed.
#[allow(clippy::too_many_arguments, reason = "the inputs of Hairer's HINIT")]
pub(crate) fn initial_step<S: OdeSystem + ?Sized>(
    ev: &mut Evaluator<'_, S>,
    tol: &Tolerances,
    t0: f64,
    y0: &[f64],
    f0: &[f64],
    direction: f64,
    order: u32,
    h_max: f64,
) -> f64 {
    let weighted = |v: &[f64]| -> f64 {
        v.iter()
            .zip(y0)
            .map(|(&vi, &yi)| (vi / tol.scale(yi, yi)).powi(2))
            .sum()
    };
    let dnf = weighted(f0);
    let dny = weighted(y0);
    let h = if dnf <= 1e-10 || dny <= 1e-10 {
        1e-6
    } else {
        (dny / dnf).sqrt() * 0.01
    };
    let h = h.min(h_max).copysign(direction);

    let y1: Vec<f64> = y0.iter().zip(f0).map(|(&y, &f)| y + h * f).collect();
    let mut f1 = vec![0.0; y0.len()];
    if ev.rhs(t0 + h, &y1, &mut f1).is_err() || !f1.iter().all(|v| v.is_finite()) {
        return h;
    }
    let diff: Vec<f64> = f1.iter().zip(f0).map(|(a, b)| a - b).collect();
    let der2 = weighted(&diff).sqrt() / h.abs();
    let der12 = der2.max(dnf.sqrt());
    let h1 = if der12 <= 1e-15 {
        (h.abs() * 1e-3).max(1e-6)
    } else {
        (0.01 / der12).powf(1.0 / f64::from(order))
    };
    (100.0 * h.abs()).min(h1).min(h_max).copysign(direction)
}
