//! Evaluating the derived equations at a state, without the computer-algebra engine.
//!
//! **Structured evaluation** ([`Compiled`], used by `hamel eval` and the numeric core). The
//! expanded normal forms of Q are exact but, written over sin/cos reduced modulo
//! sin² + cos² = 1 and multiplied out, they cancel catastrophically in floating point (terms of
//! 10¹³ summing to 10⁻⁵ were observed at well-conditioned states). So the equations (11) are
//! evaluated from small exact ingredients — Z, α, A, U, ∇U and the exact derivatives ∂Z/∂q_k,
//! ∂α/∂q_k, ∂A/∂q_k — with the linear algebra done numerically:
//!
//! * M = [Z; α], [Γ Θ] = M⁻¹ (LU), q̇ = Γη (6);
//! * Γ̇η = −M⁻¹Ṁq̇ (from M[Γ Θ] = I), Ȧ = Σ_k ∂A/∂q_k q̇_k;
//! * A_Γ η̇ = Γᵀ(∇U + ½∇_q(q̇ᵀAq̇) − Ȧq̇ − AΓ̇η), i.e. (11) with Q from (9);
//! * the paper's form adds back Q_correction = Σ_m ν_m ΓᵀV_m q̇, ν = ΘᵀAq̇.
//!
//! **Symbolic evaluation** ([`SymbolicCompiled`]) evaluates the expanded forms themselves (for
//! checking them, in higher precision).
//!
//! Both compile their trees once into a [`Tape`] (shared subexpressions, resolved inputs) and
//! evaluate over any scalar: f64, dual numbers, double-double.

use hamel_expr::{DD, Lu, Scalar, Tape};
use indexmap::IndexMap;
use nalgebra::DMatrix;
use serde::Serialize;

use crate::derivation::{Derivation, Entry, Mat};

/// Why an evaluation failed (the caller adds which state it was).
#[derive(Clone, Debug, PartialEq)]
pub struct NumericError(pub String);

impl std::fmt::Display for NumericError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}", self.0)
    }
}

impl std::error::Error for NumericError {}

/// The right-hand side at a state, checked (see [`Compiled::evaluate`]).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Evaluation {
    /// η̇ from the true equations.
    pub eta_dot: Vec<f64>,
    /// q̇ = Γη.
    pub q_dot: Vec<f64>,
    /// E = ½ηᵀA_Γη − U.
    pub energy: f64,
    /// η̇ from the paper's equations (11)/(15).
    pub eta_dot_paper: Vec<f64>,
    /// Condition number of [Z; α] at q (distance to the singular set).
    pub condition: f64,
    /// δ = det[Z; α] at q (its sign changes where a path crosses the singular set).
    pub delta: f64,
    /// The arithmetic the values were computed in (see [`Compiled::evaluate`]).
    pub precision: Precision,
    /// An estimate of the relative error of η̇ in f64 here (see [`f64_error_estimate`]).
    pub f64_error_estimate: f64,
}

impl Evaluation {
    /// The values of `r` rounded to f64, with what the evaluation knew about the state:
    /// (condition number of [Z; α], δ, the f64 error estimate).
    fn of<S: Scalar>(
        r: &Rhs<S>,
        precision: Precision,
        (condition, delta, bound): (f64, f64, f64),
    ) -> Evaluation {
        let values = |v: &[S]| v.iter().map(Scalar::value).collect::<Vec<_>>();
        Evaluation {
            eta_dot: values(&r.eta_dot),
            q_dot: values(&r.q_dot),
            energy: r.energy.value(),
            eta_dot_paper: values(&r.eta_dot_paper),
            condition,
            delta,
            precision,
            f64_error_estimate: bound,
        }
    }

    fn is_finite(&self) -> bool {
        self.eta_dot
            .iter()
            .chain(&self.eta_dot_paper)
            .chain(&self.q_dot)
            .chain([&self.energy])
            .all(|x| x.is_finite())
    }
}

/// The arithmetic of an [`Evaluation`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Precision {
    /// IEEE double precision.
    F64,
    /// Double-double (about 32 digits), rounded to f64 at the end.
    DoubleDouble,
}

/// [`Compiled::evaluate`] repeats an evaluation in double-double when [`f64_error_estimate`]
/// exceeds this: 64 units of rounding. Solving with [Z; α] or with the Gram matrix
/// A_Γ = ΓᵀAΓ in f64 can lose far more digits than the problem itself is sensitive to
/// (A_Γ squares the conditioning of the kinetic metric on the constraints: the flat rolling
/// disk, docs/stability.md); double-double does not, there. (A running error bound was tried
/// as the trigger and rejected: through the LU of badly scaled [Z; α] it overestimates by up
/// to 1e5 and sent nine states in ten to double-double.)
pub const DOUBLE_DOUBLE_ABOVE: f64 = 16.0 * f64::EPSILON;

/// The right-hand side in any scalar type, unchecked.
#[derive(Clone, Debug)]
pub struct Rhs<S> {
    /// η̇ from the true equations.
    pub eta_dot: Vec<S>,
    /// η̇ from the paper's equations.
    pub eta_dot_paper: Vec<S>,
    /// q̇ = Γη.
    pub q_dot: Vec<S>,
    /// Energy.
    pub energy: S,
    /// A_Γ.
    pub a_gamma: Vec<Vec<S>>,
    /// Γ.
    pub gamma: Vec<Vec<S>>,
    /// |Γ|ᵀ(|∇U| + |∇_q T| + |Ȧq̇| + |AΓ̇η|): the size of the terms the forcing is summed from
    /// (values only), for the error estimate of [`Compiled::evaluate`].
    pub forcing_scale: Vec<f64>,
}

fn add_mat<'a>(exprs: &mut Vec<&'a hamel_expr::Expr>, m: &'a Mat) -> usize {
    let at = exprs.len();
    exprs.extend(m.entries.iter().flatten().map(|e| &e.expr));
    at
}

fn add_list<'a>(exprs: &mut Vec<&'a hamel_expr::Expr>, v: &'a [Entry]) -> usize {
    let at = exprs.len();
    exprs.extend(v.iter().map(|e| &e.expr));
    at
}

fn block<S: Clone>(out: &[S], at: usize, rows: usize, cols: usize) -> Vec<Vec<S>> {
    (0..rows)
        .map(|i| out[at + i * cols..at + (i + 1) * cols].to_vec())
        .collect()
}

fn zero<S: Scalar>() -> S {
    S::constant(0.0)
}

/// Free functions left in the trees, as input names (`z13(phi)`, `z13_dphi(phi)`, …), sorted.
fn free_inputs(exprs: &[&hamel_expr::Expr]) -> Vec<String> {
    let mut names = Vec::new();
    for e in exprs {
        e.visit(&mut |n| {
            if let hamel_expr::Expr::Free { .. } = n {
                let s = n.to_string();
                if !names.contains(&s) {
                    names.push(s);
                }
            }
        });
    }
    names.sort();
    names
}

/// Where each ingredient sits among the structured tape's outputs.
#[derive(Clone, Debug)]
struct Layout {
    z: usize,
    alpha: usize,
    a: usize,
    u: usize,
    grad_u: usize,
    da: usize,
    dz: usize,
    dalpha: usize,
}

/// A derivation compiled for structured numeric evaluation.
#[derive(Clone, Debug)]
pub struct Compiled {
    tape: Tape,
    layout: Layout,
    coordinates: Vec<String>,
    parameters: IndexMap<String, f64>,
    ell: usize,
    mu: usize,
    sigma: usize,
    singular: String,
}

/// The expanded symbolic equations compiled for evaluation (checks of the symbolic forms).
#[derive(Clone, Debug)]
pub struct SymbolicCompiled {
    tape: Tape,
    free: Vec<String>,
    parameters: IndexMap<String, f64>,
    sigma: usize,
    a_gamma: usize,
    forcing: usize,
    q: usize,
    q_paper: usize,
}

impl Derivation {
    /// The ingredients of the structured evaluation, in order: Z (σ×ℓ, row-major), α (μ×ℓ),
    /// A (ℓ×ℓ), U, ∇U (ℓ), ∂A/∂q_k (ℓ blocks ℓ×ℓ), ∂Z/∂q_k (ℓ blocks σ×ℓ), ∂α/∂q_k (ℓ blocks μ×ℓ).
    /// Compiled here and printed as Rust by the code generator (whose runtime `Layout` has the
    /// same offsets).
    pub fn ingredient_exprs(&self) -> Result<Vec<&hamel_expr::Expr>, NumericError> {
        let ing = &self.ingredients;
        let u = ing
            .potential
            .as_ref()
            .ok_or_else(|| NumericError("the derivation carries no ingredients".into()))?;
        let mut exprs = Vec::new();
        add_mat(&mut exprs, &self.z);
        add_mat(&mut exprs, &self.alpha);
        add_mat(&mut exprs, &self.a);
        exprs.push(&u.expr);
        add_list(&mut exprs, &self.grad_u);
        for m in ing.da.iter().chain(&ing.dz).chain(&ing.dalpha) {
            add_mat(&mut exprs, m);
        }
        Ok(exprs)
    }

    /// Compile for structured evaluation (inputs: coordinates and parameters). Free functions
    /// must have been given definitions before deriving.
    pub fn compile(&self) -> Result<Compiled, NumericError> {
        let exprs = self.ingredient_exprs()?;
        let (ell, mu, sigma) = (self.ell, self.mu, self.sigma);
        let z = 0;
        let alpha = z + sigma * ell;
        let a = alpha + mu * ell;
        let u_at = a + ell * ell;
        let grad_u = u_at + 1;
        let da = grad_u + ell;
        let dz = da + ell * ell * ell;
        let dalpha = dz + ell * sigma * ell;
        let free = free_inputs(&exprs);
        if !free.is_empty() {
            return Err(NumericError(format!(
                "the quasi-velocities use free functions ({}): give them definitions to evaluate numerically",
                self.free_functions.join(", ")
            )));
        }
        let inputs: Vec<String> = self
            .coordinates
            .iter()
            .cloned()
            .chain(self.parameters.keys().cloned())
            .collect();
        let tape = Tape::compile(&exprs, &inputs).map_err(|e| NumericError(e.to_string()))?;
        Ok(Compiled {
            tape,
            layout: Layout {
                z,
                alpha,
                a,
                u: u_at,
                grad_u,
                da,
                dz,
                dalpha,
            },
            coordinates: self.coordinates.clone(),
            parameters: self.parameters.clone(),
            ell: self.ell,
            mu: self.mu,
            sigma: self.sigma,
            singular: self.singular_set_text(),
        })
    }

    /// Compile the expanded symbolic equations (inputs: coordinates, parameters, η, and the
    /// values of the free functions and their derivatives named by
    /// [`SymbolicCompiled::free_inputs`]).
    pub fn compile_symbolic(&self) -> Result<SymbolicCompiled, NumericError> {
        let mut exprs = Vec::new();
        let a_gamma = add_mat(&mut exprs, &self.a_gamma);
        let forcing = add_list(&mut exprs, &self.forcing);
        let q = exprs.len();
        for m in &self.q {
            add_mat(&mut exprs, m);
        }
        let q_paper = exprs.len();
        for m in &self.q_paper {
            add_mat(&mut exprs, m);
        }
        let free = free_inputs(&exprs);
        let inputs: Vec<String> = self
            .coordinates
            .iter()
            .cloned()
            .chain(self.parameters.keys().cloned())
            .chain((1..=self.sigma).map(|i| format!("eta{i}")))
            .chain(free.iter().cloned())
            .collect();
        let tape = Tape::compile(&exprs, &inputs).map_err(|e| NumericError(e.to_string()))?;
        Ok(SymbolicCompiled {
            tape,
            free,
            parameters: self.parameters.clone(),
            sigma: self.sigma,
            a_gamma,
            forcing,
            q,
            q_paper,
        })
    }

    /// The singular set as `f1 = 0 or f2 = 0 …` (or "nowhere").
    pub fn singular_set_text(&self) -> String {
        if self.singular_set.is_empty() {
            "nowhere".into()
        } else {
            self.singular_set
                .iter()
                .map(|e| format!("{} = 0", e.text))
                .collect::<Vec<_>>()
                .join(" or ")
        }
    }

    /// Parameter values: the model's defaults with `overrides` (unknown names are errors).
    pub fn parameters_with(
        &self,
        overrides: &IndexMap<String, f64>,
    ) -> Result<IndexMap<String, f64>, NumericError> {
        let mut p = self.parameters.clone();
        for (k, v) in overrides {
            match p.get_mut(k) {
                Some(slot) => *slot = *v,
                None => return Err(NumericError(format!("unknown parameter `{k}`"))),
            }
        }
        Ok(p)
    }
}

fn param_inputs<S: Scalar>(
    defaults: &IndexMap<String, f64>,
    params: &IndexMap<String, f64>,
) -> impl Iterator<Item = S> {
    defaults
        .iter()
        .map(|(k, v)| S::constant(params.get(k).copied().unwrap_or(*v)))
        .collect::<Vec<S>>()
        .into_iter()
}

/// The numeric pieces at one configuration.
struct Parts<S> {
    a: Vec<Vec<S>>,
    u: S,
    grad_u: Vec<S>,
    da: Vec<Vec<Vec<S>>>,
    dm: Vec<Vec<Vec<S>>>,
    dalpha: Vec<Vec<Vec<S>>>,
    lu: Lu<S>,
}

impl Compiled {
    /// Number of arithmetic operations of the compiled ingredients.
    pub fn operation_count(&self) -> usize {
        self.tape.operation_count()
    }

    /// Coordinate names, in order.
    pub fn coordinates(&self) -> &[String] {
        &self.coordinates
    }

    fn parts<S: Scalar>(
        &self,
        q: &[S],
        params: &IndexMap<String, f64>,
    ) -> Result<Parts<S>, NumericError> {
        let (ell, mu, sigma) = (self.ell, self.mu, self.sigma);
        let mut inputs: Vec<S> = q.to_vec();
        inputs.extend(param_inputs::<S>(&self.parameters, params));
        let out = self
            .tape
            .eval(&inputs)
            .map_err(|e| NumericError(e.to_string()))?;
        let l = &self.layout;
        let z = block(&out, l.z, sigma, ell);
        let alpha = block(&out, l.alpha, mu, ell);
        let m: Vec<Vec<S>> = z.into_iter().chain(alpha).collect();
        let dm = (0..ell)
            .map(|k| {
                let dz = block(&out, l.dz + k * sigma * ell, sigma, ell);
                let dalpha = block(&out, l.dalpha + k * mu * ell, mu, ell);
                dz.into_iter().chain(dalpha).collect()
            })
            .collect();
        let lu = Lu::new(m).ok_or_else(|| {
            NumericError(format!(
                "the quasi-velocity map is singular at this configuration: det[Z; α] = 0; singular where {}",
                shorten(&self.singular)
            ))
        })?;
        Ok(Parts {
            a: block(&out, l.a, ell, ell),
            u: out[l.u].clone(),
            grad_u: out[l.grad_u..l.grad_u + ell].to_vec(),
            da: (0..ell)
                .map(|k| block(&out, l.da + k * ell * ell, ell, ell))
                .collect(),
            dalpha: (0..ell)
                .map(|k| block(&out, l.dalpha + k * mu * ell, mu, ell))
                .collect(),
            dm,
            lu,
        })
    }

    /// Γ (columns 0..σ of [Z; α]⁻¹) and Θ (the rest).
    fn gamma_theta<S: Scalar>(&self, p: &Parts<S>) -> (Vec<Vec<S>>, Vec<Vec<S>>) {
        let ell = self.ell;
        let mut inv = vec![vec![zero::<S>(); ell]; ell];
        for j in 0..ell {
            let e: Vec<S> = (0..ell)
                .map(|i| S::constant(if i == j { 1.0 } else { 0.0 }))
                .collect();
            let col = p.lu.solve(&e);
            for i in 0..ell {
                inv[i][j] = col[i].clone();
            }
        }
        let gamma = inv.iter().map(|r| r[..self.sigma].to_vec()).collect();
        let theta = inv.iter().map(|r| r[self.sigma..].to_vec()).collect();
        (gamma, theta)
    }

    /// Γ(q) in any scalar type (dual numbers give Γ̇ along a direction).
    pub fn gamma<S: Scalar>(
        &self,
        q: &[S],
        params: &IndexMap<String, f64>,
    ) -> Result<Vec<Vec<S>>, NumericError> {
        let p = self.parts(q, params)?;
        Ok(self.gamma_theta(&p).0)
    }

    fn m_matrix(
        &self,
        q: &[f64],
        params: &IndexMap<String, f64>,
    ) -> Result<DMatrix<f64>, NumericError> {
        let mut inputs: Vec<f64> = q.to_vec();
        inputs.extend(param_inputs::<f64>(&self.parameters, params));
        let out = self
            .tape
            .eval(&inputs)
            .map_err(|e| NumericError(e.to_string()))?;
        let z = block(&out, self.layout.z, self.sigma, self.ell);
        let alpha = block(&out, self.layout.alpha, self.mu, self.ell);
        Ok(DMatrix::from_fn(self.ell, self.ell, |i, j| {
            if i < self.sigma {
                z[i][j]
            } else {
                alpha[i - self.sigma][j]
            }
        }))
    }

    /// Condition number of [Z; α] at q (∞ when singular).
    pub fn condition(
        &self,
        q: &[f64],
        params: &IndexMap<String, f64>,
    ) -> Result<f64, NumericError> {
        Ok(condition_number(&self.m_matrix(q, params)?))
    }

    /// The right-hand side at (q, η) in any scalar type, unchecked.
    pub fn rhs<S: Scalar>(
        &self,
        q: &[S],
        eta: &[S],
        params: &IndexMap<String, f64>,
    ) -> Result<Rhs<S>, NumericError> {
        let (ell, mu, sigma) = (self.ell, self.mu, self.sigma);
        let p = self.parts(q, params)?;
        let (gamma, theta) = self.gamma_theta(&p);
        let mat_vec = |m: &[Vec<S>], v: &[S]| -> Vec<S> {
            m.iter()
                .map(|r| {
                    r.iter()
                        .zip(v)
                        .fold(zero::<S>(), |acc, (a, b)| acc + a.clone() * b.clone())
                })
                .collect()
        };
        let t_mat_vec = |m: &[Vec<S>], v: &[S], cols: usize| -> Vec<S> {
            (0..cols)
                .map(|j| {
                    m.iter()
                        .zip(v)
                        .fold(zero::<S>(), |acc, (r, b)| acc + r[j].clone() * b.clone())
                })
                .collect()
        };
        // (6)
        let qd = mat_vec(&gamma, eta);
        // Ṁq̇, Ȧq̇ and ∇_q T = ½ q̇ᵀ ∂A/∂q_k q̇.
        let mut mdot_qd = vec![zero::<S>(); ell];
        let mut adot_qd = vec![zero::<S>(); ell];
        let mut grad_t = vec![zero::<S>(); ell];
        for k in 0..ell {
            let dmq = mat_vec(&p.dm[k], &qd);
            let daq = mat_vec(&p.da[k], &qd);
            for i in 0..ell {
                mdot_qd[i] = mdot_qd[i].clone() + dmq[i].clone() * qd[k].clone();
                adot_qd[i] = adot_qd[i].clone() + daq[i].clone() * qd[k].clone();
            }
            grad_t[k] = qd
                .iter()
                .zip(&daq)
                .fold(zero::<S>(), |acc, (a, b)| acc + a.clone() * b.clone())
                * S::constant(0.5);
        }
        // Γ̇η = −M⁻¹ Ṁ q̇
        let gdot_eta: Vec<S> = p.lu.solve(&mdot_qd).into_iter().map(|x| -x).collect();
        let a_gdot = mat_vec(&p.a, &gdot_eta);
        let force: Vec<S> = (0..ell)
            .map(|i| {
                p.grad_u[i].clone() + grad_t[i].clone() - adot_qd[i].clone() - a_gdot[i].clone()
            })
            .collect();
        let rhs_true = t_mat_vec(&gamma, &force, sigma);
        let forcing_scale: Vec<f64> = (0..sigma)
            .map(|r| {
                (0..ell)
                    .map(|i| {
                        let t = [&p.grad_u[i], &grad_t[i], &adot_qd[i], &a_gdot[i]]
                            .iter()
                            .map(|x| x.value().abs())
                            .sum::<f64>();
                        gamma[i][r].value().abs() * t
                    })
                    .sum()
            })
            .collect();
        // A_Γ = ΓᵀAΓ
        let ag_cols: Vec<Vec<S>> = (0..sigma)
            .map(|s| {
                let col: Vec<S> = gamma.iter().map(|r| r[s].clone()).collect();
                mat_vec(&p.a, &col)
            })
            .collect();
        // (A_Γ)_rs = (Γ e_r)ᵀ A Γ e_s; A is symmetric, so row r is Γᵀ(AΓe_r).
        let a_gamma: Vec<Vec<S>> = (0..sigma)
            .map(|r| t_mat_vec(&gamma, &ag_cols[r], sigma))
            .collect();
        // The paper's form adds back Q_correction = Σ_m ν_m Γᵀ V_m q̇, ν = ΘᵀAq̇,
        // (V_m q̇)_h = Σ_k (∂α_mh/∂q_k − ∂α_mk/∂q_h) q̇_k.
        let aq = mat_vec(&p.a, &qd);
        let nu = t_mat_vec(&theta, &aq, mu);
        let mut corr = vec![zero::<S>(); sigma];
        for m_ in 0..mu {
            let w: Vec<S> = (0..ell)
                .map(|h| {
                    (0..ell).fold(zero::<S>(), |acc, k| {
                        acc + (p.dalpha[k][m_][h].clone() - p.dalpha[h][m_][k].clone())
                            * qd[k].clone()
                    })
                })
                .collect();
            let gw = t_mat_vec(&gamma, &w, sigma);
            for i in 0..sigma {
                corr[i] = corr[i].clone() + nu[m_].clone() * gw[i].clone();
            }
        }
        let rhs_paper: Vec<S> = rhs_true
            .iter()
            .zip(&corr)
            .map(|(a, b)| a.clone() + b.clone())
            .collect();
        let ag_lu = Lu::new(a_gamma.clone())
            .ok_or_else(|| NumericError("A_Γ is singular at this configuration".into()))?;
        let energy = aq
            .iter()
            .zip(&qd)
            .fold(zero::<S>(), |acc, (a, b)| acc + a.clone() * b.clone())
            * S::constant(0.5)
            - p.u.clone();
        Ok(Rhs {
            eta_dot: ag_lu.solve(&rhs_true),
            eta_dot_paper: ag_lu.solve(&rhs_paper),
            q_dot: qd,
            energy,
            a_gamma,
            gamma,
            forcing_scale,
        })
    }

    /// η̇, q̇, energy and the paper's η̇ at the state (q, η) for the given parameter values.
    /// Singular configurations (det[Z; α] ≈ 0, A_Γ not positive definite) and non-finite values
    /// are errors, never NaN.
    pub fn evaluate(
        &self,
        q: &[f64],
        eta: &[f64],
        params: &IndexMap<String, f64>,
    ) -> Result<Evaluation, NumericError> {
        if q.len() != self.ell || eta.len() != self.sigma {
            return Err(NumericError(format!(
                "a state needs {} coordinates and {} quasi-velocities, got {} and {}",
                self.ell,
                self.sigma,
                q.len(),
                eta.len()
            )));
        }
        if q.iter().chain(eta).any(|x| !x.is_finite()) {
            return Err(NumericError("the state has a non-finite value".into()));
        }
        let m = self.m_matrix(q, params)?;
        let (condition, delta) = (condition_number(&m), m.determinant());
        if condition > 1e12 {
            return Err(NumericError(format!(
                "the quasi-velocity map is singular at this configuration: det[Z; α] ≈ 0 (condition number {condition:.3e}); singular where {}",
                shorten(&self.singular)
            )));
        }
        let r = self.rhs(q, eta, params)?;
        let ag = DMatrix::from_fn(self.sigma, self.sigma, |i, j| r.a_gamma[i][j]);
        if ag.clone().cholesky().is_none() {
            return Err(NumericError(
                "A_Γ is not positive definite at this configuration (the mass matrix A is degenerate here)".into(),
            ));
        }
        let bound = f64_error_estimate(&m, &ag, &r.forcing_scale, &r.eta_dot);
        let at = (condition, delta, bound);
        let out = if bound > DOUBLE_DOUBLE_ABOVE {
            let to_dd = |v: &[f64]| v.iter().map(|&x| DD::from_f64(x)).collect::<Vec<_>>();
            let r = self.rhs::<DD>(&to_dd(q), &to_dd(eta), params)?;
            Evaluation::of(&r, Precision::DoubleDouble, at)
        } else {
            Evaluation::of(&r, Precision::F64, at)
        };
        if !out.is_finite() {
            return Err(NumericError(
                "the equations give a non-finite value at this state".into(),
            ));
        }
        Ok(out)
    }
}

impl SymbolicCompiled {
    /// Names of the free-function inputs (values of free functions and derivatives at q).
    pub fn free_inputs(&self) -> &[String] {
        &self.free
    }

    /// η̇ (true and paper's) from the expanded symbolic equations, with the free-function
    /// inputs in the order of [`SymbolicCompiled::free_inputs`].
    pub fn eta_dot<S: Scalar>(
        &self,
        q: &[S],
        eta: &[S],
        params: &IndexMap<String, f64>,
        free: &[S],
    ) -> Result<(Vec<S>, Vec<S>), NumericError> {
        let sigma = self.sigma;
        let mut inputs: Vec<S> = q.to_vec();
        inputs.extend(param_inputs::<S>(&self.parameters, params));
        inputs.extend(eta.iter().cloned());
        inputs.extend(free.iter().cloned());
        let out = self
            .tape
            .eval(&inputs)
            .map_err(|e| NumericError(e.to_string()))?;
        let a_gamma = block(&out, self.a_gamma, sigma, sigma);
        let lu = Lu::new(a_gamma)
            .ok_or_else(|| NumericError("A_Γ is singular at this configuration".into()))?;
        let solve = |at: usize| -> Vec<S> {
            let rhs: Vec<S> = (0..sigma)
                .map(|i| {
                    let base = at + i * sigma * sigma;
                    let mut qi = zero::<S>();
                    for r in 0..sigma {
                        for s in 0..sigma {
                            qi = qi
                                + out[base + r * sigma + s].clone()
                                    * eta[r].clone()
                                    * eta[s].clone();
                        }
                    }
                    out[self.forcing + i].clone() - qi
                })
                .collect();
            lu.solve(&rhs)
        };
        Ok((solve(self.q), solve(self.q_paper)))
    }
}

/// Skeel's condition number ‖ |M⁻¹| |M| ‖∞ (∞ when singular): the error amplification of
/// solving with M by Gaussian elimination, whatever the scaling of M's rows.
fn skeel_condition(m: &DMatrix<f64>) -> f64 {
    match m.clone().try_inverse() {
        Some(inv) => (inv.abs() * m.abs())
            .row_iter()
            .map(|r| r.sum())
            .fold(0.0, f64::max),
        None => f64::INFINITY,
    }
}

/// The relative error of η̇ an f64 evaluation may have, to first order: ε times the sum of
/// * κ_S[Z; α], Skeel's condition number ‖ |M⁻¹| |M| ‖∞ (solving for Γ and Γ̇η);
/// * κ_S(D A_Γ D) with D = diag(A_Γ)^(−½) (the solve with A_Γ; by van der Sluis the symmetric
///   scaling removes what the units of η alone contribute);
/// * ‖ |A_Γ⁻¹| s ‖∞ / ‖η̇‖∞ with s = |Γ|ᵀ(|∇U| + |∇_q T| + |Ȧq̇| + |AΓ̇η|): cancellation in
///   summing the forcing (∞ when η̇ = 0 from terms that are not all zero).
pub fn f64_error_estimate(
    m: &DMatrix<f64>,
    a_gamma: &DMatrix<f64>,
    forcing_scale: &[f64],
    eta_dot: &[f64],
) -> f64 {
    let n = a_gamma.nrows();
    let d: Vec<f64> = (0..n)
        .map(|i| a_gamma[(i, i)].abs().sqrt().recip())
        .collect();
    let scaled = DMatrix::from_fn(n, n, |i, j| d[i] * a_gamma[(i, j)] * d[j]);
    let cancellation = match a_gamma.clone().try_inverse() {
        Some(inv) => {
            let e = inv.abs() * nalgebra::DVector::from_column_slice(forcing_scale);
            let size = eta_dot.iter().fold(0.0_f64, |a, x| a.max(x.abs()));
            let err = e.amax();
            if err == 0.0 { 0.0 } else { err / size }
        }
        None => f64::INFINITY,
    };
    f64::EPSILON * (skeel_condition(m) + skeel_condition(&scaled) + cancellation)
}

/// σ_max/σ_min (∞ when singular).
fn condition_number(m: &DMatrix<f64>) -> f64 {
    let sv = m.singular_values();
    let (max, min) = (sv.max(), sv.min());
    if min == 0.0 { f64::INFINITY } else { max / min }
}

fn shorten(s: &str) -> String {
    if s.chars().count() <= 200 {
        s.to_string()
    } else {
        format!(
            "{}… ({} characters)",
            s.chars().take(200).collect::<String>(),
            s.chars().count()
        )
    }
}
