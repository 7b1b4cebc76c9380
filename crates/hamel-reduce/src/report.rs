//! The result of a reduction analysis: plain, serialisable data.

use hamel_derive::{Entry, Mat};
use indexmap::IndexMap;
use serde::{Deserialize, Serialize};

/// An entry of a named object that shows why something fails: the object, its (1-based)
/// indices, the coordinate it contains (when the failure is about a coordinate) and the entry.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct Witness {
    /// The object, named as in the paper: `Gamma`, `A_Gamma`, `Q(2)`, `b`, `(35)`, …
    pub object: String,
    /// 1-based indices into the object.
    pub index: Vec<usize>,
    /// The eliminated coordinate the entry contains, if that is the failure.
    pub coordinate: Option<String>,
    /// The entry, in canonical form.
    pub expression: String,
    /// A sentence saying what the witness shows.
    pub note: String,
}

/// Type (A) or (B) of (31).
#[derive(Clone, Copy, Debug, Serialize, Deserialize, PartialEq, Eq)]
pub enum CoordinateKind {
    /// Absent from L (A and U) and from α: absent from (11) whenever Z avoids it.
    A,
    /// Present in L or in α.
    B,
}

/// The classification (31) of one coordinate.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct Classification {
    /// Coordinate name.
    pub coordinate: String,
    /// (A) or (B).
    pub kind: CoordinateKind,
    /// For type (B): where it occurs in A, U or α.
    pub occurs_in: Option<Witness>,
    /// Whether Z depends on it (for type (A), Z must not for the coordinate to drop out).
    pub in_z: bool,
    /// Whether it was asked to be eliminated.
    pub asked: bool,
}

/// The block structure (17)/(18) found in Z.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct BlockStructure {
    /// v: the number of quasi-velocities that are not plain velocities.
    pub v: usize,
    /// The quasi-velocities η_i = der(q_j) (unit rows of Z), as (i, q_j), 1-based i.
    pub unit_rows: Vec<(usize, String)>,
    /// The coordinates of the first block (μ + v of them).
    pub block1: Vec<String>,
    /// The coordinates of the second block (σ − v), whose velocities are quasi-velocities.
    pub block2: Vec<String>,
    /// Z₁ (v × (μ+v)).
    pub z1: Mat,
    /// Z₂ (v × (σ−v)).
    pub z2: Mat,
    /// α₁ (μ × (μ+v)), (23).
    pub alpha1: Mat,
    /// α₂ (μ × (σ−v)), (23).
    pub alpha2: Mat,
    /// Γ₁ ((μ+v) × v), (18).
    pub gamma1: Mat,
    /// Γ₂ ((μ+v) × (σ−v)), (18).
    pub gamma2: Mat,
    /// δ_R = det(Z₁; α₁), (25).
    pub delta_r: Entry,
}

/// A property (2.1 or 2.2) with the reason when it fails.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Property {
    /// What the property says.
    pub statement: String,
    /// Whether it holds.
    pub holds: bool,
    /// Why not.
    pub witness: Option<Witness>,
}

/// One hypothesis of Proposition 2.1 (or H6).
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Hypothesis {
    /// What the hypothesis requires.
    pub statement: String,
    /// Whether it holds (decided exactly).
    pub holds: bool,
    /// An entry showing the failure.
    pub witness: Option<Witness>,
}

/// Which of the coordinates asked about occur in the equations (11), decided exactly.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct GroundTruth {
    /// Asked-about coordinates absent from the true equations (11).
    pub absent: Vec<String>,
    /// Asked-about coordinates present in them.
    pub present: Vec<String>,
    /// For each present coordinate, the first entry (of A_Γ, Γᵀ∇U, Q⁽ⁱ⁾) containing it.
    pub occurrences: Vec<Witness>,
    /// The same, for the paper's equations (11) with (12)/(15).
    pub paper_absent: Vec<String>,
    /// Present in the paper's equations.
    pub paper_present: Vec<String>,
    /// Whether the kinematic equations still needed (34) are free of the eliminated
    /// coordinates too, so that the reduced system is closed.
    pub kinematics_closed: bool,
    /// When not closed: the kinematic equation that needs an eliminated coordinate.
    pub kinematics_witness: Option<Witness>,
    /// Asked-about coordinates neither proved absent nor proved present (structured form
    /// only: see `hamel_reduce::structured`).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub undecided: Vec<String>,
}

impl GroundTruth {
    /// The coordinates proved absent, as `model`'s indices (the report names them, for
    /// people and JSON).
    pub fn absent_in(&self, model: &hamel_model::Model) -> Vec<hamel_model::Coord> {
        self.absent
            .iter()
            .filter_map(|n| model.coordinate(n))
            .collect()
    }
}

/// q̇_k = (Γη)_k.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct KinematicEquation {
    /// q_k.
    pub coordinate: String,
    /// (Γη)_k.
    pub rate: Entry,
}

/// The reduced system: unknowns η and the needed coordinates.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct ReducedSystem {
    /// The state of the reduced system: η₁..η_σ and the coordinates still needed.
    pub state: Vec<String>,
    /// The σ true equations (11): A_Γη̇ + Q − Γᵀ∇U = 0 (left-hand sides).
    pub equations: Vec<Entry>,
    /// The kinematic equations (34) still needed.
    pub kinematics: Vec<KinematicEquation>,
    /// The reconstruction equations for the other coordinates.
    pub reconstruction: Vec<KinematicEquation>,
}

/// A hypothesis: H0–H5 of Proposition 2.1, and H6 for the term the paper drops.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
pub enum HypothesisId {
    /// (H0) Γ splits as (32)–(33) and Γᵀ∇U is free of q₁..q_p ([`crate::hypotheses::h0`]).
    H0,
    /// (H1) (Z₂; α₂) = 0, (17) and (23) ([`crate::hypotheses::h1`]).
    H1,
    /// (H2) the columns of A⁽¹'²⁾ are combinations of the rows of α₁ ([`crate::hypotheses::h2`]).
    H2,
    /// (H3) the expressions (22) are free of q₁..q_p ([`crate::hypotheses::h3`]).
    H3,
    /// (H4) A⁽²'²⁾ is free of q₁..q_p ([`crate::hypotheses::h4`]).
    H4,
    /// (H5) the expressions (35) are free of q₁..q_p ([`crate::hypotheses::h5`]).
    H5,
    /// (H6) the correction the paper drops is free of q₁..q_p ([`crate::hypotheses::h6`]).
    H6,
}

impl HypothesisId {
    /// The hypotheses of Proposition 2.1 (sufficient for the paper's equations).
    pub const PROPOSITION_2_1: [HypothesisId; 6] = {
        use HypothesisId::*;
        [H0, H1, H2, H3, H4, H5]
    };
    /// Every hypothesis checked.
    pub const ALL: [HypothesisId; 7] = {
        use HypothesisId::*;
        [H0, H1, H2, H3, H4, H5, H6]
    };
}

impl std::fmt::Display for HypothesisId {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{self:?}")
    }
}

/// Property 2.1 or 2.2 of the paper.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum PropertyId {
    /// Γ₂ = 0 (26).
    #[serde(rename = "2.1")]
    P2_1,
    /// Γ₁ᵀA⁽¹'²⁾ = 0 (27).
    #[serde(rename = "2.2")]
    P2_2,
}

impl std::fmt::Display for PropertyId {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            PropertyId::P2_1 => "2.1",
            PropertyId::P2_2 => "2.2",
        })
    }
}

/// The full report of `hamel reduce`.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Reduction {
    /// Model identifier.
    pub model: String,
    /// Quasi-velocity choice.
    pub eta_name: String,
    /// The quasi-velocities.
    pub eta: Vec<String>,
    /// Coordinates.
    pub coordinates: Vec<String>,
    /// The coordinates asked to be eliminated.
    pub eliminate: Vec<String>,
    /// (31) for every coordinate.
    pub classification: Vec<Classification>,
    /// (17)/(18); `None` for a structured derivation (it needs Γ in closed form).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub structure: Option<BlockStructure>,
    /// Property 2.1 (Γ₂ = 0) and Property 2.2 (Γ₁ᵀA⁽¹'²⁾ = 0) (empty for a structured
    /// derivation).
    pub properties: IndexMap<PropertyId, Property>,
    /// H0–H6 (empty for a structured derivation).
    pub hypotheses: IndexMap<HypothesisId, Hypothesis>,
    /// H0–H5 all hold (the paper's sufficient condition); `None` when not evaluated
    /// (structured derivation).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub proposition_2_1: Option<bool>,
    /// Whether the paper's equations are the true ones for this Z (correction ≡ 0); `None` for
    /// a structured derivation.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub paper_is_exact: Option<bool>,
    /// What the equations actually contain.
    pub ground_truth: GroundTruth,
    /// Sentences comparing the verdict with the truth.
    pub findings: Vec<String>,
    /// The reduced system, when every asked coordinate is absent and the kinematics close.
    pub reduced_system: Option<ReducedSystem>,
}
