//! Springs and dampers: a spring's potential enters U, a damper's generalised force enters F.
//!
//! A linear element stretches the distance d = |r| between two points, r = P₂ − P₁ in the
//! world's axes, with the partial velocities V_k = ∂ṙ/∂q̇_k of the frame tree (exact, as the
//! loads'). With s = r·r (d = √s):
//!
//! * a spring adds −½ k (d − d₀)² to U (L = T + U), written −½ k s when d₀ = 0;
//! * a damper's force −c ḋ along r has the virtual power −c ḋ ∂ḋ/∂q̇_k per unit q̇_k:
//!   F_k = −c (r·ṙ)(r·V_k)/s with ṙ = Σ_j V_j q̇_j, rational in s (no square root).
//!
//! On a coordinate q: U gains −½ k (q − q₀)², F_q gains −c q̇. Stiffness and damping must be
//! positive at the default parameters.

use hamel_expr::Expr;
use hamel_expr::build::{add, div, mul, neg, sub};

use crate::error::{BodiesError, Place, Problem, Section};
use crate::frames::Tree;
use crate::mechanism::{Anchor, Mechanism, Stretch, WORLD};
use crate::numeric::Point;
use crate::vector::{Rate, V3, apply, dot, negate, plus};

/// −½ Σ_springs k (d − d₀)²: the springs' part of U.
pub(crate) fn spring_potential(
    tree: &Tree,
    m: &Mechanism,
    reference: &Point<'_, f64>,
) -> Result<Expr, BodiesError> {
    let mut u = Expr::int(0);
    for s in &m.springs {
        let place = |field| Place::new(Section::Springs, &s.name, field);
        positive(reference, &s.stiffness, "stiffness", place("stiffness"))?;
        let half_k = mul(Expr::int(-1), div(s.stiffness.clone(), Expr::int(2)));
        let energy = match &s.stretch {
            Stretch::Coordinate(q) => {
                known_coordinate(m, q, place("coordinate"))?;
                square(sub(Expr::sym(q), s.rest.clone()))
            }
            Stretch::Between(ends) => {
                let (r, _) = separation(tree, m, ends, place("between"))?;
                let sq = dot(&r, &r);
                if s.rest.is_zero_literal() {
                    sq
                } else {
                    let d = Expr::call(hamel_expr::Func::Sqrt, sq);
                    square(sub(d, s.rest.clone()))
                }
            }
        };
        u = add(u, mul(half_k, energy));
    }
    Ok(u)
}

/// The dampers' generalised forces, one per coordinate: functions of q and der(q).
pub(crate) fn damper_forces(
    tree: &Tree,
    m: &Mechanism,
    reference: &Point<'_, f64>,
) -> Result<Vec<Expr>, BodiesError> {
    let ell = m.coordinates.len();
    let mut f = vec![Expr::int(0); ell];
    for d in &m.dampers {
        let place = |field| Place::new(Section::Dampers, &d.name, field);
        positive(reference, &d.damping, "damping", place("damping"))?;
        let c = d.damping.clone();
        match &d.stretch {
            Stretch::Coordinate(q) => {
                let k = known_coordinate(m, q, place("coordinate"))?;
                f[k] = add(f[k].clone(), neg(mul(c, Expr::Der(q.clone()))));
            }
            Stretch::Between(ends) => {
                let (r, v) = separation(tree, m, ends, place("between"))?;
                let s = dot(&r, &r);
                // r·V_k per coordinate; r·ṙ = Σ_j (r·V_j) q̇_j
                let along: Vec<Expr> = v.dot(&r);
                let rate = along
                    .iter()
                    .zip(&m.coordinates)
                    .filter(|(e, _)| !e.is_zero_literal())
                    .fold(Expr::int(0), |acc, (e, q)| {
                        add(acc, mul(e.clone(), Expr::Der(q.clone())))
                    });
                let scale = neg(div(mul(c, rate), s));
                for (fk, e) in f.iter_mut().zip(&along) {
                    if !e.is_zero_literal() {
                        *fk = add(fk.clone(), mul(scale.clone(), e.clone()));
                    }
                }
            }
        }
    }
    Ok(f)
}

fn square(e: Expr) -> Expr {
    Expr::powi(e, 2)
}

fn positive(
    reference: &Point<'_, f64>,
    e: &Expr,
    what: &'static str,
    place: Place,
) -> Result<(), BodiesError> {
    let value = reference
        .value(e)
        .map_err(|p| BodiesError::new(place.clone(), p))?;
    if value > 0.0 {
        Ok(())
    } else {
        Err(BodiesError::new(
            place,
            Problem::NotPositive { what, value },
        ))
    }
}

fn known_coordinate(m: &Mechanism, q: &str, place: Place) -> Result<usize, BodiesError> {
    m.coordinates
        .iter()
        .position(|c| c == q)
        .ok_or_else(|| BodiesError::new(place, Problem::UnknownCoordinate(q.to_string())))
}

/// r = P₂ − P₁ and ṙ (as partial velocities), both in the world's axes. r is composed in the
/// axes of the two frames' nearest common ancestor, from its origin: what moves both ends alike
/// (the sleigh's position, for a spring on the sleigh) never enters, so r stays accurate in
/// floating point when the points are close and far from the world's origin.
fn separation(
    tree: &Tree,
    m: &Mechanism,
    ends: &[Anchor; 2],
    place: Place,
) -> Result<(V3, Rate), BodiesError> {
    for end in ends {
        if !tree.contains(&end.frame) {
            return Err(BodiesError::new(
                place,
                Problem::UnknownFrame(end.frame.clone()),
            ));
        }
    }
    let (up_a, up_b) = (ancestors(m, &ends[0].frame), ancestors(m, &ends[1].frame));
    let common = up_a
        .iter()
        .find(|f| up_b.contains(f))
        .copied()
        .unwrap_or(WORLD);
    let at =
        |end: &Anchor| in_ancestor(m, end, common).map_err(|e| BodiesError::new(place.clone(), e));
    let r_common = plus(&at(&ends[1])?, &negate(&at(&ends[0])?));
    let r = apply(&tree.get(common).world_axes, &r_common);
    let va = velocity(tree, m, &ends[0], &place)?;
    let vb = velocity(tree, m, &ends[1], &place)?;
    Ok((r, vb.plus(&va.scale(&Expr::int(-1)))))
}

/// `frame` and the frames above it, up to the world (included).
fn ancestors<'m>(m: &'m Mechanism, frame: &'m str) -> Vec<&'m str> {
    let mut out = vec![frame];
    let mut name = frame;
    while name != WORLD {
        match m.frames.iter().find(|f| f.name == name) {
            Some(f) => {
                name = &f.parent;
                out.push(name);
            }
            None => break,
        }
    }
    out
}

/// The anchor's point in the axes of its frame's ancestor `ancestor`, from that frame's
/// origin: p ← R p + o up the tree (R the rotation of a frame's axes to its parent's).
fn in_ancestor(m: &Mechanism, at: &Anchor, ancestor: &str) -> Result<V3, Problem> {
    let mut p = at.point.clone();
    let mut name = at.frame.as_str();
    while name != ancestor {
        let Some(f) = m.frames.iter().find(|f| f.name == name) else {
            break;
        };
        let (r, _) = crate::frames::relative(&f.rotations, &m.coordinates)?;
        p = plus(&apply(&r, &p), &f.origin);
        name = &f.parent;
    }
    Ok(p)
}

/// A point's velocity, in the world's axes, as partial velocities.
fn velocity(tree: &Tree, m: &Mechanism, at: &Anchor, place: &Place) -> Result<Rate, BodiesError> {
    let k = tree.get(&at.frame);
    let moving = Rate::of(&at.point, &m.coordinates)
        .map_err(|e| BodiesError::new(place.clone(), Problem::Velocity(e)))?;
    let velocity = k.velocity.plus(&k.omega.cross(&at.point)).plus(&moving);
    Ok(velocity.apply(&k.world_axes))
}
