//! The frame tree and its kinematics. For every frame, in its own axes: where the world's axes
//! point, its angular velocity ω, the velocity of its origin and the origin's height, each
//! built from its parent's, one frame at a time:
//!
//! * R = R₁(θ₁)⋯R_n(θ_n) takes the frame's axes to its parent's (intrinsic rotations);
//! * ω = Rᵀω_parent + Σ_i (R_{i+1}⋯R_n)ᵀ a_i θ̇_i (the rotation rates, composed);
//! * v = Rᵀ(v_parent + ω_parent × o + ȯ), with o the origin in the parent's axes;
//! * height = height_parent + up_parent · o.
//!
//! Angular velocities come from composing rates, never from differentiating rotation matrices,
//! and nothing is expanded: the trees stay the size of the description.

use hamel_expr::Expr;
use hamel_expr::Func;
use hamel_expr::build::{mul, neg, sub};
use indexmap::IndexMap;

use crate::error::{BodiesError, Place, Problem, Section};
use crate::mechanism::{Axis, Direction, Frame, Mechanism, Rotation, WORLD};
use crate::vector::{M3, Rate, V3, apply_transpose, compose, dot, identity, negate};

/// The kinematics of one frame, in its own axes.
#[derive(Clone, Debug)]
pub(crate) struct Kinematics {
    /// Row j: the world's axis j.
    pub world_axes: M3,
    /// The up direction.
    pub up: V3,
    /// Angular velocity.
    pub omega: Rate,
    /// Velocity of the origin.
    pub velocity: Rate,
    /// Height of the origin above the ground.
    pub height: Expr,
}

/// Every frame's kinematics, the world's first, each after its parent.
pub(crate) struct Tree {
    pub frames: IndexMap<String, Kinematics>,
    /// The world's up axis.
    pub up: Axis,
}

impl Tree {
    /// The kinematics of the frame `name` (the caller has checked that it exists).
    pub fn get(&self, name: &str) -> &Kinematics {
        &self.frames[name]
    }

    /// Whether `name` is a frame.
    pub fn contains(&self, name: &str) -> bool {
        self.frames.contains_key(name)
    }
}

/// Build the tree of `m`'s frames.
pub(crate) fn build(m: &Mechanism) -> Result<Tree, BodiesError> {
    let order = order(&m.frames)?;
    let ell = m.coordinates.len();
    let up_axis = m.world.up;
    let world = Kinematics {
        world_axes: identity(),
        up: up_axis.vector(),
        omega: Rate::zero(ell),
        velocity: Rate::zero(ell),
        height: Expr::int(0),
    };
    let mut frames = IndexMap::from([(WORLD.to_string(), world)]);
    for f in order {
        let parent = &frames[&f.parent];
        let child = child_kinematics(parent, f, &m.coordinates, up_axis.index, up_axis.sign)?;
        frames.insert(f.name.clone(), child);
    }
    Ok(Tree {
        frames,
        up: up_axis,
    })
}

/// The frames, each after its parent; errors for unknown parents, duplicates and cycles.
pub fn order(frames: &[Frame]) -> Result<Vec<&Frame>, BodiesError> {
    let by_name: IndexMap<&str, &Frame> = frames.iter().map(|f| (f.name.as_str(), f)).collect();
    for (i, f) in frames.iter().enumerate() {
        let place = Place::new(Section::Frames, &f.name, "parent");
        if f.name == WORLD || frames[..i].iter().any(|g| g.name == f.name) {
            return Err(BodiesError::new(
                place,
                Problem::DuplicateFrame(f.name.clone()),
            ));
        }
        if f.parent != WORLD && !by_name.contains_key(f.parent.as_str()) {
            return Err(BodiesError::new(
                place,
                Problem::UnknownFrame(f.parent.clone()),
            ));
        }
    }
    let mut placed: Vec<&Frame> = Vec::new();
    for f in frames {
        let mut chain = vec![f];
        while let Some(&last) = chain.last() {
            if last.parent == WORLD || placed.iter().any(|p| p.name == last.parent) {
                break;
            }
            let parent = by_name[last.parent.as_str()];
            if chain.iter().any(|c| c.name == parent.name) {
                let mut names: Vec<String> = chain.iter().map(|c| c.name.clone()).collect();
                names.push(parent.name.clone());
                let place = Place::new(Section::Frames, &f.name, "parent");
                return Err(BodiesError::new(place, Problem::Cycle(names)));
            }
            chain.push(parent);
        }
        for c in chain.into_iter().rev() {
            if !placed.iter().any(|p| p.name == c.name) {
                placed.push(c);
            }
        }
    }
    Ok(placed)
}

fn child_kinematics(
    parent: &Kinematics,
    f: &Frame,
    coordinates: &[String],
    up_index: usize,
    up_sign: i64,
) -> Result<Kinematics, BodiesError> {
    let at = |field| Place::new(Section::Frames, &f.name, field);
    let (r, omega_rel) =
        relative(&f.rotations, coordinates).map_err(|e| BodiesError::new(at("rotations"), e))?;
    let o = &f.origin;
    let o_rate = Rate::of(o, coordinates).map_err(|e| BodiesError::new(at("origin"), e))?;
    let world_axes: M3 = std::array::from_fn(|j| apply_transpose(&r, &parent.world_axes[j]));
    let up = if up_sign < 0 {
        negate(&world_axes[up_index])
    } else {
        world_axes[up_index].clone()
    };
    let omega = parent.omega.apply_transpose(&r).plus(&omega_rel);
    let velocity = parent
        .velocity
        .plus(&parent.omega.cross(o))
        .plus(&o_rate)
        .apply_transpose(&r);
    let height = hamel_expr::build::add(parent.height.clone(), dot(&parent.up, o));
    Ok(Kinematics {
        world_axes,
        up,
        omega,
        velocity,
        height,
    })
}

/// R = R₁⋯R_n and the relative angular velocity Σ_i (R_{i+1}⋯R_n)ᵀ a_i θ̇_i, in the child's axes.
pub(crate) fn relative(
    rotations: &[Rotation],
    coordinates: &[String],
) -> Result<(M3, Rate), Problem> {
    let mut acc = identity();
    let mut omega = Rate::zero(coordinates.len());
    for rot in rotations.iter().rev() {
        let a = rot.axis.vector();
        let w = apply_transpose(&acc, &a);
        omega = omega.plus(&Rate::along(&w, &rot.angle, coordinates)?);
        acc = compose(&rotation(&rot.axis, &rot.angle), &acc);
    }
    Ok((acc, omega))
}

/// The rotation about `axis` by `angle` (it takes rotated axes to the original ones).
pub(crate) fn rotation(axis: &Direction, angle: &Expr) -> M3 {
    match axis {
        Direction::Axis(a) => about_axis(a.index, a.sign, angle),
        Direction::Vector(a) => rodrigues(a, angle),
    }
}

/// Rotation about coordinate axis `i` (its negative when `sign` < 0: the sines change sign).
fn about_axis(i: usize, sign: i64, theta: &Expr) -> M3 {
    let c = Expr::call(Func::Cos, theta.clone());
    let sin = Expr::call(Func::Sin, theta.clone());
    let s = if sign < 0 { neg(sin) } else { sin };
    let (j, k) = ((i + 1) % 3, (i + 2) % 3);
    let mut m = identity();
    m[j][j] = c.clone();
    m[k][k] = c;
    m[j][k] = neg(s.clone());
    m[k][j] = s;
    m
}

/// R = cos θ I + sin θ [a]× + (1 − cos θ) a aᵀ for a unit axis a.
fn rodrigues(a: &V3, theta: &Expr) -> M3 {
    let (c, s) = (
        Expr::call(Func::Cos, theta.clone()),
        Expr::call(Func::Sin, theta.clone()),
    );
    let one_minus_c = sub(Expr::int(1), c.clone());
    let skew = |i: usize, j: usize| -> Expr {
        match (i, j) {
            (0, 1) => neg(a[2].clone()),
            (0, 2) => a[1].clone(),
            (1, 0) => a[2].clone(),
            (1, 2) => neg(a[0].clone()),
            (2, 0) => neg(a[1].clone()),
            (2, 1) => a[0].clone(),
            _ => Expr::int(0),
        }
    };
    std::array::from_fn(|i| {
        std::array::from_fn(|j| {
            let diagonal = if i == j { c.clone() } else { Expr::int(0) };
            let outer = mul(one_minus_c.clone(), mul(a[i].clone(), a[j].clone()));
            hamel_expr::build::sum([diagonal, mul(s.clone(), skew(i, j)), outer])
        })
    })
}
