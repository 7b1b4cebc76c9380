//! Runtime of a generated numeric core (written by `hamel codegen`, identical in every
//! generated crate; its master copy is `crates/hamel-codegen/runtime/runtime.rs`).
//!
//! The generated `model.rs` computes the *ingredients* of the equations as straight-line code:
//! Z, α, A, U, ∇U and the exact derivatives ∂A/∂q_k, ∂Z/∂q_k, ∂α/∂q_k. This file turns them into
//! the Boltzmann–Hamel right-hand side with small dense linear algebra, exactly as hamel's
//! structured evaluator does (evaluating the expanded symbolic Q in floating point cancels
//! catastrophically; the structured form does not):
//!
//! * M = [Z; α], [Γ Θ] = M⁻¹, q̇ = Γη (6);
//! * Γ̇η = −M⁻¹Ṁq̇, Ȧ = Σ_k ∂A/∂q_k q̇_k;
//! * A_Γ η̇ = F with F = Γᵀ(∇U + ½∇_q(q̇ᵀAq̇) − Ȧq̇ − AΓ̇η): (11) with Q from (9), true form;
//! * the paper's form adds Σ_m ν_m ΓᵀV_m q̇, ν = ΘᵀAq̇.
//!
//! Everything is generic over [`Scalar`]: `f64`, and [`Dual`] for exact Jacobians.

use std::ops::{Add, Div, Mul, Neg, Sub};

/// The number types the equations are evaluated in.
pub trait Scalar:
    Copy
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<Output = Self>
    + Div<Output = Self>
    + Neg<Output = Self>
{
    /// A constant.
    fn constant(v: f64) -> Self;
    /// The value part.
    fn value(&self) -> f64;
    /// sine
    fn sin(self) -> Self;
    /// cosine
    fn cos(self) -> Self;
    /// tangent
    fn tan(self) -> Self {
        self.sin() / self.cos()
    }
    /// square root
    fn sqrt(self) -> Self;
    /// exponential
    fn exp(self) -> Self;
    /// natural logarithm
    fn ln(self) -> Self;
    /// integer power
    fn powi(self, n: i32) -> Self;
    /// real power of a positive base
    fn powf(self, e: Self) -> Self {
        (self.ln() * e).exp()
    }
}

impl Scalar for f64 {
    fn constant(v: f64) -> Self {
        v
    }
    fn value(&self) -> f64 {
        *self
    }
    fn sin(self) -> Self {
        f64::sin(self)
    }
    fn cos(self) -> Self {
        f64::cos(self)
    }
    fn tan(self) -> Self {
        f64::tan(self)
    }
    fn sqrt(self) -> Self {
        f64::sqrt(self)
    }
    fn exp(self) -> Self {
        f64::exp(self)
    }
    fn ln(self) -> Self {
        f64::ln(self)
    }
    fn powi(self, n: i32) -> Self {
        f64::powi(self, n)
    }
    fn powf(self, e: Self) -> Self {
        f64::powf(self, e)
    }
}

/// A dual number with `N` directional derivatives (forward-mode differentiation).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Dual<const N: usize> {
    /// Value.
    pub v: f64,
    /// Derivatives.
    pub d: [f64; N],
}

impl<const N: usize> Dual<N> {
    /// The variable number `i` at value `v` (derivative e_i).
    pub fn variable(v: f64, i: usize) -> Self {
        let mut d = [0.0; N];
        d[i] = 1.0;
        Dual { v, d }
    }
    fn chain(self, v: f64, dv: f64) -> Self {
        let mut d = self.d;
        for x in &mut d {
            *x *= dv;
        }
        Dual { v, d }
    }
}

impl<const N: usize> Add for Dual<N> {
    type Output = Self;
    fn add(mut self, o: Self) -> Self {
        self.v += o.v;
        for i in 0..N {
            self.d[i] += o.d[i];
        }
        self
    }
}

impl<const N: usize> Sub for Dual<N> {
    type Output = Self;
    fn sub(mut self, o: Self) -> Self {
        self.v -= o.v;
        for i in 0..N {
            self.d[i] -= o.d[i];
        }
        self
    }
}

impl<const N: usize> Mul for Dual<N> {
    type Output = Self;
    fn mul(self, o: Self) -> Self {
        let mut d = [0.0; N];
        for (i, x) in d.iter_mut().enumerate() {
            *x = self.d[i] * o.v + self.v * o.d[i];
        }
        Dual { v: self.v * o.v, d }
    }
}

impl<const N: usize> Div for Dual<N> {
    type Output = Self;
    fn div(self, o: Self) -> Self {
        let v = self.v / o.v;
        let mut d = [0.0; N];
        for (i, x) in d.iter_mut().enumerate() {
            *x = (self.d[i] - v * o.d[i]) / o.v;
        }
        Dual { v, d }
    }
}

impl<const N: usize> Neg for Dual<N> {
    type Output = Self;
    fn neg(self) -> Self {
        self.chain(-self.v, -1.0)
    }
}

impl<const N: usize> Scalar for Dual<N> {
    fn constant(v: f64) -> Self {
        Dual { v, d: [0.0; N] }
    }
    fn value(&self) -> f64 {
        self.v
    }
    fn sin(self) -> Self {
        self.chain(self.v.sin(), self.v.cos())
    }
    fn cos(self) -> Self {
        self.chain(self.v.cos(), -self.v.sin())
    }
    fn sqrt(self) -> Self {
        let r = self.v.sqrt();
        self.chain(r, 0.5 / r)
    }
    fn exp(self) -> Self {
        let e = self.v.exp();
        self.chain(e, e)
    }
    fn ln(self) -> Self {
        self.chain(self.v.ln(), 1.0 / self.v)
    }
    fn powi(self, n: i32) -> Self {
        self.chain(self.v.powi(n), n as f64 * self.v.powi(n - 1))
    }
}

/// Why an evaluation failed.
#[derive(Clone, Debug, PartialEq)]
pub struct EvalError(pub String);

impl std::fmt::Display for EvalError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for EvalError {}

/// Sizes: ℓ coordinates, μ constraints, σ = ℓ − μ quasi-velocities.
#[derive(Clone, Copy, Debug)]
pub struct Dims {
    /// ℓ
    pub ell: usize,
    /// μ
    pub mu: usize,
    /// σ
    pub sigma: usize,
}

/// Where each ingredient starts in the flat output of the generated `ingredients` function:
/// Z (σ×ℓ, row-major), α (μ×ℓ), A (ℓ×ℓ), U, ∇U (ℓ), ∂A/∂q_k (ℓ blocks ℓ×ℓ), ∂Z/∂q_k (ℓ blocks
/// σ×ℓ), ∂α/∂q_k (ℓ blocks μ×ℓ).
#[derive(Clone, Copy, Debug)]
pub struct Layout {
    /// Z
    pub z: usize,
    /// α
    pub alpha: usize,
    /// A
    pub a: usize,
    /// U
    pub u: usize,
    /// ∇U
    pub grad_u: usize,
    /// ∂A/∂q_k
    pub da: usize,
    /// ∂Z/∂q_k
    pub dz: usize,
    /// ∂α/∂q_k
    pub dalpha: usize,
    /// Total length.
    pub len: usize,
}

impl Layout {
    /// The layout for the given sizes.
    pub const fn new(d: Dims) -> Layout {
        let (l, m, s) = (d.ell, d.mu, d.sigma);
        let z = 0;
        let alpha = z + s * l;
        let a = alpha + m * l;
        let u = a + l * l;
        let grad_u = u + 1;
        let da = grad_u + l;
        let dz = da + l * l * l;
        let dalpha = dz + l * s * l;
        let len = dalpha + l * m * l;
        Layout {
            z,
            alpha,
            a,
            u,
            grad_u,
            da,
            dz,
            dalpha,
            len,
        }
    }
}

/// LU factors with partial pivoting of a small dense matrix.
pub struct Lu<S> {
    lu: Vec<Vec<S>>,
    perm: Vec<usize>,
}

impl<S: Scalar> Lu<S> {
    /// Factor `m`; `None` when a pivot is zero or below 1e-14 of the largest entry.
    pub fn new(mut m: Vec<Vec<S>>) -> Option<Lu<S>> {
        let n = m.len();
        let scale = m
            .iter()
            .flatten()
            .map(|x| x.value().abs())
            .fold(0.0, f64::max);
        if scale == 0.0 || !scale.is_finite() {
            return None;
        }
        let mut perm: Vec<usize> = (0..n).collect();
        for k in 0..n {
            let p = (k..n)
                .max_by(|&i, &j| m[i][k].value().abs().total_cmp(&m[j][k].value().abs()))
                .expect("nonempty");
            if m[p][k].value().abs() <= 1e-14 * scale {
                return None;
            }
            m.swap(k, p);
            perm.swap(k, p);
            for i in k + 1..n {
                let f = m[i][k] / m[k][k];
                m[i][k] = f;
                for j in k + 1..n {
                    let t = m[k][j];
                    m[i][j] = m[i][j] - f * t;
                }
            }
        }
        Some(Lu { lu: m, perm })
    }

    /// Solve M x = b.
    pub fn solve(&self, b: &[S]) -> Vec<S> {
        let n = self.lu.len();
        let mut x: Vec<S> = self.perm.iter().map(|&i| b[i]).collect();
        for i in 0..n {
            for j in 0..i {
                x[i] = x[i] - self.lu[i][j] * x[j];
            }
        }
        for i in (0..n).rev() {
            for j in i + 1..n {
                x[i] = x[i] - self.lu[i][j] * x[j];
            }
            x[i] = x[i] / self.lu[i][i];
        }
        x
    }
}

/// The right-hand side at one state.
#[derive(Clone, Debug)]
pub struct Rhs<S> {
    /// η̇ from the true equations (11).
    pub eta_dot: Vec<S>,
    /// η̇ from the paper's equations.
    pub eta_dot_paper: Vec<S>,
    /// q̇ = Γη.
    pub q_dot: Vec<S>,
    /// A_Γ = ΓᵀAΓ (σ×σ).
    pub a_gamma: Vec<Vec<S>>,
    /// F, the right side of A_Γ η̇ = F (true equations).
    pub forcing: Vec<S>,
    /// E = ½ q̇ᵀAq̇ − U.
    pub energy: S,
}

fn block<S: Copy>(out: &[S], at: usize, rows: usize, cols: usize) -> Vec<Vec<S>> {
    (0..rows)
        .map(|i| out[at + i * cols..at + (i + 1) * cols].to_vec())
        .collect()
}

fn dot<S: Scalar>(a: &[S], b: &[S]) -> S {
    a.iter()
        .zip(b)
        .fold(S::constant(0.0), |acc, (x, y)| acc + *x * *y)
}

fn mat_vec<S: Scalar>(m: &[Vec<S>], v: &[S]) -> Vec<S> {
    m.iter().map(|r| dot(r, v)).collect()
}

fn t_mat_vec<S: Scalar>(m: &[Vec<S>], v: &[S], cols: usize) -> Vec<S> {
    (0..cols)
        .map(|j| {
            m.iter()
                .zip(v)
                .fold(S::constant(0.0), |acc, (r, b)| acc + r[j] * *b)
        })
        .collect()
}

/// The structured right-hand side from the ingredients `out` (see [`Layout`]) at η.
pub fn structured<S: Scalar>(d: Dims, out: &[S], eta: &[S]) -> Result<Rhs<S>, EvalError> {
    let (ell, mu, sigma) = (d.ell, d.mu, d.sigma);
    let l = Layout::new(d);
    let z = block(out, l.z, sigma, ell);
    let alpha = block(out, l.alpha, mu, ell);
    let a = block(out, l.a, ell, ell);
    let m: Vec<Vec<S>> = z.into_iter().chain(alpha).collect();
    let lu = Lu::new(m).ok_or_else(|| {
        EvalError("the quasi-velocity map is singular here: det[Z; α] ≈ 0".into())
    })?;
    // [Γ Θ] = M⁻¹, column by column.
    let mut inv = vec![vec![S::constant(0.0); ell]; ell];
    for j in 0..ell {
        let e: Vec<S> = (0..ell)
            .map(|i| S::constant(if i == j { 1.0 } else { 0.0 }))
            .collect();
        for (i, x) in lu.solve(&e).into_iter().enumerate() {
            inv[i][j] = x;
        }
    }
    let gamma: Vec<Vec<S>> = inv.iter().map(|r| r[..sigma].to_vec()).collect();
    let theta: Vec<Vec<S>> = inv.iter().map(|r| r[sigma..].to_vec()).collect();
    // (6)
    let qd = mat_vec(&gamma, eta);
    let zero = S::constant(0.0);
    let mut mdot_qd = vec![zero; ell];
    let mut adot_qd = vec![zero; ell];
    let mut grad_t = vec![zero; ell];
    for k in 0..ell {
        let dz = block(out, l.dz + k * sigma * ell, sigma, ell);
        let dalpha = block(out, l.dalpha + k * mu * ell, mu, ell);
        let dm: Vec<Vec<S>> = dz.into_iter().chain(dalpha).collect();
        let da = block(out, l.da + k * ell * ell, ell, ell);
        let dmq = mat_vec(&dm, &qd);
        let daq = mat_vec(&da, &qd);
        for i in 0..ell {
            mdot_qd[i] = mdot_qd[i] + dmq[i] * qd[k];
            adot_qd[i] = adot_qd[i] + daq[i] * qd[k];
        }
        grad_t[k] = dot(&qd, &daq) * S::constant(0.5);
    }
    // Γ̇η = −M⁻¹Ṁq̇
    let gdot_eta: Vec<S> = lu.solve(&mdot_qd).into_iter().map(|x| -x).collect();
    let a_gdot = mat_vec(&a, &gdot_eta);
    let force: Vec<S> = (0..ell)
        .map(|i| out[l.grad_u + i] + grad_t[i] - adot_qd[i] - a_gdot[i])
        .collect();
    let forcing = t_mat_vec(&gamma, &force, sigma);
    let a_gamma: Vec<Vec<S>> = (0..sigma)
        .map(|r| {
            let col: Vec<S> = gamma.iter().map(|g| g[r]).collect();
            t_mat_vec(&gamma, &mat_vec(&a, &col), sigma)
        })
        .collect();
    // The paper's form: + Σ_m ν_m Γᵀ V_m q̇, (V_m q̇)_h = Σ_k (∂α_mh/∂q_k − ∂α_mk/∂q_h) q̇_k.
    let aq = mat_vec(&a, &qd);
    let nu = t_mat_vec(&theta, &aq, mu);
    let dalpha = |k: usize, m_: usize, h: usize| out[l.dalpha + k * mu * ell + m_ * ell + h];
    let mut paper = forcing.clone();
    for (m_, nu_m) in nu.iter().enumerate() {
        let w: Vec<S> = (0..ell)
            .map(|h| {
                (0..ell).fold(zero, |acc, k| {
                    acc + (dalpha(k, m_, h) - dalpha(h, m_, k)) * qd[k]
                })
            })
            .collect();
        for (i, g) in t_mat_vec(&gamma, &w, sigma).into_iter().enumerate() {
            paper[i] = paper[i] + *nu_m * g;
        }
    }
    let ag = Lu::new(a_gamma.clone()).ok_or_else(|| EvalError("A_Γ is singular here".into()))?;
    let energy = dot(&aq, &qd) * S::constant(0.5) - out[l.u];
    Ok(Rhs {
        eta_dot: ag.solve(&forcing),
        eta_dot_paper: ag.solve(&paper),
        q_dot: qd,
        a_gamma,
        forcing,
        energy,
    })
}

/// Fail on a non-finite value instead of passing NaN on.
pub fn finite(what: &str, v: &[f64]) -> Result<(), EvalError> {
    if v.iter().all(|x| x.is_finite()) {
        Ok(())
    } else {
        Err(EvalError(format!("{what} is not finite at this state")))
    }
}
