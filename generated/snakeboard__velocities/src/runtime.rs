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
//! Everything is generic over [`Scalar`]: `f64`, [`Dual`] for exact Jacobians and [`DD`]
//! (double-double, `dd.rs`). An f64 evaluation whose error estimate ([`f64_error_estimate`]:
//! the conditioning of the solves with [Z; α] and A_Γ, and cancellation in the forcing) is
//! above [`DOUBLE_DOUBLE_ABOVE`] is repeated in double-double and rounded, so that near
//! singular configurations no more digits are lost than the problem itself is sensitive to
//! (docs/stability.md).

use std::ops::{Add, Div, Mul, Neg, Sub};

pub use crate::dd::DD;

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
    /// sine and cosine together
    fn sin_cos(self) -> (Self, Self) {
        (self.sin(), self.cos())
    }
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
    /// Whether an ill-conditioned evaluation in this type is repeated in double-double (f64
    /// only: dual numbers carry derivatives, double-double is the repeat).
    const CHECKED: bool = false;
}

impl Scalar for f64 {
    const CHECKED: bool = true;
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
    fn sin_cos(self) -> (Self, Self) {
        f64::sin_cos(self)
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
    fn sin_cos(self) -> (Self, Self) {
        let (s, c) = self.v.sin_cos();
        (self.chain(s, c), self.chain(c, -s))
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

impl Scalar for DD {
    fn constant(v: f64) -> Self {
        DD::from_f64(v)
    }
    fn value(&self) -> f64 {
        self.to_f64()
    }
    fn sin(self) -> Self {
        self.sin_cos().0
    }
    fn cos(self) -> Self {
        self.sin_cos().1
    }
    fn sin_cos(self) -> (Self, Self) {
        DD::sin_cos(self)
    }
    fn sqrt(self) -> Self {
        DD::sqrt(self)
    }
    fn exp(self) -> Self {
        DD::exp(self)
    }
    fn ln(self) -> Self {
        DD::ln(self)
    }
    fn powi(self, n: i32) -> Self {
        DD::powi(self, n)
    }
}

/// An f64 evaluation is repeated in double-double when [`f64_error_estimate`] exceeds this (16
/// units of rounding, as `hamel_derive::DOUBLE_DOUBLE_ABOVE`).
pub const DOUBLE_DOUBLE_ABOVE: f64 = 16.0 * f64::EPSILON;

/// The values of `v` as exact values of another scalar type.
pub fn widen<S: Scalar, T: Scalar, const N: usize>(v: &[S]) -> [T; N] {
    std::array::from_fn(|i| T::constant(v[i].value()))
}

/// ‖ |M⁻¹| v ‖∞ for the values of `m` (∞ when singular): with v the row sums of |M|, Skeel's
/// condition number ‖ |M⁻¹| |M| ‖∞.
fn inverse_abs_times<const N: usize>(m: &[[f64; N]; N], v: &[f64; N]) -> f64 {
    let Some(lu) = Lu::new(*m) else {
        return f64::INFINITY;
    };
    let mut sums = [0.0_f64; N];
    for j in 0..N {
        let mut e = [0.0; N];
        e[j] = 1.0;
        let col = lu.solve(&e); // column j of M⁻¹
        for i in 0..N {
            sums[i] += col[i].abs() * v[j];
        }
    }
    sums.iter().fold(0.0, |m, x| m.max(*x))
}

/// Skeel's condition number ‖ |M⁻¹| |M| ‖∞ of the values of `m` (∞ when singular).
pub fn skeel_condition<S: Scalar, const N: usize>(m: &[[S; N]; N]) -> f64 {
    let values: [[f64; N]; N] = std::array::from_fn(|i| std::array::from_fn(|j| m[i][j].value()));
    let rows: [f64; N] = std::array::from_fn(|k| values[k].iter().map(|x| x.abs()).sum());
    inverse_abs_times(&values, &rows)
}

/// The relative error of η̇ an f64 evaluation may have, to first order (as
/// `hamel_derive::f64_error_estimate`): ε·(κ_S[Z; α] + κ_S(D A_Γ D) + ‖ |A_Γ⁻¹| s ‖∞/‖η̇‖∞),
/// D = diag(A_Γ)^(−½), s the forcing's term sizes ([`Fixed::forcing_scale`]).
pub fn f64_error_estimate<S: Scalar, const L: usize, const M: usize, const G: usize>(
    out: &[S],
    r: &Fixed<S, L, G>,
) -> f64 {
    let m = m_matrix::<S, L, M, G>(out);
    let ag: [[f64; G]; G] =
        std::array::from_fn(|i| std::array::from_fn(|j| r.a_gamma[i][j].value()));
    let d: [f64; G] = std::array::from_fn(|i| ag[i][i].abs().sqrt().recip());
    let scaled: [[f64; G]; G] =
        std::array::from_fn(|i| std::array::from_fn(|j| d[i] * ag[i][j] * d[j]));
    let size = r
        .eta_dot
        .iter()
        .fold(0.0_f64, |a, x| a.max(x.value().abs()));
    let err = inverse_abs_times(&ag, &r.forcing_scale);
    let cancellation = if err == 0.0 { 0.0 } else { err / size };
    f64::EPSILON * (skeel_condition(&m) + skeel_condition(&scaled) + cancellation)
}

impl<T: Scalar, const L: usize, const G: usize> Fixed<T, L, G> {
    /// The values (rounded to f64) as values of `S`.
    pub fn narrow<S: Scalar>(self) -> Fixed<S, L, G> {
        let r = |x: T| S::constant(x.value());
        Fixed {
            eta_dot: self.eta_dot.map(r),
            eta_dot_paper: self.eta_dot_paper.map(r),
            q_dot: self.q_dot.map(r),
            a_gamma: self.a_gamma.map(|row| row.map(r)),
            forcing: self.forcing.map(r),
            energy: r(self.energy),
            forcing_scale: self.forcing_scale,
            precision: self.precision,
            f64_error_estimate: self.f64_error_estimate,
        }
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

/// LU factors with partial pivoting of an L×L matrix, on the stack.
pub struct Lu<S, const L: usize> {
    lu: [[S; L]; L],
    perm: [usize; L],
}

impl<S: Scalar, const L: usize> Lu<S, L> {
    /// Factor `m`; `None` when a pivot is zero or below 1e-14 of the largest entry.
    pub fn new(mut m: [[S; L]; L]) -> Option<Self> {
        let mut scale = 0.0_f64;
        for row in &m {
            for x in row {
                scale = scale.max(x.value().abs());
            }
        }
        if scale == 0.0 || !scale.is_finite() {
            return None;
        }
        let mut perm = [0usize; L];
        for (i, p) in perm.iter_mut().enumerate() {
            *p = i;
        }
        for k in 0..L {
            let mut p = k;
            for i in k + 1..L {
                if m[i][k].value().abs() > m[p][k].value().abs() {
                    p = i;
                }
            }
            if m[p][k].value().abs() <= 1e-14 * scale {
                return None;
            }
            m.swap(k, p);
            perm.swap(k, p);
            let pivot = m[k][k];
            let (top, below) = m.split_at_mut(k + 1);
            let pivot_row = &top[k];
            for row in below {
                let f = row[k] / pivot;
                row[k] = f;
                for (x, &t) in row[k + 1..].iter_mut().zip(&pivot_row[k + 1..]) {
                    *x = *x - f * t;
                }
            }
        }
        Some(Lu { lu: m, perm })
    }

    /// Solve M x = b.
    pub fn solve(&self, b: &[S; L]) -> [S; L] {
        let mut x = [b[0]; L];
        for i in 0..L {
            x[i] = b[self.perm[i]];
        }
        for i in 0..L {
            for j in 0..i {
                x[i] = x[i] - self.lu[i][j] * x[j];
            }
        }
        for i in (0..L).rev() {
            for j in i + 1..L {
                x[i] = x[i] - self.lu[i][j] * x[j];
            }
            x[i] = x[i] / self.lu[i][i];
        }
        x
    }
}

/// The right-hand side at one state, in fixed-size arrays (L coordinates, G = σ).
#[derive(Clone, Copy, Debug)]
pub struct Fixed<S, const L: usize, const G: usize> {
    /// η̇ from the true equations (11).
    pub eta_dot: [S; G],
    /// η̇ from the paper's equations (equal to `eta_dot` when not asked for).
    pub eta_dot_paper: [S; G],
    /// q̇ = Γη.
    pub q_dot: [S; L],
    /// A_Γ = ΓᵀAΓ.
    pub a_gamma: [[S; G]; G],
    /// F, the right side of A_Γ η̇ = F (true equations).
    pub forcing: [S; G],
    /// E = ½ q̇ᵀAq̇ − U.
    pub energy: S,
    /// |Γ|ᵀ(|∇U| + |∇_q T| + |Ȧq̇| + |AΓ̇η|), values only: the size of the terms F is summed
    /// from (for [`f64_error_estimate`]; zero for types that are not [`Scalar::CHECKED`]).
    pub forcing_scale: [f64; G],
    /// The arithmetic the values come from: an f64 evaluation is repeated in double-double
    /// when [`f64_error_estimate`] exceeds [`DOUBLE_DOUBLE_ABOVE`].
    pub precision: Precision,
    /// [`f64_error_estimate`] at this state (0 when not computed: types other than f64).
    pub f64_error_estimate: f64,
}

/// The arithmetic of a result.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Precision {
    /// IEEE double precision (or the caller's type).
    F64,
    /// Double-double (about 32 digits), rounded at the end.
    DoubleDouble,
}

impl Precision {
    /// `f64` or `double_double`, as `hamel eval` prints it.
    pub fn name(self) -> &'static str {
        match self {
            Precision::F64 => "f64",
            Precision::DoubleDouble => "double_double",
        }
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
    /// The arithmetic the values come from.
    pub precision: Precision,
    /// The estimate that decided it (see [`Fixed::f64_error_estimate`]).
    pub f64_error_estimate: f64,
}

impl<S: Copy, const L: usize, const G: usize> From<Fixed<S, L, G>> for Rhs<S> {
    fn from(f: Fixed<S, L, G>) -> Self {
        Rhs {
            eta_dot: f.eta_dot.to_vec(),
            eta_dot_paper: f.eta_dot_paper.to_vec(),
            q_dot: f.q_dot.to_vec(),
            a_gamma: f.a_gamma.iter().map(|r| r.to_vec()).collect(),
            forcing: f.forcing.to_vec(),
            energy: f.energy,
            precision: f.precision,
            f64_error_estimate: f.f64_error_estimate,
        }
    }
}

/// M = [Z; α] from the ingredients `out` (row-major blocks).
fn m_matrix<S: Scalar, const L: usize, const M: usize, const G: usize>(out: &[S]) -> [[S; L]; L] {
    let l = Layout::new(Dims {
        ell: L,
        mu: M,
        sigma: G,
    });
    let mut m = [[S::constant(0.0); L]; L];
    for (i, row) in m.iter_mut().enumerate() {
        let at = if i < G {
            l.z + i * L
        } else {
            l.alpha + (i - G) * L
        };
        row.copy_from_slice(&out[at..at + L]);
    }
    m
}

/// The structured right-hand side from the ingredients `out` (see [`Layout`]) at η, with no
/// allocation: L = ℓ, M = μ, G = σ (L = M + G). `paper`: also the paper's η̇ (needs Θ).
pub fn structured<S: Scalar, const L: usize, const M: usize, const G: usize>(
    out: &[S],
    eta: &[S],
    paper: bool,
) -> Result<Fixed<S, L, G>, EvalError> {
    let l = Layout::new(Dims {
        ell: L,
        mu: M,
        sigma: G,
    });
    let zero = S::constant(0.0);
    let lu = Lu::new(m_matrix::<S, L, M, G>(out)).ok_or_else(|| {
        EvalError("the quasi-velocity map is singular here: det[Z; α] ≈ 0".into())
    })?;
    let a = |i: usize, j: usize| out[l.a + i * L + j];
    // Γ (L×G): columns 0..G of M⁻¹; q̇ = Γη (6).
    let mut gamma = [[zero; G]; L];
    for s in 0..G {
        let mut e = [zero; L];
        e[s] = S::constant(1.0);
        let col = lu.solve(&e);
        for i in 0..L {
            gamma[i][s] = col[i];
        }
    }
    let mut qd = [zero; L];
    for i in 0..L {
        for s in 0..G {
            qd[i] = qd[i] + gamma[i][s] * eta[s];
        }
    }
    // Ṁq̇ = Σ_k ∂M/∂q_k q̇ q̇_k, Ȧq̇, and ∇_q T = ½ q̇ᵀ ∂A/∂q_k q̇.
    let mut mdot_qd = [zero; L];
    let mut adot_qd = [zero; L];
    let mut grad_t = [zero; L];
    for k in 0..L {
        let mut gt = zero;
        for i in 0..L {
            let dm_row = if i < G {
                l.dz + k * G * L + i * L
            } else {
                l.dalpha + k * M * L + (i - G) * L
            };
            let mut dmq = zero;
            let mut daq = zero;
            for j in 0..L {
                dmq = dmq + out[dm_row + j] * qd[j];
                daq = daq + out[l.da + k * L * L + i * L + j] * qd[j];
            }
            mdot_qd[i] = mdot_qd[i] + dmq * qd[k];
            adot_qd[i] = adot_qd[i] + daq * qd[k];
            gt = gt + qd[i] * daq;
        }
        grad_t[k] = gt * S::constant(0.5);
    }
    // Γ̇η = −M⁻¹Ṁq̇
    let gdot_eta = lu.solve(&mdot_qd);
    let mut aq = [zero; L];
    let mut force = [zero; L];
    let mut terms = [0.0_f64; L];
    for i in 0..L {
        let mut a_gdot = zero;
        for j in 0..L {
            a_gdot = a_gdot - a(i, j) * gdot_eta[j];
            aq[i] = aq[i] + a(i, j) * qd[j];
        }
        force[i] = out[l.grad_u + i] + grad_t[i] - adot_qd[i] - a_gdot;
        if S::CHECKED {
            terms[i] = [out[l.grad_u + i], grad_t[i], adot_qd[i], a_gdot]
                .iter()
                .map(|x| x.value().abs())
                .sum();
        }
    }
    let mut forcing_scale = [0.0_f64; G];
    for (r, fs) in forcing_scale.iter_mut().enumerate().filter(|_| S::CHECKED) {
        for i in 0..L {
            *fs += gamma[i][r].value().abs() * terms[i];
        }
    }
    let mut forcing = [zero; G];
    let mut a_gamma = [[zero; G]; G];
    for r in 0..G {
        // A Γ e_r
        let ag: [S; L] =
            core::array::from_fn(|i| (0..L).fold(zero, |x, j| x + a(i, j) * gamma[j][r]));
        for s in 0..G {
            a_gamma[s][r] = gamma.iter().zip(&ag).fold(zero, |x, (g, &v)| x + g[s] * v);
        }
        forcing[r] = gamma
            .iter()
            .zip(&force)
            .fold(zero, |x, (g, &f)| x + g[r] * f);
    }
    let ag = Lu::new(a_gamma).ok_or_else(|| EvalError("A_Γ is singular here".into()))?;
    let eta_dot = ag.solve(&forcing);
    // The paper's form: + Σ_m ν_m Γᵀ V_m q̇, ν = ΘᵀAq̇ with Θ the last M columns of M⁻¹,
    // (V_m q̇)_h = Σ_k (∂α_mh/∂q_k − ∂α_mk/∂q_h) q̇_k.
    let eta_dot_paper = if paper && M > 0 {
        let dalpha = |k: usize, m_: usize, h: usize| out[l.dalpha + k * M * L + m_ * L + h];
        let mut rhs = forcing;
        for m_ in 0..M {
            let mut e = [zero; L];
            e[G + m_] = S::constant(1.0);
            let theta = lu.solve(&e);
            let nu = theta.iter().zip(&aq).fold(zero, |x, (&t, &v)| x + t * v);
            for (h, gamma_h) in gamma.iter().enumerate() {
                let w = (0..L).fold(zero, |x, k| {
                    x + (dalpha(k, m_, h) - dalpha(h, m_, k)) * qd[k]
                });
                for (x, &g) in rhs.iter_mut().zip(gamma_h) {
                    *x = *x + nu * g * w;
                }
            }
        }
        ag.solve(&rhs)
    } else {
        eta_dot
    };
    let mut energy = zero;
    for i in 0..L {
        energy = energy + aq[i] * qd[i];
    }
    Ok(Fixed {
        eta_dot,
        eta_dot_paper,
        q_dot: qd,
        a_gamma,
        forcing,
        energy: energy * S::constant(0.5) - out[l.u],
        forcing_scale,
        precision: Precision::F64,
        f64_error_estimate: 0.0,
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

/// An error, built out of line: the failing branch of a check stays small in the hot code.
#[cold]
#[inline(never)]
pub fn cold_error(message: &str) -> EvalError {
    EvalError(message.into())
}
