//! Hand-written reference right-hand sides, for benchmarks.
//!
//! **Job**: give the benchmarks the practical speed limit for three bundled models — equations
//! of motion derived by hand for the same quasi-velocities as the generated cores, simplified,
//! and written as straight-line `f64` code (no allocation, no generics, no matrix library).
//! `tests/agree.rs` proves they agree with the generated cores (`hamel_models`) to 1e-12.
//!
//! **Inputs**: coordinates `q` (ℓ entries, in the model file's order), quasi-velocities `η`
//! (σ entries, the generated core's choice) and the model's parameters ([`knife::Params`] etc.,
//! the same fields and defaults as the generated `Parameters`).
//! **Outputs**: `(η̇, q̇)`: η̇ from the true Boltzmann–Hamel equations A_Γ η̇ = F(q, η)
//! (docs/derivation.md §1) and the kinematic equations q̇ = Γ(q)η.
//! **Invariants**: engine-free; no checks — at singular states (where the generated core returns
//! an error) the result is inf/NaN or meaningless.
//!
//! Method used for all three (d'Alembert projected on the η directions). The kinetic energy T
//! and potential U are the model files'; L = T + U. Where the constraints are solved for
//! dependent velocities ṙ = B(s)ṡ in terms of independent ones ṡ = η and L does not depend on r,
//! projecting d/dt ∂L/∂q̇ − ∂L/∂q = αᵀλ on the columns of Γ gives (Voronets)
//!
//! ```text
//! d/dt ∂L_c/∂ṡ_i − ∂L_c/∂s_i + Σ_a p_a Σ_j (∂B_aj/∂s_i − ∂B_ai/∂s_j) ṡ_j = 0,
//! L_c(s, ṡ) = L(s, B(s)ṡ, ṡ),   p_a = ∂L/∂ṙ_a on the constraints.
//! ```
//!
//! L_c = ½ ηᵀA_Γη + U, so its Hessian in η is exactly the A_Γ of the generated core.

/// Knife edge, `models/knife.toml`, quasi-velocities `paper` (generated core `knife__paper`).
///
/// q = (x, y, θ), η1 = cos θ ẋ + sin θ ẏ, η2 = θ̇; T = ½m(ẋ² + ẏ²) + (m l²/24)θ̇², U = 0,
/// constraint sin θ ẋ − cos θ ẏ = 0 (docs/models/knife.md).
///
/// On the constraint ṗ = η1 e, e = (cos θ, sin θ), n = (−sin θ, cos θ), so p̈ = η̇1 e + η1η2 n;
/// the d'Alembert equations projected on Γ = [e, 0; 0, 1] are e·(m p̈) = m η̇1 = 0 and
/// (m l²/12) η̇2 = 0:
///
/// ```text
/// η̇1 = 0,  η̇2 = 0,  ẋ = η1 cos θ,  ẏ = η1 sin θ,  θ̇ = η2.
/// ```
pub mod knife {
    /// Parameters of `models/knife.toml` (defaults as the generated `Parameters`).
    #[derive(Clone, Copy, Debug, PartialEq)]
    pub struct Params {
        /// `m`, mass of the bar [kg].
        pub m: f64,
        /// `l`, length of the bar [m].
        pub l: f64,
    }

    impl Default for Params {
        fn default() -> Self {
            Params { m: 0.5, l: 0.3 }
        }
    }

    /// (η̇, q̇) at (q, η). 2 multiplications + one sin_cos.
    #[inline]
    pub fn rhs(q: &[f64; 3], eta: &[f64; 2], _p: &Params) -> ([f64; 2], [f64; 3]) {
        let (s, c) = q[2].sin_cos();
        ([0.0, 0.0], [eta[0] * c, eta[0] * s, eta[1]])
    }
}

/// Bar with a blade, `models/bar_blade.toml`, quasi-velocities `paper` (generated core
/// `bar_blade__paper`).
///
/// q = (x, y, θ, φ), η1 = cos θ ẋ + sin θ ẏ (forward speed u of P_r), η2 = φ̇. With
/// M = m_r + m_f, λ1 = (m_f + m_r/2) l_r, I_f = m_f l_f²/12, λ2 = m_r l_r²/3 + m_f l_r² + I_f
/// (docs/models/bar_blade.md), writing e = e_θ, n = n_θ, w = n·ṗ, ω = θ̇:
///
/// ```text
/// T = ½M|ṗ|² + λ1 ω w + ½λ2 ω² + I_f ω φ̇ + ½I_f φ̇²,   U = 0,
/// constraints: w = 0,  l_r cos φ ω = sin φ u   ⇒  ω = k η1,  k = tan φ / l_r.
/// ```
///
/// Projection on Γ^(2) = ∂/∂φ: d/dt[I_f(ω + φ̇)] = 0, i.e. η̇2 = −ω̇.
/// Projection on Γ^(1) = (cos θ, sin θ, k, 0): with ∂T/∂ṗ = Mṗ + λ1ωn, e·d/dt(Mṗ + λ1ωn) =
/// M u̇ − λ1ω² (w ≡ 0), ∂T/∂θ̇ = λ1w + λ2ω + I_f φ̇, ∂T/∂θ = −λ1ωu:
/// M η̇1 − λ1ω² + k(λ2ω̇ + I_f η̇2 + λ1ωη1) = 0, and the λ1 terms cancel (kη1 = ω). With
/// J = λ2 − I_f = l_r²(m_r/3 + m_f) and ω̇ = k η̇1 + c, c = η1η2(1 + tan²φ)/l_r:
///
/// ```text
/// D = M + J k²,   η̇1 = −J k c / D,   η̇2 = −ω̇ = −M c / D,
/// ẋ = η1 cos θ,  ẏ = η1 sin θ,  θ̇ = k η1,  φ̇ = η2.
/// ```
pub mod bar_blade {
    /// Parameters of `models/bar_blade.toml` (defaults as the generated `Parameters`).
    #[derive(Clone, Copy, Debug, PartialEq)]
    pub struct Params {
        /// `m_r`, mass of the rear bar [kg].
        pub m_r: f64,
        /// `l_r`, length of the rear bar [m].
        pub l_r: f64,
        /// `m_f`, mass of the front blade bar [kg].
        pub m_f: f64,
        /// `l_f`, length of the front blade bar [m] (enters only through I_f, which cancels).
        pub l_f: f64,
    }

    impl Default for Params {
        fn default() -> Self {
            Params {
                m_r: 2.0,
                l_r: 1.0,
                m_f: 0.5,
                l_f: 0.3,
            }
        }
    }

    /// (η̇, q̇) at (q, η). 22 flops (2 of them divisions) + one sin_cos and one tan.
    #[inline]
    pub fn rhs(q: &[f64; 4], eta: &[f64; 2], p: &Params) -> ([f64; 2], [f64; 4]) {
        let (s, c) = q[2].sin_cos();
        let t = q[3].tan();
        let (e1, e2) = (eta[0], eta[1]);
        let inv_l = 1.0 / p.l_r;
        let mass = p.m_r + p.m_f;
        let j = p.l_r * p.l_r * (p.m_r * (1.0 / 3.0) + p.m_f);
        let k = t * inv_l;
        let cc = e1 * e2 * (1.0 + t * t) * inv_l;
        let w = cc / (mass + j * k * k);
        ([-j * k * w, -mass * w], [e1 * c, e1 * s, k * e1, e2])
    }
}

/// Unicycle with rider, `models/unicycle_rider.toml`, quasi-velocities `velocities` (generated
/// core `unicycle_rider__velocities`).
///
/// q = (x_C, y_C, φ, ψ, θ, θ1), η = (φ̇, ψ̇, θ̇, θ̇1); constraints ẋ_C = R cos φ ψ̇,
/// ẏ_C = R sin φ ψ̇, i.e. v1 = e1·Ċ = Rψ̇, v2 = e2·Ċ = 0. T (the file's, written in v1, v2 and
/// free of x_C, y_C, φ, ψ) and U = −κ1 g cos θ + m_r g ρ cos θ1 as in docs/models/unicycle_rider.md,
/// with I_d = m_d R²/2, h = ρ1 + ρ2, m = m_d + m_f + m_r, κ1 = m_d R + m_f ρ1 + m_r h,
/// κ2 = m_d R² + m_f ρ1² + m_r h², S = h sin θ + ρ sin θ1.
///
/// Substituting the constraints (the rider's two velocity components combine to
/// h²θ̇² + ρ²θ̇1² + 2hρ cos(θ + θ1)θ̇θ̇1), L_c = ½ηᵀA_Γη + U with A_Γ = diag(B, C):
///
/// ```text
/// b11 = I_d/2 + a sin²θ + m_r S²,  a = m_d R² + I_d/2 + m_f ρ1²,
/// b12 = −(Rκ1 + I_d) sin θ − R m_r ρ sin θ1,  b22 = mR² + I_d,
/// b33 = κ2 + I_d/2,  b34 = m_r hρ cos(θ + θ1),  b44 = m_r ρ².
/// ```
///
/// Voronets term (B_x = (0, R cos φ, 0, 0), B_y = (0, R sin φ, 0, 0)): +Rψ̇ p2 in the φ equation,
/// −Rφ̇ p2 in the ψ equation, where p2 = e2·∂T/∂Ċ = κ1 cos θ θ̇ + m_r ρ cos θ1 θ̇1 is the lateral
/// momentum. With β1 = ½∂b11/∂θ = cos θ(a sin θ + m_r h S), β2 = ½∂b11/∂θ1 = m_r ρ cos θ1 S,
/// ḃ12 = −(Rp2 + I_d cos θ θ̇) and σ = m_r hρ sin(θ + θ1):
///
/// ```text
/// b11 η̇1 + b12 η̇2 = −2(β1η3 + β2η4)η1 + I_d cos θ η2η3              (φ)
/// b12 η̇1 + b22 η̇2 = η1(2R p2 + I_d cos θ η3)                          (ψ)
/// b33 η̇3 + b34 η̇4 = σ η4² + β1η1² − (Rκ1 + I_d) cos θ η1η2 + κ1 g sin θ   (θ)
/// b34 η̇3 + b44 η̇4 = σ η3² + β2η1² − R m_r ρ cos θ1 η1η2 − m_r gρ sin θ1 (θ1)
/// ẋ_C = R cos φ η2,  ẏ_C = R sin φ η2,  (φ̇, ψ̇, θ̇, θ̇1) = η.
/// ```
///
/// The two 2×2 blocks are solved by Cramer's rule; the lower determinant is written without
/// cancellation, b33 b44 − b34² = m_r ρ²(m_d R² + m_f ρ1² + I_d/2 + m_r h² sin²(θ + θ1)).
pub mod unicycle_rider {
    /// Parameters of `models/unicycle_rider.toml` (defaults as the generated `Parameters`).
    #[allow(non_snake_case)]
    #[derive(Clone, Copy, Debug, PartialEq)]
    pub struct Params {
        /// `R`, disk radius [m].
        pub R: f64,
        /// `m_d`, disk mass [kg].
        pub m_d: f64,
        /// `m_f`, frame point mass [kg].
        pub m_f: f64,
        /// `rho1`, distance of the frame point from C [m].
        pub rho1: f64,
        /// `rho2`, distance of the pivot beyond the frame point [m].
        pub rho2: f64,
        /// `m_r`, rider point mass [kg].
        pub m_r: f64,
        /// `rho`, pendulum length [m].
        pub rho: f64,
        /// `g`, gravitational acceleration [m/s²].
        pub g: f64,
    }

    impl Default for Params {
        fn default() -> Self {
            Params {
                R: 0.25,
                m_d: 2.5,
                m_f: 1.5,
                rho1: 0.6,
                rho2: 0.3,
                m_r: 60.0,
                rho: 0.4,
                g: 9.81,
            }
        }
    }

    /// (η̇, q̇) at (q, η). About 125 flops (2 divisions; about 30 of them on parameters only,
    /// which the compiler hoists when `rhs` is inlined in a loop with fixed parameters) + three
    /// sin_cos.
    #[inline]
    pub fn rhs(q: &[f64; 6], eta: &[f64; 4], p: &Params) -> ([f64; 4], [f64; 6]) {
        let (sf, cf) = q[2].sin_cos();
        let (st, ct) = q[4].sin_cos();
        let (s1, c1) = q[5].sin_cos();
        let [e1, e2, e3, e4] = *eta;
        let r = p.R;

        // parameter combinations
        let mdr2 = p.m_d * r * r;
        let id = 0.5 * mdr2;
        let id2 = 0.5 * id;
        let h = p.rho1 + p.rho2;
        let mrr = p.m_r * p.rho;
        let mrh = p.m_r * h;
        let k1 = p.m_d * r + p.m_f * p.rho1 + mrh;
        let mf_r1sq = p.m_f * p.rho1 * p.rho1;
        let a = mdr2 + id2 + mf_r1sq;
        let k2 = mdr2 + mf_r1sq + mrh * h;
        let rk1_id = r * k1 + id;
        let rmrr = r * mrr;
        let mrhr = mrh * p.rho;
        let c0 = mdr2 + mf_r1sq + id2;

        // A_Γ
        let big_s = h * st + p.rho * s1;
        let b11 = id2 + a * st * st + p.m_r * big_s * big_s;
        let b12 = -rk1_id * st - rmrr * s1;
        let b22 = (p.m_d + p.m_f + p.m_r) * r * r + id;
        let b33 = k2 + id2;
        let b34 = mrhr * (ct * c1 - st * s1);
        let b44 = mrr * p.rho;

        // forcing
        let beta1 = ct * (a * st + mrh * big_s);
        let mrr_c1 = mrr * c1;
        let beta2 = mrr_c1 * big_s;
        let sp = st * c1 + ct * s1;
        let sig = mrhr * sp;
        let id_ct_e3 = id * ct * e3;
        let p2 = k1 * ct * e3 + mrr_c1 * e4;
        let e12 = e1 * e2;
        let e11 = e1 * e1;
        let f1 = -2.0 * (beta1 * e3 + beta2 * e4) * e1 + id_ct_e3 * e2;
        let f2 = e1 * (2.0 * r * p2 + id_ct_e3);
        let f3 = sig * e4 * e4 + beta1 * e11 - rk1_id * ct * e12 + k1 * p.g * st;
        let f4 = sig * e3 * e3 + beta2 * e11 - r * mrr_c1 * e12 - mrr * p.g * s1;

        // Cramer on the two 2×2 blocks
        let inv_u = 1.0 / (b11 * b22 - b12 * b12);
        let inv_l = 1.0 / (b44 * (c0 + mrh * h * sp * sp));
        (
            [
                (b22 * f1 - b12 * f2) * inv_u,
                (b11 * f2 - b12 * f1) * inv_u,
                (b44 * f3 - b34 * f4) * inv_l,
                (b33 * f4 - b34 * f3) * inv_l,
            ],
            [r * cf * e2, r * sf * e2, e1, e2, e3, e4],
        )
    }
}
