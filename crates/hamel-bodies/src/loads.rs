//! Loads: forces at points and torques on frames, as generalised forces.
//!
//! A force f at a point P gives F_k = f · ∂v_P/∂q̇_k, a torque τ on a frame B (and −τ on its
//! reaction frame R, for a motor or a rider's steer torque between two bodies) gives
//! F_k = τ · (∂ω_B/∂q̇_k − ∂ω_R/∂q̇_k): the virtual power of the load per unit rate of q_k. The
//! partial velocities are those of the frame tree (exact, velocities composed frame by frame), so
//! F is exact. Loads may depend on q, the parameters and the inputs; they enter the equations
//! beside ∇U, as Γᵀ(∇U + F).

use hamel_expr::Expr;
use hamel_expr::build::{add, sub};

use crate::error::{BodiesError, Place, Problem, Section};
use crate::frames::Tree;
use crate::mechanism::{Load, LoadKind, Mechanism, WORLD};
use crate::vector::{Rate, V3, apply, apply_transpose};

/// The generalised forces of every load of `m`, one per coordinate (zeros without loads).
pub(crate) fn generalised_forces(tree: &Tree, m: &Mechanism) -> Result<Vec<Expr>, BodiesError> {
    let mut f = vec![Expr::int(0); m.coordinates.len()];
    for load in &m.loads {
        for (fk, add_k) in f.iter_mut().zip(generalised(tree, m, load)?) {
            *fk = add(std::mem::replace(fk, Expr::int(0)), add_k);
        }
    }
    Ok(f)
}

/// One load's generalised forces.
fn generalised(tree: &Tree, m: &Mechanism, load: &Load) -> Result<Vec<Expr>, BodiesError> {
    let place = |field| Place::new(Section::Loads, &load.name, field);
    let known = |name: &str, field| {
        if name == WORLD || tree.contains(name) {
            Ok(())
        } else {
            Err(BodiesError::new(
                place(field),
                Problem::UnknownFrame(name.to_string()),
            ))
        }
    };
    known(&load.frame, "frame")?;
    known(&load.axes, "axes")?;
    let on = tree.get(&load.frame);
    // The vector in the axes of `frame`: as written when those are its axes, else through the
    // world's.
    let in_frame = |frame: &str, v: &V3| -> V3 {
        if frame == load.axes {
            return v.clone();
        }
        let world = apply(&tree.get(&load.axes).world_axes, v);
        apply_transpose(&tree.get(frame).world_axes, &world)
    };
    let velocity_error = |e| BodiesError::new(place("point"), Problem::Velocity(e));
    match &load.kind {
        LoadKind::Force { point, force } => {
            let moving = Rate::of(point, &m.coordinates).map_err(velocity_error)?;
            let velocity = on.velocity.plus(&on.omega.cross(point)).plus(&moving);
            Ok(velocity.dot(&in_frame(&load.frame, force)))
        }
        LoadKind::Torque { torque, reaction } => {
            let tau = in_frame(&load.frame, torque);
            let Some(r) = reaction else {
                return Ok(on.omega.dot(&tau));
            };
            known(r, "reaction")?;
            // Between a frame and an ancestor: the rotation rates of the frames between them,
            // without a detour through the world's axes.
            if let Some(rel) = relative_to(m, &load.frame, r) {
                let omega = rel.map_err(|e| BodiesError::new(place("reaction"), e))?;
                return Ok(omega.dot(&tau));
            }
            let back = tree.get(r).omega.dot(&in_frame(r, torque));
            let on_frame = on.omega.dot(&tau);
            Ok(on_frame
                .into_iter()
                .zip(back)
                .map(|(a, b)| sub(a, b))
                .collect())
        }
    }
}

/// The angular velocity of `frame` relative to its ancestor `ancestor`, in `frame`'s axes
/// (None when `ancestor` is not one).
fn relative_to(m: &Mechanism, frame: &str, ancestor: &str) -> Option<Result<Rate, Problem>> {
    let mut path = Vec::new();
    let mut name = frame;
    while name != ancestor {
        let f = m.frames.iter().find(|f| f.name == name)?;
        path.push(f);
        name = &f.parent;
    }
    let mut omega = Rate::zero(m.coordinates.len());
    for f in path.into_iter().rev() {
        let (r, own) = match crate::frames::relative(&f.rotations, &m.coordinates) {
            Ok(x) => x,
            Err(e) => return Some(Err(e)),
        };
        omega = omega.apply_transpose(&r).plus(&own);
    }
    Some(Ok(omega))
}
