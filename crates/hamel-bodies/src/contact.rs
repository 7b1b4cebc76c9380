//! Contacts with the ground: rolling wheels and blades. Each gives rows of α (the velocity of
//! the material contact point may not have the components a contact forbids); a wheel kept on
//! the ground by a holonomic constraint also gives that constraint.
//!
//! **Wheel** (a thin disk of radius r, spin axis a, centre at its frame's origin). With `up` the
//! up direction, k = up − (up·a)a points from the centre towards the highest point, and the
//! contact is c = centre − r k/|k|, at height h = height(centre) − r|k|. The material point at
//! c moves with v = v_centre + ω × (c − centre); no slip makes its two horizontal components
//! vanish. When the frames do not keep the wheel on the ground, h = 0 is a holonomic constraint
//! (the wheel's `dependent` coordinate), whose velocity row is dh/dt like any other's.
//!
//! **Tyre** (`crown` ρ > 0: a torus about the spin axis, the circle of radius r swept by a
//! circle of radius ρ): the contact lies ρ further down, c = centre − r k/|k| − ρ up, at height
//! h = height(centre) − r|k| − ρ. ρ = 0 is the thin disk.
//!
//! **Rolling body** (`[rolling.NAME]`, a convex surface about a centre fixed in a frame): the
//! contact is the surface's point whose outward normal is −up, from its support function at
//! u = up (in the frame's axes): a sphere of radius a touches at centre − a·u, at height
//! height(centre) − a; an ellipsoid with semi-axes (a, b, c) at centre − w/s, w = (a²u₁, b²u₂,
//! c²u₃), s = √(u·w), at height height(centre) − s. The ellipsoid's no-slip rows are those of
//! s·v = s·v_centre + ω × (−w), and its height's rate row is s·dh/dt = s·d height(centre)/dt −
//! ½ d(s²)/dt: no square root divides them.
//!
//! The vectors are taken in the axes of the frame the wheel turns in ([`crate::carry`]), so that
//! the spin angle does not enter k. When k has a single nonzero component there, |k| is that
//! component, signed as it is at the reference configuration (the wheel above the ground), k/|k|
//! is a signed axis, and neither a square root nor a division enters the equations.

use hamel_expr::Rational;
use hamel_expr::build::{div, mul, neg, sub};
use hamel_expr::{Expr, Func};

use crate::carry::carry;
use crate::error::{BodiesError, Place, Problem, Section};
use crate::frames::Tree;
use crate::mechanism::{Blade, Direction, Frame, Roller, Surface, Wheel};
use crate::numeric::Point;
use crate::vector::{Rate, V3, cross, dot, negate, scale};

/// A row of α, named.
#[derive(Clone, Debug, PartialEq)]
pub struct Row {
    /// Its name, such as `front_no_slip_x`.
    pub name: String,
    /// The coefficients of q̇₁..q̇_ℓ.
    pub coefficients: Vec<Expr>,
}

/// What a wheel contributes.
pub(crate) struct Rolling {
    /// The no-slip rows.
    pub rows: Vec<Row>,
    /// The contact's height above the ground.
    pub height: Expr,
    /// How |k| was taken, when it was simplified.
    pub note: Option<String>,
    /// What the rows were multiplied by (1, or |k| when it is a square root): the force's
    /// components along the world's horizontal axes are the rows' multipliers times it.
    pub scale: Expr,
    /// The rolling direction ±a × k/|k| in the world's axes (horizontal), oriented forwards
    /// ([`forwards`]).
    pub rolling: V3,
}

/// The rows and contact height of a wheel. `reference`: the reference configuration, where the
/// sign of a simplified |k| is read.
pub(crate) fn wheel(
    tree: &Tree,
    frames: &[Frame],
    w: &Wheel,
    coordinates: &[String],
    reference: &Point,
) -> Result<Rolling, BodiesError> {
    let at = |field| Place::new(Section::Wheels, &w.name, field);
    let spin_axis = match &w.axis {
        Direction::Axis(a) => Some(a.index),
        Direction::Vector(_) => None,
    };
    let symmetric = |i: usize| spin_axis == Some(i);
    let zero = crate::vector::zero();
    let c = carry(tree, frames, &w.frame, zero, &symmetric, coordinates)
        .map_err(|e| BodiesError::new(at("frame"), e))?;
    let k_c = c.kinematics;
    let up = &k_c.up;
    let k = horizontal_part(up, &w.axis);
    let (norm, unit) = length(&k, reference).map_err(|e| BodiesError::new(at("axis"), e))?;
    let v_centre = c
        .velocity(coordinates)
        .map_err(|e| BodiesError::new(at("frame"), e))?;
    // v = v_centre + ω × (−r k/|k|). When |k| is a square root, the rows are those of |k|·v
    // = |k| v_centre + ω × (−r k) instead: the same constraints (|k| > 0 unless the wheel lies
    // flat), with no square root in a denominator.
    let a = w.axis.vector();
    let row_scale = match unit {
        Some(_) => Expr::int(1),
        None => norm.value.clone(),
    };
    // A tyre's contact lies a further crown radius ρ below the circle of radius r: −ρ·up.
    let crown = |times: Expr| {
        w.crown
            .as_ref()
            .map(|rho| scale(&neg(mul(rho.clone(), times)), up))
    };
    let (v, note, rolling) = match unit {
        Some(unit) => {
            let mut offset = scale(&neg(w.radius.clone()), &unit);
            if let Some(down) = crown(Expr::int(1)) {
                offset = crate::vector::plus(&offset, &down);
            }
            let rolling = cross(&a, &unit);
            (v_centre.plus(&c.omega().cross(&offset)), norm.note, rolling)
        }
        None => {
            let mut offset = scale(&neg(w.radius.clone()), &k);
            if let Some(down) = crown(norm.value.clone()) {
                offset = crate::vector::plus(&offset, &down);
            }
            let v = v_centre.scale(&norm.value).plus(&c.omega().cross(&offset));
            let note = format!(
                "its no-slip rows are multiplied by |k| = {} (positive unless the wheel lies flat), so that no square root divides them",
                norm.value
            );
            let rolling = cross(&a, &k).map(|e| div(e, norm.value.clone()));
            (v, Some(note), rolling)
        }
    };
    let rolling: V3 = std::array::from_fn(|j| dot(&k_c.world_axes[j], &rolling));
    let rolling = forwards(rolling, reference).map_err(|e| BodiesError::new(at("axis"), e))?;
    let rows = horizontal_rows(&w.name, &v, &k_c.world_axes, tree);
    let mut height = sub(c.height(), mul(w.radius.clone(), norm.value));
    if let Some(rho) = &w.crown {
        height = sub(height, rho.clone());
    }
    Ok(Rolling {
        rows,
        height,
        note,
        scale: row_scale,
        rolling,
    })
}

/// What a rolling body contributes.
pub(crate) struct Touching {
    /// The no-slip rows.
    pub rows: Vec<Row>,
    /// The contact's height above the ground.
    pub height: Expr,
    /// The row of the height constraint, when dh/dt would divide by a square root (the
    /// ellipsoid's s·dh/dt); None: dh/dt.
    pub height_rate: Option<Vec<Expr>>,
    /// What the rows were multiplied by, when not 1.
    pub note: Option<String>,
}

/// The rows and contact height of a rolling body.
pub(crate) fn roller(
    tree: &Tree,
    frames: &[Frame],
    r: &Roller,
    coordinates: &[String],
) -> Result<Touching, BodiesError> {
    let at = |field| Place::new(Section::Rolling, &r.name, field);
    // A sphere is symmetric about every axis: its centre is carried up through the rotations
    // about an axis it lies on, which then never enter its equations.
    let sphere = matches!(r.surface, Surface::Sphere { .. });
    let c = carry(
        tree,
        frames,
        &r.frame,
        r.centre.clone(),
        &|_| sphere,
        coordinates,
    )
    .map_err(|e| BodiesError::new(at("frame"), e))?;
    let up = &c.kinematics.up;
    let v_centre = c
        .velocity(coordinates)
        .map_err(|e| BodiesError::new(at("frame"), e))?;
    let (v, height, height_rate, note) = match &r.surface {
        Surface::Sphere { radius } => {
            let v = v_centre.plus(&c.omega().cross(&scale(&neg(radius.clone()), up)));
            (v, sub(c.height(), radius.clone()), None, None)
        }
        Surface::Ellipsoid { semi_axes } => {
            let w: V3 = std::array::from_fn(|i| {
                let a = &semi_axes[i];
                mul(mul(a.clone(), a.clone()), up[i].clone())
            });
            let s2 = dot(up, &w);
            let s = Expr::call(Func::Sqrt, s2.clone());
            let v = v_centre.scale(&s).plus(&c.omega().cross(&negate(&w)));
            let rate = scaled_rate(&c.height(), &s, &s2, coordinates)
                .map_err(|e| BodiesError::new(at("frame"), e))?;
            let note = format!(
                "its no-slip rows and its height's rate are multiplied by s = {s} (positive), so that no square root divides them"
            );
            (v, sub(c.height(), s), Some(rate), Some(note))
        }
    };
    let rows = horizontal_rows(&r.name, &v, &c.kinematics.world_axes, tree);
    Ok(Touching {
        rows,
        height,
        height_rate,
        note,
    })
}

/// s·d(H − s)/dt = s·dH/dt − ½ d(s²)/dt, per coordinate rate.
fn scaled_rate(
    centre_height: &Expr,
    s: &Expr,
    s2: &Expr,
    coordinates: &[String],
) -> Result<Vec<Expr>, Problem> {
    let half = Expr::Num(Rational::new(1.into(), 2.into()));
    (coordinates.iter())
        .map(|q| {
            let dh = centre_height.diff(q)?;
            let ds2 = s2.diff(q)?;
            Ok(sub(mul(s.clone(), dh), mul(half.clone(), ds2)))
        })
        .collect()
}

/// The rows `NAME_no_slip_x`, … of a contact point's velocity `v` along the world's horizontal
/// axes.
fn horizontal_rows(name: &str, v: &Rate, world_axes: &[V3; 3], tree: &Tree) -> Vec<Row> {
    (world_axes.iter().enumerate())
        .filter(|(j, _)| *j != tree.up.index)
        .map(|(j, axis)| Row {
            name: format!("{name}_no_slip_{}", ["x", "y", "z"][j]),
            coefficients: v.dot(axis),
        })
        .collect()
}

/// The rolling direction (world axes) oriented as vehicles are described: towards the world's
/// +x at the reference configuration (+y where it is across x, +z after that), whichever way
/// the wheel's axis points, so that a wheel's longitudinal force is positive forwards.
fn forwards(rolling: V3, reference: &Point) -> Result<V3, Problem> {
    let mut towards = 0.0;
    for e in &rolling {
        towards = reference.value(e)?;
        if towards.abs() > 1e-9 {
            break;
        }
    }
    Ok(if towards < 0.0 {
        rolling.map(neg)
    } else {
        rolling
    })
}

/// k = up − (up·a)a; about a coordinate axis, exactly `up` without that component (the
/// general formula would leave u − u, which no folding removes).
fn horizontal_part(up: &V3, axis: &Direction) -> V3 {
    match axis {
        Direction::Axis(ax) => {
            let mut k = up.clone();
            k[ax.index] = Expr::int(0);
            k
        }
        Direction::Vector(a) => {
            std::array::from_fn(|i| sub(up[i].clone(), mul(dot(up, a), a[i].clone())))
        }
    }
}

/// |k|, and how it was taken.
struct Length {
    value: Expr,
    note: Option<String>,
}

/// |k| and k/|k|: for a k with one nonzero component, that component signed as it is at the
/// reference configuration and the signed unit vector along it (exactly, no division); otherwise
/// sqrt(k·k), and k/sqrt(k·k) left to the caller (`None`).
fn length(k: &V3, reference: &Point) -> Result<(Length, Option<V3>), Problem> {
    let nonzero: Vec<usize> = (0..3).filter(|&i| !k[i].is_zero_literal()).collect();
    if let [i] = nonzero.as_slice() {
        let value = reference.value(&k[*i])?;
        if value == 0.0 {
            return Err(Problem::FlatWheel);
        }
        let sign = if value > 0.0 { 1 } else { -1 };
        let norm = if sign > 0 {
            k[*i].clone()
        } else {
            neg(k[*i].clone())
        };
        let note = format!(
            "|k| = sqrt(({})^2) taken as {norm}, positive at the reference configuration",
            k[*i]
        );
        let length = Length {
            value: norm,
            note: Some(note),
        };
        return Ok((length, Some(crate::vector::unit(*i, sign))));
    }
    if nonzero.is_empty() || reference.value(&dot(k, k))? <= 0.0 {
        return Err(Problem::FlatWheel);
    }
    let norm = Expr::call(Func::Sqrt, dot(k, k));
    Ok((
        Length {
            value: norm,
            note: None,
        },
        None,
    ))
}

/// The row of a blade: the contact point's velocity across the blade, in the ground plane, and
/// the direction across it (up × direction, in the blade frame's axes).
pub(crate) fn blade(tree: &Tree, b: &Blade, reference: &Point) -> Result<(Row, V3), BodiesError> {
    let k = tree.get(&b.frame);
    let v = k.velocity.plus(&k.omega.cross(&b.point));
    let across = cross(&k.up, &b.direction.vector());
    let place = Place::new(Section::Blades, &b.name, "direction");
    let size = reference
        .value(&dot(&across, &across))
        .map_err(|e| BodiesError::new(place.clone(), e))?;
    if size <= 1e-24 {
        return Err(BodiesError::new(place, Problem::VerticalBlade));
    }
    let row = Row {
        name: format!("{}_no_sideslip", b.name),
        coefficients: v.dot(&across),
    };
    Ok((row, across))
}
