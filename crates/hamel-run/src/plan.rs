//! `hamel plan SCENE`: model only what a scene requires.
//!
//! From the outputs a scene requests, decide which coordinates are integrated with the
//! dynamics, which are reconstructed alongside (quadratures q̇_k = (Γη)_k that nothing else
//! needs), and which are dropped. All decisions are exact: a coordinate "occurs" in an
//! expression when it appears in the expression's canonical form (docs/reduction.md), and the
//! elimination of everything not integrated is confirmed by `hamel reduce`'s ground truth.
//!
//! * integrated: the coordinates occurring in the true equations (11), closed under the
//!   kinematic equations q̇_k = (Γη)_k of the coordinates already integrated, then η;
//! * reconstructed: the requested coordinates not integrated, those the energy needs when it
//!   is requested (U may depend on a coordinate absent from Γᵀ∇U), all of them when the
//!   constraint residual or a constraint force is requested, closed under their own
//!   kinematic equations;
//! * dropped: the rest — not integrated, not computed.

use hamel_derive::{Derivation, Entry};
use hamel_expr::Expr;
use hamel_model::Coord;
use hamel_model::{Model, ModelError};
use indexmap::IndexMap;
use serde::Serialize;

pub use crate::request::Request;

/// The plan of a scene (`hamel plan --format json`).
#[derive(Clone, Debug, Serialize)]
pub struct Plan {
    /// Integrated with the dynamics: coordinates, then `eta1`…
    pub integrated: Vec<String>,
    /// Reconstructed alongside (quadratures nothing else needs).
    pub reconstructed: Vec<String>,
    /// Neither integrated nor computed.
    pub dropped: Vec<String>,
    /// The quasi-velocity choice used.
    pub eta: String,
    /// The requested `[expressions]` of the scene, each with the coordinates it needs
    /// (evaluated at the output times only, from the integrated and reconstructed state).
    #[serde(skip_serializing_if = "IndexMap::is_empty")]
    pub expressions: IndexMap<String, Vec<String>>,
    /// The requested constraint forces (`force.NAME.COMPONENT`), computed at the output times.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub forces: Vec<String>,
    /// The wheels the friction monitor watches, with their μ.
    #[serde(skip_serializing_if = "IndexMap::is_empty")]
    pub friction: IndexMap<String, f64>,
    /// The integrated coordinates (model order).
    #[serde(skip)]
    pub integrated_ix: Vec<Coord>,
    /// The reconstructed coordinates.
    #[serde(skip)]
    pub reconstructed_ix: Vec<Coord>,
    /// The dropped coordinates.
    #[serde(skip)]
    pub dropped_ix: Vec<Coord>,
}

/// The coordinates (indices) occurring in `e`.
fn occurring(e: &Expr, coordinates: &[String]) -> Vec<usize> {
    (0..coordinates.len())
        .filter(|&k| {
            let c = &coordinates[k];
            e.any(&mut |x| match x {
                Expr::Sym(n) | Expr::Der(n) => n == c,
                Expr::Free { args, .. } => args.contains(c),
                _ => false,
            })
        })
        .collect()
}

/// Add to `set` every coordinate the kinematic equations of its members need, until closed.
/// Without kinematic equations (a structured derivation: Γ's rows mention only coordinates of
/// Z and α, which are integrated), `set` is closed already.
fn close(set: &mut Vec<usize>, kinematics: &[Entry], coordinates: &[String]) {
    let mut k = 0;
    while k < set.len() && !kinematics.is_empty() {
        for c in occurring(&kinematics[set[k]].expr, coordinates) {
            if !set.contains(&c) {
                set.push(c);
            }
        }
        k += 1;
    }
    set.sort_unstable();
}

/// Plan the scene: the one pass ([`hamel_reduce::pass`], from the derivation store when it
/// holds it, made anew when `fresh`) derives the equations of the choice `eta` (with the
/// ingredients code generation uses) and decides exactly which coordinates they are free of;
/// [`decide`] chooses from them what is integrated, reconstructed and dropped, checked against
/// that ground truth. Pure: no file is read or written (the scene's core is
/// prepared separately, [`crate::cache::prepare`]). The plan and the derivation.
pub fn plan(
    model: &Model,
    eta: &str,
    request: &Request,
    fresh: bool,
) -> Result<Planned, ModelError> {
    use hamel_reduce::pass::{Analysis, Job, obtain};
    let located = |e: hamel_reduce::ReduceError| e.locate(model);
    let job = Job::new(model, Some(eta), Analysis::Survey)
        .map_err(located)?
        .for_code();
    let mut artefact = obtain(&job, fresh).map_err(located)?;
    let survey = artefact.reduction.take();
    let d = artefact.into_derivation().map_err(located)?;
    let Decision {
        integrated,
        reconstructed,
        dropped,
    } = decide(&d, request);
    let names = |ix: &[Coord]| model.coordinate_names(ix);
    // The decision (on the printed canonical forms) checked against the pass's survey (the
    // ground truth for every coordinate): whatever is not integrated must be proved absent.
    let proved = survey.map_or(Vec::new(), |r| r.ground_truth.absent_in(model));
    let unproved: Vec<Coord> = (model.coords())
        .filter(|k| !integrated.contains(k) && !proved.contains(k))
        .collect();
    if !unproved.is_empty() {
        let absent: Vec<Coord> = (model.coords())
            .filter(|c| !integrated.contains(c))
            .collect();
        return Err(model.error(format!(
            "internal error: the plan integrates ({}) without ({}), but `hamel reduce` does not prove {} absent from the equations",
            names(&integrated).join(", "),
            names(&absent).join(", "),
            names(&unproved).join(", ")
        )));
    }
    let plan = Plan {
        integrated: names(&integrated)
            .into_iter()
            .chain((1..=d.sigma).map(|i| format!("eta{i}")))
            .collect(),
        reconstructed: names(&reconstructed),
        dropped: names(&dropped),
        eta: d.eta_name.clone(),
        expressions: IndexMap::new(),
        forces: Vec::new(),
        friction: IndexMap::new(),
        integrated_ix: integrated,
        reconstructed_ix: reconstructed,
        dropped_ix: dropped,
    };
    Ok(Planned {
        plan,
        derivation: d,
    })
}

/// A scene planned: the plan and the derivation it was decided on.
pub struct Planned {
    /// What is integrated, reconstructed and dropped.
    pub plan: Plan,
    /// The derivation.
    pub derivation: Derivation,
}

/// What a scene integrates, reconstructs and drops ([`decide`]).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Decision {
    /// The coordinates integrated.
    pub integrated: Vec<Coord>,
    /// The requested ones the equations are free of, reconstructed by their kinematics.
    pub reconstructed: Vec<Coord>,
    /// The others.
    pub dropped: Vec<Coord>,
}

/// What is integrated, reconstructed and dropped (coordinate indices), decided on the printed
/// canonical forms of `d`: the coordinates occurring in the true equations (11), closed under
/// the kinematic equations; the requested rest (and what the energy or the constraint residual
/// needs, when requested), closed under theirs; the others.
pub fn decide(d: &Derivation, request: &Request) -> Decision {
    let coords = &d.coordinates;
    let no_kinematics: &[Entry] = &[];
    // A structured derivation has no expanded equations: the coordinates A, α, Z and U mention
    // (Γ, A_Γ and Q are made of them and their derivatives) are integrated, and Γ's rows need
    // no closing (they mention only coordinates of Z and α).
    let (equations, kinematics): (Vec<&Expr>, &[Entry]) = match d.closed() {
        Some(c) => (c.equations.iter().map(|e| &e.expr).collect(), &c.kinematics),
        None => {
            let matrices = [&d.a, &d.alpha, &d.z];
            let entries = matrices
                .into_iter()
                .flat_map(|m| m.entries.iter().flatten());
            let potential = d.ingredients.potential.iter();
            (
                entries.chain(potential).map(|e| &e.expr).collect(),
                no_kinematics,
            )
        }
    };
    let mut integrated: Vec<usize> = Vec::new();
    for e in equations {
        for c in occurring(e, coords) {
            if !integrated.contains(&c) {
                integrated.push(c);
            }
        }
    }
    close(&mut integrated, kinematics, coords);
    let mut wanted: Vec<usize> = request.coordinates.iter().map(|k| k.index()).collect();
    wanted.extend(request.needed.iter().map(|k| k.index()));
    if request.energy {
        match d.closed() {
            Some(c) => wanted.extend(occurring(&c.energy.expr, coords)),
            // E = ½q̇ᵀAq̇ − U.
            None => {
                let terms = d.a.entries.iter().flatten().map(|e| &e.expr);
                for e in terms.chain(d.ingredients.potential.as_ref().map(|u| &u.expr)) {
                    wanted.extend(occurring(e, coords));
                }
            }
        }
    }
    if request.constraint_residual || request.computes_forces() {
        wanted.extend(0..d.ell);
    }
    let mut reconstructed: Vec<usize> = Vec::new();
    for c in wanted {
        if !integrated.contains(&c) && !reconstructed.contains(&c) {
            reconstructed.push(c);
        }
    }
    close(&mut reconstructed, kinematics, coords);
    reconstructed.retain(|c| !integrated.contains(c));
    let dropped: Vec<usize> = (0..d.ell)
        .filter(|c| !integrated.contains(c) && !reconstructed.contains(c))
        .collect();
    let typed = |v: Vec<usize>| v.into_iter().map(Coord::new).collect();
    Decision {
        integrated: typed(integrated),
        reconstructed: typed(reconstructed),
        dropped: typed(dropped),
    }
}

impl Plan {
    /// The coordinates in the integrated state, as indices in model order (the positions
    /// of their values in a full configuration): integrated, then reconstructed.
    pub fn state(&self) -> Vec<usize> {
        (self.integrated_ix.iter())
            .chain(&self.reconstructed_ix)
            .map(|k| k.index())
            .collect()
    }

    /// The plan as text.
    pub fn to_text(&self) -> String {
        let list = |v: &[String]| {
            if v.is_empty() {
                "(none)".to_string()
            } else {
                v.join(", ")
            }
        };
        let expressions = self
            .expressions
            .iter()
            .map(|(name, needs)| format!("expression {name}: needs {}\n", list(needs)))
            .collect::<String>();
        let forces = if self.forces.is_empty() {
            String::new()
        } else {
            format!("constraint forces: {}\n", self.forces.join(", "))
        };
        let watched: Vec<String> = (self.friction.iter())
            .map(|(wheel, mu)| format!("{wheel} (μ = {mu})"))
            .collect();
        let friction = if watched.is_empty() {
            String::new()
        } else {
            format!("friction watched: {}\n", watched.join(", "))
        };
        format!(
            "quasi-velocities: {}\nintegrated: {}\nreconstructed: {}\ndropped: {}\n{expressions}{forces}{friction}",
            self.eta,
            list(&self.integrated),
            list(&self.reconstructed),
            list(&self.dropped),
        )
    }
}
