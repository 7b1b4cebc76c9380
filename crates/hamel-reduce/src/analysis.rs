//! Assemble a [`Reduction`]: classification (31), structure (17)/(18), Properties 2.1–2.2,
//! hypotheses, ground truth and the reduced system. Runs on the CAS thread.

use hamel_cas::{Ex, Matrix};
use hamel_derive::Symbolic;
use hamel_derive::progress::Stage;
use hamel_derive::symbolic::{entry, mat};
use hamel_model::Model;

use crate::ReduceError;
use indexmap::IndexMap;

use crate::hypotheses::{
    self as hyp, Blocks, H0, H1, H2, H3, H4, H5, H6, Id, Val, scan, scan_names, witness,
};
use crate::report::*;

/// The entries of the equations (11): A_Γ, Γᵀ∇U and Q⁽ⁱ⁾ (true or the paper's).
fn equation_entries(s: &Symbolic, paper: bool) -> Vec<(String, Vec<usize>, Val)> {
    let sigma = s.eta.len();
    let mut out = Vec::new();
    for r in 0..sigma {
        for c in r..sigma {
            out.push((
                "A_Gamma".to_string(),
                vec![r + 1, c + 1],
                Val::Over(s.a_gamma[(r, c)].clone()),
            ));
        }
    }
    for (i, f) in s.forcing.iter().enumerate() {
        out.push((
            "Gamma^T grad U".to_string(),
            vec![i + 1],
            Val::Over(f.clone()),
        ));
    }
    let q = if paper { &s.q_paper } else { &s.q_true };
    let name = if paper { "Q_paper" } else { "Q" };
    for (i, m) in q.iter().enumerate() {
        for r in 0..sigma {
            for c in r..sigma {
                out.push((
                    format!("{name}({})", i + 1),
                    vec![r + 1, c + 1],
                    Val::Over(m[(r, c)].clone()),
                ));
            }
        }
    }
    out
}

/// Which coordinates of `p` occur in the entries, with the first occurrence of each.
fn occurrences(
    s: &Symbolic,
    p: &[usize],
    entries: &[(String, Vec<usize>, Val)],
) -> (Vec<usize>, Vec<Witness>) {
    let mut present = Vec::new();
    let mut found = Vec::new();
    for &k in p {
        if let Some(w) = scan(
            s,
            &[k],
            entries.iter().cloned(),
            "the equations (11) contain it",
        ) {
            present.push(k);
            found.push(w);
        }
    }
    (present, found)
}

/// The conditions for the true equations (11) to be free of the coordinates `p`: for every
/// entry that depends on some q_k of `p`, [`Ex::dependence_conditions`] (equations `c = 0`),
/// each with the entry it comes from. Deduplicated, in entry order. Used by the search of
/// family (a), where the conditions are equations on the unknown functions.
pub(crate) fn dependence_conditions(s: &Symbolic, p: &[usize]) -> Vec<(String, Ex)> {
    let mut out: Vec<(String, Ex)> = Vec::new();
    for (object, index, v) in equation_entries(s, false) {
        let e = match &v {
            Val::Ex(e) => e.clone(),
            Val::Over(o) => o.to_ex(),
        };
        for &k in p {
            if !e.depends_on(k) {
                continue;
            }
            for c in e.dependence_conditions(k) {
                if !out
                    .iter()
                    .any(|(_, d)| (d - &c).is_zero() || (d + &c).is_zero())
                {
                    out.push((format!("{object}{index:?}"), c));
                }
            }
        }
    }
    out
}

/// The whole analysis of eliminating `p` under the derivation `s`, step by step as in the
/// paper: (31), (17)/(18), Properties 2.1–2.2, H0–H6, then the ground truth, the findings and
/// the reduced system. Errors: a determinant the engine could not compute (a bug, named).
pub(crate) fn analyse(model: &Model, s: &Symbolic, p: &[usize]) -> Result<Reduction, ReduceError> {
    let names = s.field.coordinates().to_vec();
    let mut stage = Stage::start(
        &model.name,
        "classifying the coordinates (31), blocks (17)/(18)",
    );
    let blocks = Blocks::of(&s.z);
    let classification = classify(s, &names, p);
    let structure = block_structure(s, &blocks, &names).map_err(|e| {
        ReduceError::Engine(hamel_cas::CasError::Internal(format!(
            "δ_R of (18) could not be computed: {e}"
        )))
    })?;
    stage.next("Properties 2.1 and 2.2, hypotheses H0–H6");
    let h1 = hyp::h1(s, &blocks);
    let properties = properties(s, &blocks, &names, &h1);
    let hypotheses = hypotheses(s, &blocks, p, h1);
    let proposition_2_1 = Id::PROPOSITION_2_1.iter().all(|h| hypotheses[h].holds);
    stage.next("the ground truth: which coordinates the equations (11) hold");
    let truth = Truth::of(s, p);
    let ground_truth = truth.report(&names, p);
    let findings = findings(&hypotheses, &ground_truth, &names, p);
    let reduced_system = truth.reduced_system(s, &names, p);
    Ok(Reduction {
        model: model.name.clone(),
        eta_name: s.choice().name.clone(),
        eta: s.choice().eta.iter().map(|e| e.expr.to_string()).collect(),
        coordinates: names.clone(),
        eliminate: p.iter().map(|&k| names[k].clone()).collect(),
        classification,
        structure: Some(structure),
        properties,
        hypotheses,
        proposition_2_1: Some(proposition_2_1),
        paper_is_exact: Some(s.checks.paper_is_exact),
        ground_truth,
        findings,
        reduced_system,
    })
}

/// (31): a coordinate is of type (B) when A, U or α depends on it, else of type (A).
fn classify(s: &Symbolic, names: &[String], p: &[usize]) -> Vec<Classification> {
    classify_parts(names, &s.a, &s.u, &s.alpha, &s.z, p)
}

/// (31) from A, U, α and Z themselves (shared with the structured reduction).
pub(crate) fn classify_parts(
    names: &[String],
    a: &Matrix,
    u: &Ex,
    alpha: &Matrix,
    z: &Matrix,
    p: &[usize],
) -> Vec<Classification> {
    let ell = names.len();
    (0..ell)
        .map(|k| {
            let sources = (0..ell)
                .flat_map(|i| (i..ell).map(move |j| (i, j)))
                .map(|(i, j)| {
                    (
                        "A".to_string(),
                        vec![i + 1, j + 1],
                        Val::Ex(a[(i, j)].clone()),
                    )
                })
                .chain(std::iter::once((
                    "U".to_string(),
                    vec![],
                    Val::Ex(u.clone()),
                )))
                .chain((0..alpha.rows()).flat_map(|m| {
                    (0..ell).map(move |j| {
                        (
                            "alpha".to_string(),
                            vec![m + 1, j + 1],
                            Val::Ex(alpha[(m, j)].clone()),
                        )
                    })
                }));
            let occurs_in = scan_names(names, &[k], sources, "so it is of type (B)");
            Classification {
                coordinate: names[k].clone(),
                kind: if occurs_in.is_some() {
                    CoordinateKind::B
                } else {
                    CoordinateKind::A
                },
                occurs_in,
                in_z: z.entries().iter().any(|e| e.depends_on(k)),
                asked: p.contains(&k),
            }
        })
        .collect()
}

/// (17)/(18): the blocks of Z, α and Γ, and δ_R = det[Z₁; α₁].
fn block_structure(
    s: &Symbolic,
    blocks: &Blocks,
    names: &[String],
) -> Result<BlockStructure, hamel_cas::CasError> {
    let all_mu: Vec<usize> = (0..s.alpha.rows()).collect();
    let z1 = Blocks::sub(&s.z, &blocks.rows1, &blocks.j1);
    let z2 = Blocks::sub(&s.z, &blocks.rows1, &blocks.j2);
    let alpha1 = Blocks::sub(&s.alpha, &all_mu, &blocks.j1);
    let alpha2 = Blocks::sub(&s.alpha, &all_mu, &blocks.j2);
    let gamma1 = Blocks::sub(&s.gamma, &blocks.j1, &blocks.rows1);
    let gamma2 = Blocks::sub(&s.gamma, &blocks.j1, &blocks.rows2);
    let delta_r = if z1.rows() + alpha1.rows() == 0 {
        s.field.one()
    } else if alpha1.rows() == 0 {
        z1.det()?
    } else if z1.rows() == 0 {
        alpha1.det()?
    } else {
        z1.vstack(&alpha1).det()?
    };
    Ok(BlockStructure {
        v: blocks.v(),
        unit_rows: blocks
            .rows2
            .iter()
            .zip(&blocks.j2)
            .map(|(&i, &j)| (i + 1, names[j].clone()))
            .collect(),
        block1: blocks.j1.iter().map(|&j| names[j].clone()).collect(),
        block2: blocks.j2.iter().map(|&j| names[j].clone()).collect(),
        z1: mat(&z1),
        z2: mat(&z2),
        alpha1: mat(&alpha1),
        alpha2: mat(&alpha2),
        gamma1: mat(&gamma1),
        gamma2: mat(&gamma2),
        delta_r: entry(&delta_r),
    })
}

/// Properties 2.1 (Γ₂ = 0, (26)) and 2.2 (Γ₁ᵀA⁽¹'²⁾ = 0, (27)), with witnesses.
fn properties(
    s: &Symbolic,
    blocks: &Blocks,
    names: &[String],
    h1: &Hypothesis,
) -> IndexMap<PropertyId, Property> {
    let gamma1 = Blocks::sub(&s.gamma, &blocks.j1, &blocks.rows1);
    let gamma2 = Blocks::sub(&s.gamma, &blocks.j1, &blocks.rows2);
    let gamma2_nonzero = (0..gamma2.rows())
        .flat_map(|h| (0..gamma2.cols()).map(move |c| (h, c)))
        .find(|&(h, c)| !gamma2[(h, c)].is_zero());
    let p21 = Property {
        statement: "Γ₂ = 0 (26), which holds iff (Z₂; α₂) = 0".to_string(),
        holds: gamma2_nonzero.is_none(),
        witness: gamma2_nonzero.map(|(h, c)| {
            let mut w = witness(
                s,
                "Gamma2",
                vec![h + 1, c + 1],
                None,
                &Val::Ex(gamma2[(h, c)].clone()),
                "Γ₂ ≠ 0".to_string(),
            );
            if let Some(hw) = &h1.witness {
                w.note = format!("Γ₂ ≠ 0 because {}", hw.note);
            }
            w
        }),
    };
    let a12 = Blocks::sub(&s.a, &blocks.j1, &blocks.j2);
    let g1a12 = gamma1.transpose().mul(&a12);
    let nonzero = (0..g1a12.rows())
        .flat_map(|r| (0..g1a12.cols()).map(move |c| (r, c)))
        .find(|&(r, c)| !g1a12[(r, c)].is_zero());
    let p22 = Property {
        statement: "Γ₁ᵀA⁽¹'²⁾ = 0 (27), which holds iff the columns of A⁽¹'²⁾ are \
                    combinations of the rows of α₁"
            .to_string(),
        holds: nonzero.is_none(),
        witness: nonzero.map(|(r, c)| {
            witness(
                s,
                "Gamma1^T A12",
                vec![r + 1, c + 1],
                None,
                &Val::Ex(g1a12[(r, c)].clone()),
                format!(
                    "the column of A(1,2) for `{}` is not in the row space of α₁",
                    names[blocks.j2[c]]
                ),
            )
        }),
    };
    IndexMap::from([(PropertyId::P2_1, p21), (PropertyId::P2_2, p22)])
}

/// H0–H6, each decided exactly with a witness when it fails.
fn hypotheses(
    s: &Symbolic,
    blocks: &Blocks,
    p: &[usize],
    h1: Hypothesis,
) -> IndexMap<Id, Hypothesis> {
    let h2 = hyp::h2(s, blocks).unwrap_or_else(|e| Hypothesis {
        statement: "(H2)".to_string(),
        holds: false,
        witness: Some(Witness {
            object: "alpha1".to_string(),
            index: vec![],
            coordinate: None,
            expression: String::new(),
            note: format!("the rank could not be computed: {e}"),
        }),
    });
    IndexMap::from([
        (H0, hyp::h0(s, p)),
        (H1, h1),
        (H2, h2),
        (H3, hyp::h3(s, blocks, p)),
        (H4, hyp::h4(s, blocks, p)),
        (H5, hyp::h5(s, blocks, p)),
        (H6, hyp::h6(s, p)),
    ])
}

/// What the equations actually contain: the coordinates of `p` present in the true and in the
/// paper's equations (11), the coordinates the equations need, closed under their kinematic
/// equations, and the first kinematic equation that brings back an eliminated coordinate.
struct Truth {
    present: Vec<usize>,
    occurrences: Vec<Witness>,
    paper_present: Vec<usize>,
    needed: Vec<usize>,
    kinematics_witness: Option<Witness>,
    /// The kinematic equations q̇_k = (Γη)_k.
    rates: Vec<Ex>,
}

impl Truth {
    fn of(s: &Symbolic, p: &[usize]) -> Truth {
        let ell = s.gamma.rows();
        let entries_true = equation_entries(s, false);
        let (present, witnesses) = occurrences(s, p, &entries_true);
        let (paper_present, _) = occurrences(s, p, &equation_entries(s, true));
        // The coordinates the equations (11) need: those their coefficients depend on (exactly).
        let mut needed: Vec<usize> = Vec::new();
        for (_, _, e) in &entries_true {
            for k in e.dependence(ell) {
                if !needed.contains(&k) {
                    needed.push(k);
                }
            }
        }
        let rates: Vec<Ex> = s.gamma_eta.iter().map(|e| e.to_ex()).collect();
        let kinematics_witness = close_kinematics(s, p, &rates, &mut needed);
        Truth {
            present,
            occurrences: witnesses,
            paper_present,
            needed,
            kinematics_witness,
            rates,
        }
    }

    fn kinematics_closed(&self, p: &[usize]) -> bool {
        !self.needed.iter().any(|k| p.contains(k))
    }

    fn report(&self, names: &[String], p: &[usize]) -> GroundTruth {
        let list = |v: &[usize]| v.iter().map(|&k| names[k].clone()).collect::<Vec<_>>();
        let absent: Vec<usize> = p
            .iter()
            .copied()
            .filter(|k| !self.present.contains(k))
            .collect();
        let paper_absent: Vec<usize> = p
            .iter()
            .copied()
            .filter(|k| !self.paper_present.contains(k))
            .collect();
        let kinematics_closed = self.kinematics_closed(p);
        GroundTruth {
            absent: list(&absent),
            present: list(&self.present),
            occurrences: self.occurrences.clone(),
            paper_absent: list(&paper_absent),
            paper_present: list(&self.paper_present),
            kinematics_closed,
            kinematics_witness: if kinematics_closed {
                None
            } else {
                self.kinematics_witness.clone()
            },
            undecided: Vec::new(),
        }
    }

    /// The reduced system, when every asked coordinate is absent and the kinematics close.
    fn reduced_system(&self, s: &Symbolic, names: &[String], p: &[usize]) -> Option<ReducedSystem> {
        if !(self.present.is_empty() && self.kinematics_closed(p)) {
            return None;
        }
        let ell = names.len();
        let needed = &self.needed;
        // Canonical forms may still mention a coordinate they do not depend on (as in
        // (1 − cos²θ)/sin θ): write the reduced equations without the dropped coordinates.
        let dropped: Vec<usize> = (0..ell).filter(|k| !needed.contains(k)).collect();
        let without = |e: Ex| -> Ex {
            dropped
                .iter()
                .fold(e, |e, &k| e.without_coordinate(k).unwrap_or(e))
        };
        let kin = |k: usize| KinematicEquation {
            coordinate: names[k].clone(),
            rate: entry(&without(self.rates[k].clone())),
        };
        let sigma = s.eta.len();
        let mut state: Vec<String> = (1..=sigma).map(|i| format!("eta{i}")).collect();
        state.extend(needed.iter().map(|&k| names[k].clone()));
        Some(ReducedSystem {
            state,
            equations: s
                .lhs(&s.q_eta)
                .iter()
                .map(|e| entry(&without(e.to_ex())))
                .collect(),
            kinematics: needed.iter().map(|&k| kin(k)).collect(),
            reconstruction: dropped.iter().map(|&k| kin(k)).collect(),
        })
    }
}

/// Close `needed` under the kinematic equations q̇_k = `rates`[k] of its members; the first
/// equation of a kept coordinate that brings in one of `p`, as a witness.
fn close_kinematics(
    s: &Symbolic,
    p: &[usize],
    rates: &[Ex],
    needed: &mut Vec<usize>,
) -> Option<Witness> {
    let names = s.field.coordinates();
    let mut kin_witness = None;
    let mut i = 0;
    while i < needed.len() {
        let k = needed[i];
        for j in rates[k].coordinate_dependence() {
            if !needed.contains(&j) {
                if p.contains(&j) && kin_witness.is_none() && !p.contains(&k) {
                    kin_witness = Some(witness(
                        s,
                        "Gamma eta",
                        vec![k + 1],
                        Some(j),
                        &Val::Ex(rates[k].clone()),
                        format!(
                            "the kinematic equation of `{}`, needed by the reduced system, \
                             contains `{}`",
                            names[k], names[j]
                        ),
                    ));
                }
                needed.push(j);
            }
        }
        i += 1;
    }
    needed.sort_unstable();
    kin_witness
}

/// Sentences comparing the verdict of Proposition 2.1 (and H6) with the ground truth.
fn findings(
    hypotheses: &IndexMap<Id, Hypothesis>,
    truth: &GroundTruth,
    names: &[String],
    p: &[usize],
) -> Vec<String> {
    let failing: Vec<String> = Id::PROPOSITION_2_1
        .into_iter()
        .filter(|h| !hypotheses[h].holds)
        .map(|h| h.to_string())
        .collect();
    let proposition_2_1 = failing.is_empty();
    let h6 = hypotheses[&H6].holds;
    let eliminated = truth.present.is_empty();
    let asked = p
        .iter()
        .map(|&k| names[k].as_str())
        .collect::<Vec<_>>()
        .join(", ");
    let mut findings = Vec::new();
    if eliminated && !failing.is_empty() {
        findings.push(format!(
            "eliminated although {} fail{}: the true equations (11) are free of {asked}, \
             but Proposition 2.1 does not apply (its hypotheses are only sufficient)",
            failing.join(", "),
            if failing.len() == 1 { "s" } else { "" }
        ));
    }
    if proposition_2_1 && !h6 {
        findings.push(format!(
            "hypotheses hold but the paper's equations are not the true ones: H0–H5 hold, so \
             the paper's (11) are free of {asked}, but H6 fails{}",
            if eliminated {
                " (the true equations are free of them all the same)"
            } else {
                " and the true equations contain them"
            }
        ));
    }
    if proposition_2_1 && h6 && !eliminated {
        findings.push(
            "H0–H6 hold but the equations contain an eliminated coordinate: this contradicts \
             Proposition 2.1 and is a bug in hamel; please report it"
                .to_string(),
        );
    }
    if eliminated && failing.is_empty() {
        findings.push(format!(
            "eliminated, as Proposition 2.1 predicts: the true equations (11) are free of {asked}"
        ));
    }
    if !eliminated {
        findings.push(format!(
            "not eliminated: the true equations (11) contain {}",
            truth.present.join(", ")
        ));
    }
    if eliminated && !truth.paper_present.is_empty() {
        findings.push(format!(
            "the paper's equations contain {} although the true ones do not",
            truth.paper_present.join(", ")
        ));
    } else if !eliminated && truth.paper_present.is_empty() {
        findings.push(format!(
            "the paper's equations are free of {asked}, but they are not the true equations"
        ));
    }
    if eliminated && !truth.kinematics_closed {
        findings.push(
            "the kinematic equations still needed (34) contain an eliminated coordinate, so \
             (11) cannot be solved apart from it"
                .to_string(),
        );
    }
    findings
}
