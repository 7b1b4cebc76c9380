//! Why a mechanism could not be expanded, and where in its description.

use hamel_expr::DiffError;

/// A section of the description.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Section {
    /// `[world]`
    World,
    /// `[frames.NAME]`
    Frames,
    /// `[bodies.NAME]`
    Bodies,
    /// `[wheels.NAME]`
    Wheels,
    /// `[rolling.NAME]`
    Rolling,
    /// `[blades.NAME]`
    Blades,
    /// `[holonomic.NAME]`
    Holonomic,
    /// `[loads.NAME]`
    Loads,
    /// `[springs.NAME]`
    Springs,
    /// `[dampers.NAME]`
    Dampers,
}

impl Section {
    /// The section's key in a model file.
    pub fn key(self) -> &'static str {
        match self {
            Section::World => "world",
            Section::Frames => "frames",
            Section::Bodies => "bodies",
            Section::Wheels => "wheels",
            Section::Rolling => "rolling",
            Section::Blades => "blades",
            Section::Holonomic => "holonomic",
            Section::Loads => "loads",
            Section::Springs => "springs",
            Section::Dampers => "dampers",
        }
    }
}

/// Where a problem is: a section, the entry's name (none for `[world]`) and a field.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Place {
    /// The section.
    pub section: Section,
    /// The entry.
    pub name: Option<String>,
    /// The field.
    pub field: &'static str,
}

impl Place {
    /// The place of `field` of the entry `name` of `section`.
    pub fn new(section: Section, name: &str, field: &'static str) -> Place {
        Place {
            section,
            name: Some(name.to_string()),
            field,
        }
    }

    /// The key path, such as `frames.fork.parent`.
    pub fn key(&self) -> String {
        match &self.name {
            Some(n) => format!("{}.{n}.{}", self.section.key(), self.field),
            None => format!("{}.{}", self.section.key(), self.field),
        }
    }
}

impl std::fmt::Display for Place {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.key())
    }
}

/// What is wrong.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum Problem {
    /// A frame named that does not exist.
    #[error("unknown frame `{0}`")]
    UnknownFrame(String),
    /// Two frames with one name (or a frame named `world`).
    #[error("a second frame named `{0}`")]
    DuplicateFrame(String),
    /// The parents never reach the world.
    #[error("the frames form a cycle: {}", .0.join(" → "))]
    Cycle(Vec<String>),
    /// A coordinate named that does not exist.
    #[error("`{0}` is not a coordinate")]
    UnknownCoordinate(String),
    /// An expression of the configuration that cannot be differentiated: it holds a velocity,
    /// or its derivative would be too large.
    #[error("{0}")]
    Velocity(#[from] DiffError),
    /// An expression could not be evaluated at the default parameters.
    #[error("cannot evaluate at the default parameters: {0}")]
    Evaluation(String),
    /// An inertia that no rigid body has.
    #[error("the inertia is not positive definite at the default parameters ({0})")]
    Inertia(String),
    /// A spring's stiffness or a damper's damping that is not positive.
    #[error("the {what} is not positive at the default parameters ({value})")]
    NotPositive {
        /// `stiffness` or `damping`.
        what: &'static str,
        /// Its value there.
        value: f64,
    },
    /// A negative or zero mass.
    #[error("the mass is not positive at the default parameters ({0})")]
    Mass(f64),
    /// A zero direction.
    #[error("the direction is zero at the default parameters")]
    ZeroAxis,
    /// A direction of another length than one.
    #[error("the direction must have unit length; at the default parameters it has length {0}")]
    NotUnit(f64),
    /// A wheel whose spin axis points up at the reference configuration.
    #[error(
        "the wheel lies flat on the ground at the reference configuration (its axis is vertical)"
    )]
    FlatWheel,
    /// A blade along the vertical at the reference configuration.
    #[error("the blade is vertical at the reference configuration")]
    VerticalBlade,
    /// A non-positive radius.
    #[error("the radius is not positive at the default parameters ({0})")]
    Radius(f64),
    /// A non-positive semi-axis of an ellipsoid.
    #[error("the semi-axis along {axis} is not positive at the default parameters ({value})")]
    SemiAxis {
        /// `x`, `y` or `z`.
        axis: &'static str,
        /// Its value there.
        value: f64,
    },
    /// A tyre's crown radius that is negative or not below its wheel's radius.
    #[error(
        "the crown radius must be at least 0 and less than the wheel's radius {radius} at the default parameters; it is {crown}"
    )]
    Crown {
        /// The crown radius.
        crown: f64,
        /// The wheel's radius.
        radius: f64,
    },
    /// A wheel or rolling body whose frames do not keep it on the ground and that names no
    /// dependent coordinate.
    #[error(
        "the {what}'s contact leaves the ground (height {height:.3e} at q = {at:?}): name the coordinate its height constraint determines with `dependent`"
    )]
    OffGround {
        /// `wheel` or `rolling body`.
        what: &'static str,
        /// The contact's height there.
        height: f64,
        /// The configuration.
        at: Vec<f64>,
    },
    /// A contact whose height does not involve the coordinate named to determine it: its frames
    /// cannot bring it to the ground by that coordinate.
    #[error(
        "the contact's height does not depend on `{0}`: moving it cannot bring the contact to the ground (name a coordinate its frames' height involves)"
    )]
    HeightFree(String),
    /// A holonomic constraint that cannot be solved for its dependent coordinate.
    #[error(
        "the constraint does not determine `{coordinate}` at the reference configuration: {reason}"
    )]
    Undetermined {
        /// The dependent coordinate.
        coordinate: String,
        /// Why.
        reason: String,
    },
    /// Two holonomic constraints that name one dependent coordinate.
    #[error("`{0}` is already the dependent coordinate of another constraint")]
    DependentTwice(String),
}

/// A problem and its place.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("{place}: {problem}")]
pub struct BodiesError {
    /// Where.
    pub place: Place,
    /// What.
    pub problem: Problem,
}

impl BodiesError {
    /// `problem` at `place`.
    pub fn new(place: Place, problem: impl Into<Problem>) -> BodiesError {
        BodiesError {
            place,
            problem: problem.into(),
        }
    }
}
