//! Re-expressing a point of a frame (a wheel's centre, a body's centre of mass) in the axes of an
//! ancestor, so that angles that cannot matter never enter the equations.
//!
//! A wheel's spin angle does not change where its centre is, nor (the wheel being symmetric about
//! its axle) its inertia, nor the direction of its axle. Written in the wheel's own axes, the
//! velocities still carry the spin angle through Rᵀ, and only trigonometric identities remove it
//! again. Written in the axes of the frame the wheel turns in, it never appears. [`carry`] hops
//! up from a frame while that holds: through frames without rotations (their axes are their
//! parent's), and through frames whose rotations are all about one coordinate axis on which the
//! point lies, when the caller says the rest is symmetric about it (a body's inertia, a wheel's
//! spin axis). The rotation rates passed on the way become the spin, along that axis.

use hamel_expr::Expr;
use hamel_expr::build::add;

use crate::error::Problem;
use crate::frames::{Kinematics, Tree};
use crate::mechanism::{Direction, Frame};
use crate::vector::{Rate, V3, dot, plus};

/// A point of a frame, in the axes of an ancestor.
pub(crate) struct Carried<'t> {
    /// The ancestor's kinematics.
    pub kinematics: &'t Kinematics,
    /// The point, in the ancestor's axes.
    pub point: V3,
    /// The frame's angular velocity relative to the ancestor, in the ancestor's axes.
    pub spin: Rate,
}

impl Carried<'_> {
    /// The point's velocity, in the ancestor's axes: v + ω × p + ṗ.
    pub fn velocity(&self, coordinates: &[String]) -> Result<Rate, Problem> {
        let k = self.kinematics;
        let moving = Rate::of(&self.point, coordinates)?;
        Ok(k.velocity.plus(&k.omega.cross(&self.point)).plus(&moving))
    }

    /// The frame's angular velocity, in the ancestor's axes.
    pub fn omega(&self) -> Rate {
        self.kinematics.omega.plus(&self.spin)
    }

    /// The point's height above the ground.
    pub fn height(&self) -> Expr {
        add(
            self.kinematics.height.clone(),
            dot(&self.kinematics.up, &self.point),
        )
    }
}

/// Carry `point` (in the axes of frame `name`) as far up as it goes unturned; `symmetric(i)`:
/// whether what comes with the point is symmetric about coordinate axis i.
pub(crate) fn carry<'t>(
    tree: &'t Tree,
    frames: &[Frame],
    name: &str,
    point: V3,
    symmetric: &dyn Fn(usize) -> bool,
    coordinates: &[String],
) -> Result<Carried<'t>, Problem> {
    let mut name = name.to_string();
    let mut point = point;
    let mut spin = Rate::zero(coordinates.len());
    let mut line: Option<usize> = None;
    while let Some(f) = frames.iter().find(|f| f.name == name) {
        match turning_axis(f) {
            Turning::None => {}
            Turning::About(i) => {
                let same = line.is_none_or(|l| l == i);
                if !(same && on_axis(&point, i) && symmetric(i)) {
                    break;
                }
                line = Some(i);
                for r in &f.rotations {
                    spin = spin.plus(&Rate::along(&r.axis.vector(), &r.angle, coordinates)?);
                }
            }
            Turning::Otherwise => break,
        }
        point = plus(&f.origin, &point);
        name = f.parent.clone();
    }
    Ok(Carried {
        kinematics: tree.get(&name),
        point,
        spin,
    })
}

/// How a frame turns relative to its parent.
enum Turning {
    /// It does not.
    None,
    /// Only about coordinate axis i.
    About(usize),
    /// Some other way.
    Otherwise,
}

fn turning_axis(f: &Frame) -> Turning {
    let mut axes = f.rotations.iter().map(|r| match &r.axis {
        Direction::Axis(a) => Some(a.index),
        Direction::Vector(_) => None,
    });
    match axes.next() {
        None => Turning::None,
        Some(Some(i)) if axes.all(|a| a == Some(i)) => Turning::About(i),
        Some(_) => Turning::Otherwise,
    }
}

/// Whether the point lies on coordinate axis i (its other components are literal zeros).
fn on_axis(p: &V3, i: usize) -> bool {
    (0..3).all(|j| j == i || p[j].is_zero_literal())
}
