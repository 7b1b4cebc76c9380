//! The raw TOML schema (what serde reads), before names are resolved.

use indexmap::IndexMap;
use serde::Deserialize;
use toml::Spanned;

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct RawModel {
    pub name: Spanned<String>,
    pub title: Spanned<String>,
    #[serde(default)]
    pub description: Option<String>,
    pub coordinates: Spanned<Vec<Spanned<String>>>,
    #[serde(default)]
    pub parameters: IndexMap<String, Spanned<toml::Value>>,
    /// Parameters declared positive (masses, lengths), for printing.
    #[serde(default)]
    pub positive: Option<Spanned<Vec<Spanned<String>>>>,
    /// Named inputs (steer torque, pedalling) and their default values.
    #[serde(default)]
    pub inputs: IndexMap<String, Spanned<toml::Value>>,
    pub lagrangian: Option<Spanned<RawLagrangian>>,
    /// Generalised forces of the applied loads that U does not give, by coordinate.
    #[serde(default)]
    pub forces: IndexMap<String, Spanned<String>>,
    #[serde(default)]
    pub constraints: IndexMap<String, Spanned<String>>,
    pub world: Option<Spanned<RawWorld>>,
    #[serde(default)]
    pub frames: IndexMap<String, Spanned<RawFrame>>,
    #[serde(default)]
    pub bodies: IndexMap<String, Spanned<RawBody>>,
    #[serde(default)]
    pub wheels: IndexMap<String, Spanned<RawWheel>>,
    /// Rolling bodies with a curved surface (issue 62).
    #[serde(default)]
    pub rolling: IndexMap<String, Spanned<RawRoller>>,
    #[serde(default)]
    pub blades: IndexMap<String, Spanned<RawBlade>>,
    #[serde(default)]
    pub holonomic: IndexMap<String, Spanned<RawHolonomic>>,
    #[serde(default)]
    pub loads: IndexMap<String, Spanned<RawLoad>>,
    #[serde(default)]
    pub springs: IndexMap<String, Spanned<RawSpring>>,
    #[serde(default)]
    pub dampers: IndexMap<String, Spanned<RawDamper>>,
    /// Shapes to draw on frames (animated pages only).
    #[serde(default)]
    pub shapes: IndexMap<String, Spanned<RawShape>>,
    #[serde(default)]
    pub quasi_velocities: IndexMap<String, Spanned<RawChoice>>,
    #[serde(default)]
    pub symmetries: IndexMap<String, Spanned<IndexMap<String, Spanned<String>>>>,
    /// Steady motions, by name.
    #[serde(default)]
    pub steady: IndexMap<String, Spanned<RawSteady>>,
    /// Names for groups of parameters that printing uses (`m = "m_d + m_f + m_r"`).
    #[serde(default)]
    pub abbreviations: IndexMap<String, Spanned<String>>,
}

/// `[steady.NAME]`: a steady motion in named steady parameters.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct RawSteady {
    #[serde(default)]
    pub description: Option<String>,
    /// The steady parameters (such as the speed v) and their default values.
    #[serde(default)]
    pub parameters: IndexMap<String, Spanned<toml::Value>>,
    /// Values of coordinates (the others are 0, the dependent ones completed).
    #[serde(default)]
    pub q: IndexMap<String, Spanned<RawScalar>>,
    /// Values of velocities der(q_k) (the others solved from the constraints).
    #[serde(default)]
    pub velocities: IndexMap<String, Spanned<RawScalar>>,
}

/// A matrix of expressions as rows of strings, each with its place in the file.
pub(crate) type RawMatrix = Vec<Spanned<Vec<Spanned<String>>>>;

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct RawLagrangian {
    pub kinetic: Option<Spanned<String>>,
    pub mass_matrix: Option<Spanned<RawMatrix>>,
    pub potential: Option<Spanned<String>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct RawChoice {
    pub eta: Spanned<Vec<Spanned<String>>>,
    #[serde(default)]
    pub description: Option<String>,
}

/// A scalar written as an expression string or as a number.
#[derive(Deserialize, Clone)]
#[serde(untagged)]
pub(crate) enum RawScalar {
    Text(String),
    Integer(i64),
    Float(f64),
}

impl RawScalar {
    /// The expression text.
    pub fn text(&self) -> String {
        match self {
            RawScalar::Text(t) => t.clone(),
            RawScalar::Integer(i) => i.to_string(),
            RawScalar::Float(f) => format!("{f:?}"),
        }
    }
}

/// A vector of three scalars.
pub(crate) type RawVector = Spanned<Vec<Spanned<RawScalar>>>;

/// A direction: an axis name (`x`, `-z`, …) or a vector.
#[derive(Deserialize)]
#[serde(untagged)]
pub(crate) enum RawDirection {
    Axis(String),
    Vector(Vec<RawScalar>),
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct RawWorld {
    pub up: Spanned<String>,
    pub gravity: Option<Spanned<RawScalar>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct RawRotation {
    pub axis: Spanned<RawDirection>,
    pub angle: Spanned<RawScalar>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct RawFrame {
    pub parent: Option<Spanned<String>>,
    pub origin: Option<RawVector>,
    #[serde(default)]
    pub rotations: Vec<Spanned<RawRotation>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct RawInertia {
    pub xx: Spanned<RawScalar>,
    pub yy: Spanned<RawScalar>,
    pub zz: Spanned<RawScalar>,
    pub xy: Option<Spanned<RawScalar>>,
    pub xz: Option<Spanned<RawScalar>>,
    pub yz: Option<Spanned<RawScalar>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct RawBody {
    pub frame: Spanned<String>,
    pub mass: Spanned<RawScalar>,
    pub centre_of_mass: Option<RawVector>,
    pub inertia: Option<Spanned<RawInertia>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct RawWheel {
    pub frame: Spanned<String>,
    pub axis: Spanned<RawDirection>,
    pub radius: Spanned<RawScalar>,
    /// The tyre's crown radius (a torus about the axis); absent: a thin disk.
    pub crown: Option<Spanned<RawScalar>>,
    pub dependent: Option<Spanned<String>>,
}

/// `[rolling.NAME]`: a convex surface on a frame, exactly one of `sphere` and `ellipsoid`.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct RawRoller {
    pub frame: Spanned<String>,
    /// The radius.
    pub sphere: Option<Spanned<RawScalar>>,
    /// The semi-axes along the frame's axes.
    pub ellipsoid: Option<RawVector>,
    /// The surface's centre in the frame's axes (default: the origin).
    pub centre: Option<RawVector>,
    pub dependent: Option<Spanned<String>>,
}

/// `[shapes.NAME]`: exactly one of `box`, `cylinder`, `sphere`, on a frame.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct RawShape {
    pub frame: Spanned<String>,
    /// Side lengths along the frame's axes.
    #[serde(rename = "box")]
    pub cuboid: Option<RawVector>,
    pub cylinder: Option<Spanned<RawCylinder>>,
    /// The radius.
    pub sphere: Option<Spanned<RawScalar>>,
    pub centre: Option<RawVector>,
    pub colour: Option<Spanned<String>>,
}

/// A shape's `cylinder = { radius = …, length = …, axis = "z" }`.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct RawCylinder {
    pub radius: Spanned<RawScalar>,
    pub length: Spanned<RawScalar>,
    pub axis: Option<Spanned<String>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct RawBlade {
    pub frame: Spanned<String>,
    pub point: Option<RawVector>,
    pub direction: Spanned<RawDirection>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct RawHolonomic {
    pub h: Spanned<String>,
    pub dependent: Spanned<String>,
}

/// `[loads.NAME]`: a force at a point of a frame, or a torque on a frame.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct RawLoad {
    pub frame: Spanned<String>,
    pub point: Option<RawVector>,
    pub force: Option<RawVector>,
    pub torque: Option<RawVector>,
    pub axes: Option<Spanned<String>>,
    pub reaction: Option<Spanned<String>>,
}

/// A point of a frame: `{ frame = "body", point = [x, y, z] }` (default the frame's origin).
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct RawAnchor {
    pub frame: Spanned<String>,
    pub point: Option<RawVector>,
}

/// `[springs.NAME]`: between two points (`between`) or on a coordinate (`coordinate`).
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct RawSpring {
    pub between: Option<Spanned<Vec<RawAnchor>>>,
    pub coordinate: Option<Spanned<String>>,
    pub stiffness: Spanned<RawScalar>,
    /// The rest length (or angle); default 0.
    pub rest: Option<Spanned<RawScalar>>,
}

/// `[dampers.NAME]`: between two points (`between`) or on a coordinate (`coordinate`).
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct RawDamper {
    pub between: Option<Spanned<Vec<RawAnchor>>>,
    pub coordinate: Option<Spanned<String>>,
    pub damping: Spanned<RawScalar>,
}
