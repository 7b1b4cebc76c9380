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
//! Every row of the model's constraints enters, the rows hamel drops as dependent on the
//! others included (two wheels on one axle): α is then rank-deficient, the multipliers are not
//! unique, and the system is solved by complete pivoting to its known rank ℓ + rank α (the
//! model's μ), the free multipliers set to zero; q̈ is unique all the same.
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
    /// Constraint forces' multipliers λ (one per row of the model, dependent rows included:
    /// not unique when there are such rows).
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
    let alpha = nm.all_constraint_rows::<S>(q)?;
    let mu = alpha.len();
    // Ȧ and α̇ along q̇.
    let a_dot = nm.mass_matrix::<Dual<S>>(&duals(q, qd))?;
    let alpha_dot = nm.all_constraint_rows::<Dual<S>>(&duals(q, qd))?;
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
    let forces = nm.forces::<S>(q, qd)?;
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
    let sol = solve_kkt(nm, m, rhs).ok_or(OracleError::Singular)?;
    Ok(Accelerations {
        q_ddot: sol[..ell].to_vec(),
        lambda: sol[ell..].to_vec(),
    })
}

/// [A αᵀ; α 0] x = rhs with every row of the model's α: LU when the rows are independent, else
/// [`solve_to_rank`] to the known rank ℓ + μ.
fn solve_kkt<S: Scalar>(nm: &NumericModel<'_>, m: Vec<Vec<S>>, rhs: Vec<S>) -> Option<Vec<S>> {
    let rank = nm.model().ell() + nm.model().mu();
    if rank == rhs.len() {
        solve(m, rhs)
    } else {
        solve_to_rank(m, rhs, rank)
    }
}

/// A consistent n×n system of known rank `rank` < n by Gaussian elimination with complete
/// pivoting: `rank` pivots, the unknowns of the columns left without one set to zero. `None`
/// when a pivot is zero before `rank` (the rank is lower than known).
fn solve_to_rank<S: Scalar>(mut m: Vec<Vec<S>>, mut b: Vec<S>, rank: usize) -> Option<Vec<S>> {
    let n = b.len();
    let mut cols: Vec<usize> = (0..n).collect();
    for k in 0..rank {
        let (mut pr, mut pc, mut best) = (k, k, 0.0_f64);
        for (r, row) in m.iter().enumerate().skip(k) {
            for (c, x) in row.iter().enumerate().skip(k) {
                if x.value().abs() > best {
                    (pr, pc, best) = (r, c, x.value().abs());
                }
            }
        }
        if best == 0.0 || !best.is_finite() {
            return None;
        }
        m.swap(k, pr);
        b.swap(k, pr);
        for row in m.iter_mut() {
            row.swap(k, pc);
        }
        cols.swap(k, pc);
        for r in k + 1..n {
            let f = m[r][k] / m[k][k];
            for c in k..n {
                let x = m[k][c];
                m[r][c] = m[r][c] - f * x;
            }
            let x = b[k];
            b[r] = b[r] - f * x;
        }
    }
    let mut y = vec![S::constant(0.0); n];
    for k in (0..rank).rev() {
        let mut s = b[k];
        for c in k + 1..rank {
            s = s - m[k][c] * y[c];
        }
        y[k] = s / m[k][k];
    }
    let mut x = vec![S::constant(0.0); n];
    for (k, &c) in cols.iter().enumerate() {
        x[c] = y[k];
    }
    Some(x)
}

/// Project a velocity onto the constraint manifold: q̇ − QQᵀq̇, with the columns of Q an
/// orthonormal basis of the row space of α (Householder QR of αᵀ).
///
/// The projection is backward stable: ‖α q̇‖ stays at rounding level however nearly parallel
/// the constraints are. The normal equations (q̇ − αᵀ(ααᵀ)⁻¹αq̇), used until issue 19's
/// thousand random models, square α's condition number and left ‖αq̇‖ at 2e-6 for two nearly
/// parallel knife edges (tests/models/random/velocity_check_near_singular.toml).
///
/// The kept rows of α span the constraints wherever they have full rank; a model with
/// dependent rows is projected on all its rows instead, by the SVD truncated to its rank μ,
/// so that the projection holds where the kept rows lose rank too.
pub fn project(nm: &NumericModel<'_>, q: &[f64], v: &[f64]) -> Result<Vec<f64>, OracleError> {
    if !nm.model().dependent.is_empty() {
        return project_all_rows(nm, q, v);
    }
    let alpha = nm.constraint_matrix::<f64>(q)?;
    if alpha.is_empty() {
        return Ok(v.to_vec());
    }
    let ell = q.len();
    let alpha_t = DMatrix::from_fn(ell, alpha.len(), |j, i| alpha[i][j]);
    let qr = alpha_t.qr();
    let r = qr.r();
    let largest = r.diagonal().amax();
    if r.diagonal().iter().any(|d| d.abs() <= DEPENDENT * largest) {
        return Err(OracleError::DependentConstraints);
    }
    let basis = qr.q();
    let vv = DVector::from_column_slice(v);
    let out = &vv - &basis * (basis.transpose() * &vv);
    Ok(out.iter().copied().collect())
}

fn project_all_rows(nm: &NumericModel<'_>, q: &[f64], v: &[f64]) -> Result<Vec<f64>, OracleError> {
    // αᵀ = QRPᵀ with column pivoting reveals the rank: the first μ columns of Q span the rows
    // of α. (Not nalgebra's SVD, which loses digits on a matrix with a zero singular value,
    // dimforge/nalgebra#1172: 7e-5 on the Segway at cos ψ = 1e-4.)
    let alpha = nm.all_constraint_rows::<f64>(q)?;
    let ell = q.len();
    let alpha_t = DMatrix::from_fn(ell, alpha.len(), |j, i| alpha[i][j]);
    let basis = alpha_t
        .col_piv_qr()
        .q()
        .columns(0, nm.model().mu())
        .into_owned();
    let vv = DVector::from_column_slice(v);
    let out = &vv - &basis * (basis.transpose() * &vv);
    Ok(out.iter().copied().collect())
}

/// Relative size of a diagonal entry of R (in αᵀ = QR) below which the constraints are taken
/// as dependent.
const DEPENDENT: f64 = 1e-14;

/// Project a velocity onto the constraints in the kinetic metric: the admissible w closest to
/// v in ½(w − v)ᵀA(w − v), i.e. the velocity just after the constraints act impulsively
/// (Gauss), from [A αᵀ; α 0][w; μ] = [A v; 0]. Unlike [`project`] it does not mix units
/// (lengths and angles), and it never raises the kinetic energy.
pub fn project_kinetic(
    nm: &NumericModel<'_>,
    q: &[f64],
    v: &[f64],
) -> Result<Vec<f64>, OracleError> {
    let alpha = nm.all_constraint_rows::<f64>(q)?;
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
    let sol = solve_kkt(nm, m, rhs).ok_or(OracleError::CannotProject)?;
    Ok(sol[..ell].to_vec())
}

/// Residual ‖α(q) q̇‖∞.
pub fn constraint_residual(
    nm: &NumericModel<'_>,
    q: &[f64],
    qd: &[f64],
) -> Result<f64, OracleError> {
    let alpha = nm.all_constraint_rows::<f64>(q)?;
    Ok(alpha
        .iter()
        .map(|row| row.iter().zip(qd).map(|(a, v)| a * v).sum::<f64>().abs())
        .fold(0.0, f64::max))
}

#[cfg(test)]
mod tests {
    use super::*;
    use hamel_expr::DD;
    use hamel_model::Model;
    use indexmap::IndexMap;

    /// Two knife edges whose directions can be made nearly parallel (the chain's link turns
    /// about a skew axis).
    const NEARLY_PARALLEL: &str = r#"
name = "nearly_parallel"
title = "two nearly parallel knife edges"
coordinates = ["x", "y", "theta", "a1"]
[world]
up = "z"
[frames.base]
origin = ["x", "y", "1/10"]
rotations = [{ axis = "z", angle = "theta" }]
[bodies.base]
frame = "base"
mass = "1"
inertia = { xx = "3/10", yy = "1/10", zz = "1/10" }
[frames.link1]
parent = "base"
origin = ["-1/10", "2/10", "-3/10"]
rotations = [{ axis = ["1/3", "2/3", "2/3"], angle = "a1" }]
[bodies.link1]
frame = "link1"
mass = "1"
inertia = { xx = "4/10", yy = "1/10", zz = "4/10" }
[blades.edge]
frame = "base"
point = ["-1/10", "-2/10", 0]
direction = "x"
[blades.last]
frame = "link1"
direction = "y"
"#;

    /// ‖α⁺αq̇‖ (the distance of q̇ from α's kernel) in double-double, where the normal
    /// equations are accurate to cond(α)²·1e-32.
    fn distance_from_kernel(nm: &NumericModel<'_>, q: &[f64], qd: &[f64]) -> f64 {
        let q: Vec<DD> = q.iter().map(|&x| DD::constant(x)).collect();
        let alpha = nm.constraint_matrix::<DD>(&q).unwrap();
        let times = |row: &[DD], x: &[DD]| {
            row.iter()
                .zip(x)
                .fold(DD::constant(0.0), |s, (a, b)| s + *a * *b)
        };
        let qd: Vec<DD> = qd.iter().map(|&x| DD::constant(x)).collect();
        let gram = alpha
            .iter()
            .map(|r| alpha.iter().map(|s| times(r, s)).collect())
            .collect();
        let y = solve(gram, alpha.iter().map(|r| times(r, &qd)).collect()).unwrap();
        (0..qd.len())
            .map(|j| {
                let column: Vec<DD> = alpha.iter().map(|r| r[j]).collect();
                times(&column, &y).value().abs()
            })
            .fold(0.0, f64::max)
    }

    /// The projection lies on α's kernel to cond(α)·ε, however nearly dependent the
    /// constraints are, and projecting twice changes nothing. (The normal equations, at the
    /// first of these states, were 2e-6 off the kernel.)
    #[test]
    fn projection_is_stable_near_dependent_constraints() {
        let model = Model::from_source("nearly_parallel.toml", NEARLY_PARALLEL).unwrap();
        let nm = NumericModel::new(&model, &IndexMap::new()).unwrap();
        // A state of tests/random_models.rs's 888th model, then its a1 brought nearer the
        // value where the two edges are parallel.
        let (x, y, theta, a1) = (
            -0.727444725579725,
            1.6965599745795892,
            -0.7568783109553943,
            -2.4981134693425147,
        );
        let v = [
            1.4524242495721573,
            -1.005701923725539,
            -1.7847479859943354,
            -0.7038190802672419,
        ];
        let mut worst_condition = 0.0_f64;
        for d in [0.0, 1e-3, 1e-4, 1e-5, 1e-6, -1e-6] {
            let q = [x, y, theta, a1 + d];
            let alpha = nm.constraint_matrix::<f64>(&q).unwrap();
            let s = DMatrix::from_fn(alpha.len(), 4, |i, j| alpha[i][j]).singular_values();
            let condition = s.max() / s.min();
            worst_condition = worst_condition.max(condition);
            let qd = project(&nm, &q, &v).unwrap();
            let distance = distance_from_kernel(&nm, &q, &qd);
            assert!(
                distance <= 1e-16 * condition * 2.0,
                "a1 + {d}: q̇ is {distance:e} off α's kernel at cond(α) = {condition:e}"
            );
            let again = project(&nm, &q, &qd).unwrap();
            let moved = again
                .iter()
                .zip(&qd)
                .map(|(a, b)| (a - b).abs())
                .fold(0.0, f64::max);
            assert!(
                moved <= 1e-16 * condition * 2.0,
                "a1 + {d}: projecting again moved {moved:e}"
            );
        }
        // The states came near the dependent set (else the test shows nothing).
        assert!(
            worst_condition > 1e5,
            "cond(α) reached only {worst_condition}"
        );
    }
}
