//! Human-readable report of a [`Reduction`].

use std::fmt::Write;

use hamel_derive::Printer;

use crate::report::{BlockStructure, CoordinateKind, Reduction, Witness};

fn witness_line(w: &Witness) -> String {
    let idx: Vec<String> = w.index.iter().map(|i| i.to_string()).collect();
    format!(
        "{}[{}] = {}\n        ({})",
        w.object,
        idx.join(", "),
        w.expression,
        w.note
    )
}

/// (17)/(18) as text.
fn structure_text<'e>(o: &mut String, st: &'e BlockStructure, p: Printer<'_, 'e>) {
    let _ = writeln!(o, "\nBlock structure (17)/(18): v = {}", st.v);
    let _ = writeln!(o, "  block 1 (μ + v): {}", st.block1.join(", "));
    let _ = writeln!(
        o,
        "  block 2 (σ − v): {}",
        if st.block2.is_empty() {
            "(none)".to_string()
        } else {
            st.block2.join(", ")
        }
    );
    for (i, q) in &st.unit_rows {
        let _ = writeln!(o, "  eta{i} = der({q})");
    }
    hamel_derive::entry_line(o, "  δ_R = ", p, &st.delta_r);
}

impl Reduction {
    /// The report as text, entries in their canonical form.
    pub fn to_text(&self) -> String {
        self.to_text_with(&hamel_derive::canonical)
    }

    /// The report as text, each entry of the block structure and of the reduced system
    /// written by `p`.
    pub fn to_text_with<'e>(&'e self, p: Printer<'_, 'e>) -> String {
        let mut o = String::new();
        let _ = writeln!(
            o,
            "Reduction of `{}` with quasi-velocities `{}`: eliminate {}",
            self.model,
            self.eta_name,
            self.eliminate.join(", ")
        );
        for (i, e) in self.eta.iter().enumerate() {
            let _ = writeln!(o, "  eta{} = {e}", i + 1);
        }
        self.classification_text(&mut o);
        match &self.structure {
            Some(st) => structure_text(&mut o, st, p),
            None => {
                let _ = writeln!(
                    o,
                    "\nStructured form: the block structure (17)/(18), the Properties and H0–H6 need Γ in closed form (not computed)"
                );
            }
        }
        self.properties_text(&mut o);
        if let Some(applies) = self.proposition_2_1 {
            let _ = writeln!(
                o,
                "\nProposition 2.1 (H0–H5 ⇒ the paper's (11) are free of them): {}",
                if applies { "applies" } else { "does not apply" }
            );
        }
        self.ground_truth_text(&mut o);
        let _ = writeln!(o, "\nFindings:");
        for f in &self.findings {
            let _ = writeln!(o, "  - {f}");
        }
        self.reduced_system_text(&mut o, p);
        o
    }

    /// The classification of the coordinates, (31).
    fn classification_text(&self, o: &mut String) {
        let _ = writeln!(o, "\nClassification (31):");
        for c in &self.classification {
            let kind = match c.kind {
                CoordinateKind::A => "(A) absent from L and α".to_string(),
                CoordinateKind::B => format!(
                    "(B) {}",
                    c.occurs_in
                        .as_ref()
                        .map(|w| {
                            let idx: Vec<String> = w.index.iter().map(|i| i.to_string()).collect();
                            format!("occurs in {}[{}]", w.object, idx.join(", "))
                        })
                        .unwrap_or_default()
                ),
            };
            let _ = writeln!(
                o,
                "  {}{:<10} {kind}{}",
                if c.asked { "* " } else { "  " },
                c.coordinate,
                if c.in_z { "; Z depends on it" } else { "" }
            );
        }
    }

    /// The Properties and the hypotheses H0–H6, each with its witness.
    fn properties_text(&self, o: &mut String) {
        if !self.properties.is_empty() || !self.hypotheses.is_empty() {
            let _ = writeln!(o, "\nProperties:");
            for (name, p) in &self.properties {
                let _ = writeln!(
                    o,
                    "  {name}: {} — {}",
                    if p.holds { "holds" } else { "fails" },
                    p.statement
                );
                if let Some(w) = &p.witness {
                    let _ = writeln!(o, "      {}", witness_line(w));
                }
            }
            let _ = writeln!(o, "\nHypotheses:");
            for (name, h) in &self.hypotheses {
                let _ = writeln!(
                    o,
                    "  {name}: {:<5}  {}",
                    if h.holds { "holds" } else { "FAILS" },
                    h.statement
                );
                if let Some(w) = &h.witness {
                    let _ = writeln!(o, "      {}", witness_line(w));
                }
            }
        }
    }

    /// The ground truth: which coordinates are absent from the true equations, and from the
    /// paper's.
    fn ground_truth_text(&self, o: &mut String) {
        let gt = &self.ground_truth;
        let _ = writeln!(
            o,
            "\nGround truth (decided exactly on the true equations{}):",
            if self.structure.is_none() {
                "; structured form: absent by (31) or by a symmetry, present by a certified derivative"
            } else {
                ""
            }
        );
        let _ = writeln!(o, "  absent:  {}", gt.absent.join(", "));
        let _ = writeln!(o, "  present: {}", gt.present.join(", "));
        if !gt.undecided.is_empty() {
            let _ = writeln!(o, "  undecided: {}", gt.undecided.join(", "));
        }
        for w in &gt.occurrences {
            let _ = writeln!(o, "      {}", witness_line(w));
        }
        if self.paper_is_exact.is_some() {
            let _ = writeln!(
                o,
                "  in the paper's equations: absent {}; present {}",
                if gt.paper_absent.is_empty() {
                    "(none)".to_string()
                } else {
                    gt.paper_absent.join(", ")
                },
                if gt.paper_present.is_empty() {
                    "(none)".to_string()
                } else {
                    gt.paper_present.join(", ")
                }
            );
        }
        if let Some(w) = &gt.kinematics_witness {
            let _ = writeln!(o, "  kinematics not closed: {}", witness_line(w));
        }
    }

    /// The reduced system (11) with its kinematic equations, and the reconstruction.
    fn reduced_system_text<'e>(&'e self, o: &mut String, p: Printer<'_, 'e>) {
        match &self.reduced_system {
            None => {
                let _ = writeln!(o, "\nNo reduced system.");
            }
            Some(r) => {
                let _ = writeln!(o, "\nReduced system, state ({}):", r.state.join(", "));
                if r.equations.is_empty() && self.structure.is_none() {
                    let _ = writeln!(
                        o,
                        "  (structured form: (11) and the kinematic equations are evaluated from A, α, Z and U)"
                    );
                }
                for (i, e) in r.equations.iter().enumerate() {
                    let _ = write!(o, "  (11.{}) ", i + 1);
                    let start = o.len();
                    p(e, o);
                    if !hamel_derive::is_whole_equation(&o[start..]) {
                        o.insert_str(start, "0 = ");
                    }
                    o.push('\n');
                }
                for k in &r.kinematics {
                    hamel_derive::entry_line(
                        o,
                        format_args!("  der({}) = ", k.coordinate),
                        p,
                        &k.rate,
                    );
                }
                let _ = writeln!(o, "Reconstruction:");
                for k in &r.reconstruction {
                    hamel_derive::entry_line(
                        o,
                        format_args!("  der({}) = ", k.coordinate),
                        p,
                        &k.rate,
                    );
                }
            }
        }
    }
}
