//! Reduction of a derivation in structured form (too large to expand, such as the bicycle's):
//! what can be decided from its exact ingredients A, α, Z and U alone. Runs on the CAS thread.
//!
//! * The classification (31), exactly, as for the closed form.
//! * **Absent**: a coordinate of type (A) that Z does not contain. Γ, A_Γ, Γᵀ∇U and Q are
//!   built from A, α, Z, U and their derivatives, all free of it, so the true equations (11)
//!   and the kinematic equations are free of it: a proof, on canonical forms.
//! * **Present**: ∂η̇_i/∂q_k certified nonzero at one state, by interval arithmetic with dual
//!   numbers through the structured evaluation itself ([`hamel_derive::certify`]): a proof that
//!   the equations contain q_k.
//! * Otherwise **undecided**, and said so: the closed form (or a symmetry of the system) would
//!   decide it.
//!
//! The block structure (17)/(18), the Properties and the hypotheses H0–H6 are statements about
//! Γ in closed form; a structured reduction does not make them.

use hamel_derive::certify::{Interval, generic, point};
use hamel_derive::{Compiled, Derivation, StructuredSymbolic};

use crate::invariance::{by_symmetry, symmetries, symmetry_findings};
use hamel_expr::Dual;
use hamel_model::Model;

use crate::ReduceError;
use indexmap::IndexMap;

use crate::analysis::classify_parts;
use crate::report::*;

/// How many states [`dependence`] tries.
const ATTEMPTS: usize = 4;

/// What was decided about one asked coordinate.
enum Verdict {
    Absent,
    /// Absent by the invariance under this symmetry.
    BySymmetry(String),
    Present(Witness),
    Undecided,
}

/// The structured analysis of eliminating `p`; `d` is `s` as plain data.
pub(crate) fn analyse(
    model: &Model,
    s: &StructuredSymbolic,
    d: &Derivation,
    p: &[usize],
) -> Result<Reduction, ReduceError> {
    let names = model.coordinates.clone();
    let classification = classify_parts(&names, &s.a, &s.u, &s.alpha, &s.z, p);
    let compiled = d
        .compile()
        .map_err(|e| ReduceError::NotCompiled(e.to_string()))?;
    // (31): type (A) and not in Z; nor in the forces F, which enter the equations beside ∇U.
    let by_31: Vec<bool> = classification
        .iter()
        .enumerate()
        .map(|(k, c)| {
            c.kind == CoordinateKind::A && !c.in_z && !s.forces.iter().any(|f| f.depends_on(k))
        })
        .collect();
    let (invariant, rejected) = symmetries(model, s);
    let by_symmetry = by_symmetry(&invariant, &mut by_31.clone());
    let verdicts: Vec<Verdict> = p
        .iter()
        .map(|&k| {
            if by_31[k] {
                return Verdict::Absent;
            }
            if let Some(name) = &by_symmetry[k] {
                return Verdict::BySymmetry(name.clone());
            }
            match dependence(&compiled, &d.parameters, &names, k) {
                Some(w) => Verdict::Present(w),
                None => Verdict::Undecided,
            }
        })
        .collect();
    let pick = |f: fn(&Verdict) -> bool| -> Vec<String> {
        p.iter()
            .zip(&verdicts)
            .filter(|(_, v)| f(v))
            .map(|(&k, _)| names[k].clone())
            .collect()
    };
    let absent = pick(|v| matches!(v, Verdict::Absent | Verdict::BySymmetry(_)));
    let undecided = pick(|v| matches!(v, Verdict::Undecided));
    let occurrences: Vec<Witness> = verdicts
        .iter()
        .filter_map(|v| match v {
            Verdict::Present(w) => Some(w.clone()),
            _ => None,
        })
        .collect();
    let present = pick(|v| matches!(v, Verdict::Present(_)));
    // Every asked coordinate absent by (31) leaves Γ, hence every kinematic equation, free of
    // them. One absent by a symmetry leaves free of it the rates of the coordinates the
    // symmetry does not move: each kept coordinate must be one of those.
    let moved: Vec<&str> = verdicts
        .iter()
        .filter_map(|v| match v {
            Verdict::BySymmetry(n) => Some(n.as_str()),
            _ => None,
        })
        .flat_map(|n| invariant.iter().filter(move |i| i.name == n))
        .flat_map(|i| i.moves.iter().map(String::as_str))
        .collect();
    let kept_moved = (0..names.len())
        .filter(|k| !p.contains(k))
        .find(|&k| moved.contains(&names[k].as_str()));
    let all_absent = absent.len() == p.len() && kept_moved.is_none();
    let kinematics_witness = kept_moved.map(|k| Witness {
        object: "kinematics".into(),
        index: vec![k + 1],
        coordinate: None,
        expression: format!("der({}) = (Γη)_{}", names[k], k + 1),
        note: format!(
            "`{}` is kept but moved by the symmetry that proves the others absent, so its rate may contain them",
            names[k]
        ),
    });
    let ground_truth = GroundTruth {
        absent,
        present,
        occurrences,
        paper_absent: Vec::new(),
        paper_present: Vec::new(),
        kinematics_closed: kinematics_witness.is_none(),
        kinematics_witness,
        undecided,
    };
    let mut findings = findings(&ground_truth, &names, p);
    let proved: Vec<(String, String)> = p
        .iter()
        .zip(&verdicts)
        .filter_map(|(&k, v)| match v {
            Verdict::BySymmetry(by) => Some((names[k].clone(), by.clone())),
            _ => None,
        })
        .collect();
    findings.extend(symmetry_findings(&invariant, &rejected, &proved));
    let reduced_system = all_absent.then(|| ReducedSystem {
        state: (1..=d.sigma)
            .map(|i| format!("eta{i}"))
            .chain(
                (0..d.ell)
                    .filter(|k| !p.contains(k))
                    .map(|k| names[k].clone()),
            )
            .collect(),
        equations: Vec::new(),
        kinematics: Vec::new(),
        reconstruction: Vec::new(),
    });
    Ok(Reduction {
        model: model.name.clone(),
        eta_name: d.eta_name.clone(),
        eta: d.eta.clone(),
        coordinates: names.clone(),
        eliminate: p.iter().map(|&k| names[k].clone()).collect(),
        classification,
        structure: None,
        properties: IndexMap::new(),
        hypotheses: IndexMap::new(),
        proposition_2_1: None,
        paper_is_exact: None,
        ground_truth,
        findings,
        reduced_system,
    })
}

/// A witness that η̇ depends on q_k: a state where some ∂η̇_i/∂q_k, evaluated in interval
/// arithmetic with dual numbers, certainly is not zero. `None` when no state tried shows it
/// (which proves nothing).
fn dependence(
    c: &Compiled,
    params: &IndexMap<String, f64>,
    names: &[String],
    k: usize,
) -> Option<Witness> {
    (0..ATTEMPTS).find_map(|a| {
        let at = point(a, names, params);
        let q: Vec<Dual<Interval>> = names
            .iter()
            .enumerate()
            .map(|(j, n)| {
                Dual::new(
                    Interval::point(at[n]),
                    Interval::point(f64::from(u8::from(j == k))),
                )
            })
            .collect();
        let sigma = c.dims().sigma;
        let eta: Vec<Dual<Interval>> = (0..sigma)
            .map(|i| Dual::new(Interval::point(generic(a + 100, i)), Interval::point(0.0)))
            .collect();
        let at_params: IndexMap<String, f64> = params.keys().map(|n| (n.clone(), at[n])).collect();
        let rhs = c.rhs(&q, &eta, &at_params).ok()?;
        let (i, d) = rhs
            .eta_dot
            .iter()
            .enumerate()
            .find(|(_, e)| e.d.excludes_zero())?;
        let state: Vec<String> = names
            .iter()
            .map(|n| format!("{n} = {:.6}", at[n]))
            .chain((0..sigma).map(|s| format!("eta{} = {:.6}", s + 1, eta[s].v.lo)))
            .collect();
        Some(Witness {
            object: "eta_dot".into(),
            index: vec![i + 1],
            coordinate: Some(names[k].clone()),
            expression: format!(
                "∂η̇{}/∂{} ∈ [{:.6e}, {:.6e}]",
                i + 1,
                names[k],
                d.d.lo,
                d.d.hi
            ),
            note: format!(
                "certified nonzero (interval arithmetic through the structured evaluation) at {}{}: the equations (11) contain `{}`",
                state.join(", "),
                if a == 0 {
                    ""
                } else {
                    " (parameters perturbed from their defaults)"
                },
                names[k]
            ),
        })
    })
}

/// Sentences on the verdict of a structured reduction.
fn findings(truth: &GroundTruth, names: &[String], p: &[usize]) -> Vec<String> {
    let asked: Vec<&str> = p.iter().map(|&k| names[k].as_str()).collect();
    let mut out = vec![
        "structured form: the hypotheses H0–H6 and the block structure (17)/(18) need Γ in closed form and were not evaluated".to_string(),
    ];
    if truth.absent.len() == p.len() {
        out.push(format!(
            "eliminated: the true equations (11) are free of {}",
            asked.join(", ")
        ));
    }
    if !truth.present.is_empty() {
        out.push(format!(
            "not eliminated: the true equations (11) contain {}",
            truth.present.join(", ")
        ));
    }
    if !truth.undecided.is_empty() {
        out.push(format!(
            "undecided: {} occur in A, U, α or Z, and no state tried shows the equations depending on them; the structured form cannot decide it",
            truth.undecided.join(", ")
        ));
    }
    out
}
