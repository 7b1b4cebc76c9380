//! The plain-text rendering of a derivation: each entry by a printer given to
//! [`Derivation::to_text_with`] (its canonical text in [`Derivation::to_text`]; `hamel-print`
//! gives the collected, factored and named forms), the rest around them.

use std::fmt::Write;

use crate::derivation::{Closed, Derivation, Entry, Form, Mat, StructuredForm};

/// How an entry is written: the printer appends its text to the report's (no string per
/// entry).
/// `'e`: the entries' own lifetime, so a printer may keep them (hamel-print collects the
/// entries shown, then prints them together). For a row of the equations of motion a printer
/// may write the whole equation (text containing ` = 0`, with a note after it); otherwise
/// ` = 0` is appended.
pub type Printer<'p, 'e> = &'p dyn Fn(&'e Entry, &mut String);

/// The canonical printer: each entry's canonical text.
pub fn canonical(e: &Entry, out: &mut String) {
    out.push_str(&e.text);
}

/// One line of a report: `before`, then `e` as `p` writes it.
pub fn entry_line<'e>(
    out: &mut String,
    before: impl std::fmt::Display,
    p: Printer<'_, 'e>,
    e: &'e Entry,
) {
    let _ = write!(out, "{before}");
    p(e, out);
    out.push('\n');
}

fn mat_text<'e>(out: &mut String, name: &str, m: &'e Mat, p: Printer<'_, 'e>) {
    if m.rows == 0 || m.cols == 0 {
        let _ = writeln!(out, "{name} = [] ({}×{})", m.rows, m.cols);
        return;
    }
    let _ = writeln!(out, "{name} =");
    for row in &m.entries {
        out.push_str("  [");
        for (j, e) in row.iter().enumerate() {
            if j > 0 {
                out.push_str(",  ");
            }
            p(e, out);
        }
        out.push_str("]\n");
    }
}

fn list_text<'e>(out: &mut String, name: &str, v: &'e [Entry], p: Printer<'_, 'e>) {
    let _ = writeln!(out, "{name} =");
    for (i, e) in v.iter().enumerate() {
        entry_line(out, format_args!("  ({}) ", i + 1), p, e);
    }
}

/// A row set to zero: `p`'s text of it and ` = 0`, unless the printer wrote the whole
/// equation (`hamel-print` writes a row multiplied through by its positive denominator as
/// `num = 0   (multiplied by D > 0)`).
fn write_equation<'e>(out: &mut String, p: Printer<'_, 'e>, e: &'e Entry) {
    let start = out.len();
    p(e, out);
    if !is_whole_equation(&out[start..]) {
        out.push_str(" = 0");
    }
}

/// Whether a printer's text of an equation's row is the whole equation (see [`Printer`]):
/// the one test of that convention, for every report that writes equations.
pub fn is_whole_equation(text: &str) -> bool {
    text.contains(" = 0")
}

fn yes(b: bool) -> &'static str {
    if b { "verified" } else { "FAILS" }
}

/// The rows of α by name, and each dropped row as the combination of them it is (exact).
fn dependent_text<'e>(o: &mut String, d: &'e Derivation, p: Printer<'_, 'e>) {
    if d.dependent_rows.is_empty() {
        return;
    }
    let names: Vec<String> = (d.constraints.iter().enumerate())
        .map(|(i, n)| format!("({}) {n}", i + 1))
        .collect();
    let _ = writeln!(o, "rows of α: {}", names.join(", "));
    let _ = writeln!(
        o,
        "dropped rows, each a combination of the rows of α (exact; rank α = {} of {} rows{}):",
        d.mu,
        d.mu + d.dependent_rows.len(),
        match d.dependent_rows.iter().find_map(|r| r.on_manifold.as_ref()) {
            Some(h) => format!(" where {h} = 0"),
            None => String::new(),
        }
    );
    for r in &d.dependent_rows {
        let _ = write!(o, "  {} =", r.name);
        if r.combination.is_empty() {
            o.push_str(" 0");
        }
        for (i, t) in r.combination.iter().enumerate() {
            o.push_str(if i == 0 { " (" } else { " + (" });
            p(&t.coefficient, o);
            let _ = write!(o, ")*{}", t.row);
        }
        if let Some(h) = &r.on_manifold {
            let _ = write!(
                o,
                "   where {h} = 0 (only there: on the constraint manifold)"
            );
        }
        o.push('\n');
        if !r.singular.is_empty() {
            let at: Vec<String> = r
                .singular
                .iter()
                .map(|e| format!("{} = 0", e.text))
                .collect();
            let _ = writeln!(
                o,
                "    (the rows it is combined from lose rank where {}: δ vanishes there too)",
                at.join(" or ")
            );
        }
    }
}

/// The closed form: Γ, Θ, δ, A_Γ, Q, the equations and the exact checks.
fn closed_text<'e>(o: &mut String, d: &Derivation, c: &'e Closed, p: Printer<'_, 'e>) {
    entry_line(o, "δ = det[Z; α] = ", p, &c.delta);
    let _ = writeln!(o, "singular set: {}", d.singular_set_text());
    mat_text(o, "Γ (q̇ = Γη)", &c.gamma, p);
    mat_text(o, "Θ", &c.theta, p);
    mat_text(o, "A_Γ = ΓᵀAΓ", &c.a_gamma, p);
    forces_text(o, d);
    let forcing = match d.forces.is_empty() {
        true => "Γᵀ∇U",
        false => "Γᵀ(∇U + F), F at q̇ = Γη",
    };
    list_text(o, forcing, &c.forcing, p);
    mat_text(o, "ΘᵀAΓ (ν = ΘᵀAΓη)", &c.nu, p);
    for i in 0..d.sigma {
        mat_text(o, &format!("Q({}) (true, symmetric)", i + 1), &c.q[i], p);
        mat_text(
            o,
            &format!("Q({}) paper (12)/(15)", i + 1),
            &c.q_paper[i],
            p,
        );
        mat_text(
            o,
            &format!("Q({}) correction", i + 1),
            &c.q_correction[i],
            p,
        );
    }
    o.push('\n');
    let _ = writeln!(o, "equations of motion (true, from (9)):");
    for (i, e) in c.equations.iter().enumerate() {
        let _ = write!(o, "  ({}) ", i + 1);
        write_equation(o, p, e);
        o.push('\n');
    }
    let _ = writeln!(o, "equations as printed in the paper (11)/(12):");
    for (i, e) in c.equations_paper.iter().enumerate() {
        let _ = write!(o, "  ({}) ", i + 1);
        write_equation(o, p, e);
        o.push('\n');
    }
    let _ = writeln!(o, "kinematic equations (6):");
    for (k, e) in c.kinematics.iter().enumerate() {
        entry_line(o, format_args!("  der({}) = ", d.coordinates[k]), p, e);
    }
    entry_line(o, "energy E = T − U = ", p, &c.energy);
    if let Some(power) = &c.power {
        entry_line(o, "power of the forces (Γη)ᵀF = ", p, power);
    }
    o.push('\n');
    let checks = &c.checks;
    let _ = writeln!(o, "checks (exact):");
    let _ = writeln!(
        o,
        "  Q = Q_paper + Q_correction: {}",
        yes(checks.split_identity)
    );
    let _ = writeln!(
        o,
        "  dE/dt = 0 along the true equations: {}",
        yes(checks.energy_conserved)
    );
    let _ = writeln!(
        o,
        "  dE/dt = 0 along the paper's equations: {}",
        yes(checks.energy_conserved_paper)
    );
    if let Some(balance) = checks.energy_balance {
        let _ = writeln!(
            o,
            "  dE/dt = (Γη)ᵀF along the true equations (Q does no work): {}",
            yes(balance)
        );
        let working = match checks.working_forces.is_empty() {
            true => "none".to_string(),
            false => checks.working_forces.join(", "),
        };
        let _ = writeln!(o, "  forces that do work (coordinates): {working}");
    }
    let _ = writeln!(
        o,
        "  paper's equations exact for this Z: {}",
        if checks.paper_is_exact {
            "yes (Q_correction ≡ 0)"
        } else {
            "NO: the paper's (11)/(15) miss Q_correction"
        }
    );
    if let Some(el) = checks.euler_lagrange {
        let _ = writeln!(
            o,
            "  holonomic, Z = I: equations are Euler–Lagrange: {}",
            yes(el)
        );
    }
}

/// The generalised forces F(q, q̇), canonical (none without forces).
fn forces_text(o: &mut String, d: &Derivation) {
    if d.forces.is_empty() {
        return;
    }
    let _ = writeln!(o, "F (generalised forces beside ∇U) =");
    for (q, f) in d.coordinates.iter().zip(&d.forces) {
        let _ = writeln!(o, "  F_{q} = {}", f.text);
    }
}

/// The structured form: what the equations are made of, and the certificate.
fn structured_text<'e>(o: &mut String, d: &'e Derivation, st: &StructuredForm, p: Printer<'_, 'e>) {
    o.push_str("U = ");
    if let Some(u) = &d.ingredients.potential {
        p(u, o);
    }
    o.push('\n');
    list_text(o, "∇U", &d.grad_u, p);
    forces_text(o, d);
    let _ = writeln!(o, "\nstructured form: {}", st.structured);
    let _ = writeln!(
        o,
        "equations (evaluated from A, α, Z, U and their exact derivatives):"
    );
    let _ = writeln!(
        o,
        "  [Z; α] q̇ = [η; 0]                        q̇ = Γη (6), Γ from [Z; α] at each state"
    );
    let applied = match d.forces.is_empty() {
        true => "Γᵀ∇U",
        false => "Γᵀ(∇U + F)",
    };
    let _ = writeln!(
        o,
        "  A_Γ η̇ = {applied} − Γᵀ (d/dt(AΓ)) η + ½ Γᵀ∇_q(q̇ᵀAq̇)   (9), A_Γ = ΓᵀAΓ (8)"
    );
    let _ = writeln!(o, "singular set: {}", d.singular_set_text());
    let c = &st.certificate;
    let at: Vec<String> = c.point.iter().map(|(k, v)| format!("{k} = {v}")).collect();
    let _ = writeln!(
        o,
        "certified (interval arithmetic): [Z; α] is nonsingular at {}, every pivot at least {:.3e} in magnitude; so δ = det[Z; α] is not identically zero and α has full rank μ = {}",
        at.join(", "),
        c.smallest_pivot,
        d.mu
    );
}

impl Derivation {
    /// The entries [`Derivation::to_text_with`] gives its printer, in that order (an entry as
    /// often as it is shown), without writing the text: what a printer that prints the
    /// entries together (hamel-print) reads first. The tests hold it to the text's order.
    pub fn shown(&self) -> Vec<&Entry> {
        // The runs of entries counted first, then gathered into one vector of the right size
        // (growing it copies it, and a large model shows thousands).
        let mut size = 0;
        self.shown_runs(&mut |run| size += run.len());
        let mut out = Vec::with_capacity(size);
        self.shown_runs(&mut |run| out.extend(run));
        out
    }

    /// [`Derivation::shown`]'s entries in runs (a matrix's rows, lists, single entries), each
    /// given to `f`, in order.
    fn shown_runs<'e>(&'e self, f: &mut impl FnMut(&'e [Entry])) {
        let rows = |m: &'e Mat, f: &mut dyn FnMut(&'e [Entry])| {
            m.entries.iter().for_each(|row| f(row));
        };
        rows(&self.a, f);
        rows(&self.alpha, f);
        for d in &self.dependent_rows {
            for t in &d.combination {
                f(std::slice::from_ref(&t.coefficient));
            }
        }
        rows(&self.z, f);
        match &self.form {
            Form::Closed(c) => {
                f(std::slice::from_ref(&c.delta));
                for m in [&c.gamma, &c.theta, &c.a_gamma] {
                    rows(m, f);
                }
                f(&c.forcing);
                rows(&c.nu, f);
                for i in 0..self.sigma {
                    for m in [&c.q[i], &c.q_paper[i], &c.q_correction[i]] {
                        rows(m, f);
                    }
                }
                for run in [&c.equations[..], &c.equations_paper, &c.kinematics] {
                    f(run);
                }
                f(std::slice::from_ref(&c.energy));
                f(c.power.as_slice());
            }
            Form::Structured(_) => {
                f(self.ingredients.potential.as_slice());
                f(&self.grad_u);
            }
        }
    }

    /// The derivation as plain text, entries in their canonical form.
    pub fn to_text(&self) -> String {
        self.to_text_with(&canonical)
    }

    /// The derivation as plain text, each entry written by `p`.
    pub fn to_text_with<'e>(&'e self, p: Printer<'_, 'e>) -> String {
        // Room for a small model's whole text (the unicycle's is 10 kB): growing from empty
        // copies it at every doubling.
        let mut o = String::with_capacity(16 * 1024);
        let _ = writeln!(o, "model {}: {}", self.model, self.title);
        let _ = writeln!(
            o,
            "coordinates q = ({})   ℓ = {}, μ = {}, σ = {}",
            self.coordinates.join(", "),
            self.ell,
            self.mu,
            self.sigma
        );
        let _ = writeln!(o, "quasi-velocities `{}`:", self.eta_name);
        for (i, e) in self.eta.iter().enumerate() {
            let _ = writeln!(o, "  eta{} = {}", i + 1, e);
        }
        if !self.free_functions.is_empty() {
            let _ = writeln!(o, "free functions: {}", self.free_functions.join(", "));
        }
        o.push('\n');
        mat_text(&mut o, "A (T = ½ q̇ᵀAq̇)", &self.a, p);
        mat_text(&mut o, "α (constraints α q̇ = 0)", &self.alpha, p);
        dependent_text(&mut o, self, p);
        mat_text(&mut o, "Z (η = Z q̇)", &self.z, p);
        match &self.form {
            Form::Closed(c) => closed_text(&mut o, self, c, p),
            Form::Structured(st) => structured_text(&mut o, self, st, p),
        }
        o
    }
}
