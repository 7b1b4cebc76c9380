//! Symmetries a mechanism has by its construction, as candidate vector fields ξ on the
//! coordinates: the rotation about the vertical through the world origin, when every frame on
//! the world turns first about the up axis by one and the same coordinate ψ and sits at a
//! horizontal position given by plain coordinates. Rotating the world by ε about the up axis
//! then shifts ψ by ε and turns those positions: ξ = ∂/∂ψ + Σ (â × o)_i ∂/∂o_i.
//!
//! These are candidates only. Whoever uses one (the structured reduction, `hamel-reduce`)
//! checks exactly that it leaves A, U, the constraints and the quasi-velocities invariant.

use hamel_expr::Expr;
use indexmap::IndexMap;

use crate::mechanism::{Direction, Mechanism, WORLD};
use crate::vector::{cross, unit};

/// A vector field ξ = Σ_k ξ_k ∂/∂q_k, by its nonzero components.
#[derive(Clone, Debug, PartialEq)]
pub struct Symmetry {
    /// Its name.
    pub name: String,
    /// ξ_k for the coordinates it moves, in coordinate order.
    pub components: IndexMap<String, Expr>,
}

/// The rotation about the vertical, when the frames on the world allow it (see the module
/// documentation); `None` otherwise.
pub fn vertical_rotation(m: &Mechanism) -> Option<Symmetry> {
    let up = m.world.up.index;
    let roots: Vec<_> = m.frames.iter().filter(|f| f.parent == WORLD).collect();
    let mut angle: Option<(String, i64)> = None;
    let mut components: IndexMap<String, Expr> = IndexMap::new();
    for f in &roots {
        let first = f.rotations.first()?;
        let Direction::Axis(a) = first.axis else {
            return None;
        };
        let Expr::Sym(psi) = &first.angle else {
            return None;
        };
        if a.index != up || !m.coordinates.contains(psi) {
            return None;
        }
        match &angle {
            Some(seen) if *seen != (psi.clone(), a.sign) => return None,
            _ => angle = Some((psi.clone(), a.sign)),
        }
        let turned = cross(&unit(up, a.sign), &f.origin);
        for i in (0..3).filter(|&i| i != up) {
            match &f.origin[i] {
                Expr::Sym(x) if m.coordinates.contains(x) => {
                    let xi = turned[i].clone();
                    if components.get(x).is_some_and(|seen| *seen != xi) {
                        return None;
                    }
                    components.insert(x.clone(), xi);
                }
                o if o.is_zero_literal() => {}
                _ => return None,
            }
        }
    }
    let (psi, _) = angle?;
    components.insert(psi, Expr::int(1));
    let order = |k: &String| m.coordinates.iter().position(|q| q == k);
    components.sort_by(|a, _, b, _| order(a).cmp(&order(b)));
    Some(Symmetry {
        name: "vertical_rotation".into(),
        components,
    })
}
