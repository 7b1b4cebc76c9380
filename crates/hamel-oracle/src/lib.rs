//! The independent oracle.
//!
//! **Job**: compute q̈ for a model at a state by the Lagrange-multiplier (d'Alembert) form
//!
//! ```text
//! [ A  αᵀ ] [ q̈ ]   [ ∇U + F − (Ȧ q̇ − ∇_q T) ]
//! [ α  0  ] [ λ ] = [ −α̇ q̇                   ]
//! ```
//!
//! solved numerically, with A, α, U and the forces F evaluated straight from the model file's
//! expressions and their derivatives taken by forward-mode automatic differentiation (dual
//! numbers). Nothing
//! here uses quasi-velocities, Γ, Q or the computer-algebra engine, so agreement with hamel's
//! Boltzmann–Hamel equations is evidence that those are right. It runs in any
//! [`Scalar`]: f64, or double-double ([`hamel_expr::DD`]) when the reference must be far more
//! accurate than what it checks.
//!
//! **Inputs**: a [`hamel_model::NumericModel`] and a state (q, q̇) with α(q)q̇ = 0.
//! **Outputs**: q̈ and the multipliers λ; projection of velocities onto the constraints
//! (Euclidean, or in the kinetic metric for initial conditions given as q̇).
#![warn(missing_docs)]

use hamel_expr::{Dual, Scalar, solve};
use hamel_model::NumericModel;
use nalgebra::{DMatrix, DVector};

/// Result of the oracle at one state.
#[derive(Clone, Debug)]
pub struct Accelerations<S = f64> {
    /// q̈.
    pub q_ddot: Vec<S>,
    /// Constraint forces' multipliers λ (one per constraint).
    pub lambda: Vec<S>,
}

/// Why the oracle has no answer at a state.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum OracleError {
    /// The model's own expressions could not be evaluated there.
    #[error(transparent)]
    Eval(#[from] hamel_expr::EvalError),
    /// [A αᵀ; α 0] is singular: no unique accelerations and multipliers.
    #[error("the Lagrange-multiplier system is singular at this state")]
    Singular,
    /// ααᵀ is singular.
    #[error("α has dependent rows at this configuration")]
    DependentConstraints,
    /// The kinetic-metric projection's system is singular.
    #[error(
        "the constraints cannot be applied here (A is singular on them, or α has dependent rows)"
    )]
    CannotProject,
}

fn duals<S: Scalar>(q: &[S], dir: &[S]) -> Vec<Dual<S>> {
    q.iter().zip(dir).map(|(v, d)| Dual::new(*v, *d)).collect()
}

fn unit<S: Scalar>(ell: usize, j: usize) -> Vec<S> {
    (0..ell)
        .map(|k| S::constant(if k == j { 1.0 } else { 0.0 }))
        .collect()
}

/// q̈ and λ at (q, q̇) by the Lagrange-multiplier form:
/// A q̈ + Ȧq̇ − ∇_q T = ∇U + F + αᵀλ, α q̈ + α̇ q̇ = 0.
pub fn accelerations<S: Scalar>(
    nm: &NumericModel<'_>,
    q: &[S],
    qd: &[S],
) -> Result<Accelerations<S>, OracleError> {
    let ell = q.len();
    let zero = || S::constant(0.0);
    let a = nm.mass_matrix::<S>(q)?;
    let alpha = nm.constraint_matrix::<S>(q)?;
    let mu = alpha.len();
    // Ȧ and α̇ along q̇.
    let a_dot = nm.mass_matrix::<Dual<S>>(&duals(q, qd))?;
    let alpha_dot = nm.constraint_matrix::<Dual<S>>(&duals(q, qd))?;
    // ∇_q T = ½ q̇ᵀ (∂A/∂q_j) q̇ and ∇U, one direction at a time.
    let mut grad_t = Vec::with_capacity(ell);
    let mut grad_u = Vec::with_capacity(ell);
    for j in 0..ell {
        let dq = duals(q, &unit::<S>(ell, j));
        let daj = nm.mass_matrix::<Dual<S>>(&dq)?;
        let mut s = zero();
        for r in 0..ell {
            for c in 0..ell {
                s = s + qd[r] * daj[r][c].d * qd[c];
            }
        }
        grad_t.push(s * S::constant(0.5));
        grad_u.push(nm.potential::<Dual<S>>(&dq)?.d);
    }
    let forces = nm.forces::<S>(q)?;
    let n = ell + mu;
    let mut m = vec![vec![zero(); n]; n];
    let mut rhs = vec![zero(); n];
    for i in 0..ell {
        let mut adq = zero();
        for j in 0..ell {
            m[i][j] = a[i][j];
            adq = adq + a_dot[i][j].d * qd[j];
        }
        rhs[i] = grad_u[i] + forces[i] - (adq - grad_t[i]);
    }
    for (r, row) in alpha.iter().enumerate() {
        let mut s = zero();
        for j in 0..ell {
            m[ell + r][j] = row[j];
            m[j][ell + r] = row[j];
            s = s + alpha_dot[r][j].d * qd[j];
        }
        rhs[ell + r] = -s;
    }
    let sol = solve(m, rhs).ok_or(OracleError::Singular)?;
    Ok(Accelerations {
        q_ddot: sol[..ell].to_vec(),
        lambda: sol[ell..].to_vec(),
    })
}

/// Project a velocity onto the constraint manifold: q̇ − α⁺αq̇ with α⁺ = αᵀ(ααᵀ)⁻¹.
pub fn project(nm: &NumericModel<'_>, q: &[f64], v: &[f64]) -> Result<Vec<f64>, OracleError> {
    let alpha = nm.constraint_matrix::<f64>(q)?;
    if alpha.is_empty() {
        return Ok(v.to_vec());
    }
    let ell = q.len();
    let al = DMatrix::from_fn(alpha.len(), ell, |i, j| alpha[i][j]);
    let vv = DVector::from_column_slice(v);
    let gram = &al * al.transpose();
    let y = gram
        .lu()
        .solve(&(&al * &vv))
        .ok_or(OracleError::DependentConstraints)?;
    let out = vv - al.transpose() * y;
    Ok(out.iter().copied().collect())
}

/// Project a velocity onto the constraints in the kinetic metric: the admissible w closest to
/// v in ½(w − v)ᵀA(w − v), i.e. the velocity just after the constraints act impulsively
/// (Gauss), from [A αᵀ; α 0][w; μ] = [A v; 0]. Unlike [`project`] it does not mix units
/// (lengths and angles), and it never raises the kinetic energy.
pub fn project_kinetic(
    nm: &NumericModel<'_>,
    q: &[f64],
    v: &[f64],
) -> Result<Vec<f64>, OracleError> {
    let alpha = nm.constraint_matrix::<f64>(q)?;
    let a = nm.mass_matrix::<f64>(q)?;
    let (ell, mu) = (q.len(), alpha.len());
    let n = ell + mu;
    let mut m = vec![vec![0.0; n]; n];
    let mut rhs = vec![0.0; n];
    for i in 0..ell {
        for j in 0..ell {
            m[i][j] = a[i][j];
            rhs[i] += a[i][j] * v[j];
        }
    }
    for (r, row) in alpha.iter().enumerate() {
        for j in 0..ell {
            m[ell + r][j] = row[j];
            m[j][ell + r] = row[j];
        }
    }
    let sol = solve(m, rhs).ok_or(OracleError::CannotProject)?;
    Ok(sol[..ell].to_vec())
}

/// Residual ‖α(q) q̇‖∞.
pub fn constraint_residual(
    nm: &NumericModel<'_>,
    q: &[f64],
    qd: &[f64],
) -> Result<f64, OracleError> {
    let alpha = nm.constraint_matrix::<f64>(q)?;
    Ok(alpha
        .iter()
        .map(|row| row.iter().zip(qd).map(|(a, v)| a * v).sum::<f64>().abs())
        .fold(0.0, f64::max))
}
