//! Text reports of linearisations and sweeps (the JSON is their serde form).

use std::fmt::Write;

use crate::forms::{Polynomial, Symbolic};
use crate::{
    Crossing, CrossingKind, Linearisation, Stability, Structural, StructuralKind, Study, Sweep,
};

/// A matrix, one row per line, every entry to 15 significant digits.
fn matrix(name: &str, m: &[Vec<f64>]) -> String {
    let mut out = format!("{name} =\n");
    for row in m {
        let cells: Vec<String> = row.iter().map(|x| format!("{x:>22.15e}")).collect();
        let _ = writeln!(out, "  [{} ]", cells.join(" "));
    }
    out
}

fn complex(z: [f64; 2]) -> String {
    if z[1] == 0.0 {
        format!("{:.15e}", z[0])
    } else {
        format!(
            "{:.15e} {} {:.15e}i",
            z[0],
            if z[1] < 0.0 { "-" } else { "+" },
            z[1].abs()
        )
    }
}

impl Stability {
    /// A word for it.
    pub fn word(self) -> &'static str {
        match self {
            Stability::Asymptotic => "asymptotically stable",
            Stability::Marginal => "marginally stable (eigenvalues on the imaginary axis)",
            Stability::Unstable => "unstable",
        }
    }
}

fn structural(list: &[Structural]) -> String {
    let mut dropped = Vec::new();
    let mut family = Vec::new();
    let mut persistent = Vec::new();
    for s in list {
        match &s.kind {
            StructuralKind::DroppedCoordinate { coordinate } => dropped.push(coordinate.clone()),
            StructuralKind::SteadyFamily { parameter } => family.push(parameter.clone()),
            StructuralKind::Persistent => persistent.push(complex(s.eigenvalue)),
        }
    }
    let mut out = String::new();
    if !dropped.is_empty() {
        let _ = writeln!(
            out,
            "  {} from coordinates the equations are free of: {}",
            dropped.len(),
            dropped.join(", ")
        );
    }
    if !family.is_empty() {
        let _ = writeln!(
            out,
            "  {} along the steady family: ∂/∂{}",
            family.len(),
            family.join(", ∂/∂")
        );
    }
    if !persistent.is_empty() {
        let _ = writeln!(
            out,
            "  {} present all along the family (computed: {})",
            persistent.len(),
            persistent.join(", ")
        );
    }
    if out.is_empty() {
        out.push_str("  none\n");
    }
    out
}

impl Study {
    /// The linearisation at a point as text.
    pub fn linearisation_text(&self, l: &Linearisation) -> String {
        let mut out = format!(
            "Linearisation of `{}` about the steady motion `{}` (quasi-velocities `{}`) at {}\n",
            self.model.name,
            self.steady.name,
            self.eta_name,
            l.point.text()
        );
        let values = |m: &indexmap::IndexMap<String, f64>| {
            m.iter()
                .map(|(k, v)| format!("{k} = {v}"))
                .collect::<Vec<_>>()
                .join(", ")
        };
        let _ = writeln!(out, "  steady parameters: {}", values(&l.steady_parameters));
        let _ = writeln!(out, "  q: {}", values(&l.q));
        let _ = writeln!(out, "  q': {}", values(&l.q_dot));
        let eta: Vec<String> = self
            .eta
            .iter()
            .zip(&l.eta)
            .enumerate()
            .map(|(i, (e, v))| format!("eta{} = {e} = {v}", i + 1))
            .collect();
        let _ = writeln!(out, "  {}", eta.join(", "));
        let _ = writeln!(
            out,
            "  steady: {}; max |x'| = {:.1e}",
            l.steady_check.text(),
            l.residual
        );
        let dependent = self.dependent();
        if !dependent.is_empty() {
            let _ = writeln!(
                out,
                "  completed from the holonomic constraints: {}",
                dependent.join(", ")
            );
        }
        if !l.loads.is_empty() {
            let _ = writeln!(out, "  loads (constraint forces): {}", values(&l.loads));
        }
        let _ = writeln!(
            out,
            "State: {}\nReduced state (the steady family's directions taken out): {}",
            l.state.join(", "),
            l.reduced_state.join(", ")
        );
        match &l.second_order {
            Some(s) => {
                let _ = writeln!(
                    out,
                    "\nM q'' + C q' + K q = B u, q = ({}), q' = ({}), u = ({})",
                    s.q.join(", "),
                    s.speeds.join(", "),
                    l.inputs.join(", ")
                );
                for (name, m) in [("M", &s.m), ("C", &s.c), ("K", &s.k), ("B", &s.b)] {
                    out.push_str(&matrix(name, m));
                }
            }
            None => {
                let _ = writeln!(
                    out,
                    "\nx' = A x + B u, x = ({}), u = ({})",
                    l.reduced_state.join(", "),
                    l.inputs.join(", ")
                );
                out.push_str(&matrix("A", &l.a));
                out.push_str(&matrix("B", &l.b));
            }
        }
        out.push_str("\nEigenvalues:\n");
        for z in &l.eigenvalues {
            let _ = writeln!(out, "  {}", complex(*z));
        }
        out.push_str("Structural zero eigenvalues (reported apart):\n");
        out.push_str(&structural(&l.structural));
        let _ = writeln!(out, "Stability: {}", l.stability.word());
        out
    }

    /// A sweep as text.
    pub fn sweep_text(&self, base: &Linearisation, s: &Sweep) -> String {
        let mut out = format!(
            "Sweep of `{}` about the steady motion `{}` (quasi-velocities `{}`) over {}\n",
            self.model.name, self.steady.name, self.eta_name, s.parameter
        );
        let _ = writeln!(out, "Reduced state: {}", base.reduced_state.join(", "));
        out.push_str("Structural zero eigenvalues (reported apart):\n");
        out.push_str(&structural(&base.with_persistent_view(s.persistent_zeros)));
        let _ = writeln!(out, "\n{:>12}  eigenvalues (re ± im i)", s.parameter);
        for p in &s.points {
            // A complex pair once, as re ± im i.
            let z: Vec<String> = p
                .eigenvalues
                .iter()
                .filter(|z| z[1] >= 0.0)
                .map(|z| short(*z))
                .collect();
            let _ = writeln!(
                out,
                "{:>12.6}  {}   {}",
                p.value,
                z.join("  "),
                p.stability.word()
            );
        }
        out.push_str("\nCrossings:\n");
        if s.crossings.is_empty() {
            out.push_str("  none in the range\n");
        }
        for c in &s.crossings {
            out.push_str(&crossing(&s.parameter, c));
        }
        match (&s.matrices, &s.matrices_note) {
            (Some(m), _) => out.push_str(&symbolic(m, &base.inputs)),
            (None, Some(why)) => {
                let _ = writeln!(out, "\nMatrices: {why}");
            }
            (None, None) => {}
        }
        out
    }
}

impl Study {
    /// A map as text: the largest real part at each point, rows by the second parameter.
    pub fn map_text(&self, m: &crate::Map) -> String {
        let mut out = format!(
            "Stability map of `{}` about `{}`: largest real part of the eigenvalues ({} persistent zeros apart); rows {}, columns {}\n",
            self.model.name, self.steady.name, m.persistent_zeros, m.y.parameter, m.x.parameter
        );
        let xs: Vec<String> = m.x.values().iter().map(|x| format!("{x:>10.4}")).collect();
        let _ = writeln!(out, "{:>10}  {}", "", xs.join(" "));
        for (y, row) in m.y.values().iter().zip(&m.values) {
            let cells: Vec<String> = row.iter().map(|v| format!("{v:>10.3e}")).collect();
            let _ = writeln!(out, "{y:>10.4}  {}", cells.join(" "));
        }
        out
    }
}

impl Linearisation {
    /// The structural zeros as they are with `persistent` found along a sweep.
    fn with_persistent_view(&self, persistent: usize) -> Vec<Structural> {
        self.clone().with_persistent(persistent).structural
    }
}

fn short(z: [f64; 2]) -> String {
    if z[1] == 0.0 {
        format!("{:>10.6}", z[0])
    } else {
        format!("{:>10.6} ± {:.6}i", z[0], z[1].abs())
    }
}

fn crossing(p: &str, c: &Crossing) -> String {
    let what = match c.kind {
        CrossingKind::RealZero if c.zeros >= 2 => {
            "a real pair meets at zero and turns imaginary (det A = 0)".to_string()
        }
        CrossingKind::RealZero => "a real eigenvalue passes through zero (det A = 0)".to_string(),
        CrossingKind::Hopf => format!(
            "a complex pair crosses the imaginary axis at ±{:.12}i (Hopf)",
            c.eigenvalue[1].abs()
        ),
    };
    format!(
        "  {p} = {:.14}: {what}; {} below, {} above\n",
        c.value,
        c.below.word(),
        c.above.word()
    )
}

fn polynomial(name: &str, p: &Polynomial) -> String {
    let mut out = String::new();
    let terms: Vec<String> = p
        .coefficients
        .keys()
        .map(|k| match k {
            0 => format!("{name}0"),
            1 => format!("{} {name}1", p.parameter),
            k => format!("{}^{k} {name}{k}", p.parameter),
        })
        .collect();
    let _ = writeln!(
        out,
        "{name}({}) = {}",
        p.parameter,
        if terms.is_empty() {
            "0".into()
        } else {
            terms.join(" + ")
        }
    );
    for (k, m) in &p.coefficients {
        out.push_str(&matrix(&format!("{name}{k}"), m));
    }
    out
}

/// K(p) with its constant term as g K0 (+ Kr): the benchmark bicycle's g K0 + v² K2.
fn gravity_form(k: &Polynomial, g: &crate::forms::Gravity) -> String {
    let mut terms = vec![format!("{} K0", g.parameter)];
    if g.rest.is_some() {
        terms.push("Kr".into());
    }
    terms.extend(k.coefficients.keys().filter(|&&p| p > 0).map(|p| match p {
        1 => format!("{} K1", k.parameter),
        p => format!("{}^{p} K{p}", k.parameter),
    }));
    let mut out = format!(
        "K({}) = {}   ({} enters only through U, linearly)\n",
        k.parameter,
        terms.join(" + "),
        g.parameter
    );
    out.push_str(&matrix("K0", &g.k0));
    if let Some(r) = &g.rest {
        out.push_str(&matrix("Kr", r));
    }
    for (p, m) in k.coefficients.iter().filter(|(p, _)| **p > 0) {
        out.push_str(&matrix(&format!("K{p}"), m));
    }
    out
}

fn symbolic(s: &Symbolic, inputs: &[String]) -> String {
    let mut out = format!(
        "\nThe linear equations in {} (exact polynomials, interpolated and checked):\n",
        s.parameter
    );
    match (&s.m, &s.c, &s.k) {
        (Some(m), Some(c), Some(k)) => {
            out.push_str(&matrix("M", m));
            out.push_str(&polynomial("C", c));
            match &s.gravity {
                Some(g) => out.push_str(&gravity_form(k, g)),
                None => out.push_str(&polynomial("K", k)),
            }
            if let Some(b) = &s.b_forces {
                out.push_str(&matrix(&format!("B (u = ({}))", inputs.join(", ")), b));
            }
        }
        _ => {
            out.push_str(&polynomial("A", &s.a));
            out.push_str(&matrix(&format!("B (u = ({}))", inputs.join(", ")), &s.b));
        }
    }
    out
}
