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
use hamel_expr::Expr;
use hamel_model::{Item, Kinetic, Model, QuasiVelocityChoice, Site};

use crate::error::DeriveError;

use crate::certify::Certificate;
use crate::dependence::{Dependence, OnManifold};
use crate::derivation::{
    Checks, Closed, Derivation, Entry, Form, Ingredients, Mat, StructuredForm, Trees, Why,
};
use crate::progress::Stage;

/// An exact value as plain data (canonical text, tree, and the polynomials the tree is
/// written from).
pub fn entry(e: &Ex) -> Entry {
    Entry::of_canonical(e.to_canonical())
}

fn entry_over(e: &Over) -> Entry {
    Entry::of_canonical(e.to_canonical())
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
    /// A CAS error while working on `site`: the input's (division by zero, a construct the
    /// engine does not handle), located there; or the engine's own failure, typed as such.
    fn cas(&self, site: Option<&Site>, e: CasError) -> DeriveError {
        DeriveError::cas(site, e)
    }

    /// The coefficients of an expression that must be linear and homogeneous in the
    /// velocities: c = Σ_j row_j der(q_j), exactly.
    fn linear_row(
        &self,
        f: &Field,
        c: &Ex,
        site: &Site,
        what: &str,
    ) -> Result<Vec<Ex>, DeriveError> {
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
            return Err(DeriveError::NotLinear {
                site: site.clone(),
                what: what.to_string(),
                detail,
            });
        }
        Ok(row)
    }

    /// The generalised forces F of the model, converted (empty when it has none).
    fn forces(&self, f: &Field) -> Result<Vec<Ex>, DeriveError> {
        if !self.model.has_forces() {
            return Ok(Vec::new());
        }
        self.model
            .forces
            .iter()
            .map(|i| f.convert(&i.expr).map_err(|e| self.cas(Some(&i.site), e)))
            .collect()
    }

    /// F(q, Γη): the forces with the velocities q̇ = Γη put in, converted (empty without
    /// forces; F itself when it has no velocities). `Ok(Err(reason))` when the result leaves
    /// the field (a velocity inside a square root or an exponential).
    fn forces_along(
        &self,
        f: &Field,
        gamma: &Matrix,
    ) -> Result<Result<Vec<Ex>, String>, DeriveError> {
        let written = self.forces(f)?;
        if !self.model.has_velocity_forces() {
            return Ok(Ok(written));
        }
        let eta: Vec<Expr> = eta_names(gamma.cols()).map(|n| Expr::sym(&n)).collect();
        let rate = |k: usize| -> Expr {
            let terms: Vec<Expr> = (0..gamma.cols())
                .filter(|&s| !gamma[(k, s)].is_zero())
                .map(|s| Expr::Mul(vec![entry(&gamma[(k, s)]).expr, eta[s].clone()]))
                .collect();
            if terms.is_empty() {
                Expr::int(0)
            } else {
                Expr::Add(terms)
            }
        };
        let rates: Vec<Expr> = (0..gamma.rows()).map(rate).collect();
        let coords = &self.model.coordinates;
        let mut out = Vec::with_capacity(written.len());
        for item in &self.model.forces {
            let put = item.expr.map(&mut |n| match n {
                Expr::Der(q) => match coords.iter().position(|c| *c == q) {
                    Some(k) => rates[k].clone(),
                    None => Expr::Der(q),
                },
                other => other,
            });
            match f.convert(&put) {
                Ok(e) => out.push(e),
                Err(e @ CasError::Internal(_)) => return Err(DeriveError::Engine(e)),
                Err(e) => return Ok(Err(e.to_string())),
            }
        }
        Ok(Ok(out))
    }

    fn mass_matrix(&self, f: &Field) -> Result<Matrix, DeriveError> {
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
                    return Err(DeriveError::NotQuadratic {
                        site: t.site.clone(),
                        detail,
                    });
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
                            return Err(DeriveError::NotSymmetric {
                                site: rows[i][j].site.clone(),
                                row: i + 1,
                                column: j + 1,
                            });
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
    /// The generalised forces F (empty without `[forces]`).
    pub forces: Vec<Over>,
    /// Γᵀ(∇U + F).
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
    /// (Γη)ᵀF(q, Γη), the forces' power (None without forces).
    pub power: Option<Over>,
    /// Exact checks.
    pub checks: Checks,
    /// The model's dropped rows, each a combination of α's rows.
    pub dependence: Vec<Dependence>,
    /// The factors of δ at which α's kept rows lose rank, with their powers in δ.
    pub rank_loss: Vec<(Ex, u32)>,
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
        let to_list = |v: &[Over]| -> Vec<Entry> { v.iter().map(entry_over).collect() };
        let to_mats = |v: &[OMatrix]| -> Vec<Mat> { v.iter().map(mat_over).collect() };
        let dependent = dependent_rows(&self.dependence, model.ell());
        derivation(
            model,
            choice,
            Computed {
                field: &self.field,
                dependence: &self.dependence,
                rank_loss: &self.rank_loss,
                a: mat(&self.a),
                alpha: mat(&self.alpha),
                z: mat(&self.z),
                grad_u: to_list(&self.grad_u),
                forces: to_list(&self.forces),
                form: Form::Closed(Box::new(Closed {
                    gamma: mat(&self.gamma),
                    theta: mat(&self.theta),
                    delta: entry(&self.delta),
                    singular_set: self.singular.iter().map(entry).collect(),
                    a_gamma: mat_over(&self.a_gamma),
                    forcing: to_list(&self.forcing),
                    nu: mat_over(&self.nu),
                    q: to_mats(&self.q_true),
                    q_paper: to_mats(&self.q_paper),
                    q_correction: to_mats(&self.q_correction),
                    kinematics: to_list(&self.gamma_eta),
                    equations: to_list(&self.lhs(&self.q_eta)),
                    equations_paper: to_list(&self.lhs(&self.q_eta_paper)),
                    energy: entry_over(&self.energy),
                    power: self.power.as_ref().map(entry_over),
                    checks: self.checks.clone(),
                })),
                ingredients: Ingredients {
                    potential: Some(entry(&self.u)),
                    applied: Some(applied_trees(model)),
                    forces: written_forces(model),
                    velocity_forces: model.has_velocity_forces(),
                    trees: None,
                    da: (0..model.ell()).map(|k| mat(&self.a.diff(k))).collect(),
                    dz: (0..model.ell()).map(|k| mat(&self.z.diff(k))).collect(),
                    dalpha: (0..model.ell()).map(|k| mat(&self.alpha.diff(k))).collect(),
                    dependent: dependent.as_ref().map(mat),
                    ddependent: (dependent.iter())
                        .flat_map(|m| (0..model.ell()).map(|k| mat(&m.diff(k))))
                        .collect(),
                    eta_rhs: Vec::new(),
                    eta_dot: None,
                    blocks: None,
                },
            },
        )
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

/// Which form of the equations a derivation computes.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum FormRequest {
    /// The closed form when exact elimination of [Z; α] stays within its budget
    /// ([`hamel_cas::linalg::ELIMINATION_WORK`]), else the structured form.
    #[default]
    Auto,
    /// The closed form, or an error when exact elimination of [Z; α] outgrows its budget
    /// (however large the equations are).
    Closed,
    /// As [`FormRequest::Auto`], without [`CLOSED_FORM_TERMS`]: the closed form whenever exact
    /// elimination succeeds, however long (`hamel search`, whose exact checks decide on it
    /// within the search's own wall-clock budget).
    AutoExact,
    /// The structured form: the ingredients only.
    Structured,
}

/// A derivation on the CAS thread, in the form computed.
pub enum Derived {
    /// Closed form: every object canonical.
    Closed(Box<Symbolic>),
    /// Structured form: the ingredients canonical, [Z; α] certified nonsingular at a point.
    Structured(Box<StructuredSymbolic>),
}

impl Derived {
    /// Plain data; `code` adds what code generation simplifies with (closed form only).
    pub fn to_derivation(&self, code: bool) -> Derivation {
        match self {
            Derived::Closed(s) if code => s.to_derivation_for_code(),
            Derived::Closed(s) => s.to_derivation(),
            Derived::Structured(s) => s.to_derivation(),
        }
    }
}

/// The exact ingredients of a structured derivation: A, α, Z, U in canonical form, and the
/// certificate that [Z; α] is nonsingular somewhere.
pub struct StructuredSymbolic {
    /// The field of the expressions.
    pub field: Field,
    /// A (ℓ×ℓ).
    pub a: Matrix,
    /// α (μ×ℓ).
    pub alpha: Matrix,
    /// Z (σ×ℓ).
    pub z: Matrix,
    /// U.
    pub u: Ex,
    /// The generalised forces F (empty without `[forces]`).
    pub forces: Vec<Ex>,
    /// Why the closed form was not computed.
    pub why: Why,
    /// Where [Z; α] is certainly nonsingular.
    pub certificate: Certificate,
    /// The model's dropped rows, each a combination of α's rows.
    pub dependence: Vec<Dependence>,
    model: Model,
    choice: QuasiVelocityChoice,
}

impl StructuredSymbolic {
    /// Plain data: the ingredients, and the structured form with its certificate. The
    /// derivatives ∂A/∂q_k, ∂Z/∂q_k, ∂α/∂q_k, ∇U are taken on the trees of the canonical forms
    /// ([`Expr::diff`]): exact, and evaluated numerically only, so they need no lowest terms
    /// (which cost seconds per entry in a field with square-root kernels).
    pub fn to_derivation(&self) -> Derivation {
        let (model, choice) = (&self.model, &self.choice);
        let ell = model.ell();
        let trees = model_trees(model, choice);
        let d = |m: &Mat, k: usize| m.map_entries(|e| tree_diff(e, &model.coordinates[k]));
        let dependent = dependent_trees(model);
        let ingredients = Ingredients {
            potential: Some(entry(&self.u)),
            applied: None,
            forces: written_forces(model),
            velocity_forces: model.has_velocity_forces(),
            da: (0..ell).map(|k| d(&trees.a, k)).collect(),
            dz: (0..ell).map(|k| d(&trees.z, k)).collect(),
            dalpha: (0..ell).map(|k| d(&trees.alpha, k)).collect(),
            ddependent: match &dependent {
                Some(m) => (0..ell).map(|k| d(m, k)).collect(),
                None => Vec::new(),
            },
            dependent,
            trees: Some(trees),
            eta_rhs: Vec::new(),
            eta_dot: None,
            blocks: None,
        };
        let u = entry(&self.u);
        derivation(
            model,
            choice,
            Computed {
                field: &self.field,
                dependence: &self.dependence,
                rank_loss: &[],
                grad_u: (0..ell)
                    .map(|k| tree_diff(&u, &model.coordinates[k]))
                    .collect(),
                a: mat(&self.a),
                alpha: mat(&self.alpha),
                z: mat(&self.z),
                forces: self.forces.iter().map(entry).collect(),
                form: Form::Structured(StructuredForm {
                    structured: self.why.clone(),
                    certificate: self.certificate.clone(),
                }),
                ingredients,
            },
        )
    }
}

/// The plain data of a dependence, with the kept rows' names: the nonzero terms.
fn plain_dependence(d: &Dependence, kept: &[String]) -> crate::derivation::Dependent {
    crate::derivation::Dependent {
        name: d.name.clone(),
        row: d.row.iter().map(entry).collect(),
        combination: (kept.iter().zip(&d.coefficients))
            .filter(|(_, c)| !c.is_zero())
            .map(|(name, c)| crate::derivation::Term {
                row: name.clone(),
                coefficient: entry(c),
            })
            .collect(),
        singular: d.rank_loss_factors().iter().map(entry).collect(),
        on_manifold: d.on.clone(),
    }
}

/// The dependent rows' entries as a matrix (None without them).
fn dependent_rows(dependence: &[Dependence], ell: usize) -> Option<Matrix> {
    (!dependence.is_empty())
        .then(|| Matrix::from_fn(dependence.len(), ell, |i, j| dependence[i].row[j].clone()))
}

/// The model's dependent rows as trees: the coefficients of the velocities in the rows as
/// written (None without them).
fn dependent_trees(model: &Model) -> Option<Mat> {
    (!model.dependent.is_empty()).then(|| {
        velocity_rows(
            &model.coordinates,
            &mut model.dependent.iter().map(|d| &d.item.expr),
        )
    })
}

/// Rows linear in the velocities as the matrix of their coefficients (one column per
/// coordinate), on the rows' trees.
fn velocity_rows(coords: &[String], items: &mut dyn Iterator<Item = &Expr>) -> Mat {
    let entries: Vec<Vec<Entry>> = items
        .map(|e| {
            (coords.iter())
                .map(|q| Entry::of(e.velocity_coefficient(q)))
                .collect()
        })
        .collect();
    Mat {
        rows: entries.len(),
        cols: coords.len(),
        entries,
    }
}

/// The model's own trees of the ingredients ([`Trees`]): A as written (a model of bodies gives
/// it entry by entry, built frame by frame) or the second velocity derivatives of T's tree; α
/// and Z the velocity coefficients of the rows as written; U and ∇U on U's tree. The canonical
/// forms of the derivation are the conversions of these same rows (checked linear there), so
/// the two are equal.
fn model_trees(model: &Model, choice: &QuasiVelocityChoice) -> Trees {
    let coords = &model.coordinates;
    let matrix = |entries: Vec<Vec<Entry>>| Mat {
        rows: entries.len(),
        cols: coords.len(),
        entries,
    };
    let rows = |items: &mut dyn Iterator<Item = &Expr>| velocity_rows(coords, items);
    let a = match &model.kinetic {
        Kinetic::MassMatrix(m) => m
            .iter()
            .map(|r| r.iter().map(|i| Entry::of(i.expr.clone())).collect())
            .collect(),
        Kinetic::Energy(t) => coords
            .iter()
            .map(|qi| {
                let row = t.expr.velocity_coefficient(qi);
                coords
                    .iter()
                    .map(|qj| Entry::of(row.velocity_coefficient(qj)))
                    .collect()
            })
            .collect(),
    };
    let u = Entry::of(model.potential.expr.clone());
    Trees {
        a: matrix(a),
        alpha: rows(&mut model.constraints.iter().map(|(_, i)| &i.expr)),
        z: rows(&mut choice.eta.iter().map(|i| &i.expr)),
        grad_u: applied_trees(model),
        u,
    }
}

/// ∇U on U's tree, plus the forces as written when they do not depend on the velocities: what
/// the numeric evaluation reads in ∇U's place. The tree's derivative is exact like the
/// canonical gradient, and better conditioned where the canonical form expands a square
/// (a spring of rest length d₀ near d = 0: k(d² − d₀√(d²))/d with d² expanded loses the digits
/// of d², its tree keeps them).
fn applied_trees(model: &Model) -> Vec<Entry> {
    let u = Entry::of(model.potential.expr.clone());
    let with_forces = !model.has_velocity_forces();
    (model.coordinates.iter().zip(&model.forces))
        .map(|(q, force)| {
            let g = tree_diff(&u, q).expr;
            match with_forces && force.expr != Expr::int(0) {
                true => Entry::of(hamel_expr::build::add(g, force.expr.clone())),
                false => Entry::of(g),
            }
        })
        .collect()
}

/// The model's forces as written (None without forces), for numeric evaluation at (q, q̇).
fn written_forces(model: &Model) -> Option<Vec<Entry>> {
    model.has_forces().then(|| {
        model
            .forces
            .iter()
            .map(|f| Entry::of(f.expr.clone()))
            .collect()
    })
}

/// What a derivation adds to the model's and the choice's own data.
struct Computed<'d> {
    field: &'d Field,
    dependence: &'d [Dependence],
    rank_loss: &'d [(Ex, u32)],
    a: Mat,
    alpha: Mat,
    z: Mat,
    grad_u: Vec<Entry>,
    forces: Vec<Entry>,
    form: Form,
    ingredients: Ingredients,
}

/// The plain-data derivation of `model` for `choice` with `parts`.
fn derivation(model: &Model, choice: &QuasiVelocityChoice, parts: Computed) -> Derivation {
    let kept: Vec<String> = model.constraints.iter().map(|(n, _)| n.clone()).collect();
    let force_uniqueness =
        crate::uniqueness::decide(parts.field, &model.contact_forces, &kept, parts.dependence);
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
        abbreviations: model
            .abbreviations
            .iter()
            .map(|(k, i)| (k.clone(), Entry::of(i.expr.clone())))
            .collect(),
        positive: model.positive.clone(),
        coordinates: model.coordinates.clone(),
        parameters: model.parameters.clone(),
        live: model.live.clone(),
        ell: model.ell(),
        mu: model.mu(),
        sigma: model.sigma(),
        a: parts.a,
        alpha: parts.alpha,
        z: parts.z,
        grad_u: parts.grad_u,
        forces: parts.forces,
        dependent_rows: (parts.dependence.iter())
            .map(|d| plain_dependence(d, &kept))
            .collect(),
        constraints: kept,
        kept_rank_loss: (parts.rank_loss.iter())
            .map(|(f, m)| crate::derivation::Power {
                factor: entry(f),
                power: *m,
            })
            .collect(),
        holonomic: model
            .holonomic
            .iter()
            .map(|c| crate::derivation::Holonomic {
                name: c.name.clone(),
                h: Entry::of(c.h.clone()),
                dependent: model
                    .coordinates
                    .iter()
                    .position(|q| *q == c.dependent)
                    .expect("the model checked its dependent coordinates"),
            })
            .collect(),
        form: parts.form,
        ingredients: parts.ingredients,
        force_uniqueness,
        contact_forces: model.contact_forces.clone(),
    }
}

/// ∂e/∂x on e's tree. The trees of canonical forms of A, α, Z and U hold no velocities, so
/// the derivative exists; a velocity would be a bug upstream, kept visible as a symbol that
/// evaluation rejects.
fn tree_diff(e: &Entry, x: &str) -> Entry {
    Entry::of(
        e.expr
            .diff(x)
            .unwrap_or_else(|err| Expr::sym(&format!("<{err}>"))),
    )
}

/// A, α and Z of a derivation that has begun: converted, checked, α of full rank.
struct Begun {
    choice: QuasiVelocityChoice,
    f: Field,
    a: Matrix,
    alpha: Matrix,
    z: Matrix,
    dependence: Vec<Dependence>,
    /// The holonomic constraint's manifold, where dependences were looked for off it.
    manifold: Option<OnManifold>,
    stage: Stage,
}

fn begin(model: &Model, choice: &str) -> Result<Begun, DeriveError> {
    let choice = model.choice(Some(choice))?.clone();
    let ctx = Ctx { model };
    let stage = Stage::start(&model.name, "A, α and Z in canonical form, rank of α");
    let f = field(&ctx, &choice)?;
    let (a, alpha, z) = ctx.matrices(&f, &choice)?;
    let manifold = (!model.dependent.is_empty() && !model.holonomic.is_empty())
        .then(|| crate::dependence::on_manifold(model, &f));
    let dependence = ctx.dependences(&f, &alpha, manifold.as_ref())?;
    Ok(Begun {
        choice,
        f,
        a,
        alpha,
        z,
        dependence,
        manifold,
        stage,
    })
}

/// The exact derivation of `model` for the choice `choice` in closed form; an error when the
/// exact inverse of [Z; α] outgrows its budget. Must run on the CAS thread (inside
/// [`hamel_cas::run`]).
pub fn symbolic(model: &Model, choice: &str) -> Result<Symbolic, DeriveError> {
    let mut b = begin(model, choice)?;
    let ctx = Ctx { model };
    b.stage
        .next("[Z; α]⁻¹ = [Γ Θ], δ and the singular set (4)–(6)");
    match ctx.inverse(&b.z, &b.alpha, &b.choice)? {
        Ok(inverse) => match closed(model, b, inverse, usize::MAX)? {
            Ok(s) => Ok(s),
            Err((_, why)) => Err(DeriveError::ClosedFormUnavailable {
                why: why.to_string(),
            }),
        },
        Err(work) => Err(DeriveError::ClosedFormTooLarge { work }),
    }
}

/// The derivation of `model` for `choice` in the form `request` asks for. Must run on the CAS
/// thread.
pub fn derive_form(
    model: &Model,
    choice: &str,
    request: FormRequest,
) -> Result<Derived, DeriveError> {
    let ctx = Ctx { model };
    match request {
        FormRequest::Closed => return Ok(Derived::Closed(Box::new(symbolic(model, choice)?))),
        FormRequest::Structured => {
            let b = begin(model, choice)?;
            return structured(&ctx, b, Why::Requested);
        }
        FormRequest::Auto | FormRequest::AutoExact => {}
    }
    let limit = match request {
        FormRequest::Auto => CLOSED_FORM_TERMS,
        _ => usize::MAX,
    };
    let mut b = begin(model, choice)?;
    b.stage
        .next("[Z; α]⁻¹ = [Γ Θ], δ and the singular set (4)–(6)");
    match ctx.inverse(&b.z, &b.alpha, &b.choice)? {
        Ok(inverse) => match closed(model, b, inverse, limit)? {
            Ok(s) => Ok(Derived::Closed(Box::new(s))),
            Err((b, why)) => structured(&ctx, b, why),
        },
        Err(terms) => structured(&ctx, b, Why::TooLarge(terms)),
    }
}

/// The structured form: U converted, and [Z; α] certified nonsingular at a point.
fn structured(ctx: &Ctx, mut b: Begun, why: Why) -> Result<Derived, DeriveError> {
    let model = ctx.model;
    if let Some(d) = b.dependence.iter().find(|d| d.on.is_some()) {
        return Err(DeriveError::ManifoldDependenceStructured {
            row: d.name.clone(),
            why: why.to_string(),
        });
    }
    b.stage
        .next("[Z; α] certified nonsingular at a point (interval arithmetic)");
    let rows: Vec<Vec<Expr>> = (0..b.z.rows())
        .map(|i| (0..b.z.cols()).map(|j| b.z[(i, j)].to_expr()).collect())
        .chain((0..b.alpha.rows()).map(|i| {
            (0..b.alpha.cols())
                .map(|j| b.alpha[(i, j)].to_expr())
                .collect()
        }))
        .collect();
    let refs: Vec<Vec<&Expr>> = rows.iter().map(|r| r.iter().collect()).collect();
    let Some(certificate) = crate::certify::full_rank(&refs, &model.coordinates, &model.parameters)
    else {
        return Err(DeriveError::Uncertified {
            site: span_site(format!("quasi_velocities.{}", b.choice.name), &b.choice.eta),
            attempts: crate::certify::ATTEMPTS,
        });
    };
    let u =
        b.f.convert(&model.potential.expr)
            .map_err(|e| ctx.cas(Some(&model.potential.site), e))?;
    let forces = ctx.forces(&b.f)?;
    Ok(Derived::Structured(Box::new(StructuredSymbolic {
        field: b.f,
        a: b.a,
        alpha: b.alpha,
        z: b.z,
        u,
        forces,
        why,
        certificate,
        dependence: b.dependence,
        model: model.clone(),
        choice: b.choice,
    })))
}

/// Everything from Γ on, in closed form ((8), (9)/(11), (12)/(15), the correction, the checks).
/// The largest closed form computed, in terms of the numerators of A_Γ, Γᵀ(∇U + F) and the
/// Q⁽ⁱ⁾ of the true equations together (the unicycle with a rider, hamel's largest bundled
/// closed form, has about 9,500 for its `family` choice). Bringing the equations to lowest terms for output costs more than
/// linearly in it: a random model of 4 coordinates with 150,000 terms took minutes. Past the
/// budget, [`FormRequest::Auto`] derives the structured form.
pub const CLOSED_FORM_TERMS: usize = 30_000;

/// The closed form from A, α, Z and [Z; α]⁻¹, or (when its equations outgrow the limit, in
/// terms, or the forces leave its field) what it began from, and why.
type ClosedOrBegun = Result<Symbolic, (Begun, Why)>;

fn closed(
    model: &Model,
    b: Begun,
    inverse: (Matrix, Matrix, Ex),
    limit: usize,
) -> Result<ClosedOrBegun, DeriveError> {
    let ctx = Ctx { model };
    let Begun {
        choice,
        f,
        a,
        alpha,
        z,
        dependence,
        manifold,
        mut stage,
    } = b;
    let (gamma, theta, delta) = inverse;
    crate::dependence::check_delta(model, &dependence, manifold.as_ref(), &delta)?;
    let singular = singular_set(&delta, &gamma);
    stage.next("common denominators, ∂A/∂q");
    // Everything below is computed over the common denominator factors (see hamel_cas::over):
    // polynomial numerators, no gcd until the results are brought to lowest terms for output.
    let o = Parts::new(&f, &a, &alpha, &z, &gamma, &theta);
    stage.next("A_Γ (8) and Γᵀ∇U");
    let (ell, sigma) = (o.ell, o.sigma);
    // (8)
    let a_gamma = o.gamma_t.mul(&o.a).mul(&o.gamma);
    let u = f
        .convert(&model.potential.expr)
        .map_err(|e| ctx.cas(Some(&model.potential.site), e))?;
    let u_o = o.dens.over(&u);
    let grad_u: Vec<Over> = (0..ell).map(|k| u_o.diff(k)).collect();
    let forces: Vec<Over> = ctx.forces(&f)?.iter().map(|e| o.dens.over(e)).collect();
    // F(q, Γη): the forces along the motion
    let along = match ctx.forces_along(&f, &gamma)? {
        Ok(v) => v.iter().map(|e| o.dens.over(e)).collect::<Vec<Over>>(),
        Err(why) => {
            let b = Begun {
                choice,
                f,
                a,
                alpha,
                z,
                dependence,
                manifold,
                stage,
            };
            return Ok(Err((b, Why::VelocityForces(why))));
        }
    };
    // Γᵀ(∇U + F)
    let applied: Vec<Over> = match along.is_empty() {
        true => grad_u.clone(),
        false => grad_u.iter().zip(&along).map(|(g, x)| g.add(x)).collect(),
    };
    let forcing: Vec<Over> = (0..sigma)
        .map(|i| o.sum((0..ell).map(|h| o.gamma[(h, i)].mul(&applied[h])).collect()))
        .collect();
    stage.next("Q⁽ⁱ⁾ of the true equations (9)/(11)");
    let q_true = o.q_true();
    let terms = a_gamma.size()
        + forcing.iter().map(Over::size).sum::<usize>()
        + q_true.iter().map(OMatrix::size).sum::<usize>();
    if terms > limit {
        let b = Begun {
            choice,
            f,
            a,
            alpha,
            z,
            dependence,
            manifold,
            stage,
        };
        return Ok(Err((b, Why::ClosedTooLarge(terms))));
    }
    stage.next("the paper's Q⁽ⁱ⁾ (15) and the correction");
    let d_agamma: Vec<OMatrix> = (0..ell)
        .map(|h| {
            if o.moves[h] {
                a_gamma.diff(h)
            } else {
                OMatrix::zeros(&o.dens, sigma, sigma)
            }
        })
        .collect();
    let q_paper = o.q_paper(&a_gamma, &d_agamma);
    let (nu, q_correction) = o.q_correction();
    stage.next("the equations along η and the exact checks");
    let ev = o.along_eta(&f, &q_true, &q_paper, &d_agamma);
    let work = Work::of(&ev, &along, &model.coordinates);
    let rate = ev.energy_rate(&ev.q_eta);
    let checks = Checks {
        split_identity: (0..sigma)
            .all(|i| q_true[i].sub(&q_paper[i]).sub(&q_correction[i]).is_zero()),
        energy_conserved: work.conserved(&rate),
        energy_conserved_paper: work.conserved(&ev.energy_rate(&ev.q_eta_paper)),
        energy_balance: work.power.as_ref().map(|_| rate.is_zero()),
        working_forces: work.working.clone(),
        paper_is_exact: q_correction.iter().all(OMatrix::is_zero),
        euler_lagrange: o.euler_lagrange(&f, &z, &q_true),
    };
    let energy = quadratic_form(&ev.dens, &ev.eta, &a_gamma)
        .mul(&o.half)
        .sub(&u_o);
    let rank_loss = crate::dependence::rank_loss(&dependence, &delta);
    Ok(Ok(Symbolic {
        field: f.clone(),
        dens: o.dens.clone(),
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
        forces,
        forcing,
        nu,
        q_true,
        q_paper,
        q_correction,
        eta: ev.eta,
        eta_dot: ev.eta_dot,
        gamma_eta: ev.gamma_eta,
        q_eta: ev.q_eta,
        q_eta_paper: ev.q_eta_paper,
        energy,
        power: work.power,
        checks,
        rank_loss,
        dependence,
        model: model.clone(),
        choice,
    }))
}

/// The work the forces do along the motion: their power (Γη)ᵀF(q, Γη) and the coordinates
/// whose force does work.
struct Work {
    power: Option<Over>,
    working: Vec<String>,
}

impl Work {
    fn of(ev: &AlongEta, along: &[Over], coordinates: &[String]) -> Work {
        if along.is_empty() {
            return Work {
                power: None,
                working: Vec::new(),
            };
        }
        let terms: Vec<Over> = (ev.gamma_eta.iter().zip(along))
            .map(|(v, f)| v.mul(f))
            .collect();
        let working = (coordinates.iter().zip(&terms))
            .filter(|(_, t)| !t.is_zero())
            .map(|(q, _)| q.clone())
            .collect();
        Work {
            power: Some(sum_over(&ev.dens, terms)),
            working,
        }
    }

    /// Whether dE/dt = rate + power vanishes identically (`rate`: what Q contributes).
    fn conserved(&self, rate: &Over) -> bool {
        match &self.power {
            Some(p) => rate.add(p).is_zero(),
            None => rate.is_zero(),
        }
    }
}

/// The field of the model's expressions: its coordinates, parameters, the choice's free
/// functions (to second order), and η₁…η_σ, η̇₁…η̇_σ as plain symbols.
fn field(ctx: &Ctx, choice: &QuasiVelocityChoice) -> Result<Field, DeriveError> {
    let model = ctx.model;
    let sigma = model.sigma();
    let mut expressions = Vec::new();
    match &model.kinetic {
        Kinetic::Energy(t) => expressions.push(t.expr.clone()),
        Kinetic::MassMatrix(rows) => {
            expressions.extend(rows.iter().flatten().map(|i| i.expr.clone()))
        }
    }
    expressions.push(model.potential.expr.clone());
    expressions.extend(model.forces.iter().map(|i| i.expr.clone()));
    expressions.extend(model.constraints.iter().map(|(_, c)| c.expr.clone()));
    expressions.extend(model.dependent.iter().map(|d| d.item.expr.clone()));
    if !model.dependent.is_empty() {
        // Where a dropped row may depend on the kept ones on h = 0 only (dependence.rs).
        expressions.extend(model.holonomic.iter().map(|h| h.h.clone()));
    }
    expressions.extend(choice.eta.iter().map(|e| e.expr.clone()));
    expressions.extend(
        model
            .symmetries
            .iter()
            .flat_map(|s| s.components.iter().map(|(_, i)| i.expr.clone())),
    );
    let spec = FieldSpec {
        coordinates: model.coordinates.clone(),
        parameters: model.parameters.keys().cloned().collect(),
        free_functions: choice.free_functions.clone(),
        free_order: 2,
        unknowns: eta_names(sigma).chain(eta_dot_names(sigma)).collect(),
        expressions,
    };
    Field::new(&spec).map_err(|e| ctx.cas(None, e))
}

fn eta_names(sigma: usize) -> impl Iterator<Item = String> {
    (1..=sigma).map(|i| format!("eta{i}"))
}

fn eta_dot_names(sigma: usize) -> impl Iterator<Item = String> {
    (1..=sigma).map(|i| format!("eta{i}_dot"))
}

/// The singular set of the choice: the factors of δ and of Γ's denominators, sorted by text.
fn singular_set(delta: &Ex, gamma: &Matrix) -> Vec<Ex> {
    let mut singular: Vec<Ex> = delta.numerator_factors();
    for e in gamma.entries() {
        for d in e.denominator_factors() {
            if !singular.contains(&d) {
                singular.push(d);
            }
        }
    }
    singular.sort_by_cached_key(|e| e.to_string());
    singular
}

impl Ctx<'_> {
    /// A, α (checked of full rank μ) and Z, each row checked linear and homogeneous in q̇.
    fn matrices(
        &self,
        f: &Field,
        choice: &QuasiVelocityChoice,
    ) -> Result<(Matrix, Matrix, Matrix), DeriveError> {
        let model = self.model;
        let (ell, mu, sigma) = (model.ell(), model.mu(), model.sigma());
        let a = self.mass_matrix(f)?;
        let mut alpha_rows = Vec::new();
        for (name, item) in &model.constraints {
            let c = f
                .convert(&item.expr)
                .map_err(|e| self.cas(Some(&item.site), e))?;
            alpha_rows.push(self.linear_row(f, &c, &item.site, &format!("constraint `{name}`"))?);
        }
        let alpha = Matrix::from_fn(mu, ell, |i, j| alpha_rows[i][j].clone());
        if mu > 0 && !self.certified_full_rank(&alpha) {
            let rank = match alpha.rank() {
                Err(CasError::TooLarge(work)) => {
                    return Err(DeriveError::RankUndecided {
                        attempts: crate::certify::ATTEMPTS,
                        work,
                    });
                }
                other => other.map_err(|e| self.cas(None, e))?,
            };
            if rank < mu {
                let items: Vec<Item> = model.constraints.iter().map(|(_, i)| i.clone()).collect();
                return Err(DeriveError::RankDeficient {
                    site: span_site("constraints".into(), &items),
                    rank,
                    mu,
                });
            }
        }
        let mut z_rows = Vec::new();
        for (i, item) in choice.eta.iter().enumerate() {
            let c = f
                .convert(&item.expr)
                .map_err(|e| self.cas(Some(&item.site), e))?;
            let what = format!("quasi-velocity η{}", i + 1);
            z_rows.push(self.linear_row(f, &c, &item.site, &what)?);
        }
        let z = Matrix::from_fn(sigma, ell, |i, j| z_rows[i][j].clone());
        Ok((a, alpha, z))
    }

    /// The exact dependence of each of the model's dropped rows on the kept rows `alpha`
    /// ([`crate::dependence`]).
    fn dependences(
        &self,
        f: &Field,
        alpha: &Matrix,
        manifold: Option<&OnManifold>,
    ) -> Result<Vec<Dependence>, DeriveError> {
        let model = self.model;
        model
            .dependent
            .iter()
            .map(|d| {
                let c = f
                    .convert(&d.item.expr)
                    .map_err(|e| self.cas(Some(&d.item.site), e))?;
                let what = format!("constraint `{}`", d.name);
                let row = self.linear_row(f, &c, &d.item.site, &what)?;
                crate::dependence::dependence(alpha, d, row, f, manifold)
            })
            .collect()
    }

    /// Whether α is certified of full rank at some point ([`crate::certify`]): a proof, so the
    /// exact rank is needed only when this fails (free functions, or a deficient rank).
    fn certified_full_rank(&self, alpha: &Matrix) -> bool {
        let rows: Vec<Vec<Expr>> = (0..alpha.rows())
            .map(|i| (0..alpha.cols()).map(|j| alpha[(i, j)].to_expr()).collect())
            .collect();
        let refs: Vec<Vec<&Expr>> = rows.iter().map(|r| r.iter().collect()).collect();
        crate::certify::full_rank(&refs, &self.model.coordinates, &self.model.parameters).is_some()
    }

    /// (4)–(5): [Z; α]⁻¹ = [Γ Θ] and δ = det[Z; α] (checked not identically zero); `Err(n)`
    /// inside when exact elimination outgrows n terms per entry.
    #[allow(clippy::type_complexity)]
    fn inverse(
        &self,
        z: &Matrix,
        alpha: &Matrix,
        choice: &QuasiVelocityChoice,
    ) -> Result<Result<(Matrix, Matrix, Ex), usize>, DeriveError> {
        let (ell, mu, sigma) = (self.model.ell(), self.model.mu(), self.model.sigma());
        let m = if mu > 0 { z.vstack(alpha) } else { z.clone() };
        let (minv, delta) = match m.inverse() {
            Ok(Some(found)) => found,
            Ok(None) => {
                return Err(DeriveError::Singular {
                    site: span_site(format!("quasi_velocities.{}", choice.name), &choice.eta),
                });
            }
            Err(CasError::TooLarge(n)) => return Ok(Err(n)),
            Err(e) => return Err(self.cas(None, e)),
        };
        Ok(Ok((
            minv.columns(0, sigma),
            minv.columns(sigma, ell),
            delta,
        )))
    }
}

/// A, α, Z, Γ, Θ over their common denominator factors, with what every step below needs.
struct Parts {
    dens: Denominators,
    half: Over,
    a: OMatrix,
    alpha: OMatrix,
    z: OMatrix,
    gamma: OMatrix,
    gamma_t: OMatrix,
    theta: OMatrix,
    /// ∂A/∂q_j, every j.
    da: Vec<OMatrix>,
    /// Whether q_k moves at all (row k of Γ not zero).
    moves: Vec<bool>,
    ell: usize,
    mu: usize,
    sigma: usize,
}

impl Parts {
    fn new(
        f: &Field,
        a: &Matrix,
        alpha: &Matrix,
        z: &Matrix,
        gamma: &Matrix,
        theta: &Matrix,
    ) -> Parts {
        let seeds: Vec<&Ex> = a
            .entries()
            .iter()
            .chain(alpha.entries())
            .chain(z.entries())
            .chain(gamma.entries())
            .chain(theta.entries())
            .collect();
        let dens = Denominators::new(f, &seeds);
        let half = dens.over(&f.rational(&1.into(), &2.into()).expect("1/2"));
        let gamma_o = OMatrix::from_matrix(&dens, gamma);
        let (ell, sigma) = (gamma.rows(), gamma.cols());
        let moves = (0..ell)
            .map(|k| (0..sigma).any(|s| !gamma_o[(k, s)].is_zero()))
            .collect();
        let a_o = OMatrix::from_matrix(&dens, a);
        Parts {
            half,
            da: (0..ell).map(|j| a_o.diff(j)).collect(),
            a: a_o,
            alpha: OMatrix::from_matrix(&dens, alpha),
            z: OMatrix::from_matrix(&dens, z),
            gamma_t: gamma_o.transpose(),
            gamma: gamma_o,
            theta: OMatrix::from_matrix(&dens, theta),
            moves,
            ell,
            mu: alpha.rows(),
            sigma,
            dens,
        }
    }

    fn sum(&self, terms: Vec<Over>) -> Over {
        sum_over(&self.dens, terms)
    }

    fn zeros(&self) -> Vec<OMatrix> {
        vec![OMatrix::zeros(&self.dens, self.sigma, self.sigma); self.sigma]
    }

    /// True Q from (9): Q⁽ⁱ⁾_rs = sym[ Σ_k (Γᵀ ∂(AΓ)/∂q_k)_ir γ_ks − ½ Σ_j γ_ji (Γᵀ ∂A/∂q_j Γ)_rs ].
    fn q_true(&self) -> Vec<OMatrix> {
        let (ell, sigma) = (self.ell, self.sigma);
        let b_mat = self.a.mul(&self.gamma);
        let mut t1 = self.zeros();
        for k in (0..ell).filter(|&k| self.moves[k]) {
            let db = b_mat.diff(k);
            if db.is_zero() {
                continue;
            }
            let g = self.gamma_t.mul(&db);
            for (i, t) in t1.iter_mut().enumerate() {
                for r in 0..sigma {
                    if g[(i, r)].is_zero() {
                        continue;
                    }
                    for s in 0..sigma {
                        t[(r, s)] = t[(r, s)].add(&g[(i, r)].mul(&self.gamma[(k, s)]));
                    }
                }
            }
        }
        for (j, d) in self.da.iter().enumerate() {
            if !self.moves[j] || d.is_zero() {
                continue;
            }
            let h = self.gamma_t.mul(d).mul(&self.gamma);
            for (i, t) in t1.iter_mut().enumerate() {
                let c = self.gamma[(j, i)].mul(&self.half);
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
        t1.iter().map(|t| sym(&self.dens, t, &self.half)).collect()
    }

    /// The paper's Q, (12)/(15), with the second and third terms summed over h only.
    fn q_paper(&self, a_gamma: &OMatrix, d_agamma: &[OMatrix]) -> Vec<OMatrix> {
        let (ell, sigma) = (self.ell, self.sigma);
        let dz: Vec<OMatrix> = (0..ell).map(|k| self.z.diff(k)).collect();
        let mut qp = self.zeros();
        for j in 0..sigma {
            // (C_j)_hk = ∂z_jh/∂q_k − ∂z_jk/∂q_h
            let c = OMatrix::from_fn(&self.dens, ell, ell, |h, k| {
                dz[k][(j, h)].sub(&dz[h][(j, k)])
            });
            if c.is_zero() {
                continue;
            }
            let p = self.gamma_t.mul(&c).mul(&self.gamma);
            for (i, t) in qp.iter_mut().enumerate() {
                for r in 0..sigma {
                    for s in 0..sigma {
                        t[(r, s)] = t[(r, s)].add(&a_gamma[(j, r)].mul(&p[(i, s)]));
                    }
                }
            }
        }
        for (h, dh) in d_agamma.iter().enumerate() {
            if !self.moves[h] || dh.is_zero() {
                continue;
            }
            for (i, t) in qp.iter_mut().enumerate() {
                for r in 0..sigma {
                    for s in 0..sigma {
                        let second = self.gamma[(h, s)].mul(&dh[(r, i)]);
                        let third = self.gamma[(h, i)].mul(&dh[(r, s)]).mul(&self.half);
                        t[(r, s)] = t[(r, s)].add(&second).sub(&third);
                    }
                }
            }
        }
        qp.iter().map(|t| sym(&self.dens, t, &self.half)).collect()
    }

    /// The correction the paper drops, Σ_m ν_m ΓᵀV_mΓη with ν = ΘᵀAΓη and
    /// (V_m)_hk = ∂α_mh/∂q_k − ∂α_mk/∂q_h: ν's matrix ΘᵀAΓ and the coefficients.
    fn q_correction(&self) -> (OMatrix, Vec<OMatrix>) {
        let (ell, sigma) = (self.ell, self.sigma);
        let nu = self.theta.transpose().mul(&self.a).mul(&self.gamma);
        let dalpha: Vec<OMatrix> = (0..ell).map(|k| self.alpha.diff(k)).collect();
        let mut qc = self.zeros();
        for m_ in 0..self.mu {
            let v = OMatrix::from_fn(&self.dens, ell, ell, |h, k| {
                dalpha[k][(m_, h)].sub(&dalpha[h][(m_, k)])
            });
            if v.is_zero() {
                continue;
            }
            let rm = self.gamma_t.mul(&v).mul(&self.gamma);
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
        let q_correction = qc.iter().map(|t| sym(&self.dens, t, &self.half)).collect();
        (nu, q_correction)
    }

    /// With Z = I and no constraints, Q must be the Christoffel symbols of the first kind of A
    /// (the Euler–Lagrange equations); `None` otherwise.
    fn euler_lagrange(&self, f: &Field, z: &Matrix, q_true: &[OMatrix]) -> Option<bool> {
        let ell = self.ell;
        if !(self.mu == 0 && z.sub(&Matrix::identity(f, ell)).is_zero()) {
            return None;
        }
        let da = &self.da;
        Some((0..ell).all(|i| {
            (0..ell).all(|r| {
                (0..ell).all(|s| {
                    let christoffel = da[s][(i, r)]
                        .add(&da[r][(i, s)])
                        .sub(&da[i][(r, s)])
                        .mul(&self.half);
                    q_true[i][(r, s)].sub(&christoffel).is_zero()
                })
            })
        }))
    }

    /// The equations along η: η, η̇ as symbols, Γη, ηᵀQ⁽ⁱ⁾η (true and paper's), and what the
    /// energy check needs.
    fn along_eta(
        &self,
        f: &Field,
        q_true: &[OMatrix],
        q_paper: &[OMatrix],
        d_agamma: &[OMatrix],
    ) -> AlongEta {
        let unknown = |n: String| self.dens.over(&f.unknown(&n).expect("declared symbol"));
        let eta: Vec<Over> = eta_names(self.sigma).map(unknown).collect();
        let eta_dot: Vec<Over> = eta_dot_names(self.sigma).map(unknown).collect();
        let quad = |m: &OMatrix| quadratic_form(&self.dens, &eta, m);
        let q_eta = q_true.iter().map(quad).collect();
        let q_eta_paper = q_paper.iter().map(quad).collect();
        let gamma_eta: Vec<Over> = (0..self.ell)
            .map(|k| {
                self.sum(
                    (0..self.sigma)
                        .map(|s| self.gamma[(k, s)].mul(&eta[s]))
                        .collect(),
                )
            })
            .collect();
        // dE/dt = −ηᵀQ(η) + ½ Σ_k (Γη)_k ηᵀ ∂A_Γ/∂q_k η along (11); the forcing terms cancel
        // exactly.
        let gyro = self.sum(
            (0..self.ell)
                .filter(|&k| self.moves[k])
                .map(|k| gamma_eta[k].mul(&quad(&d_agamma[k])).mul(&self.half))
                .collect(),
        );
        AlongEta {
            dens: self.dens.clone(),
            eta,
            eta_dot,
            gamma_eta,
            q_eta,
            q_eta_paper,
            gyro,
        }
    }
}

/// The quantities along η of [`Parts::along_eta`].
struct AlongEta {
    dens: Denominators,
    eta: Vec<Over>,
    eta_dot: Vec<Over>,
    gamma_eta: Vec<Over>,
    q_eta: Vec<Over>,
    q_eta_paper: Vec<Over>,
    /// ½ Σ_k (Γη)_k ηᵀ ∂A_Γ/∂q_k η.
    gyro: Over,
}

/// ηᵀ M η.
fn quadratic_form(dens: &Denominators, eta: &[Over], m: &OMatrix) -> Over {
    sum_over(
        dens,
        (0..m.rows())
            .flat_map(|r| (0..m.cols()).map(move |s| (r, s)))
            .filter(|&(r, s)| !m[(r, s)].is_zero())
            .map(|(r, s)| m[(r, s)].mul(&eta[r]).mul(&eta[s]))
            .collect::<Vec<_>>(),
    )
}

impl AlongEta {
    /// dE/dt along (11) with the coefficients `q_eta` (ηᵀQ⁽ⁱ⁾η): zero iff energy is conserved.
    fn energy_rate(&self, q_eta: &[Over]) -> Over {
        let work = sum_over(
            &self.dens,
            (0..self.eta.len())
                .map(|i| self.eta[i].mul(&q_eta[i]))
                .collect::<Vec<_>>(),
        );
        self.gyro.sub(&work)
    }
}
