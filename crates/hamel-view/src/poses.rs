//! Where every frame of a mechanism is, at a configuration: its origin in world coordinates
//! and the unit quaternion of its axes, evaluated from the frames' own expressions (no
//! derivation, no computer algebra).
//!
//! As `hamel_bodies::frames` defines them: a frame's origin is given in its parent's axes, and
//! its rotations are intrinsic, R = R₁(θ₁)⋯R_n(θ_n) taking the frame's axes to its parent's.
//! So, in the world: q_frame = q_parent ⊗ q₁ ⊗ ⋯ ⊗ q_n and p_frame = p_parent + q_parent·o.

use hamel_bodies::{Mechanism, Point, WORLD};
use indexmap::IndexMap;

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
    /// A frame's parent comes after it or does not exist (the mechanism was not checked).
    #[error("frame `{frame}`: its parent `{parent}` is not placed before it")]
    Parent {
        /// The frame.
        frame: String,
        /// Its parent.
        parent: String,
    },
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
    for f in ordered(m) {
        let fail = |why: String| PoseError::Evaluation {
            frame: f.name.clone(),
            why,
        };
        let value = |e: &hamel_expr::Expr| point.value(e).map_err(|p| fail(p.to_string()));
        let parent = *placed.get(&f.parent).ok_or_else(|| PoseError::Parent {
            frame: f.name.clone(),
            parent: f.parent.clone(),
        })?;
        let o = [
            value(&f.origin[0])?,
            value(&f.origin[1])?,
            value(&f.origin[2])?,
        ];
        let mut rotation = parent.rotation;
        for r in &f.rotations {
            let a = r.axis.vector();
            let a = [value(&a[0])?, value(&a[1])?, value(&a[2])?];
            let norm = (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt();
            if norm == 0.0 {
                return Err(PoseError::Axis {
                    frame: f.name.clone(),
                });
            }
            let half = 0.5 * value(&r.angle)?;
            let s = half.sin() / norm;
            rotation = multiply(rotation, [half.cos(), s * a[0], s * a[1], s * a[2]]);
        }
        let position = parent.apply(o);
        placed.insert(f.name.clone(), Pose { position, rotation });
    }
    Ok(placed)
}

/// The frames, each after its parent (a checked mechanism has no cycle; a parent that never
/// comes is reported by [`poses`]).
fn ordered(m: &Mechanism) -> Vec<&hamel_bodies::Frame> {
    let mut out: Vec<&hamel_bodies::Frame> = Vec::with_capacity(m.frames.len());
    let mut left: Vec<&hamel_bodies::Frame> = m.frames.iter().collect();
    while !left.is_empty() {
        let ready =
            |f: &&hamel_bodies::Frame| f.parent == WORLD || out.iter().any(|p| p.name == f.parent);
        match left.iter().position(ready) {
            Some(i) => out.push(left.remove(i)),
            // An orphan: placed last, where its missing parent is reported.
            None => out.push(left.remove(0)),
        }
    }
    out
}

/// The Hamilton product a ⊗ b.
fn multiply(a: [f64; 4], b: [f64; 4]) -> [f64; 4] {
    [
        a[0] * b[0] - a[1] * b[1] - a[2] * b[2] - a[3] * b[3],
        a[0] * b[1] + a[1] * b[0] + a[2] * b[3] - a[3] * b[2],
        a[0] * b[2] - a[1] * b[3] + a[2] * b[0] + a[3] * b[1],
        a[0] * b[3] + a[1] * b[2] - a[2] * b[1] + a[3] * b[0],
    ]
}

/// v turned by the unit quaternion q.
pub fn rotate(q: [f64; 4], v: [f64; 3]) -> [f64; 3] {
    let [w, x, y, z] = q;
    // v + 2w (u × v) + 2 u × (u × v), u = (x, y, z)
    let t = [
        2.0 * (y * v[2] - z * v[1]),
        2.0 * (z * v[0] - x * v[2]),
        2.0 * (x * v[1] - y * v[0]),
    ];
    [
        v[0] + w * t[0] + (y * t[2] - z * t[1]),
        v[1] + w * t[1] + (z * t[0] - x * t[2]),
        v[2] + w * t[2] + (x * t[1] - y * t[0]),
    ]
}
