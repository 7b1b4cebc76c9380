//! Where every frame of a mechanism is, at a configuration: its origin in world coordinates
//! and the unit quaternion of its axes, evaluated from the frames' own expressions (no
//! derivation, no computer algebra).
//!
//! As `hamel_bodies::frames` defines them: a frame's origin is given in its parent's axes, and
//! its rotations are intrinsic, R = R₁(θ₁)⋯R_n(θ_n) taking the frame's axes to its parent's.
//! So, in the world: q_frame = q_parent ⊗ q₁ ⊗ ⋯ ⊗ q_n and p_frame = p_parent + q_parent·o.

use hamel_bodies::{Mechanism, Point, WORLD};
use indexmap::IndexMap;
use nalgebra::{Quaternion, UnitQuaternion, Vector3};

/// A frame's place in the world: the position of its origin and the unit quaternion
/// (w, x, y, z) that turns the world's axes into the frame's.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Pose {
    /// The origin, in world coordinates.
    pub position: [f64; 3],
    /// The rotation, (w, x, y, z), of unit length.
    pub rotation: [f64; 4],
}

/// Why a pose cannot be computed.
#[derive(Clone, Debug, thiserror::Error)]
pub enum PoseError {
    /// An expression of a frame does not evaluate to a finite number here.
    #[error("frame `{frame}`: {why}")]
    Evaluation {
        /// The frame.
        frame: String,
        /// Why.
        why: String,
    },
    /// The frame tree is not a tree (an unknown parent, a duplicate, a cycle: a mechanism
    /// that was not checked).
    #[error(transparent)]
    Tree(#[from] hamel_bodies::BodiesError),
    /// A rotation's axis has zero length here.
    #[error("frame `{frame}`: a rotation axis of zero length")]
    Axis {
        /// The frame.
        frame: String,
    },
}

impl Pose {
    /// The world's own pose.
    pub const WORLD: Pose = Pose {
        position: [0.0; 3],
        rotation: [1.0, 0.0, 0.0, 0.0],
    };

    /// A point given in the frame's axes, in world coordinates.
    pub fn apply(&self, v: [f64; 3]) -> [f64; 3] {
        let r = rotate(self.rotation, v);
        [
            self.position[0] + r[0],
            self.position[1] + r[1],
            self.position[2] + r[2],
        ]
    }
}

/// Every frame's pose (the world first, then the frames in the order they are given, each
/// after its parent) at the configuration `q` of `m.coordinates`, with parameter values
/// `params`.
pub fn poses(
    m: &Mechanism,
    q: &[f64],
    params: &IndexMap<String, f64>,
) -> Result<IndexMap<String, Pose>, PoseError> {
    let point = Point::at(&m.coordinates, q, params);
    let mut placed = IndexMap::from([(WORLD.to_string(), Pose::WORLD)]);
    for f in hamel_bodies::frames_in_order(&m.frames)? {
        let fail = |why: String| PoseError::Evaluation {
            frame: f.name.clone(),
            why,
        };
        let value = |e: &hamel_expr::Expr| point.value(e).map_err(|p| fail(p.to_string()));
        let parent = placed[&f.parent];
        let o = [
            value(&f.origin[0])?,
            value(&f.origin[1])?,
            value(&f.origin[2])?,
        ];
        let mut rotation = unit(parent.rotation);
        for r in &f.rotations {
            let a = r.axis.vector();
            let a = [value(&a[0])?, value(&a[1])?, value(&a[2])?];
            let axis =
                nalgebra::Unit::try_new(Vector3::from(a), 0.0).ok_or_else(|| PoseError::Axis {
                    frame: f.name.clone(),
                })?;
            rotation *= UnitQuaternion::from_axis_angle(&axis, value(&r.angle)?);
        }
        let position = parent.apply(o);
        let rotation = [rotation.w, rotation.i, rotation.j, rotation.k];
        placed.insert(f.name.clone(), Pose { position, rotation });
    }
    Ok(placed)
}

/// (w, x, y, z) as nalgebra's unit quaternion (normalised).
fn unit(q: [f64; 4]) -> UnitQuaternion<f64> {
    UnitQuaternion::from_quaternion(Quaternion::new(q[0], q[1], q[2], q[3]))
}

/// v turned by the unit quaternion q = (w, x, y, z).
pub fn rotate(q: [f64; 4], v: [f64; 3]) -> [f64; 3] {
    let r = unit(q) * Vector3::from(v);
    [r.x, r.y, r.z]
}
