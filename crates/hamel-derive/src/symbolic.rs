//! The derivation proper. Runs on the computer-algebra thread.
//!
//! Notation as in Talamucci (2015): q ∈ R^ℓ, constraints α(q)q̇ = 0 (μ rows), quasi-velocities
//! η = Z(q)q̇ (σ = ℓ − μ rows), [Z; α]⁻¹ = [Γ Θ] (5), A_Γ = ΓᵀAΓ (8).
//!
//! **The true equations** come from (9), Γᵀ(d/dt ∇_q̇L − ∇_qL) = 0, with ∇_q̇L = Aq̇ = AΓη:
//!   A_Γ η̇ + Γᵀ (d/dt (AΓ)) η − ½ Γᵀ ∇_q(q̇ᵀAq̇)|_{q̇=Γη} − Γᵀ∇U = 0,
//! so Q⁽ⁱ⁾_rs = sym_rs[ Σ_k (Γᵀ ∂(AΓ)/∂q_k)_ir γ_ks − ½ Σ_j γ_ji (Γᵀ ∂A/∂q_j Γ)_rs ].
//!
//! **The paper's equations** (10)–(15) use ∇_q̇L = Zᵀ∇_ηL̃, which misses αᵀν with
//! ν = ΘᵀAΓη (since ΓZ + Θα = I). Its coefficients are (15) with the second and third terms
//! summed over h only:
//!   Q⁽ⁱ⁾_rs = Σ_j b_jr (Γᵀ C_j Γ)_is + Σ_h γ_hs ∂b_ri/∂q_h − ½ Σ_h γ_hi ∂b_rs/∂q_h,
//!   (C_j)_hk = ∂z_jh/∂q_k − ∂z_jk/∂q_h.
//!
//! **The correction** restoring the dropped term is Σ_m ν_m Γᵀ V_m Γ η with
//! (V_m)_hk = ∂α_mh/∂q_k − ∂α_mk/∂q_h, so that Q = Q_paper + Q_correction; this identity is
//! checked exactly for every derivation.

use hamel_cas::{CasError, Denominators, Ex, Field, FieldSpec, Matrix, OMatrix, Over, sum_over};
use hamel_model::{Item, Kinetic, Model, ModelError, Site};

use crate::derivation::{Checks, Derivation, Entry, Ingredients, Mat};

/// An exact value as plain data (canonical text and tree).
pub fn entry(e: &Ex) -> Entry {
    let expr = e.to_expr();
    Entry {
        text: expr.to_string(),
        expr,
    }
}

fn entry_over(e: &Over) -> Entry {
    let expr = e.to_expr();
    Entry {
        text: expr.to_string(),
        expr,
    }
}

fn mat_over(m: &OMatrix) -> Mat {
    Mat {
        rows: m.rows(),
        cols: m.cols(),
        entries: (0..m.rows())
            .map(|i| (0..m.cols()).map(|j| entry_over(&m[(i, j)])).collect())
            .collect(),
    }
}

/// An exact matrix as plain data.
pub fn mat(m: &Matrix) -> Mat {
    Mat {
        rows: m.rows(),
        cols: m.cols(),
        entries: (0..m.rows())
            .map(|i| (0..m.cols()).map(|j| entry(&m[(i, j)])).collect())
            .collect(),
    }
}

/// Symmetric part (M + Mᵀ)/2 of a square matrix.
fn sym(den: &Denominators, m: &OMatrix, half: &Over) -> OMatrix {
    OMatrix::from_fn(den, m.rows(), m.cols(), |r, s| {
        if r == s {
            m[(r, s)].clone()
        } else {
            m[(r, s)].add(&m[(s, r)]).mul(half)
        }
    })
}

/// Σ over terms, skipping zeros.
fn sum(f: &Field, terms: impl IntoIterator<Item = Ex>) -> Ex {
    terms
        .into_iter()
        .filter(|t| !t.is_zero())
        .fold(f.zero(), |acc, t| &acc + &t)
}

struct Ctx<'m> {
    model: &'m Model,
}

impl Ctx<'_> {
    fn cas(&self, site: Option<&Site>, e: CasError) -> ModelError {
        match site {
            Some(s) => self.model.error_at(s, e.to_string()),
            None => self.model.error(e.to_string()),
        }
    }

    /// The coefficients of an expression that must be linear and homogeneous in the
    /// velocities: c = Σ_j row_j der(q_j), exactly.
    fn linear_row(
        &self,
        f: &Field,
        c: &Ex,
        site: &Site,
        what: &str,
    ) -> Result<Vec<Ex>, ModelError> {
        let ell = f.ncoords();
        let row: Vec<Ex> = (0..ell).map(|j| c.diff_velocity(j)).collect();
        let rebuilt = sum(f, (0..ell).map(|j| &row[j] * &f.velocity(j)));
        if row.iter().any(Ex::has_velocities) || !(c - &rebuilt).is_zero() {
            let rest = c - &rebuilt;
            let detail = if row.iter().any(Ex::has_velocities) {
                "it has terms of degree 2 or more in the velocities".to_string()
            } else {
                format!(
                    "it has a part without velocities: `{}`",
                    shorten(&rest.to_string())
                )
            };
            return Err(self
                .model
                .error_at(site, format!("the {what} is not linear and homogeneous in the velocities der(q): {detail}"))
                .with_help("write it as a sum of terms (coefficient depending on q) * der(q)"));
        }
        Ok(row)
    }

    fn mass_matrix(&self, f: &Field) -> Result<Matrix, ModelError> {
        let ell = f.ncoords();
        match &self.model.kinetic {
            Kinetic::Energy(t) => {
                let te = f.convert(&t.expr).map_err(|e| self.cas(Some(&t.site), e))?;
                let a = Matrix::from_fn(ell, ell, |i, j| te.diff_velocity(i).diff_velocity(j));
                let quad = sum(
                    f,
                    (0..ell)
                        .flat_map(|i| (0..ell).map(move |j| (i, j)))
                        .map(|(i, j)| &(&a[(i, j)] * &f.velocity(i)) * &f.velocity(j)),
                );
                let half = f.rational(&1.into(), &2.into()).expect("1/2");
                let rest = &te - &(&quad * &half);
                if a.entries().iter().any(Ex::has_velocities) || !rest.is_zero() {
                    let detail = if a.entries().iter().any(Ex::has_velocities) {
                        "it has terms of degree 3 or more in the velocities (or velocities in a denominator)".to_string()
                    } else {
                        format!(
                            "T − ½q̇ᵀAq̇ = `{}` is not zero (terms of degree 0 or 1 in the velocities)",
                            shorten(&rest.to_string())
                        )
                    };
                    return Err(self
                        .model
                        .error_at(
                            &t.site,
                            format!("T is not a quadratic form in the velocities der(q): {detail}"),
                        )
                        .with_help(
                            "T must be ½ q̇ᵀA(q)q̇: every term of degree exactly 2 in der(q)",
                        ));
                }
                Ok(a)
            }
            Kinetic::MassMatrix(rows) => {
                let a = Matrix::try_from_fn(ell, ell, |i, j| {
                    let item: &Item = &rows[i][j];
                    f.convert(&item.expr)
                        .map_err(|e| self.cas(Some(&item.site), e))
                })?;
                for i in 0..ell {
                    for j in 0..i {
                        if !(&a[(i, j)] - &a[(j, i)]).is_zero() {
                            return Err(self.model.error_at(
                                &rows[i][j].site,
                                format!("the mass matrix is not symmetric: entry ({}, {}) differs from entry ({}, {})", i + 1, j + 1, j + 1, i + 1),
                            ));
                        }
                    }
                }
                Ok(a)
            }
        }
    }
}

fn shorten(s: &str) -> String {
    if s.chars().count() <= 120 {
        s.to_string()
    } else {
        format!("{}…", s.chars().take(120).collect::<String>())
    }
}

fn span_site(key: String, items: &[Item]) -> Site {
    let start = items.iter().map(|i| i.site.span.start).min().unwrap_or(0);
    let end = items.iter().map(|i| i.site.span.end).max().unwrap_or(0);
    Site {
        key,
        span: start..end,
    }
}

/// The exact objects of a derivation, as computer-algebra values. Lives on the CAS thread
/// only (not `Send`); later stages (reduction, search) analyse it there, and
/// [`Symbolic::to_derivation`] turns it into plain data.
pub struct Symbolic {
    /// The field every expression lives in (coordinates, parameters, free functions, and the
    /// unknowns `eta1..`, `eta1_dot..`).
    pub field: Field,
    /// The common denominators of the [`Over`] values below.
    pub dens: Denominators,
    /// Mass matrix A (ℓ×ℓ).
    pub a: Matrix,
    /// Constraint matrix α (μ×ℓ).
    pub alpha: Matrix,
    /// Z (σ×ℓ).
    pub z: Matrix,
    /// Γ (ℓ×σ), (5).
    pub gamma: Matrix,
    /// Θ (ℓ×μ), (5).
    pub theta: Matrix,
    /// δ = det[Z; α], (4).
    pub delta: Ex,
    /// Factors whose vanishing makes the map singular.
    pub singular: Vec<Ex>,
    /// U.
    pub u: Ex,
    /// A_Γ (8).
    pub a_gamma: OMatrix,
    /// ∇U.
    pub grad_u: Vec<Over>,
    /// Γᵀ∇U.
    pub forcing: Vec<Over>,
    /// ΘᵀAΓ.
    pub nu: OMatrix,
    /// Q⁽ⁱ⁾ of the true equations.
    pub q_true: Vec<OMatrix>,
    /// Q⁽ⁱ⁾ of the paper's (12)/(15).
    pub q_paper: Vec<OMatrix>,
    /// Q⁽ⁱ⁾ of the correction.
    pub q_correction: Vec<OMatrix>,
    /// The symbols η₁..η_σ.
    pub eta: Vec<Over>,
    /// The symbols η̇₁..η̇_σ.
    pub eta_dot: Vec<Over>,
    /// Γη (the right-hand sides of the kinematic equations (6)).
    pub gamma_eta: Vec<Over>,
    /// Q_i = ηᵀQ⁽ⁱ⁾η, true equations.
    pub q_eta: Vec<Over>,
    /// Q_i of the paper's equations.
    pub q_eta_paper: Vec<Over>,
    /// E = ½ηᵀA_Γη − U.
    pub energy: Over,
    /// Exact checks.
    pub checks: Checks,
    model: Model,
    choice: hamel_model::QuasiVelocityChoice,
}

impl Symbolic {
    /// The model this derivation is of.
    pub fn model(&self) -> &Model {
        &self.model
    }

    /// The quasi-velocity choice.
    pub fn choice(&self) -> &hamel_model::QuasiVelocityChoice {
        &self.choice
    }

    /// Left-hand sides A_Γη̇ + Q − Γᵀ∇U of (11), for the given Q_i.
    pub fn lhs(&self, q_eta: &[Over]) -> Vec<Over> {
        let sigma = self.eta.len();
        (0..sigma)
            .map(|i| {
                let inertia = sum_over(
                    &self.dens,
                    (0..sigma).map(|r| self.a_gamma[(i, r)].mul(&self.eta_dot[r])),
                );
                inertia.add(&q_eta[i]).sub(&self.forcing[i])
            })
            .collect()
    }

    /// Plain data for output and numeric evaluation.
    pub fn to_derivation(&self) -> Derivation {
        let (model, choice) = (&self.model, &self.choice);
        let (mu, sigma) = (model.mu(), model.sigma());
        let to_list = |v: &[Over]| -> Vec<Entry> { v.iter().map(entry_over).collect() };
        let to_mats = |v: &[OMatrix]| -> Vec<Mat> { v.iter().map(mat_over).collect() };
        Derivation {
            model: model.name.clone(),
            title: model.title.clone(),
            eta_name: choice.name.clone(),
            eta: choice.eta.iter().map(|e| e.expr.to_string()).collect(),
            free_functions: choice
                .free_functions
                .iter()
                .map(|(n, a)| format!("{n}({})", a.join(", ")))
                .collect(),
            coordinates: model.coordinates.clone(),
            parameters: model.parameters.clone(),
            ell: model.ell(),
            mu,
            sigma,
            a: mat(&self.a),
            alpha: mat(&self.alpha),
            z: mat(&self.z),
            gamma: mat(&self.gamma),
            theta: mat(&self.theta),
            delta: entry(&self.delta),
            singular_set: self.singular.iter().map(entry).collect(),
            a_gamma: mat_over(&self.a_gamma),
            grad_u: to_list(&self.grad_u),
            forcing: to_list(&self.forcing),
            nu: mat_over(&self.nu),
            q: to_mats(&self.q_true),
            q_paper: to_mats(&self.q_paper),
            q_correction: to_mats(&self.q_correction),
            kinematics: to_list(&self.gamma_eta),
            equations: to_list(&self.lhs(&self.q_eta)),
            equations_paper: to_list(&self.lhs(&self.q_eta_paper)),
            energy: entry_over(&self.energy),
            checks: self.checks.clone(),
            ingredients: Ingredients {
                potential: Some(entry(&self.u)),
                da: (0..model.ell()).map(|k| mat(&self.a.diff(k))).collect(),
                dz: (0..model.ell()).map(|k| mat(&self.z.diff(k))).collect(),
                dalpha: (0..model.ell()).map(|k| mat(&self.alpha.diff(k))).collect(),
                eta_rhs: Vec::new(),
                eta_dot: None,
                blocks: None,
            },
        }
    }

    /// [`Symbolic::to_derivation`] with the ingredients code generation simplifies with: the
    /// right-hand sides b of A_Γ η̇ = b (11) as normal forms, and η̇ = A_Γ⁻¹ b itself when
    /// exact elimination keeps every intermediate under [`SOLUTION_TERMS`] terms.
    pub fn to_derivation_for_code(&self) -> Derivation {
        let mut d = self.to_derivation();
        let sigma = self.eta.len();
        let b: Vec<Ex> = (0..sigma)
            .map(|i| self.forcing[i].sub(&self.q_eta[i]).to_ex())
            .collect();
        d.ingredients.eta_rhs = b.iter().map(entry).collect();
        let a = self.a_gamma.to_matrix();
        let a: Vec<Vec<Ex>> = (0..sigma)
            .map(|i| (0..sigma).map(|j| a[(i, j)].clone()).collect())
            .collect();
        d.ingredients.blocks = blocks(&a);
        d.ingredients.eta_dot =
            solve_capped(a, b, SOLUTION_TERMS).map(|x| x.iter().map(entry).collect());
        d
    }
}

/// The largest entry (in terms) of A_Γ for which [`blocks`] computes cofactors.
const BLOCK_ENTRY_TERMS: usize = 40;

/// The diagonal blocks of `a` (connected components of its exact non-zero pattern) with
/// determinant, adjugate and leading minors each, when every block has at most 3 rows and
/// entries of at most [`BLOCK_ENTRY_TERMS`] terms.
fn blocks(a: &[Vec<Ex>]) -> Option<Vec<crate::derivation::Block>> {
    let g = a.len();
    let mut comp: Vec<usize> = (0..g).collect();
    fn root(c: &mut [usize], i: usize) -> usize {
        if c[i] == i {
            i
        } else {
            let r = root(c, c[i]);
            c[i] = r;
            r
        }
    }
    for i in 0..g {
        for j in i + 1..g {
            if !a[i][j].is_zero() || !a[j][i].is_zero() {
                let (ri, rj) = (root(&mut comp, i), root(&mut comp, j));
                comp[ri.max(rj)] = ri.min(rj);
            }
        }
    }
    let mut out = Vec::new();
    for r in 0..g {
        let rows: Vec<usize> = (0..g).filter(|&i| root(&mut comp, i) == r).collect();
        if rows.is_empty() {
            continue;
        }
        // Small blocks of small entries only: cofactors multiply entries, so their size is
        // about the product of the entries' sizes.
        let terms = rows.iter().flat_map(|&i| rows.iter().map(move |&j| (i, j)));
        if rows.len() > 3
            || terms
                .into_iter()
                .any(|(i, j)| a[i][j].size() > BLOCK_ENTRY_TERMS)
        {
            return None;
        }
        let sub = |n: usize| Matrix::from_fn(n, n, |i, j| a[rows[i]][rows[j]].clone());
        let (inv, det) = sub(rows.len()).inverse().ok()??;
        let adj = (0..rows.len())
            .map(|i| {
                (0..rows.len())
                    .map(|j| entry(&(&inv[(i, j)] * &det)))
                    .collect()
            })
            .collect();
        let mut minors = (1..rows.len())
            .map(|n| sub(n).det().ok().map(|m| entry(&m)))
            .collect::<Option<Vec<_>>>()?;
        minors.push(entry(&det));
        out.push(crate::derivation::Block {
            rows,
            det: entry(&det),
            adj,
            minors,
        });
    }
    Some(out)
}

/// The largest number of terms an intermediate of the exact solution of A_Γ η̇ = b may have
/// before code generation gives it up (the normal form of η̇ puts everything over one
/// denominator, which is compact for small systems and explodes for coupled larger ones).
pub const SOLUTION_TERMS: usize = 400;

/// x with a x = b by exact Gaussian elimination (no pivoting: A_Γ is symmetric positive definite,
/// so its leading minors are not identically zero), or `None` when an intermediate grows over
/// `cap` terms or a division fails.
fn solve_capped(mut a: Vec<Vec<Ex>>, mut b: Vec<Ex>, cap: usize) -> Option<Vec<Ex>> {
    let g = b.len();
    let small = |e: &Ex| e.size() <= cap;
    if !a.iter().flatten().chain(&b).all(small) {
        return None;
    }
    // Products are formed only when the operands' sizes bound theirs by cap²/16 (lowest terms
    // of a larger product cost more than the whole solution is worth).
    let mul = |x: &Ex, y: &Ex| (x.size() * y.size() <= cap * cap / 16).then(|| x * y);
    for k in 0..g {
        for i in k + 1..g {
            if a[i][k].is_zero() {
                continue;
            }
            let f = mul(&a[i][k], &a[k][k].inv().ok()?)?;
            for j in k + 1..g {
                a[i][j] = &a[i][j] - &mul(&f, &a[k][j])?;
                small(&a[i][j]).then_some(())?;
            }
            b[i] = &b[i] - &mul(&f, &b[k])?;
            small(&b[i]).then_some(())?;
        }
    }
    let mut x = b.clone();
    for k in (0..g).rev() {
        let mut r = b[k].clone();
        for j in k + 1..g {
            r = &r - &mul(&a[k][j], &x[j])?;
            small(&r).then_some(())?;
        }
        x[k] = mul(&r, &a[k][k].inv().ok()?)?;
        small(&x[k]).then_some(())?;
    }
    Some(x)
}

/// The exact derivation of `model` for the choice `choice`. Must run on the CAS thread
/// (inside [`hamel_cas::run`]).
pub fn symbolic(model: &Model, choice: &str) -> Result<Symbolic, ModelError> {
    let choice = model.choice(Some(choice))?.clone();
    let ctx = Ctx { model };
    let (ell, mu, sigma) = (model.ell(), model.mu(), model.sigma());
    let eta_names: Vec<String> = (1..=sigma).map(|i| format!("eta{i}")).collect();
    let eta_dot_names: Vec<String> = (1..=sigma).map(|i| format!("eta{i}_dot")).collect();

    let mut expressions = Vec::new();
    match &model.kinetic {
        Kinetic::Energy(t) => expressions.push(t.expr.clone()),
        Kinetic::MassMatrix(rows) => {
            expressions.extend(rows.iter().flatten().map(|i| i.expr.clone()))
        }
    }
    expressions.push(model.potential.expr.clone());
    expressions.extend(model.constraints.iter().map(|(_, c)| c.expr.clone()));
    expressions.extend(choice.eta.iter().map(|e| e.expr.clone()));
    let spec = FieldSpec {
        coordinates: model.coordinates.clone(),
        parameters: model.parameters.keys().cloned().collect(),
        free_functions: choice.free_functions.clone(),
        free_order: 2,
        unknowns: eta_names.iter().chain(&eta_dot_names).cloned().collect(),
        expressions,
    };
    let f = Field::new(&spec).map_err(|e| ctx.cas(None, e))?;
    let half = f.rational(&1.into(), &2.into()).expect("1/2");

    // A, α, Z.
    let a = ctx.mass_matrix(&f)?;
    let mut alpha_rows = Vec::new();
    for (name, item) in &model.constraints {
        let c = f
            .convert(&item.expr)
            .map_err(|e| ctx.cas(Some(&item.site), e))?;
        alpha_rows.push(ctx.linear_row(&f, &c, &item.site, &format!("constraint `{name}`"))?);
    }
    let alpha = Matrix::from_fn(mu, ell, |i, j| alpha_rows[i][j].clone());
    if mu > 0 {
        let rank = alpha.rank().map_err(|e| ctx.cas(None, e))?;
        if rank < mu {
            let items: Vec<Item> = model.constraints.iter().map(|(_, i)| i.clone()).collect();
            return Err(model
                .error_at(&span_site("constraints".into(), &items), format!(
                    "the constraint matrix α is rank-deficient: rank {rank} < μ = {mu} (the constraints are not independent)"
                ))
                .with_help("remove the constraints that are combinations of the others"));
        }
    }
    let mut z_rows = Vec::new();
    for (i, item) in choice.eta.iter().enumerate() {
        let c = f
            .convert(&item.expr)
            .map_err(|e| ctx.cas(Some(&item.site), e))?;
        z_rows.push(ctx.linear_row(&f, &c, &item.site, &format!("quasi-velocity η{}", i + 1))?);
    }
    let z = Matrix::from_fn(sigma, ell, |i, j| z_rows[i][j].clone());

    // (4)–(5): [Z; α]⁻¹ = [Γ Θ], δ = det[Z; α].
    let m = if mu > 0 { z.vstack(&alpha) } else { z.clone() };
    let Some((minv, delta)) = m.inverse().map_err(|e| ctx.cas(None, e))? else {
        return Err(model
            .error_at(&span_site(format!("quasi_velocities.{}", choice.name), &choice.eta), "det[Z; α] is identically zero: these quasi-velocities are not independent of each other and of the constraints")
            .with_help("each η must add a direction of motion that the constraints and the other η's do not fix"));
    };
    let gamma = minv.columns(0, sigma);
    let theta = minv.columns(sigma, ell);

    let mut singular: Vec<Ex> = delta.numerator_factors();
    for e in gamma.entries() {
        for d in e.denominator_factors() {
            if !singular.contains(&d) {
                singular.push(d);
            }
        }
    }
    singular.sort_by_cached_key(|e| e.to_string());

    // Everything below is computed over the common denominator factors (see hamel_cas::over):
    // polynomial numerators, no gcd until the results are brought to lowest terms for output.
    let seeds: Vec<&Ex> = a
        .entries()
        .iter()
        .chain(alpha.entries())
        .chain(z.entries())
        .chain(gamma.entries())
        .chain(theta.entries())
        .collect();
    let dens = Denominators::new(&f, &seeds);
    let half = dens.over(&half);
    let sum = |terms: Vec<Over>| sum_over(&dens, terms);
    let a_o = OMatrix::from_matrix(&dens, &a);
    let alpha_o = OMatrix::from_matrix(&dens, &alpha);
    let z_o = OMatrix::from_matrix(&dens, &z);
    let gamma_o = OMatrix::from_matrix(&dens, &gamma);
    let theta_o = OMatrix::from_matrix(&dens, &theta);
    let gamma_t = gamma_o.transpose();
    let moves: Vec<bool> = (0..ell)
        .map(|k| (0..sigma).any(|s| !gamma_o[(k, s)].is_zero()))
        .collect();

    // (8)
    let a_gamma = gamma_t.mul(&a_o).mul(&gamma_o);
    let u = f
        .convert(&model.potential.expr)
        .map_err(|e| ctx.cas(Some(&model.potential.site), e))?;
    let u_o = dens.over(&u);
    let grad_u: Vec<Over> = (0..ell).map(|k| u_o.diff(k)).collect();
    let forcing: Vec<Over> = (0..sigma)
        .map(|i| sum((0..ell).map(|h| gamma_o[(h, i)].mul(&grad_u[h])).collect()))
        .collect();

    // True Q from (9): Q⁽ⁱ⁾_rs = sym[ Σ_k (Γᵀ ∂(AΓ)/∂q_k)_ir γ_ks − ½ Σ_j γ_ji (Γᵀ ∂A/∂q_j Γ)_rs ].
    let b_mat = a_o.mul(&gamma_o);
    let mut t1 = vec![OMatrix::zeros(&dens, sigma, sigma); sigma];
    for k in (0..ell).filter(|&k| moves[k]) {
        let db = b_mat.diff(k);
        if db.is_zero() {
            continue;
        }
        let g = gamma_t.mul(&db);
        for (i, t) in t1.iter_mut().enumerate() {
            for r in 0..sigma {
                if g[(i, r)].is_zero() {
                    continue;
                }
                for s in 0..sigma {
                    t[(r, s)] = t[(r, s)].add(&g[(i, r)].mul(&gamma_o[(k, s)]));
                }
            }
        }
    }
    let da: Vec<OMatrix> = (0..ell).map(|j| a_o.diff(j)).collect();
    for (j, d) in da.iter().enumerate() {
        if d.is_zero() || !(0..sigma).any(|i| !gamma_o[(j, i)].is_zero()) {
            continue;
        }
        let h = gamma_t.mul(d).mul(&gamma_o);
        for (i, t) in t1.iter_mut().enumerate() {
            let c = gamma_o[(j, i)].mul(&half);
            if c.is_zero() {
                continue;
            }
            for r in 0..sigma {
                for s in 0..sigma {
                    t[(r, s)] = t[(r, s)].sub(&c.mul(&h[(r, s)]));
                }
            }
        }
    }
    let q_true: Vec<OMatrix> = t1.iter().map(|t| sym(&dens, t, &half)).collect();

    // The paper's Q, (12)/(15), with the second and third terms summed over h only.
    let d_agamma: Vec<OMatrix> = (0..ell)
        .map(|h| {
            if moves[h] {
                a_gamma.diff(h)
            } else {
                OMatrix::zeros(&dens, sigma, sigma)
            }
        })
        .collect();
    let dz: Vec<OMatrix> = (0..ell).map(|k| z_o.diff(k)).collect();
    let mut qp = vec![OMatrix::zeros(&dens, sigma, sigma); sigma];
    for j in 0..sigma {
        // (C_j)_hk = ∂z_jh/∂q_k − ∂z_jk/∂q_h
        let c = OMatrix::from_fn(&dens, ell, ell, |h, k| dz[k][(j, h)].sub(&dz[h][(j, k)]));
        if c.is_zero() {
            continue;
        }
        let p = gamma_t.mul(&c).mul(&gamma_o);
        for (i, t) in qp.iter_mut().enumerate() {
            for r in 0..sigma {
                for s in 0..sigma {
                    t[(r, s)] = t[(r, s)].add(&a_gamma[(j, r)].mul(&p[(i, s)]));
                }
            }
        }
    }
    for (h, dh) in d_agamma.iter().enumerate() {
        if !moves[h] || dh.is_zero() {
            continue;
        }
        for (i, t) in qp.iter_mut().enumerate() {
            for r in 0..sigma {
                for s in 0..sigma {
                    let second = gamma_o[(h, s)].mul(&dh[(r, i)]);
                    let third = gamma_o[(h, i)].mul(&dh[(r, s)]).mul(&half);
                    t[(r, s)] = t[(r, s)].add(&second).sub(&third);
                }
            }
        }
    }
    let q_paper: Vec<OMatrix> = qp.iter().map(|t| sym(&dens, t, &half)).collect();

    // The correction Σ_m ν_m ΓᵀV_mΓη, ν = ΘᵀAΓη, (V_m)_hk = ∂α_mh/∂q_k − ∂α_mk/∂q_h.
    let nu = theta_o.transpose().mul(&a_o).mul(&gamma_o);
    let dalpha: Vec<OMatrix> = (0..ell).map(|k| alpha_o.diff(k)).collect();
    let mut qc = vec![OMatrix::zeros(&dens, sigma, sigma); sigma];
    for m_ in 0..mu {
        let v = OMatrix::from_fn(&dens, ell, ell, |h, k| {
            dalpha[k][(m_, h)].sub(&dalpha[h][(m_, k)])
        });
        if v.is_zero() {
            continue;
        }
        let rm = gamma_t.mul(&v).mul(&gamma_o);
        for (i, t) in qc.iter_mut().enumerate() {
            for r in 0..sigma {
                if nu[(m_, r)].is_zero() {
                    continue;
                }
                for s in 0..sigma {
                    t[(r, s)] = t[(r, s)].add(&nu[(m_, r)].mul(&rm[(i, s)]));
                }
            }
        }
    }
    let q_correction: Vec<OMatrix> = qc.iter().map(|t| sym(&dens, t, &half)).collect();

    // Exact checks.
    let split_identity =
        (0..sigma).all(|i| q_true[i].sub(&q_paper[i]).sub(&q_correction[i]).is_zero());
    let paper_is_exact = q_correction.iter().all(OMatrix::is_zero);
    let unknown = |n: &String| dens.over(&f.unknown(n).expect("declared symbol"));
    let eta: Vec<Over> = eta_names.iter().map(unknown).collect();
    let eta_dot: Vec<Over> = eta_dot_names.iter().map(unknown).collect();
    let quad = |m: &OMatrix, x: &[Over], y: &[Over]| {
        sum((0..m.rows())
            .flat_map(|r| (0..m.cols()).map(move |s| (r, s)))
            .filter(|&(r, s)| !m[(r, s)].is_zero())
            .map(|(r, s)| m[(r, s)].mul(&x[r]).mul(&y[s]))
            .collect())
    };
    let q_eta: Vec<Over> = q_true.iter().map(|m| quad(m, &eta, &eta)).collect();
    let q_eta_paper: Vec<Over> = q_paper.iter().map(|m| quad(m, &eta, &eta)).collect();
    let gamma_eta: Vec<Over> = (0..ell)
        .map(|k| sum((0..sigma).map(|s| gamma_o[(k, s)].mul(&eta[s])).collect()))
        .collect();
    // dE/dt = −ηᵀQ(η) + ½ Σ_k (Γη)_k ηᵀ ∂A_Γ/∂q_k η along (11); the forcing terms cancel exactly.
    let gyro = sum((0..ell)
        .filter(|&k| moves[k])
        .map(|k| gamma_eta[k].mul(&quad(&d_agamma[k], &eta, &eta)).mul(&half))
        .collect());
    let energy_rate =
        |qe: &[Over]| gyro.sub(&sum((0..sigma).map(|i| eta[i].mul(&qe[i])).collect()));
    let energy_conserved = energy_rate(&q_eta).is_zero();
    let energy_conserved_paper = energy_rate(&q_eta_paper).is_zero();
    let euler_lagrange = (mu == 0 && z.sub(&Matrix::identity(&f, ell)).is_zero()).then(|| {
        (0..ell).all(|i| {
            (0..ell).all(|r| {
                (0..ell).all(|s| {
                    // Christoffel symbol of the first kind.
                    let christoffel = da[s][(i, r)]
                        .add(&da[r][(i, s)])
                        .sub(&da[i][(r, s)])
                        .mul(&half);
                    q_true[i][(r, s)].sub(&christoffel).is_zero()
                })
            })
        })
    });

    let energy = quad(&a_gamma, &eta, &eta).mul(&half).sub(&u_o);
    Ok(Symbolic {
        field: f.clone(),
        dens: dens.clone(),
        a,
        alpha,
        z,
        gamma,
        theta,
        delta,
        singular,
        u,
        a_gamma,
        grad_u,
        forcing,
        nu,
        q_true,
        q_paper,
        q_correction,
        eta,
        eta_dot,
        gamma_eta,
        q_eta,
        q_eta_paper,
        energy,
        checks: Checks {
            split_identity,
            energy_conserved,
            energy_conserved_paper,
            paper_is_exact,
            euler_lagrange,
        },
        model: model.clone(),
        choice,
    })
}
