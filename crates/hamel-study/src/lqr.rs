//! The linear-quadratic regulator of a linearisation: the gain K minimising
//! ∫ (xᵀQx + uᵀRu) dt for ẋ = Ax + Bu, from the stabilising solution X of the continuous
//! algebraic Riccati equation (CARE)
//!
//! ```text
//! AᵀX + XA − XBR⁻¹BᵀX + Q = 0,    K = R⁻¹BᵀX,    u = −Kx.
//! ```
//!
//! X spans the stable invariant subspace [I; X] of the Hamiltonian H = [A −G; −Q −Aᵀ],
//! G = BR⁻¹Bᵀ. It is computed by the matrix sign function of H (Newton's iteration
//! Z ← (cZ + (cZ)⁻¹)/2 with determinantal scaling, Byers 1987): (sign H + I)[I; X] = 0 is solved
//! for X by least squares, and then refined by Newton–Kleinman steps (a Lyapunov equation
//! each, solved densely). The relative residual
//! ‖AᵀX + XA − XGX + Q‖_F / (‖AᵀX‖_F + ‖XA‖_F + ‖XGX‖_F + ‖Q‖_F) is reported, and above
//! [`RESIDUAL`] the result is an error: no gain is given that has not been checked.

use nalgebra::DMatrix;
use serde::Serialize;

/// The largest relative residual of the CARE accepted.
pub const RESIDUAL: f64 = 1e-9;

/// The sign iteration's cap (it converges quadratically; a Hamiltonian with eigenvalues on or
/// near the imaginary axis, an unstabilisable pair, makes it stall).
const SIGN_ITERATIONS: usize = 100;

/// The regulator: its gain, the Riccati solution and how well it solves the CARE.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Lqr {
    /// K (inputs × state): u = −K x.
    pub k: Vec<Vec<f64>>,
    /// X (state × state), symmetric positive semidefinite.
    pub x: Vec<Vec<f64>>,
    /// The CARE's relative residual at X (at most [`RESIDUAL`]).
    pub residual: f64,
    /// The eigenvalues of A − BK (re, im), sorted: all with negative real parts.
    pub closed_loop: Vec<[f64; 2]>,
}

/// Why no regulator was computed.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum LqrError {
    /// The matrices do not fit together.
    #[error("the LQR's matrices do not fit: {0}")]
    Sizes(String),
    /// R is not symmetric positive definite.
    #[error("the input weight R is not positive definite")]
    InputWeight,
    /// Q is not symmetric positive semidefinite.
    #[error("the state weight Q is not symmetric positive semidefinite")]
    StateWeight,
    /// The Hamiltonian has eigenvalues on the imaginary axis: (A, B) is not stabilisable or
    /// (A, Q) not detectable.
    #[error(
        "the Riccati equation has no stabilising solution: the Hamiltonian has eigenvalues on the imaginary axis (a mode that the inputs cannot move, or that Q does not weigh, is not stable)"
    )]
    NoStabilisingSolution,
    /// The solution found does not solve the equation to [`RESIDUAL`].
    #[error("the Riccati solution's relative residual is {0:.2e}, above {RESIDUAL:.0e}")]
    Residual(f64),
}

/// The LQR gain of ẋ = Ax + Bu for the weights Q (state) and R (inputs).
pub fn lqr(
    a: &DMatrix<f64>,
    b: &DMatrix<f64>,
    q: &DMatrix<f64>,
    r: &DMatrix<f64>,
) -> Result<Lqr, LqrError> {
    check(a, b, q, r)?;
    let r_inv = r.clone().cholesky().ok_or(LqrError::InputWeight)?.inverse();
    let g = b * &r_inv * b.transpose();
    let mut x = sign_solution(a, &g, q)?;
    for _ in 0..3 {
        if residual(a, &g, q, &x) <= 1e-14 {
            break;
        }
        match kleinman(a, &g, q, &x) {
            Some(next) if residual(a, &g, q, &next) < residual(a, &g, q, &x) => x = next,
            _ => break,
        }
    }
    let res = residual(a, &g, q, &x);
    if res.is_nan() || res > RESIDUAL {
        return Err(LqrError::Residual(res));
    }
    let k = &r_inv * b.transpose() * &x;
    let closed = a - b * &k;
    let mut closed_loop: Vec<[f64; 2]> = closed
        .complex_eigenvalues()
        .iter()
        .map(|z| [z.re, z.im])
        .collect();
    closed_loop.sort_by(|p, q| p[0].total_cmp(&q[0]).then(p[1].total_cmp(&q[1])));
    if closed_loop.iter().any(|z| z[0] >= 0.0) {
        return Err(LqrError::NoStabilisingSolution);
    }
    Ok(Lqr {
        k: rows(&k),
        x: rows(&x),
        residual: res,
        closed_loop,
    })
}

fn rows(m: &DMatrix<f64>) -> Vec<Vec<f64>> {
    (0..m.nrows())
        .map(|i| m.row(i).iter().copied().collect())
        .collect()
}

fn check(
    a: &DMatrix<f64>,
    b: &DMatrix<f64>,
    q: &DMatrix<f64>,
    r: &DMatrix<f64>,
) -> Result<(), LqrError> {
    let n = a.nrows();
    let m = b.ncols();
    if a.ncols() != n || b.nrows() != n || q.shape() != (n, n) || r.shape() != (m, m) || m == 0 {
        return Err(LqrError::Sizes(format!(
            "A {:?}, B {:?}, Q {:?}, R {:?}",
            a.shape(),
            b.shape(),
            q.shape(),
            r.shape()
        )));
    }
    let finite = |x: &DMatrix<f64>| x.iter().all(|v| v.is_finite());
    if !(finite(a) && finite(b) && finite(q) && finite(r)) {
        return Err(LqrError::Sizes("a value is not finite".into()));
    }
    if (r - r.transpose()).amax() > 1e-14 * r.amax() {
        return Err(LqrError::InputWeight);
    }
    let symmetric = (q - q.transpose()).amax() <= 1e-14 * q.amax().max(f64::MIN_POSITIVE);
    let semidefinite = q
        .clone()
        .symmetric_eigenvalues()
        .iter()
        .all(|&l| l >= -1e-12 * q.amax());
    if !(symmetric && semidefinite) {
        return Err(LqrError::StateWeight);
    }
    Ok(())
}

/// X from the sign of the Hamiltonian: [W₁₂; W₂₂ + I] X = −[W₁₁ + I; W₂₁], W = sign H.
fn sign_solution(
    a: &DMatrix<f64>,
    g: &DMatrix<f64>,
    q: &DMatrix<f64>,
) -> Result<DMatrix<f64>, LqrError> {
    let n = a.nrows();
    let mut h = DMatrix::zeros(2 * n, 2 * n);
    h.view_mut((0, 0), (n, n)).copy_from(a);
    h.view_mut((0, n), (n, n)).copy_from(&(-g));
    h.view_mut((n, 0), (n, n)).copy_from(&(-q));
    h.view_mut((n, n), (n, n)).copy_from(&(-a.transpose()));
    let mut z = h;
    let mut converged = false;
    for _ in 0..SIGN_ITERATIONS {
        let lu = z.clone().lu();
        let det = lu.determinant();
        let inv = lu.try_inverse().ok_or(LqrError::NoStabilisingSolution)?;
        if det == 0.0 || !det.is_finite() {
            return Err(LqrError::NoStabilisingSolution);
        }
        let c = det.abs().powf(-1.0 / (2 * n) as f64);
        let next = (&z * c + inv / c) * 0.5;
        let change = (&next - &z).norm() / next.norm();
        z = next;
        if change <= 1e-13 {
            converged = true;
            break;
        }
    }
    if !converged || z.iter().any(|v| !v.is_finite()) {
        return Err(LqrError::NoStabilisingSolution);
    }
    let id = DMatrix::<f64>::identity(n, n);
    let mut lhs = DMatrix::zeros(2 * n, n);
    lhs.view_mut((0, 0), (n, n))
        .copy_from(&z.view((0, n), (n, n)));
    lhs.view_mut((n, 0), (n, n))
        .copy_from(&(z.view((n, n), (n, n)) + &id));
    let mut rhs = DMatrix::zeros(2 * n, n);
    rhs.view_mut((0, 0), (n, n))
        .copy_from(&(-(z.view((0, 0), (n, n)) + &id)));
    rhs.view_mut((n, 0), (n, n))
        .copy_from(&(-z.view((n, 0), (n, n))));
    let x = lhs
        .svd(true, true)
        .solve(&rhs, 1e-14)
        .map_err(|_| LqrError::NoStabilisingSolution)?;
    Ok((&x + x.transpose()) * 0.5)
}

/// One Newton–Kleinman step from X: with A_c = A − GX, the X' of A_cᵀX' + X'A_c = −(Q + XGX).
fn kleinman(
    a: &DMatrix<f64>,
    g: &DMatrix<f64>,
    q: &DMatrix<f64>,
    x: &DMatrix<f64>,
) -> Option<DMatrix<f64>> {
    let ac = a - g * x;
    let rhs = -(q + x * g * x);
    let next = lyapunov(&ac, &rhs)?;
    Some((&next + next.transpose()) * 0.5)
}

/// The X of AᵀX + XA = C, by the Kronecker form (I ⊗ Aᵀ + Aᵀ ⊗ I) vec X = vec C (dense; the
/// states of a linearisation are a few dozen at most).
fn lyapunov(a: &DMatrix<f64>, c: &DMatrix<f64>) -> Option<DMatrix<f64>> {
    let n = a.nrows();
    let at = a.transpose();
    let mut m = DMatrix::zeros(n * n, n * n);
    // vec is column-major: X[(i, j)] at j*n + i; (AᵀX)[(i, j)] = Σ_k Aᵀ[(i, k)] X[(k, j)],
    // (XA)[(i, j)] = Σ_k X[(i, k)] A[(k, j)].
    for j in 0..n {
        for i in 0..n {
            let row = j * n + i;
            for k in 0..n {
                m[(row, j * n + k)] += at[(i, k)];
                m[(row, k * n + i)] += a[(k, j)];
            }
        }
    }
    let vec_c = DMatrix::from_column_slice(n * n, 1, c.as_slice());
    let v = m.lu().solve(&vec_c)?;
    Some(DMatrix::from_column_slice(n, n, v.as_slice()))
}

/// ‖AᵀX + XA − XGX + Q‖_F over the sum of its terms' norms.
pub fn residual(a: &DMatrix<f64>, g: &DMatrix<f64>, q: &DMatrix<f64>, x: &DMatrix<f64>) -> f64 {
    let (t1, t2, t3) = (a.transpose() * x, x * a, x * g * x);
    let r = &t1 + &t2 - &t3 + q;
    let scale = t1.norm() + t2.norm() + t3.norm() + q.norm();
    if scale == 0.0 { 0.0 } else { r.norm() / scale }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The double integrator ẍ = u with Q = I, R = 1: X = [[√3, 1], [1, √3]], K = [1, √3]
    /// (the classical closed form).
    #[test]
    fn the_double_integrator_has_its_closed_form() {
        let a = DMatrix::from_row_slice(2, 2, &[0.0, 1.0, 0.0, 0.0]);
        let b = DMatrix::from_row_slice(2, 1, &[0.0, 1.0]);
        let q = DMatrix::identity(2, 2);
        let r = DMatrix::identity(1, 1);
        let l = lqr(&a, &b, &q, &r).unwrap();
        let s3 = 3f64.sqrt();
        assert!(
            (l.k[0][0] - 1.0).abs() < 1e-12 && (l.k[0][1] - s3).abs() < 1e-12,
            "{:?}",
            l.k
        );
        assert!((l.x[0][0] - s3).abs() < 1e-12 && (l.x[0][1] - 1.0).abs() < 1e-12);
        assert!(l.residual <= 1e-14, "{}", l.residual);
        assert!(l.closed_loop.iter().all(|z| z[0] < 0.0));
    }

    /// An inverted pendulum on a cart (unstable open loop): the gain stabilises it, and X
    /// solves the CARE to rounding.
    #[test]
    fn an_inverted_pendulum_is_stabilised() {
        let a = DMatrix::from_row_slice(
            4,
            4,
            &[
                0.0, 1.0, 0.0, 0.0, //
                0.0, 0.0, -1.2, 0.0, //
                0.0, 0.0, 0.0, 1.0, //
                0.0, 0.0, 21.6, 0.0,
            ],
        );
        let b = DMatrix::from_row_slice(4, 1, &[0.0, 1.0, 0.0, -2.0]);
        let q = DMatrix::from_diagonal(&nalgebra::DVector::from_vec(vec![10.0, 1.0, 100.0, 1.0]));
        let r = DMatrix::identity(1, 1) * 0.1;
        let l = lqr(&a, &b, &q, &r).unwrap();
        assert!(l.residual <= 1e-12, "{}", l.residual);
        assert!(
            l.closed_loop.iter().all(|z| z[0] < -1e-3),
            "{:?}",
            l.closed_loop
        );
    }

    /// A mode no input moves and no weight sees, on the imaginary axis: an error, not a gain.
    #[test]
    fn an_unstabilisable_pair_is_an_error() {
        let a = DMatrix::from_row_slice(2, 2, &[0.0, 1.0, -1.0, 0.0]);
        let b = DMatrix::zeros(2, 1);
        let q = DMatrix::zeros(2, 2);
        let r = DMatrix::identity(1, 1);
        assert!(lqr(&a, &b, &q, &r).is_err());
        let bad_r = -DMatrix::identity(1, 1);
        assert_eq!(
            lqr(
                &a,
                &DMatrix::from_row_slice(2, 1, &[0.0, 1.0]),
                &DMatrix::identity(2, 2),
                &bad_r
            ),
            Err(LqrError::InputWeight)
        );
    }
}

/// The LQR of a linearisation ([`crate::Linearisation`]): diagonal weights by name on its
/// reduced state and its inputs, the gain, and the steady values it regulates about.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Regulator {
    /// The reduced state's components (the columns of K).
    pub state: Vec<String>,
    /// The inputs (the rows of K).
    pub inputs: Vec<String>,
    /// diag Q, in the order of `state`.
    pub state_weights: Vec<f64>,
    /// diag R, in the order of `inputs`.
    pub input_weights: Vec<f64>,
    /// The steady value x* of each state component.
    pub steady_state: Vec<f64>,
    /// The steady value u* of each input (the point's value).
    pub steady_inputs: Vec<f64>,
    /// The gain and its checks: u = u* − K (x − x*).
    #[serde(flatten)]
    pub lqr: Lqr,
}

/// Why a regulator could not be made.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum RegulatorError {
    /// The model has no inputs.
    #[error("the model has no [inputs]: there is nothing for a regulator to drive")]
    NoInputs,
    /// A weight names neither a state component nor an input.
    #[error(
        "`{name}` is neither a component of the reduced state ({state}) nor an input ({inputs})"
    )]
    UnknownWeight {
        /// The name given.
        name: String,
        /// The state's components.
        state: String,
        /// The inputs.
        inputs: String,
    },
    /// An input to drive that the model does not have.
    #[error("`{name}` is not an input of the model ({inputs})")]
    UnknownInput {
        /// The name given.
        name: String,
        /// The model's inputs.
        inputs: String,
    },
    /// A weight that is negative (a state's) or not positive (an input's).
    #[error("the weight of `{0}` must be {1}")]
    BadWeight(String, &'static str),
    /// The Riccati equation.
    #[error("{0}")]
    Lqr(#[from] LqrError),
}

impl Regulator {
    /// The LQR of `l` driving the inputs `drive` (empty: all of them), with the weights
    /// `weights` (name ↦ weight; 1 for every name not given); `defaults`: the model's
    /// parameter values, for the inputs the point does not set.
    pub fn of(
        l: &crate::Linearisation,
        drive: &[String],
        weights: &[(String, f64)],
        defaults: &indexmap::IndexMap<String, f64>,
    ) -> Result<Regulator, RegulatorError> {
        if l.inputs.is_empty() {
            return Err(RegulatorError::NoInputs);
        }
        if let Some(u) = drive.iter().find(|u| !l.inputs.contains(u)) {
            return Err(RegulatorError::UnknownInput {
                name: u.clone(),
                inputs: l.inputs.join(", "),
            });
        }
        let columns: Vec<usize> = (0..l.inputs.len())
            .filter(|&j| drive.is_empty() || drive.contains(&l.inputs[j]))
            .collect();
        let state = l.reduced_state.clone();
        let inputs: Vec<String> = columns.iter().map(|&j| l.inputs[j].clone()).collect();
        let mut state_weights = vec![1.0; state.len()];
        let mut input_weights = vec![1.0; inputs.len()];
        for (name, w) in weights {
            if let Some(i) = state.iter().position(|s| s == name) {
                if !(*w >= 0.0 && w.is_finite()) {
                    return Err(RegulatorError::BadWeight(name.clone(), "zero or positive"));
                }
                state_weights[i] = *w;
            } else if let Some(i) = inputs.iter().position(|s| s == name) {
                if !(*w > 0.0 && w.is_finite()) {
                    return Err(RegulatorError::BadWeight(name.clone(), "positive"));
                }
                input_weights[i] = *w;
            } else {
                return Err(RegulatorError::UnknownWeight {
                    name: name.clone(),
                    state: state.join(", "),
                    inputs: inputs.join(", "),
                });
            }
        }
        let (n, m) = (state.len(), inputs.len());
        let a = DMatrix::from_fn(n, n, |i, j| l.a[i][j]);
        let b = DMatrix::from_fn(n, m, |i, j| l.b[i][columns[j]]);
        let q = DMatrix::from_diagonal(&nalgebra::DVector::from_vec(state_weights.clone()));
        let r = DMatrix::from_diagonal(&nalgebra::DVector::from_vec(input_weights.clone()));
        let lqr = lqr(&a, &b, &q, &r)?;
        let steady_state = state.iter().map(|s| steady_value(l, s)).collect();
        let steady_inputs = inputs
            .iter()
            .map(|u| {
                (l.point.0.get(u).or(defaults.get(u)))
                    .copied()
                    .unwrap_or(0.0)
            })
            .collect();
        Ok(Regulator {
            state,
            inputs,
            state_weights,
            input_weights,
            steady_state,
            steady_inputs,
            lqr,
        })
    }

    /// As text: the weights, K by rows, the closed loop's eigenvalues and the residual.
    pub fn text(&self) -> String {
        use std::fmt::Write;
        let mut o = String::new();
        let diag = |names: &[String], w: &[f64]| {
            (names.iter().zip(w))
                .map(|(n, w)| format!("{n}: {w}"))
                .collect::<Vec<_>>()
                .join(", ")
        };
        let _ = writeln!(
            o,
            "LQR (∫ xᵀQx + uᵀRu dt, u = u* − K(x − x*)), Q = diag({}), R = diag({}):",
            diag(&self.state, &self.state_weights),
            diag(&self.inputs, &self.input_weights)
        );
        let _ = writeln!(o, "  x = ({})", self.state.join(", "));
        for (u, row) in self.inputs.iter().zip(&self.lqr.k) {
            let entries: Vec<String> = row.iter().map(|k| format!("{k:.6e}")).collect();
            let _ = writeln!(o, "  K[{u}] = [{}]", entries.join(", "));
        }
        let eig: Vec<String> = (self.lqr.closed_loop.iter())
            .map(|z| format!("{:.6} {:+.6}i", z[0], z[1]))
            .collect();
        let _ = writeln!(o, "  closed-loop eigenvalues: {}", eig.join(", "));
        let _ = writeln!(
            o,
            "  Riccati residual {:.1e} (relative; at most {RESIDUAL:.0e} accepted)",
            self.lqr.residual
        );
        o
    }
}

impl Regulator {
    /// The gain's name for input `u` and state component `x` in a scene block: `K_u_x`.
    pub fn gain_name(u: &str, x: &str) -> String {
        format!("K_{u}_{x}")
    }

    /// The law u = u* − K(x − x*) as a scene's `[gains]` and `[inputs]`, ready to paste into a
    /// scene of the same model with `eta = "{eta}"` (the law's eta1… are that choice's);
    /// `about` names the steady motion. Numbers are written to round-trip exactly.
    pub fn scene_block(&self, eta: &str, about: &str) -> String {
        use std::fmt::Write;
        let mut o = String::new();
        let _ = writeln!(
            o,
            "# The LQR law about the steady motion `{about}`, u = u* − K(x − x*) with x = ({}):",
            self.state.join(", ")
        );
        let _ = writeln!(
            o,
            "# paste into a scene of this model with eta = \"{eta}\" (an ensemble may vary the gains)."
        );
        let _ = writeln!(o, "[gains]");
        for (u, row) in self.inputs.iter().zip(&self.lqr.k) {
            for (x, k) in self.state.iter().zip(row) {
                let _ = writeln!(o, "{} = {k:?}", Self::gain_name(u, x));
            }
        }
        let _ = writeln!(o, "\n[inputs]");
        for (i, u) in self.inputs.iter().enumerate() {
            let terms: Vec<String> = (self.state.iter().zip(&self.steady_state))
                .map(|(x, &xs)| {
                    let dx = if xs == 0.0 {
                        x.clone()
                    } else {
                        format!("({x} - {xs:?})")
                    };
                    format!("{}*{dx}", Self::gain_name(u, x))
                })
                .collect();
            let us = self.steady_inputs[i];
            let head = if us == 0.0 {
                String::new()
            } else {
                format!("{us:?} ")
            };
            let _ = writeln!(o, "{u} = \"{head}-({})\"", terms.join(" + "));
        }
        o
    }
}

/// The steady value of a reduced state component: a coordinate's, or η_i's.
fn steady_value(l: &crate::Linearisation, name: &str) -> f64 {
    if let Some(v) = l.q.get(name) {
        return *v;
    }
    name.strip_prefix("eta")
        .and_then(|i| i.parse::<usize>().ok())
        .and_then(|i| l.eta.get(i.wrapping_sub(1)))
        .copied()
        .unwrap_or(0.0)
}
