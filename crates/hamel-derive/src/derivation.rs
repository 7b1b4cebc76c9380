//! The result of a derivation: plain data (canonical text plus evaluable trees), `Send`.

use std::sync::Arc;

use hamel_expr::{Canonical, Expr};
use indexmap::IndexMap;
use serde::{Deserialize, Serialize, Serializer};

use crate::certify::Certificate;

/// One derived expression: its canonical text and its tree.
#[derive(Clone, Debug, PartialEq)]
pub struct Entry {
    /// Canonical text (model-file syntax; `etaR` are the quasi-velocities, `etaR_dot` their
    /// rates).
    pub text: String,
    /// The same expression as a tree, for numeric evaluation.
    pub expr: Expr,
    /// The same expression as the computer algebra held it (polynomials over its atoms, of
    /// which `expr` is the tree), where it was exported from there; None for a tree made
    /// otherwise (a derivative taken on the tree, a substitution).
    pub canonical: Option<Arc<Canonical>>,
}

/// An entry is written as its text for a reader (JSON); a stored derivation
/// ([`crate::store`], a binary format) keeps the text, the tree and the canonical form.
impl Serialize for Entry {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        if s.is_human_readable() {
            return s.serialize_str(&self.text);
        }
        EntryData {
            text: std::borrow::Cow::Borrowed(&self.text),
            expr: std::borrow::Cow::Borrowed(&self.expr),
            canonical: self.canonical.clone(),
        }
        .serialize(s)
    }
}

/// An entry as stored: read back whole (never from its text alone).
impl<'de> Deserialize<'de> for Entry {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Entry, D::Error> {
        let e = EntryData::deserialize(d)?;
        Ok(Entry {
            text: e.text.into_owned(),
            expr: e.expr.into_owned(),
            canonical: e.canonical,
        })
    }
}

/// The stored fields of an [`Entry`].
#[derive(Serialize, Deserialize)]
struct EntryData<'a> {
    text: std::borrow::Cow<'a, str>,
    expr: std::borrow::Cow<'a, Expr>,
    canonical: Option<Arc<Canonical>>,
}

/// A matrix of derived expressions (row-major; serialised as a list of rows of strings).
#[derive(Clone, Debug, PartialEq)]
pub struct Mat {
    /// Number of rows.
    pub rows: usize,
    /// Number of columns.
    pub cols: usize,
    /// Rows of entries.
    pub entries: Vec<Vec<Entry>>,
}

impl Mat {
    /// Entry (i, j).
    pub fn at(&self, i: usize, j: usize) -> &Entry {
        &self.entries[i][j]
    }
}

/// For a reader, the rows of entries; stored, with its shape.
impl Serialize for Mat {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        if s.is_human_readable() {
            return self.entries.serialize(s);
        }
        (self.rows, self.cols, &self.entries).serialize(s)
    }
}

impl<'de> Deserialize<'de> for Mat {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Mat, D::Error> {
        let (rows, cols, entries) = <(usize, usize, Vec<Vec<Entry>>)>::deserialize(d)?;
        Ok(Mat {
            rows,
            cols,
            entries,
        })
    }
}

/// Exact checks made on the derived equations.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Checks {
    /// Q (true) = Q_paper + Q_correction, coefficient by coefficient.
    pub split_identity: bool,
    /// dE/dt = 0 identically along the true equations (E = ½ηᵀA_Γη − U), the forces F
    /// included: false when some force does work.
    pub energy_conserved: bool,
    /// dE/dt = 0 identically along the paper's equations too (the correction is gyroscopic).
    pub energy_conserved_paper: bool,
    /// With forces: dE/dt = (Γη)ᵀF identically along the true equations (Q does no work, the
    /// forces do all of it). None without forces.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub energy_balance: Option<bool>,
    /// The coordinates whose generalised force does work, (Γη)_k F_k ≢ 0 (motor torques,
    /// dampers); empty without forces.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub working_forces: Vec<String>,
    /// Q_correction ≡ 0: the paper's equations (11)/(15) are the true ones for this Z.
    pub paper_is_exact: bool,
    /// For holonomic models with Z = I: the equations are the Euler–Lagrange equations
    /// (Q⁽ⁱ⁾ are the Christoffel symbols of the first kind). `None` when not applicable.
    pub euler_lagrange: Option<bool>,
}

/// The Boltzmann–Hamel equations of a model for one choice of quasi-velocities.
///
/// The equations are A_Γ η̇ + Q(q, η) − Γᵀ∇U = 0 (11) with Q_i = Σ_rs Q⁽ⁱ⁾_rs η_r η_s, joined
/// to the kinematic equations q̇ = Γη (6). The coefficient matrices Q⁽ⁱ⁾ are given symmetrised
/// (a quadratic form determines only its symmetric part).
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Derivation {
    /// Model identifier.
    pub model: String,
    /// Model title.
    pub title: String,
    /// Name of the quasi-velocity choice.
    pub eta_name: String,
    /// The quasi-velocities η = Z q̇ as written in the model.
    pub eta: Vec<String>,
    /// Free functions of the choice, as `name(args)`.
    pub free_functions: Vec<String>,
    /// The model's `[abbreviations]`: names for expressions in the parameters, which printing
    /// uses (the derivation does not).
    #[serde(default, skip_serializing_if = "IndexMap::is_empty")]
    pub abbreviations: IndexMap<String, Entry>,
    /// The parameters the model declares positive (`positive = [...]`), which printing uses
    /// to multiply an equation through by its denominator.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub positive: Vec<String>,
    /// Coordinates q₁..q_ℓ.
    pub coordinates: Vec<String>,
    /// Parameters with their default values.
    pub parameters: IndexMap<String, f64>,
    /// The parameters set at every evaluation instead of once ([`hamel_model::Model::live`]: the time of a
    /// scene's control law, inputs read from tables); never specialised, never folded into
    /// the prepared constants of generated code.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub live: Vec<String>,
    /// ℓ, μ, σ.
    pub ell: usize,
    /// Number of constraints.
    pub mu: usize,
    /// Number of quasi-velocities.
    pub sigma: usize,
    /// Mass matrix A (ℓ×ℓ), T = ½ q̇ᵀAq̇.
    pub a: Mat,
    /// Constraint matrix α (μ×ℓ).
    pub alpha: Mat,
    /// Z (σ×ℓ).
    pub z: Mat,
    /// ∇U.
    pub grad_u: Vec<Entry>,
    /// The holonomic constraints h(q) = 0 (their velocity rows are among α's), each with the
    /// coordinate it determines: generated code projects onto them; empty for most models.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub holonomic: Vec<Holonomic>,
    /// The names of α's rows (the kept ones, in order).
    pub constraints: Vec<String>,
    /// The rows of the model dropped from α as combinations of the kept ones (two wheels on
    /// one axle), each with its exact dependence; empty for most models.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub dependent_rows: Vec<Dependent>,
    /// The factors of δ = det[Z; α] at which α's kept rows lose rank (the dependent rows'
    /// denominators), each with its power in δ: δ over their product vanishes only where
    /// [Z; α] with every row does (closed form only; empty otherwise).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub kept_rank_loss: Vec<Power>,
    /// The generalised forces F of the loads U does not give (`[forces]`, bodies' loads), one
    /// per coordinate; empty when the model has none. They enter as Γᵀ(∇U + F).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub forces: Vec<Entry>,
    /// The equations: in closed form (Γ, A_Γ, Q, … as canonical expressions), or structured
    /// (evaluated from the ingredients only, for derivations too large to expand). Serialised
    /// in place: the closed form's fields, or `structured` and `certificate`.
    #[serde(flatten)]
    pub form: Form,
    /// Ingredients of the structured numeric evaluation (not serialised): U and the exact
    /// partial derivatives ∂A/∂q_k, ∂Z/∂q_k, ∂α/∂q_k, k = 1..ℓ.
    #[serde(skip)]
    pub ingredients: Ingredients,
    /// How the wheels' and blades' forces are read off the multipliers (the model's; not
    /// serialised): compiled beside the ingredients ([`Derivation::compile`]).
    #[serde(skip)]
    pub contact_forces: hamel_bodies::ContactForces,
    /// Which of those forces the motion determines where α has dependent rows (decided
    /// exactly, [`crate::uniqueness`]; not serialised).
    #[serde(skip)]
    pub force_uniqueness: crate::uniqueness::Uniqueness,
}

/// The equations in closed form: every derived object as one canonical expression.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Closed {
    /// Γ (ℓ×σ): q̇ = Γη (5)–(6).
    pub gamma: Mat,
    /// Θ (ℓ×μ): [Z; α]⁻¹ = [Γ Θ] (5).
    pub theta: Mat,
    /// δ = det[Z; α] (4).
    pub delta: Entry,
    /// Expressions whose vanishing makes [Z; α] singular or Γ undefined (factors of δ's
    /// numerator and of Γ's denominators); empty when the map is regular everywhere.
    pub singular_set: Vec<Entry>,
    /// A_Γ = ΓᵀAΓ (8).
    pub a_gamma: Mat,
    /// Γᵀ∇U.
    pub forcing: Vec<Entry>,
    /// ΘᵀAΓ (μ×σ): ν = ΘᵀAΓη are the momenta along the constrained directions.
    pub nu: Mat,
    /// Q⁽ⁱ⁾ of the true equations, i = 1..σ (each σ×σ, symmetric).
    pub q: Vec<Mat>,
    /// Q⁽ⁱ⁾ of the paper's (12)/(15) (with (15)'s second and third terms summed over h only).
    pub q_paper: Vec<Mat>,
    /// Q⁽ⁱ⁾ of the correction Σ_m ν_m Γᵀ V_m Γ η, (V_m)_hk = ∂α_mh/∂q_k − ∂α_mk/∂q_h.
    pub q_correction: Vec<Mat>,
    /// Kinematic equations: q̇_k = (Γη)_k.
    pub kinematics: Vec<Entry>,
    /// Left-hand sides of the true equations (11), each = 0.
    pub equations: Vec<Entry>,
    /// Left-hand sides of the paper's equations (11) with (12).
    pub equations_paper: Vec<Entry>,
    /// Energy E = T − U = ½ηᵀA_Γη − U.
    pub energy: Entry,
    /// With forces: their power (Γη)ᵀF(q, Γη), so that dE/dt = power along the true
    /// equations.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub power: Option<Entry>,
    /// Exact checks.
    pub checks: Checks,
}

/// How a derivation gives its equations.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(untagged)]
pub enum Form {
    /// Γ, Θ, δ, A_Γ, Q, the equations and the exact checks, each a canonical expression.
    Closed(Box<Closed>),
    /// Only the ingredients (A, α, Z, U and their exact derivatives) are canonical; the
    /// equations are evaluated from them ([`hamel_runtime::Structured`]), and the
    /// nonsingularity of [Z; α] is certified at a point ([`crate::certify`]).
    Structured(StructuredForm),
}

/// Why a derivation is in structured form, and the proof that its quasi-velocities are valid.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct StructuredForm {
    /// Why the closed form was not computed.
    #[serde(serialize_with = "crate::derivation::as_text")]
    pub structured: Why,
    /// A point where [Z; α] is certainly nonsingular (so δ = det[Z; α] is not identically
    /// zero, and α has full rank).
    pub certificate: Certificate,
}

/// Why the closed form of a derivation was not computed.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum Why {
    /// The user asked for the structured form.
    Requested,
    /// Exact elimination for [Z; α]⁻¹ outgrew its budget of work
    /// ([`hamel_cas::linalg::Budget`], this many units).
    TooLarge(usize),
    /// The closed form's equations outgrew [`crate::CLOSED_FORM_TERMS`] (this many terms).
    ClosedTooLarge(usize),
    /// The forces depend on the velocities in a way the closed form cannot hold after
    /// q̇ = Γη is put in (inside a square root, an exponential…): the engine's reason.
    VelocityForces(String),
}

impl std::fmt::Display for Why {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Why::Requested => write!(f, "requested (--form structured)"),
            Why::TooLarge(n) => write!(
                f,
                "the exact inverse [Z; α]⁻¹ = [Γ Θ] outgrows the budget of exact elimination ({n} units of work, no product above 10⁴ terms²); the equations are evaluated from the ingredients"
            ),
            Why::ClosedTooLarge(n) => write!(
                f,
                "the closed form's A_Γ, Γᵀ∇U and Q⁽ⁱ⁾ have {n} terms, above the budget of {}; the equations are evaluated from the ingredients",
                crate::CLOSED_FORM_TERMS
            ),
            Why::VelocityForces(m) => write!(
                f,
                "the forces F(q, q̇) with q̇ = Γη put in leave the closed form's field ({m}); the equations are evaluated from the ingredients, F at q̇ = Γη"
            ),
        }
    }
}

pub(crate) fn as_text<T: std::fmt::Display + Serialize, S: Serializer>(
    v: &T,
    s: S,
) -> Result<S::Ok, S::Error> {
    if s.is_human_readable() {
        s.serialize_str(&v.to_string())
    } else {
        v.serialize(s)
    }
}

/// The closed form was needed and the derivation is structured.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error(
    "the derivation of `{model}` for `{eta}` is in structured form ({why}); {needs} needs the closed form"
)]
pub struct NotClosed {
    /// Model name.
    pub model: String,
    /// The quasi-velocity choice.
    pub eta: String,
    /// Why it is structured.
    pub why: Why,
    /// What needed the closed form.
    pub needs: &'static str,
}

impl Derivation {
    /// The closed form, when the derivation has one.
    pub fn closed(&self) -> Option<&Closed> {
        match &self.form {
            Form::Closed(c) => Some(c),
            Form::Structured(_) => None,
        }
    }

    /// The closed form, or an error saying that `needs` needs it.
    pub fn closed_for(&self, needs: &'static str) -> Result<&Closed, NotClosed> {
        match &self.form {
            Form::Closed(c) => Ok(c),
            Form::Structured(s) => Err(NotClosed {
                model: self.model.clone(),
                eta: self.eta_name.clone(),
                why: s.structured.clone(),
                needs,
            }),
        }
    }
}

/// Small exact expressions from which the equations are evaluated numerically without
/// expanding them (see `numeric`).
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
pub struct Ingredients {
    /// U.
    pub potential: Option<Entry>,
    /// ∇U + F, evaluated in place of ∇U when the model has forces that do not depend on the
    /// velocities.
    pub applied: Option<Vec<Entry>>,
    /// The forces F(q, q̇) as the model writes them (with `der(q)`), when it has forces: for
    /// their power, and added to ∇U at q̇ = Γη when they depend on the velocities
    /// ([`Ingredients::velocity_forces`]).
    pub forces: Option<Vec<Entry>>,
    /// Whether F depends on the velocities: then ∇U stands alone among the ingredients and F
    /// is evaluated after Γ, at q̇ = Γη.
    pub velocity_forces: bool,
    /// The model's own trees of the ingredients, for structured derivations: evaluated in place
    /// of the canonical forms, with `da`, `dz`, `dalpha` their derivatives.
    pub trees: Option<Trees>,
    /// ∂A/∂q_k.
    pub da: Vec<Mat>,
    /// ∂Z/∂q_k.
    pub dz: Vec<Mat>,
    /// ∂α/∂q_k.
    pub dalpha: Vec<Mat>,
    /// The model's rows that depend on α's (dependent×ℓ; none for most models), evaluated
    /// after α's rows so that the structured evaluation can use them where α's kept rows
    /// lose rank (`hamel_runtime::structured::select`); canonical forms, or the model's trees
    /// for a structured derivation.
    pub dependent: Option<Mat>,
    /// ∂/∂q_k of `dependent` (empty without dependent rows).
    pub ddependent: Vec<Mat>,
    /// For code generation ([`Symbolic::to_derivation_for_code`](crate::Symbolic)), else empty:
    /// the right-hand sides b_i = (Γᵀ∇U)_i − Σ_rs Q⁽ⁱ⁾_rs η_r η_s of (11), A_Γ η̇ = b, each one
    /// normal form in q, the parameters and the symbols `eta1..`.
    pub eta_rhs: Vec<Entry>,
    /// For code generation, when small enough: η̇ = A_Γ⁻¹ b, each one normal form (exact
    /// elimination; abandoned when an intermediate exceeds [`SOLUTION_TERMS`](crate::SOLUTION_TERMS) terms).
    pub eta_dot: Option<Vec<Entry>>,
    /// For code generation, when A_Γ splits into diagonal blocks of at most 3 rows (after
    /// ordering): each block's rows, its determinant, adjugate and leading principal minors
    /// as normal forms (Cramer's rule per block; Sylvester's criterion for definiteness).
    pub blocks: Option<Vec<Block>>,
}

/// A, α, Z, U and ∇U as the model writes them: for a model of bodies, built frame by frame and
/// never expanded; α and Z the coefficients of the velocities in the rows as written; ∇U taken
/// on U's tree. Each converts to the canonical form of the derivation (which is computed from
/// them), so they are equal by construction; they are for evaluation, the canonical forms for
/// deciding. The bicycle's A is 860 operations shared as a tree, 14,000 expanded.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Trees {
    /// A (ℓ×ℓ).
    pub a: Mat,
    /// α (μ×ℓ).
    pub alpha: Mat,
    /// Z (σ×ℓ).
    pub z: Mat,
    /// U.
    pub u: Entry,
    /// ∇U + F (ℓ): ∇U on U's tree, plus the forces as written (∇U alone when they depend on
    /// the velocities).
    pub grad_u: Vec<Entry>,
}

impl Trees {
    fn map_expr(&self, f: &dyn Fn(&Expr) -> Expr) -> Trees {
        Trees {
            a: self.a.map_expr(f),
            alpha: self.alpha.map_expr(f),
            z: self.z.map_expr(f),
            u: self.u.map_expr(f),
            grad_u: self.grad_u.iter().map(|e| e.map_expr(f)).collect(),
        }
    }
}

/// A row of the model dropped from α: row = Σ_j c_j α_j exactly, over the kept rows α_j.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Dependent {
    /// Its name.
    pub name: String,
    /// Its entries (the coefficients of der(q_1)..der(q_ℓ)).
    pub row: Vec<Entry>,
    /// The kept rows with a nonzero coefficient, in α's order.
    pub combination: Vec<Term>,
    /// The factors of the coefficients' denominators: where the kept rows lose rank (and
    /// the dependence as written fails), sorted by text.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub singular: Vec<Entry>,
    /// The holonomic constraint on whose manifold (h = 0) the combination holds, and only
    /// there (the rank of α is lower on it than off it); absent when it holds everywhere.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub on_manifold: Option<String>,
}

/// A factor and its power.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Power {
    /// The factor.
    pub factor: Entry,
    /// Its power.
    pub power: u32,
}

/// One term c_j α_j of a dependence.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Term {
    /// The kept row's name.
    pub row: String,
    /// c_j.
    pub coefficient: Entry,
}

/// A holonomic constraint h(q) = 0 of a derivation.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Holonomic {
    /// Its name.
    pub name: String,
    /// h, as the model gives it.
    pub h: Entry,
    /// The index of the coordinate it determines.
    pub dependent: usize,
}

/// A diagonal block of A_Γ (the rows `rows`, coupled to no other row), for Cramer's rule.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Block {
    /// Indices of η in the block.
    pub rows: Vec<usize>,
    /// Its determinant.
    pub det: Entry,
    /// Its adjugate (det × inverse), row-major.
    pub adj: Vec<Vec<Entry>>,
    /// Its leading principal minors of orders 1..n (the last is `det`).
    pub minors: Vec<Entry>,
}

impl Entry {
    /// The entry of a tree, its text printed from it.
    pub(crate) fn of(expr: Expr) -> Entry {
        Entry {
            text: expr.to_string(),
            expr,
            canonical: None,
        }
    }

    /// The entry of a value exported from the computer algebra: its tree written from
    /// `canonical`, its text from the tree.
    pub(crate) fn of_canonical(canonical: Canonical) -> Entry {
        let expr = canonical.to_expr();
        Entry {
            text: expr.to_string(),
            expr,
            canonical: Some(Arc::new(canonical)),
        }
    }

    /// The entry with `f` applied to its tree (text printed from the result).
    fn map_expr(&self, f: &dyn Fn(&Expr) -> Expr) -> Entry {
        Entry::of(f(&self.expr))
    }
}

impl Mat {
    fn map_expr(&self, f: &dyn Fn(&Expr) -> Expr) -> Mat {
        self.map_entries(|e| e.map_expr(f))
    }

    /// The matrix of `f` of each entry.
    pub(crate) fn map_entries(&self, f: impl Fn(&Entry) -> Entry) -> Mat {
        Mat {
            rows: self.rows,
            cols: self.cols,
            entries: self
                .entries
                .iter()
                .map(|r| r.iter().map(&f).collect())
                .collect(),
        }
    }
}

fn map_all<T>(v: &[T], f: impl Fn(&T) -> T) -> Vec<T> {
    v.iter().map(f).collect()
}

/// A derivation with the size of each object, serialised side by side (see
/// [`Derivation::json`]).
#[derive(Serialize)]
pub struct DerivationJson<'a> {
    /// The derivation's fields.
    #[serde(flatten)]
    pub derivation: &'a Derivation,
    /// Characters and operations of each derived object.
    pub sizes: IndexMap<&'static str, Size>,
}

/// The size of a derived object: characters of its canonical text, and arithmetic operations of
/// its trees with nothing shared ([`Expr::tree_operations`]). Swell shows here first.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
pub struct Size {
    /// Characters of the canonical text, all entries together.
    pub characters: usize,
    /// Operations of the trees, all entries together.
    pub operations: usize,
}

impl Size {
    fn of<'a>(entries: impl IntoIterator<Item = &'a Entry>) -> Size {
        entries.into_iter().fold(Size::default(), |s, e| Size {
            characters: s.characters + e.text.chars().count(),
            operations: s.operations + e.expr.tree_operations(),
        })
    }
}

impl Mat {
    fn all(&self) -> impl Iterator<Item = &Entry> {
        self.entries.iter().flatten()
    }
}

impl Derivation {
    /// The size of each derived object, keyed by its name in the JSON output (Γ `gamma`, Θ
    /// `theta`, δ `delta`, the singular set, A_Γ `a_gamma` (8), Γᵀ∇U `forcing`, ΘᵀAΓ `nu`,
    /// the Q⁽ⁱ⁾ of (11), of the paper and of the correction, the equations, the kinematic
    /// equations and the energy).
    pub fn sizes(&self) -> IndexMap<&'static str, Size> {
        let mats = |v: &[Mat]| Size::of(v.iter().flat_map(Mat::all));
        let Some(c) = self.closed() else {
            // Structured: the ingredients are what is derived.
            return IndexMap::from([
                ("a", Size::of(self.a.all())),
                ("alpha", Size::of(self.alpha.all())),
                ("z", Size::of(self.z.all())),
                ("grad_u", Size::of(&self.grad_u)),
            ]);
        };
        IndexMap::from([
            ("gamma", Size::of(c.gamma.all())),
            ("theta", Size::of(c.theta.all())),
            ("delta", Size::of([&c.delta])),
            ("singular_set", Size::of(&c.singular_set)),
            ("a_gamma", Size::of(c.a_gamma.all())),
            ("forcing", Size::of(&c.forcing)),
            ("nu", Size::of(c.nu.all())),
            ("q", mats(&c.q)),
            ("q_paper", mats(&c.q_paper)),
            ("q_correction", mats(&c.q_correction)),
            ("equations", Size::of(&c.equations)),
            ("equations_paper", Size::of(&c.equations_paper)),
            ("kinematics", Size::of(&c.kinematics)),
            ("energy", Size::of([&c.energy])),
        ])
    }

    /// What `hamel derive --format json` prints: the derivation and [`Derivation::sizes`].
    pub fn json(&self) -> DerivationJson<'_> {
        DerivationJson {
            derivation: self,
            sizes: self.sizes(),
        }
    }

    /// The derivation for fixed values of some parameters (a scene's): every expression with
    /// those parameters replaced by their exact values and its constants folded
    /// ([`Expr::specialise`]); they leave [`Derivation::parameters`]. The exact checks are
    /// those of the general derivation (they hold for every value). Errors name a parameter
    /// that is not the model's or a value that is not finite.
    pub fn specialise(
        &self,
        values: &IndexMap<String, f64>,
    ) -> Result<Derivation, SpecialiseError> {
        let mut exact = std::collections::HashMap::new();
        for (name, &v) in values {
            if !self.parameters.contains_key(name) {
                return Err(SpecialiseError::UnknownParameter(name.clone()));
            }
            if self.live.contains(name) {
                return Err(SpecialiseError::Live(name.clone()));
            }
            let r = hamel_expr::rational_of_f64(v)
                .ok_or_else(|| SpecialiseError::NotFinite(name.clone(), v))?;
            exact.insert(name.clone(), r);
        }
        let f = |e: &Expr| e.specialise(&exact);
        let mats = |v: &[Mat]| map_all(v, |m| m.map_expr(&f));
        let entries = |v: &[Entry]| map_all(v, |e| e.map_expr(&f));
        let ing = &self.ingredients;
        Ok(Derivation {
            parameters: self
                .parameters
                .iter()
                .filter(|(k, _)| !values.contains_key(*k))
                .map(|(k, v)| (k.clone(), *v))
                .collect(),
            positive: (self.positive.iter())
                .filter(|k| !values.contains_key(*k))
                .cloned()
                .collect(),
            a: self.a.map_expr(&f),
            alpha: self.alpha.map_expr(&f),
            z: self.z.map_expr(&f),
            grad_u: entries(&self.grad_u),
            forces: entries(&self.forces),
            dependent_rows: map_all(&self.dependent_rows, |r| Dependent {
                name: r.name.clone(),
                row: entries(&r.row),
                combination: map_all(&r.combination, |t| Term {
                    row: t.row.clone(),
                    coefficient: t.coefficient.map_expr(&f),
                }),
                singular: entries(&r.singular),
                on_manifold: r.on_manifold.clone(),
            }),
            kept_rank_loss: map_all(&self.kept_rank_loss, |p| Power {
                factor: p.factor.map_expr(&f),
                power: p.power,
            }),
            holonomic: map_all(&self.holonomic, |c| Holonomic {
                name: c.name.clone(),
                h: c.h.map_expr(&f),
                dependent: c.dependent,
            }),
            form: match &self.form {
                Form::Closed(c) => Form::Closed(Box::new(c.map_expr(&f))),
                Form::Structured(st) => Form::Structured(st.clone()),
            },
            ingredients: Ingredients {
                potential: ing.potential.as_ref().map(|e| e.map_expr(&f)),
                applied: ing.applied.as_ref().map(|v| entries(v)),
                forces: ing.forces.as_ref().map(|v| entries(v)),
                velocity_forces: ing.velocity_forces,
                trees: ing.trees.as_ref().map(|t| t.map_expr(&f)),
                da: mats(&ing.da),
                dz: mats(&ing.dz),
                dalpha: mats(&ing.dalpha),
                dependent: ing.dependent.as_ref().map(|m| m.map_expr(&f)),
                ddependent: mats(&ing.ddependent),
                eta_rhs: entries(&ing.eta_rhs),
                eta_dot: ing.eta_dot.as_ref().map(|v| entries(v)),
                blocks: ing.blocks.as_ref().map(|bs| {
                    map_all(bs, |b| Block {
                        rows: b.rows.clone(),
                        det: b.det.map_expr(&f),
                        adj: map_all(&b.adj, |r| entries(r)),
                        minors: entries(&b.minors),
                    })
                }),
            },
            contact_forces: self.contact_forces.map_exprs(&mut |e| f(e)),
            ..self.clone()
        })
    }
}

impl Closed {
    fn map_expr(&self, f: &dyn Fn(&Expr) -> Expr) -> Closed {
        let mats = |v: &[Mat]| map_all(v, |m| m.map_expr(f));
        let entries = |v: &[Entry]| map_all(v, |e| e.map_expr(f));
        Closed {
            gamma: self.gamma.map_expr(f),
            theta: self.theta.map_expr(f),
            delta: self.delta.map_expr(f),
            singular_set: entries(&self.singular_set),
            a_gamma: self.a_gamma.map_expr(f),
            forcing: entries(&self.forcing),
            nu: self.nu.map_expr(f),
            q: mats(&self.q),
            q_paper: mats(&self.q_paper),
            q_correction: mats(&self.q_correction),
            kinematics: entries(&self.kinematics),
            equations: entries(&self.equations),
            equations_paper: entries(&self.equations_paper),
            energy: self.energy.map_expr(f),
            power: self.power.as_ref().map(|e| e.map_expr(f)),
            checks: self.checks.clone(),
        }
    }
}

/// Why a derivation could not be specialised for parameter values.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum SpecialiseError {
    /// A name that is not a parameter of the model.
    #[error("`{0}` is not a parameter of the model")]
    UnknownParameter(String),
    /// A value that is not a finite number.
    #[error("parameter `{0}` = {1} is not finite")]
    NotFinite(String, f64),
    /// A parameter set at every evaluation ([`Derivation::live`]), which has no fixed value.
    #[error(
        "parameter `{0}` is set at every evaluation (the time of a control law, or a table): it cannot be fixed"
    )]
    Live(String),
}
