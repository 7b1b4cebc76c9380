//! The structured Boltzmann–Hamel right-hand side, from the ingredients Z, α, A, U, ∇U and the
//! exact derivatives ∂A/∂q_k, ∂Z/∂q_k, ∂α/∂q_k (laid out as [`Layout`] says), with small dense
//! linear algebra in caller-owned storage ([`Structured`]):
//!
//! * M = [Z; α], [Γ Θ] = M⁻¹, q̇ = Γη (6); when α has rows that depend on its μ independent
//!   ones ([`Dims::dependent`]), M has more rows than columns and is factored on ℓ rows
//!   that are independent where it is evaluated (see [`select`]): Γ and the true equations do
//!   not depend on which;
//! * Γ̇η = −M⁻¹Ṁq̇ (from M[Γ Θ] = I), Ȧ = Σ_k ∂A/∂q_k q̇_k;
//! * A_Γ η̇ = F with F = Γᵀ(∇U + F(q, q̇) + ½∇_q(q̇ᵀAq̇) − Ȧq̇ − AΓ̇η): (11) with Q from (9),
//!   true form, the velocity-dependent forces F(q, q̇) evaluated by the caller at q̇ = Γη
//!   ([`Structured::evaluate_with`]);
//! * the paper's form adds Σ_m ν_m ΓᵀV_m q̇, ν = ΘᵀAq̇, (V_m q̇)_h = Σ_k (∂α_mh/∂q_k −
//!   ∂α_mk/∂q_h) q̇_k.
//!
//! Evaluating the expanded symbolic Q in floating point cancels catastrophically; this form
//! does not. [`Structured::f64_error_estimate`] says when an f64 evaluation should be repeated
//! in double-double ([`DOUBLE_DOUBLE_ABOVE`]).

use crate::lu::{self, EVALUATOR_PIVOT, Pivot};
use crate::scalar::Scalar;

/// Sizes: ℓ coordinates, μ constraints (the rank of α), σ = ℓ − μ quasi-velocities, and the
/// rows of α beyond μ that depend on the others.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Dims {
    /// ℓ
    pub ell: usize,
    /// μ
    pub mu: usize,
    /// σ
    pub sigma: usize,
    /// Rows of α after its μ independent ones, each a combination of them (two wheels on one
    /// axle): 0 for most models.
    pub dependent: usize,
}

/// Where each ingredient starts in the flat output of an ingredients evaluation: Z (σ×ℓ,
/// row-major), α (ρ×ℓ with ρ = μ + dependent rows), A (ℓ×ℓ), U, ∇U (ℓ), ∂A/∂q_k (ℓ blocks
/// ℓ×ℓ), ∂Z/∂q_k (ℓ blocks σ×ℓ), ∂α/∂q_k (ℓ blocks ρ×ℓ).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
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
        let (l, m, s) = (d.ell, d.rho(), d.sigma);
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

    /// Where M = [Z; α] lies in the ingredients, row-major: α's rows follow Z's, so M is
    /// one contiguous (ℓ + dependent)×ℓ block.
    pub const fn m(&self, d: Dims) -> std::ops::Range<usize> {
        self.z..self.z + d.m_rows() * d.ell
    }

    /// Where row `i` of ∂M/∂q_k = [∂Z/∂q_k; ∂α/∂q_k] starts in the ingredients.
    pub const fn dm_row(&self, d: Dims, k: usize, i: usize) -> usize {
        let (l, m, g) = (d.ell, d.rho(), d.sigma);
        if i < g {
            self.dz + k * g * l + i * l
        } else {
            self.dalpha + k * m * l + (i - g) * l
        }
    }
}

impl Dims {
    /// Sizes without dependent rows.
    pub const fn new(ell: usize, mu: usize, sigma: usize) -> Dims {
        Dims {
            ell,
            mu,
            sigma,
            dependent: 0,
        }
    }

    /// ρ = μ + dependent: the rows of α.
    pub const fn rho(self) -> usize {
        self.mu + self.dependent
    }

    /// The rows of M = [Z; α]: ℓ + dependent.
    pub const fn m_rows(self) -> usize {
        self.ell + self.dependent
    }

    /// Scalars of storage a [`Structured`] needs: the results (η̇, the paper's η̇, q̇, A_Γ, F,
    /// the energy, Γ) and the scratch of the evaluation.
    pub const fn scalars(self) -> usize {
        part(self, PARTS - 1).end
    }

    /// Indices of storage a [`Structured`] needs (the pivots of [Z; α] and of A_Γ).
    pub const fn indices(self) -> usize {
        self.m_rows() + self.sigma
    }

    /// f64 of storage a [`Structured`] needs (the term sizes of the forcing, and the
    /// conditioning estimate's matrices).
    pub const fn reals(self) -> usize {
        let l = self.ell;
        l + self.sigma + l * l + 4 * l
    }
}

/// The parts of the scalar storage, by index, in the order [`Parts::carve`] lays them out:
/// the results (read by the accessors of [`Structured`]), then the scratch of an evaluation.
const ETA_DOT: usize = 0;
const ETA_DOT_PAPER: usize = 1;
const Q_DOT: usize = 2;
const A_GAMMA: usize = 3;
const FORCING: usize = 4;
const ENERGY: usize = 5;
const GAMMA: usize = 6;
const PARTS: usize = 18;

/// The lengths of the parts: η̇, the paper's η̇, q̇, A_Γ, F, E, Γ; then the scratch M's factors,
/// A_Γ's factors, Ṁq̇, Ȧq̇, ∇_qT, Γ̇η, Aq̇, the ℓ-terms of F, AΓ̇η, a column, a solve's
/// temporary.
const fn part_lengths(d: Dims) -> [usize; PARTS] {
    let (l, g, r) = (d.ell, d.sigma, d.m_rows());
    [
        g,
        g,
        l,
        g * g,
        g,
        1,
        l * g,
        r * l,
        g * g,
        r,
        l,
        l,
        r,
        l,
        l,
        l,
        r,
        l,
    ]
}

/// Where part `k` lies in the scalar storage.
const fn part(d: Dims, k: usize) -> std::ops::Range<usize> {
    let len = part_lengths(d);
    let (mut start, mut i) = (0, 0);
    while i < k {
        start += len[i];
        i += 1;
    }
    start..start + len[k]
}

/// An f64 evaluation is repeated in double-double when [`Structured::f64_error_estimate`]
/// exceeds this: 16 units of rounding. Solving with [Z; α] or with the Gram matrix
/// A_Γ = ΓᵀAΓ in f64 can lose far more digits than the problem itself is sensitive to (A_Γ
/// squares the conditioning of the kinetic metric on the constraints: the flat rolling disk,
/// docs/stability.md); double-double does not, there.
pub const DOUBLE_DOUBLE_ABOVE: f64 = 16.0 * f64::EPSILON;

/// Why a structured evaluation failed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Failure {
    /// [Z; α] is numerically singular (a pivot below 1e-14 of its largest entry).
    QuasiVelocityMap,
    /// A_Γ is numerically singular.
    AGamma,
    /// Fewer ingredients or quasi-velocities than the sizes say.
    Inputs,
    /// Storage smaller than the sizes need, or sizes with ℓ ≠ μ + σ.
    Storage,
    /// The forces F(q, q̇) could not be evaluated at q̇ = Γη (a damper whose two points meet).
    Forces,
}

impl std::fmt::Display for Failure {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Failure::QuasiVelocityMap => "the quasi-velocity map is singular here: det[Z; α] ≈ 0",
            Failure::AGamma => "A_Γ is singular here",
            Failure::Inputs => "structured evaluation: too few inputs",
            Failure::Storage => "structured evaluation: storage too small for the sizes",
            Failure::Forces => "the forces F(q, q̇) cannot be evaluated here",
        })
    }
}

/// The storage of one structured evaluation, owned by the caller (stack arrays in generated
/// code, vectors in the interpreter: see [`Buffers`]); the results are read from it after
/// [`Structured::evaluate`].
pub struct Structured<'a, S> {
    d: Dims,
    layout: Layout,
    pivot: Pivot,
    s: &'a mut [S],
    idx: &'a mut [usize],
    re: &'a mut [f64],
}

/// The pieces of the scalar storage, in order: results, then scratch.
struct Parts<'b, S> {
    eta_dot: &'b mut [S],
    eta_dot_paper: &'b mut [S],
    q_dot: &'b mut [S],
    a_gamma: &'b mut [S],
    forcing: &'b mut [S],
    energy: &'b mut [S],
    gamma: &'b mut [S],
    m: &'b mut [S],
    ag_lu: &'b mut [S],
    mdot_qd: &'b mut [S],
    adot_qd: &'b mut [S],
    grad_t: &'b mut [S],
    gdot: &'b mut [S],
    aq: &'b mut [S],
    force: &'b mut [S],
    a_gdot: &'b mut [S],
    col: &'b mut [S],
    tmp: &'b mut [S],
}

/// The first `n` entries of `buf`, leaving the rest in `buf`.
#[inline(always)]
fn take<'b, T>(buf: &mut &'b mut [T], n: usize) -> &'b mut [T] {
    let (head, tail) = std::mem::take(buf).split_at_mut(n);
    *buf = tail;
    head
}

impl<'b, S> Parts<'b, S> {
    #[inline(always)]
    fn carve(d: Dims, mut s: &'b mut [S]) -> Parts<'b, S> {
        let len = part_lengths(d);
        let mut k = 0;
        let mut next = || {
            k += 1;
            take(&mut s, len[k - 1])
        };
        // fields are initialised in the order written: the order of `part_lengths`
        Parts {
            eta_dot: next(),
            eta_dot_paper: next(),
            q_dot: next(),
            a_gamma: next(),
            forcing: next(),
            energy: next(),
            gamma: next(),
            m: next(),
            ag_lu: next(),
            mdot_qd: next(),
            adot_qd: next(),
            grad_t: next(),
            gdot: next(),
            aq: next(),
            force: next(),
            a_gdot: next(),
            col: next(),
            tmp: next(),
        }
    }
}

impl<'a, S: Scalar> Structured<'a, S> {
    /// Storage for sizes `d`: `s`, `idx` and `re` at least [`Dims::scalars`],
    /// [`Dims::indices`] and [`Dims::reals`] long ([`Failure::Storage`] otherwise).
    #[inline(always)]
    pub fn new(
        d: Dims,
        s: &'a mut [S],
        idx: &'a mut [usize],
        re: &'a mut [f64],
    ) -> Result<Self, Failure> {
        if d.ell != d.mu + d.sigma
            || s.len() < d.scalars()
            || idx.len() < d.indices()
            || re.len() < d.reals()
        {
            return Err(Failure::Storage);
        }
        Ok(Structured {
            d,
            layout: Layout::new(d),
            pivot: EVALUATOR_PIVOT,
            s,
            idx,
            re,
        })
    }

    /// When a pivot of [Z; α] or A_Γ counts as zero (default [`EVALUATOR_PIVOT`]: a
    /// numerically singular matrix is an error). [`Pivot::Exact`] solves whatever is not
    /// exactly singular, for callers that check the conditioning themselves.
    pub fn with_pivot(mut self, pivot: Pivot) -> Self {
        self.pivot = pivot;
        self
    }

    /// The sizes.
    pub fn dims(&self) -> Dims {
        self.d
    }

    /// Evaluate at η from the ingredients `out` (see [`Layout`]). `paper`: also the paper's η̇
    /// (otherwise it equals η̇). Errors where [Z; α] or A_Γ is numerically singular.
    #[inline(always)]
    pub fn evaluate(&mut self, out: &[S], eta: &[S], paper: bool) -> Result<(), Failure> {
        self.evaluate_with(out, eta, paper, |_, _| true)
    }

    /// [`Structured::evaluate`] for forces that depend on the velocities: `forces(q̇, f)`
    /// writes F(q, q̇) into `f` (ℓ entries, zero on entry) at q̇ = Γη, and F is added to ∇U in
    /// (11); `false` from it is [`Failure::Forces`]. The ingredients' ∇U must then not hold F.
    #[inline(always)]
    pub fn evaluate_with(
        &mut self,
        out: &[S],
        eta: &[S],
        paper: bool,
        forces: impl FnOnce(&[S], &mut [S]) -> bool,
    ) -> Result<(), Failure> {
        let (d, lay) = (self.d, self.layout);
        if out.len() < lay.len || eta.len() < d.sigma {
            return Err(Failure::Inputs);
        }
        let mut p = Parts::carve(d, self.s);
        let (perm_m, perm_g) = self.idx.split_at_mut(d.m_rows());
        let (terms, rest) = self.re.split_at_mut(d.ell);
        let forcing_scale = &mut rest[..d.sigma];
        gamma_and_velocities(d, lay, out, eta, &mut p, perm_m, self.pivot)?;
        p.force.fill(S::constant(0.0));
        if !forces(p.q_dot, p.force) {
            return Err(Failure::Forces);
        }
        forcing(d, lay, out, &mut p, perm_m, terms, forcing_scale);
        a_gamma(d, lay, out, &mut p);
        p.ag_lu.copy_from_slice(p.a_gamma);
        if !lu::factor(d.sigma, p.ag_lu, perm_g, self.pivot) {
            return Err(Failure::AGamma);
        }
        p.eta_dot.copy_from_slice(p.forcing);
        lu::solve(d.sigma, p.ag_lu, perm_g, p.eta_dot, p.tmp);
        if paper && d.rho() > 0 {
            paper_form(d, lay, out, &mut p, perm_m, perm_g);
        } else {
            p.eta_dot_paper.copy_from_slice(p.eta_dot);
        }
        let mut energy = S::constant(0.0);
        for i in 0..d.ell {
            energy = energy + p.aq[i] * p.q_dot[i];
        }
        p.energy[0] = energy * S::constant(0.5) - out[lay.u];
        Ok(())
    }

    /// η̇ from the true equations (11).
    pub fn eta_dot(&self) -> &[S] {
        &self.s[part(self.d, ETA_DOT)]
    }

    /// η̇ from the paper's equations (equal to [`Structured::eta_dot`] when not asked for).
    pub fn eta_dot_paper(&self) -> &[S] {
        &self.s[part(self.d, ETA_DOT_PAPER)]
    }

    /// q̇ = Γη (6).
    pub fn q_dot(&self) -> &[S] {
        &self.s[part(self.d, Q_DOT)]
    }

    /// A_Γ = ΓᵀAΓ, σ×σ row-major.
    pub fn a_gamma(&self) -> &[S] {
        &self.s[part(self.d, A_GAMMA)]
    }

    /// F, the right side of A_Γ η̇ = F (true equations).
    pub fn forcing(&self) -> &[S] {
        &self.s[part(self.d, FORCING)]
    }

    /// E = ½ q̇ᵀAq̇ − U.
    pub fn energy(&self) -> S {
        self.s[part(self.d, ENERGY).start]
    }

    /// Γ, ℓ×σ row-major.
    pub fn gamma(&self) -> &[S] {
        &self.s[part(self.d, GAMMA)]
    }

    /// The generalised force of the constraints at the state last evaluated and their
    /// multipliers. R = AΓη̇ + AΓ̇η − (∇U + F + ∇_qT − Ȧq̇) into `r` (ℓ entries), so that the
    /// Lagrange form reads A q̈ + Ȧq̇ − ∇_qT = ∇U + F + R with q̈ = Γη̇ + Γ̇η; and y with
    /// [Z; α]ᵀ y = R on the ℓ rows the factorisation selected into `y` ([`Dims::m_rows`]
    /// entries, by row of [Z; α]; the rows not selected 0). Γᵀ R = 0 is (11), so the Z entries
    /// of y vanish (to rounding) and λ = y[σ..] are the multipliers, R = αᵀλ: for a row
    /// written as the velocity of a point along a direction, the force there along it. With
    /// dependent rows λ is one choice among many (only R is unique). `tmp`: ℓ entries. Call it
    /// right after the evaluation ([`Structured::f64_error_estimate`] reuses its storage).
    /// The accelerations q̈ = Γη̇ + Γ̇η go into `q_ddot` (ℓ entries).
    pub fn constraint_force(
        &mut self,
        out: &[S],
        r: &mut [S],
        y: &mut [S],
        q_ddot: &mut [S],
        tmp: &mut [S],
    ) {
        let (d, lay) = (self.d, self.layout);
        let (l, g) = (d.ell, d.sigma);
        let p = Parts::carve(d, self.s);
        // Γη̇ into y (overwritten by the solve below); p.gdot holds M⁻¹Ṁq̇ = −Γ̇η
        for j in 0..l {
            let mut x = S::constant(0.0);
            for s in 0..g {
                x = x + p.gamma[j * g + s] * p.eta_dot[s];
            }
            y[j] = x;
            q_ddot[j] = x - p.gdot[j];
        }
        for i in 0..l {
            // p.force holds ∇U + F + ∇_qT − Ȧq̇ − AΓ̇η ([`forcing`])
            let mut x = -p.force[i];
            for j in 0..l {
                x = x + out[lay.a + i * l + j] * y[j];
            }
            r[i] = x;
        }
        lu::solve_transposed(l, p.m, &self.idx[..d.m_rows()], r, y, tmp);
    }

    /// |Γ|ᵀ(|∇U| + |∇_q T| + |Ȧq̇| + |AΓ̇η|), values only: the size of the terms F is summed
    /// from (zero for types that are not [`Scalar::CHECKED`]).
    pub fn forcing_scale(&self) -> &[f64] {
        &self.re[self.d.ell..self.d.ell + self.d.sigma]
    }
}

/// M = [Z; α] factored into `p.m`, Γ (columns 0..σ of M⁻¹) and q̇ = Γη (6).
#[inline(always)]
fn gamma_and_velocities<S: Scalar>(
    d: Dims,
    lay: Layout,
    out: &[S],
    eta: &[S],
    p: &mut Parts<'_, S>,
    perm_m: &mut [usize],
    pivot: Pivot,
) -> Result<(), Failure> {
    let (l, g) = (d.ell, d.sigma);
    if !select(d, &out[lay.m(d)], p.m, perm_m, pivot) {
        return Err(Failure::QuasiVelocityMap);
    }
    let zero = S::constant(0.0);
    for s in 0..g {
        p.col.fill(zero);
        p.col[s] = S::constant(1.0);
        lu::solve(l, p.m, perm_m, p.col, p.tmp);
        for i in 0..l {
            p.gamma[i * g + s] = p.col[i];
        }
    }
    for i in 0..l {
        let mut x = zero;
        for s in 0..g {
            x = x + p.gamma[i * g + s] * eta[s];
        }
        p.q_dot[i] = x;
    }
    Ok(())
}

/// A pivot of the first ℓ rows of M = [Z; α] below this fraction of M's largest entry sends the
/// factorisation to all of M's rows ([`select`]).
pub const KEPT_ROWS_PIVOT: f64 = 1e-8;

/// Factor M = [Z; α] (`src`, [`Dims::m_rows`]×ℓ) into `m`, `perm` its rows' order. Without
/// dependent rows, LU with partial pivoting (`pivot`). With them, the first ℓ rows (Z and α's
/// μ independent rows) while every pivot stays above [`KEPT_ROWS_PIVOT`] of M's largest entry;
/// else, where those rows lose rank (the heading at which two wheels' kept rows are parallel),
/// with the pivots chosen among all the rows ([`lu::factor_rows`]), so that ℓ independent ones
/// are used wherever [Z; α] has rank ℓ. The true equations do not depend on which rows are
/// used; the paper's do (their multipliers are not unique). `false` when M has rank below ℓ
/// (the quasi-velocity map is singular).
#[inline(always)]
pub fn select<S: Scalar>(
    d: Dims,
    src: &[S],
    m: &mut [S],
    perm: &mut [usize],
    pivot: Pivot,
) -> bool {
    let l = d.ell;
    m.copy_from_slice(src);
    if d.dependent == 0 {
        return lu::factor(l, m, perm, pivot);
    }
    if S::RECORDS_DECISIONS {
        // which rows are used is decided by a floor relative to other rows' entries
        S::undecidable();
    }
    let scale = src.iter().fold(0.0_f64, |a, x| a.max(x.value().abs()));
    let kept_floor = match pivot {
        Pivot::Relative(r) if r > KEPT_ROWS_PIVOT => r,
        _ => KEPT_ROWS_PIVOT,
    };
    let kept_scale = m[..l * l]
        .iter()
        .fold(0.0_f64, |a, x| a.max(x.value().abs()));
    let relative = if kept_scale > 0.0 {
        kept_floor * scale / kept_scale
    } else {
        1.0
    };
    if lu::factor(l, m, perm, Pivot::Relative(relative)) {
        for (i, p) in perm.iter_mut().enumerate().skip(l) {
            *p = i;
        }
        return true;
    }
    m.copy_from_slice(src);
    lu::factor_rows(d.m_rows(), l, m, perm, pivot)
}

/// Ṁq̇, Ȧq̇, ∇_qT, Γ̇η, Aq̇ and the forcing F = Γᵀ(∇U + F(q, q̇) + ∇_qT − Ȧq̇ − AΓ̇η) of
/// (11) with Q from (9), `p.force` holding F(q, q̇) on entry; for f64, the sizes of its terms.
#[inline(always)]
fn forcing<S: Scalar>(
    d: Dims,
    lay: Layout,
    out: &[S],
    p: &mut Parts<'_, S>,
    perm_m: &[usize],
    terms: &mut [f64],
    forcing_scale: &mut [f64],
) {
    let (l, g) = (d.ell, d.sigma);
    let zero = S::constant(0.0);
    let qd = &*p.q_dot;
    p.mdot_qd.fill(zero);
    p.adot_qd.fill(zero);
    for k in 0..l {
        let mut gt = zero;
        for i in 0..l {
            let dm_row = lay.dm_row(d, k, i);
            let da_row = lay.da + k * l * l + i * l;
            let (mut dmq, mut daq) = (zero, zero);
            for j in 0..l {
                dmq = dmq + out[dm_row + j] * qd[j];
                daq = daq + out[da_row + j] * qd[j];
            }
            p.mdot_qd[i] = p.mdot_qd[i] + dmq * qd[k];
            p.adot_qd[i] = p.adot_qd[i] + daq * qd[k];
            gt = gt + qd[i] * daq;
        }
        p.grad_t[k] = gt * S::constant(0.5);
        // the dependent rows of Ṁq̇, read by the solve where the pivoting selected them
        for i in l..d.m_rows() {
            let dm_row = lay.dm_row(d, k, i);
            let mut dmq = zero;
            for j in 0..l {
                dmq = dmq + out[dm_row + j] * qd[j];
            }
            p.mdot_qd[i] = p.mdot_qd[i] + dmq * qd[k];
        }
    }
    // M⁻¹Ṁq̇ = −Γ̇η
    p.gdot.copy_from_slice(p.mdot_qd);
    lu::solve(l, p.m, perm_m, p.gdot, p.tmp);
    let a = |i: usize, j: usize| out[lay.a + i * l + j];
    for i in 0..l {
        let (mut a_gdot, mut aq) = (zero, zero);
        for j in 0..l {
            a_gdot = a_gdot - a(i, j) * p.gdot[j];
            aq = aq + a(i, j) * qd[j];
        }
        p.a_gdot[i] = a_gdot;
        p.aq[i] = aq;
        let applied = p.force[i];
        p.force[i] = out[lay.grad_u + i] + applied + p.grad_t[i] - p.adot_qd[i] - a_gdot;
        if S::CHECKED {
            terms[i] = [
                out[lay.grad_u + i],
                applied,
                p.grad_t[i],
                p.adot_qd[i],
                a_gdot,
            ]
            .iter()
            .map(|x| x.value().abs())
            .sum();
        }
    }
    for r in 0..g {
        let mut f = zero;
        let mut scale = 0.0;
        for i in 0..l {
            f = f + p.gamma[i * g + r] * p.force[i];
            if S::CHECKED {
                scale += p.gamma[i * g + r].value().abs() * terms[i];
            }
        }
        p.forcing[r] = f;
        forcing_scale[r] = scale;
    }
}

/// A_Γ = ΓᵀAΓ: column r is Γᵀ(AΓe_r).
#[inline(always)]
fn a_gamma<S: Scalar>(d: Dims, lay: Layout, out: &[S], p: &mut Parts<'_, S>) {
    let (l, g) = (d.ell, d.sigma);
    let zero = S::constant(0.0);
    for r in 0..g {
        for i in 0..l {
            let mut x = zero;
            for j in 0..l {
                x = x + out[lay.a + i * l + j] * p.gamma[j * g + r];
            }
            p.col[i] = x;
        }
        for s in 0..g {
            let mut x = zero;
            for i in 0..l {
                x = x + p.gamma[i * g + s] * p.col[i];
            }
            p.a_gamma[s * g + r] = x;
        }
    }
}

/// The paper's η̇: A_Γ η̇ = F + Σ_m ν_m ΓᵀV_m q̇ with ν = ΘᵀAq̇ (Θ the last μ columns of
/// M⁻¹; with dependent rows, the columns of the rows [`select`] used, ν = 0 for the others)
/// and (V_m q̇)_h = Σ_k (∂α_mh/∂q_k − ∂α_mk/∂q_h) q̇_k: the term (12)/(15) keeps.
#[inline(always)]
fn paper_form<S: Scalar>(
    d: Dims,
    lay: Layout,
    out: &[S],
    p: &mut Parts<'_, S>,
    perm_m: &[usize],
    perm_g: &[usize],
) {
    let (l, m, g) = (d.ell, d.rho(), d.sigma);
    let zero = S::constant(0.0);
    let dalpha = |k: usize, m_: usize, h: usize| out[lay.dalpha + k * m * l + m_ * l + h];
    let rhs = &mut *p.eta_dot_paper;
    rhs.copy_from_slice(p.forcing);
    for m_ in 0..m {
        p.col.fill(zero);
        p.col[g + m_] = S::constant(1.0);
        lu::solve(l, p.m, perm_m, p.col, p.tmp);
        let mut nu = zero;
        for i in 0..l {
            nu = nu + p.col[i] * p.aq[i];
        }
        for h in 0..l {
            let mut w = zero;
            for k in 0..l {
                w = w + (dalpha(k, m_, h) - dalpha(h, m_, k)) * p.q_dot[k];
            }
            for (x, &gh) in rhs.iter_mut().zip(&p.gamma[h * g..(h + 1) * g]) {
                *x = *x + nu * gh * w;
            }
        }
    }
    lu::solve(g, p.ag_lu, perm_g, rhs, p.tmp);
}

impl<S: Scalar> Structured<'_, S> {
    /// The relative error of η̇ an f64 evaluation may have, to first order: ε times the sum of
    /// * κ_S[Z; α], Skeel's condition number ‖ |M⁻¹| |M| ‖∞ (solving for Γ and Γ̇η);
    /// * κ_S(D A_Γ D) with D = diag(A_Γ)^(−½) (the solve with A_Γ; by van der Sluis the
    ///   symmetric scaling removes what the units of η alone contribute);
    /// * ‖ |A_Γ⁻¹| s ‖∞ / ‖η̇‖∞ with s = [`Structured::forcing_scale`]: cancellation in summing
    ///   the forcing (∞ when η̇ = 0 from terms that are not all zero).
    ///
    /// Call after [`Structured::evaluate`] with the same ingredients `out`.
    #[inline(always)]
    pub fn f64_error_estimate(&mut self, out: &[S]) -> f64 {
        let (d, lay) = (self.d, self.layout);
        let (l, g) = (d.ell, d.sigma);
        let size = self
            .eta_dot()
            .iter()
            .fold(0.0_f64, |a, x| a.max(x.value().abs()));
        let ag = &self.s[part(d, A_GAMMA)];
        let (head, work) = self.re.split_at_mut(l + g);
        let forcing_scale = &head[l..];
        let perm = &mut self.idx[..d.m_rows()];
        let (mat, rest) = work.split_at_mut(l * l);
        // the ℓ rows of M the evaluation used (all of them without dependent rows)
        let m = &out[lay.m(d)];
        for i in 0..l {
            let row = if d.dependent == 0 { i } else { perm[i] };
            for j in 0..l {
                mat[i * l + j] = m[row * l + j].value();
            }
        }
        let perm = &mut perm[..l];
        let kappa_m = skeel(l, mat, None, perm, rest);
        let scale = |i: usize| ag[i * g + i].value().abs().sqrt().recip();
        for i in 0..g {
            for j in 0..g {
                mat[i * g + j] = scale(i) * ag[i * g + j].value() * scale(j);
            }
        }
        let kappa_ag = skeel(g, mat, None, perm, rest);
        for (x, a) in mat.iter_mut().zip(ag) {
            *x = a.value();
        }
        let err = skeel(g, mat, Some(forcing_scale), perm, rest);
        let cancellation = if err == 0.0 { 0.0 } else { err / size };
        f64::EPSILON * (kappa_m + kappa_ag + cancellation)
    }
}

/// ‖ |M⁻¹| v ‖∞ for the n×n `m` (overwritten by its factors; ∞ when singular), with v the row
/// sums of |M| (Skeel's condition number ‖ |M⁻¹| |M| ‖∞) unless given. `work` holds 3n.
#[inline(always)]
fn skeel(n: usize, m: &mut [f64], v: Option<&[f64]>, perm: &mut [usize], work: &mut [f64]) -> f64 {
    let (rows, rest) = work.split_at_mut(n);
    let (col, rest) = rest.split_at_mut(n);
    let (tmp, rest) = rest.split_at_mut(n);
    let sums = &mut rest[..n];
    for i in 0..n {
        rows[i] = match v {
            Some(v) => v[i],
            None => m[i * n..(i + 1) * n].iter().map(|x| x.abs()).sum(),
        };
    }
    if !lu::factor(n, m, perm, EVALUATOR_PIVOT) {
        return f64::INFINITY;
    }
    sums.fill(0.0);
    for j in 0..n {
        col.fill(0.0);
        col[j] = 1.0;
        lu::solve(n, m, perm, col, tmp); // column j of M⁻¹
        for i in 0..n {
            sums[i] += col[i].abs() * rows[j];
        }
    }
    sums.iter().fold(0.0, |a, x| a.max(*x))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fixed::{Buffers, Fixed, Storage};

    const D: Dims = Dims::new(3, 1, 2);
    const M: f64 = 2.0;
    const I: f64 = 0.3;
    const G_SIN: f64 = 9.81 * 0.25;

    /// The knife edge on an incline, q = (x, y, θ), T = ½m(ẋ² + ẏ²) + ½Iθ̇², U = m g sin(a) x,
    /// α = (−sin θ, cos θ, 0), η = (cos θ ẋ + sin θ ẏ, θ̇): its ingredients, written by hand.
    /// `z_row`: Z's first row (the sliding direction makes [Z; α] singular).
    fn knife(q: [f64; 3], z_row: [f64; 3]) -> Vec<f64> {
        let (x, th) = (q[0], q[2]);
        let (s, c) = th.sin_cos();
        let lay = Layout::new(D);
        let mut out = vec![0.0; lay.len];
        out[lay.z..lay.z + 6].copy_from_slice(&[z_row[0], z_row[1], z_row[2], 0.0, 0.0, 1.0]);
        out[lay.alpha..lay.alpha + 3].copy_from_slice(&[-s, c, 0.0]);
        for (i, a) in [M, M, I].into_iter().enumerate() {
            out[lay.a + 4 * i] = a;
        }
        out[lay.u] = M * G_SIN * x;
        out[lay.grad_u] = M * G_SIN;
        // ∂Z/∂θ and ∂α/∂θ (k = 2); everything else is constant in q
        if z_row == [c, s, 0.0] {
            out[lay.dz + 2 * 6..lay.dz + 2 * 6 + 3].copy_from_slice(&[-s, c, 0.0]);
        }
        out[lay.dalpha + 2 * 3..lay.dalpha + 2 * 3 + 3].copy_from_slice(&[-c, -s, 0.0]);
        out
    }

    #[test]
    fn the_knife_on_an_incline_has_its_closed_form() {
        let (q, eta) = ([0.4, -1.0, 0.7], [1.3, -0.6]);
        let (s, c) = q[2].sin_cos();
        let out = knife(q, [c, s, 0.0]);
        let mut buffers = Buffers::<f64>::new(D);
        let mut r = buffers.structured();
        r.evaluate(&out, &eta, true).unwrap();
        let close = |a: &[f64], b: &[f64]| a.iter().zip(b).all(|(x, y)| (x - y).abs() < 1e-14);
        assert!(close(r.eta_dot(), &[G_SIN * c, 0.0]), "{:?}", r.eta_dot());
        assert!(close(r.eta_dot_paper(), r.eta_dot()));
        assert!(close(r.q_dot(), &[eta[0] * c, eta[0] * s, eta[1]]));
        assert!(close(r.a_gamma(), &[M, 0.0, 0.0, I]));
        let energy = 0.5 * (M * eta[0] * eta[0] + I * eta[1] * eta[1]) - M * G_SIN * q[0];
        assert!((r.energy() - energy).abs() < 1e-14);
        assert!(r.f64_error_estimate(&out) < DOUBLE_DOUBLE_ABOVE);
        // the same on the stack, through the fixed-size results
        let mut storage = Storage::<f64, 64, 5, 32>::new();
        let mut s2 = storage.structured(D).unwrap();
        s2.evaluate(&out, &eta, false).unwrap();
        let fixed: Fixed<f64, 3, 2> = Fixed::read(&s2);
        assert_eq!(fixed.eta_dot.to_vec(), r.eta_dot().to_vec());
    }

    #[test]
    fn the_accessors_read_the_parts_an_evaluation_writes() {
        let d = Dims::new(4, 1, 3);
        let mut buffers = Buffers::<f64>::new(d);
        let r = buffers.structured();
        let p = Parts::carve(d, &mut *r.s);
        let results = [
            p.eta_dot,
            p.eta_dot_paper,
            p.q_dot,
            p.a_gamma,
            p.forcing,
            p.energy,
            p.gamma,
        ];
        for (mark, part) in results.into_iter().enumerate() {
            part.fill(mark as f64);
        }
        for part in [
            p.m, p.ag_lu, p.mdot_qd, p.adot_qd, p.grad_t, p.gdot, p.aq, p.force,
        ] {
            part.fill(-1.0);
        }
        for part in [p.a_gdot, p.col, p.tmp] {
            part.fill(-1.0);
        }
        let read: [&[f64]; 7] = [
            r.eta_dot(),
            r.eta_dot_paper(),
            r.q_dot(),
            r.a_gamma(),
            r.forcing(),
            &[r.energy()],
            r.gamma(),
        ];
        let lengths = [3, 3, 4, 9, 3, 1, 12];
        for (mark, (v, n)) in read.into_iter().zip(lengths).enumerate() {
            assert_eq!(v, vec![mark as f64; n], "result {mark}");
        }
    }

    #[test]
    fn a_singular_quasi_velocity_map_and_small_storage_are_errors() {
        let q = [0.0, 0.0, 0.3];
        let (s, c) = q[2].sin_cos();
        let out = knife(q, [-s, c, 0.0]);
        let mut buffers = Buffers::<f64>::new(D);
        let err = buffers.structured().evaluate(&out, &[1.0, 1.0], true);
        assert_eq!(err, Err(Failure::QuasiVelocityMap));
        let mut storage = Storage::<f64, 8, 5, 32>::new();
        assert!(storage.structured(D).is_err());
    }
}
