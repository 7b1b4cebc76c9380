//! The description of a mechanism: the world, a tree of frames, bodies on them, rolling wheels,
//! blades and holonomic constraints. Every expression is a function of the coordinates and
//! parameters (no velocities); names are resolved by the caller.

use hamel_expr::Expr;

use crate::vector::{V3, unit};

/// A coordinate axis with a sign: `x`, `-z`, …
#[derive(serde::Serialize, serde::Deserialize, Clone, Copy, Debug, PartialEq, Eq)]
pub struct Axis {
    /// 0, 1, 2 for x, y, z.
    pub index: usize,
    /// +1 or −1.
    pub sign: i64,
}

impl Axis {
    /// The axis named `x`, `y`, `z`, `-x`, `-y`, `-z` (`+x` … too).
    pub fn parse(text: &str) -> Option<Axis> {
        let t = text.trim();
        let (sign, name) = match t.strip_prefix('-') {
            Some(rest) => (-1, rest.trim()),
            None => (1, t.strip_prefix('+').unwrap_or(t).trim()),
        };
        let index = ["x", "y", "z"].iter().position(|a| *a == name)?;
        Some(Axis { index, sign })
    }

    /// The unit vector.
    pub fn vector(self) -> V3 {
        unit(self.index, self.sign)
    }
}

/// A direction in a frame's axes: a signed coordinate axis, or a vector of expressions (of
/// unit length).
#[derive(serde::Serialize, serde::Deserialize, Clone, Debug, PartialEq)]
pub enum Direction {
    /// A coordinate axis.
    Axis(Axis),
    /// Components in the frame's axes.
    Vector(V3),
}

impl Direction {
    /// The components.
    pub fn vector(&self) -> V3 {
        match self {
            Direction::Axis(a) => a.vector(),
            Direction::Vector(v) => v.clone(),
        }
    }
}

/// The world: which way is up, and gravity's strength.
#[derive(serde::Serialize, serde::Deserialize, Clone, Debug, PartialEq)]
pub struct World {
    /// The up direction, a world axis; the ground is the plane through the origin normal to it.
    pub up: Axis,
    /// The gravitational acceleration's magnitude (acting against `up`).
    pub gravity: Expr,
}

/// One rotation of a frame relative to its parent: about `axis` (in the axes reached by the
/// rotations before it) by `angle`.
#[derive(serde::Serialize, serde::Deserialize, Clone, Debug, PartialEq)]
pub struct Rotation {
    /// The axis.
    pub axis: Direction,
    /// The angle (right-handed about the axis).
    pub angle: Expr,
}

/// A frame: its parent (`world` or another frame), the position of its origin in the parent's
/// axes, and the successive rotations that take the parent's axes to its own.
#[derive(serde::Serialize, serde::Deserialize, Clone, Debug, PartialEq)]
pub struct Frame {
    /// Its name.
    pub name: String,
    /// The parent's name (`world` for the fixed frame).
    pub parent: String,
    /// The origin, in the parent's axes.
    pub origin: V3,
    /// Rotations, applied in order (intrinsic).
    pub rotations: Vec<Rotation>,
}

/// An inertia tensor about the centre of mass, in the body's axes.
#[derive(serde::Serialize, serde::Deserialize, Clone, Debug, PartialEq)]
pub struct Inertia {
    /// I_xx, I_yy, I_zz, I_xy, I_xz, I_yz (the matrix entries: I_xy = −∫xy dm).
    pub entries: [Expr; 6],
}

impl Inertia {
    /// Whether it is symmetric about coordinate axis `i`, as written: no products of inertia
    /// with that axis or across it, and equal moments about the other two axes.
    pub fn is_symmetric_about(&self, i: usize) -> bool {
        let m = self.matrix();
        let (j, k) = ((i + 1) % 3, (i + 2) % 3);
        let zero = |e: &Expr| e.is_zero_literal();
        zero(&m[i][j]) && zero(&m[i][k]) && zero(&m[j][k]) && m[j][j] == m[k][k]
    }

    /// The matrix.
    pub fn matrix(&self) -> [[Expr; 3]; 3] {
        let [xx, yy, zz, xy, xz, yz] = self.entries.clone();
        [
            [xx, xy.clone(), xz.clone()],
            [xy, yy, yz.clone()],
            [xz, yz, zz],
        ]
    }
}

/// A rigid body attached to a frame.
#[derive(serde::Serialize, serde::Deserialize, Clone, Debug, PartialEq)]
pub struct Body {
    /// Its name.
    pub name: String,
    /// The frame it moves with.
    pub frame: String,
    /// Its mass.
    pub mass: Expr,
    /// The centre of mass, in the frame's axes.
    pub centre_of_mass: V3,
    /// The inertia about the centre of mass, in the frame's axes (none: a point mass).
    pub inertia: Option<Inertia>,
}

/// A wheel rolling without slipping on the ground: a thin disk, or a tyre (a torus) with a crown.
#[derive(serde::Serialize, serde::Deserialize, Clone, Debug, PartialEq)]
pub struct Wheel {
    /// Its name.
    pub name: String,
    /// The frame that turns with the wheel; its origin is the wheel's centre.
    pub frame: String,
    /// The spin axis, in the frame's axes (unit length).
    pub axis: Direction,
    /// The radius (a torus's major radius: from the axis to the middle of the tyre's crown).
    pub radius: Expr,
    /// The crown radius of a tyre (the torus's minor radius, about the circle of `radius`);
    /// None: a thin disk.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub crown: Option<Expr>,
    /// The coordinate the contact's height constraint determines, if the frames do not keep
    /// the wheel on the ground by construction.
    pub dependent: Option<String>,
}

/// A convex surface of a body, rolling without slipping on the ground (`[rolling.NAME]`,
/// issue 62): a ball, a ball robot's shell, a rattleback's hull.
#[derive(serde::Serialize, serde::Deserialize, Clone, Debug, PartialEq)]
pub struct Roller {
    /// Its name.
    pub name: String,
    /// The frame the surface is fixed in.
    pub frame: String,
    /// The surface's centre, in the frame's axes (a Routh sphere's centre of mass is off it).
    pub centre: V3,
    /// The surface.
    pub surface: Surface,
    /// The coordinate the contact's height constraint determines, if the frames do not keep
    /// the surface on the ground by construction.
    pub dependent: Option<String>,
}

/// A rolling body's convex surface, about its centre.
#[derive(serde::Serialize, serde::Deserialize, Clone, Debug, PartialEq)]
pub enum Surface {
    /// A sphere of this radius.
    Sphere {
        /// The radius.
        radius: Expr,
    },
    /// An ellipsoid with these semi-axes along the frame's axes.
    Ellipsoid {
        /// The semi-axes (x, y, z).
        semi_axes: V3,
    },
}

/// A blade (knife edge, sleigh runner, skate): the point may not move across the blade, in the
/// ground plane.
#[derive(serde::Serialize, serde::Deserialize, Clone, Debug, PartialEq)]
pub struct Blade {
    /// Its name.
    pub name: String,
    /// The frame it is fixed in.
    pub frame: String,
    /// The contact point, in the frame's axes.
    pub point: V3,
    /// The blade's direction, in the frame's axes.
    pub direction: Direction,
}

/// A load: a force at a point of a frame, or a torque on a frame.
#[derive(serde::Serialize, serde::Deserialize, Clone, Debug, PartialEq)]
pub struct Load {
    /// Its name.
    pub name: String,
    /// The frame it acts on.
    pub frame: String,
    /// The frame whose axes its vector is written in (`world`, or a frame).
    pub axes: String,
    /// What it is.
    pub kind: LoadKind,
}

/// A force or a torque.
#[derive(serde::Serialize, serde::Deserialize, Clone, Debug, PartialEq)]
pub enum LoadKind {
    /// A force applied at a point.
    Force {
        /// The point, in the frame's axes.
        point: V3,
        /// The force.
        force: V3,
    },
    /// A torque, and the frame that takes its reaction −τ (a motor, a rider's steer torque).
    Torque {
        /// The torque.
        torque: V3,
        /// The frame that takes −τ, if any.
        reaction: Option<String>,
    },
}

/// A point of a frame (moving in it where its components depend on q).
#[derive(serde::Serialize, serde::Deserialize, Clone, Debug, PartialEq)]
pub struct Anchor {
    /// The frame (`world`, or a frame).
    pub frame: String,
    /// The point, in the frame's axes.
    pub point: V3,
}

/// What a spring or a damper stretches: the distance between two points, or a coordinate.
#[derive(serde::Serialize, serde::Deserialize, Clone, Debug, PartialEq)]
pub enum Stretch {
    /// The distance between two points of two frames (a linear element).
    Between(Box<[Anchor; 2]>),
    /// A coordinate (a torsional element on a joint angle, or a linear one on a slider).
    Coordinate(String),
}

/// A linear spring: U gains −½ k (d − d₀)², d the stretch (L = T + U).
#[derive(serde::Serialize, serde::Deserialize, Clone, Debug, PartialEq)]
pub struct Spring {
    /// Its name.
    pub name: String,
    /// What it stretches.
    pub stretch: Stretch,
    /// k, positive at the default parameters.
    pub stiffness: Expr,
    /// d₀: the rest length (or angle).
    pub rest: Expr,
}

/// A linear damper: the force −c ḋ along the stretch d, which enters F (it does work).
#[derive(serde::Serialize, serde::Deserialize, Clone, Debug, PartialEq)]
pub struct Damper {
    /// Its name.
    pub name: String,
    /// What it stretches.
    pub stretch: Stretch,
    /// c, positive at the default parameters.
    pub damping: Expr,
}

/// A holonomic constraint h(q) = 0 and the coordinate it determines.
#[derive(serde::Serialize, serde::Deserialize, Clone, Debug, PartialEq)]
pub struct Holonomic {
    /// Its name.
    pub name: String,
    /// h.
    pub h: Expr,
    /// The dependent coordinate.
    pub dependent: String,
}

/// A whole mechanism.
#[derive(serde::Serialize, serde::Deserialize, Clone, Debug, PartialEq)]
pub struct Mechanism {
    /// The coordinates q₁..q_ℓ, in order.
    pub coordinates: Vec<String>,
    /// Up and gravity.
    pub world: World,
    /// The frames (any order; parents are found by name).
    pub frames: Vec<Frame>,
    /// The bodies.
    pub bodies: Vec<Body>,
    /// Rolling wheels.
    pub wheels: Vec<Wheel>,
    /// Rolling bodies with a curved surface (`[rolling.NAME]`: spheres, ellipsoids).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub rollers: Vec<Roller>,
    /// Blades.
    pub blades: Vec<Blade>,
    /// Holonomic constraints.
    pub holonomic: Vec<Holonomic>,
    /// Loads that U does not give.
    pub loads: Vec<Load>,
    /// Springs (they enter U).
    pub springs: Vec<Spring>,
    /// Dampers (they enter F).
    pub dampers: Vec<Damper>,
    /// Shapes to draw (`[shapes.NAME]`): what an animated page shows of the frames; no
    /// effect on the dynamics.
    #[serde(default)]
    pub shapes: Vec<Shape>,
}

/// A solid drawn on a frame (`[shapes.NAME]`, issue 60). It stands in, on an animated page,
/// for the bodies of its frame, which are otherwise drawn as the solids of their inertia; it
/// has no mass and no effect on the dynamics.
#[derive(serde::Serialize, serde::Deserialize, Clone, Debug, PartialEq)]
pub struct Shape {
    /// Its name.
    pub name: String,
    /// The frame it moves with (`world` for scenery).
    pub frame: String,
    /// Its centre, in the frame's axes.
    pub centre: V3,
    /// What it is, and its sizes (expressions of the parameters).
    pub geometry: Geometry,
    /// Its colour as red, green, blue; None: the page's palette.
    pub colour: Option<[u8; 3]>,
}

/// A shape's solid.
#[derive(serde::Serialize, serde::Deserialize, Clone, Debug, PartialEq)]
pub enum Geometry {
    /// A box with these side lengths along the frame's axes.
    Box {
        /// Full side lengths (x, y, z).
        size: V3,
    },
    /// A circular cylinder about a frame axis, centred on the shape's centre.
    Cylinder {
        /// Its radius.
        radius: Expr,
        /// Its length along the axis.
        length: Expr,
        /// Its axis.
        axis: Axis,
    },
    /// A sphere.
    Sphere {
        /// Its radius.
        radius: Expr,
    },
}

/// The name of the fixed frame.
pub const WORLD: &str = "world";

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn axes_parse_with_signs() {
        assert_eq!(Axis::parse("-z"), Some(Axis { index: 2, sign: -1 }));
        assert_eq!(Axis::parse("+y"), Some(Axis { index: 1, sign: 1 }));
        assert_eq!(Axis::parse("x"), Some(Axis { index: 0, sign: 1 }));
        assert_eq!(Axis::parse("w"), None);
    }
}
