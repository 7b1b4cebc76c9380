//! A model written back as a file of the hand-typed form (`[lagrangian]` with the mass matrix,
//! `[constraints]`, `[holonomic]`): what `hamel expand` prints, so that a user sees what hamel
//! derived from the bodies, and can load it like any other model.

use toml_edit::{Array, DocumentMut, Item as TomlItem, Table, value};

use crate::loader::{Kinetic, Origin};
use crate::model::{ChoiceOrigin, Model};

impl Model {
    /// The model as an L/α model file: T as its mass matrix, U, the rows of α that are not
    /// holonomic in `[constraints]`, the holonomic constraints in `[holonomic]`, the generalised
    /// forces of the loads in `[forces]`, the parameters (derived ones as their expressions),
    /// the inputs, and the file's quasi-velocity choices. Loading it gives the same A, U, α
    /// and F.
    pub fn to_lagrangian_toml(&self) -> String {
        let mut doc = DocumentMut::new();
        doc["name"] = value(self.name.as_str());
        doc["title"] = value(self.title.as_str());
        if let Some(d) = &self.description {
            doc["description"] = value(d.as_str());
        }
        doc["coordinates"] = value(strings(self.coordinates.iter().map(String::as_str)));
        if !self.positive.is_empty() {
            doc["positive"] = value(strings(self.positive.iter().map(String::as_str)));
        }
        doc["parameters"] = TomlItem::Table(self.parameter_table());
        if !self.inputs.is_empty() {
            let mut t = Table::new();
            for k in &self.inputs {
                t[k] = value(self.parameters[k]);
            }
            doc["inputs"] = TomlItem::Table(t);
        }
        doc["lagrangian"] = TomlItem::Table(self.lagrangian_table());
        if self.has_forces() {
            let mut t = Table::new();
            for (q, f) in self.coordinates.iter().zip(&self.forces) {
                if f.expr != hamel_expr::Expr::int(0) {
                    t[q] = value(f.expr.to_string());
                }
            }
            doc["forces"] = TomlItem::Table(t);
        }
        let constraints = self.row_table();
        if !constraints.is_empty() {
            doc["constraints"] = TomlItem::Table(constraints);
        }
        if !self.holonomic.is_empty() {
            doc["holonomic"] = TomlItem::Table(self.holonomic_table());
        }
        let choices = self.choice_table();
        if !choices.is_empty() {
            doc["quasi_velocities"] = TomlItem::Table(choices);
        }
        if !self.symmetries.is_empty() {
            doc["symmetries"] = TomlItem::Table(self.symmetry_table());
        }
        if !self.steady.is_empty() {
            doc["steady"] = TomlItem::Table(self.steady_table());
        }
        if !self.abbreviations.is_empty() {
            let mut t = Table::new();
            for (k, item) in &self.abbreviations {
                t[k] = value(item.text.as_str());
            }
            doc["abbreviations"] = TomlItem::Table(t);
        }
        format!("{}{doc}", self.header())
    }

    fn header(&self) -> String {
        let from = match self.origin {
            Origin::Bodies => "from its bodies, frames and contacts",
            Origin::Lagrangian => "as typed",
        };
        let mut h = format!(
            "# {}: L = T + U and α {from}, written out by `hamel expand`.\n",
            self.file
        );
        for n in &self.notes {
            h += &format!("# note: {n}\n");
        }
        if !self.dependent.is_empty() {
            let manifold = self.dependent.iter().filter(|d| d.only_on_manifold).count();
            h += &format!(
                "# note: the {} rows of α have rank {}{}; hamel keeps the others and drops the rows that depend on them:\n",
                self.mu() + self.dependent.len(),
                self.mu(),
                match manifold {
                    0 => String::new(),
                    n => format!(
                        " where the holonomic constraints hold (up to {} off them)",
                        self.mu() + n
                    ),
                }
            );
        }
        for d in &self.dependent {
            let on: Vec<&str> =
                d.on.iter()
                    .map(|&j| self.constraints[j].0.as_str())
                    .collect();
            h += &format!(
                "#   {} depends on {}{} (at sample configurations; `hamel derive` writes the exact dependence)\n",
                d.name,
                if on.is_empty() {
                    "nothing: it is zero".to_string()
                } else {
                    on.join(", ")
                },
                if d.only_on_manifold {
                    " only where the holonomic constraints hold"
                } else {
                    ""
                }
            );
        }
        h
    }

    fn parameter_table(&self) -> Table {
        let mut t = Table::new();
        for (k, v) in self
            .parameters
            .iter()
            .filter(|(k, _)| !self.inputs.contains(k))
        {
            match self.derived.get(k) {
                Some(item) => t[k] = value(item.text.as_str()),
                None => t[k] = value(*v),
            }
        }
        t
    }

    fn lagrangian_table(&self) -> Table {
        let mut t = Table::new();
        match &self.kinetic {
            Kinetic::Energy(item) => t["kinetic"] = value(item.expr.to_string()),
            Kinetic::MassMatrix(rows) => {
                let mut m = Array::new();
                for row in rows {
                    let mut r = strings(row.iter().map(|i| i.expr.to_string()));
                    r.decor_mut().set_prefix("\n  ");
                    m.push_formatted(r.into());
                }
                m.set_trailing("\n");
                t["mass_matrix"] = value(m);
            }
        }
        t["potential"] = value(self.potential.expr.to_string());
        t
    }

    /// The rows of α that are not the velocity rows of holonomic constraints, the dependent
    /// ones among them in the model's order.
    fn row_table(&self) -> Table {
        let mut t = Table::new();
        for (name, item, _) in self.all_rows() {
            if !self.holonomic.iter().any(|h| h.name == name) {
                t[name] = value(item.expr.to_string());
            }
        }
        t
    }

    fn holonomic_table(&self) -> Table {
        let mut t = Table::new();
        t.set_implicit(true);
        for h in &self.holonomic {
            let mut c = Table::new();
            c["h"] = value(h.h.to_string());
            c["dependent"] = value(h.dependent.as_str());
            t[h.name.as_str()] = TomlItem::Table(c);
        }
        t
    }

    fn symmetry_table(&self) -> Table {
        let mut t = Table::new();
        t.set_implicit(true);
        for s in &self.symmetries {
            let mut st = Table::new();
            for (q, e) in &s.components {
                st[q.as_str()] = value(e.expr.to_string());
            }
            t[s.name.as_str()] = TomlItem::Table(st);
        }
        t
    }

    fn steady_table(&self) -> Table {
        let mut t = Table::new();
        t.set_implicit(true);
        for s in &self.steady {
            let mut st = Table::new();
            if let Some(d) = &s.description {
                st["description"] = value(d.as_str());
            }
            let mut p = toml_edit::InlineTable::new();
            for (k, v) in &s.parameters {
                p.insert(k, (*v).into());
            }
            st["parameters"] = value(p);
            for (key, items) in [("q", &s.q), ("velocities", &s.velocities)] {
                let mut it = toml_edit::InlineTable::new();
                for (k, item) in items.iter() {
                    it.insert(&self.coordinates[*k], item.text.as_str().into());
                }
                st[key] = value(it);
            }
            t[s.name.as_str()] = TomlItem::Table(st);
        }
        t
    }

    fn choice_table(&self) -> Table {
        let mut t = Table::new();
        t.set_implicit(true);
        for c in self
            .choices
            .iter()
            .filter(|c| c.origin == ChoiceOrigin::File)
        {
            let mut ct = Table::new();
            ct["eta"] = value(strings(c.eta.iter().map(|i| i.text.clone())));
            if let Some(d) = &c.description {
                ct["description"] = value(d.as_str());
            }
            t[c.name.as_str()] = TomlItem::Table(ct);
        }
        t
    }
}

fn strings<S: Into<String>>(items: impl Iterator<Item = S>) -> Array {
    let mut a = Array::new();
    for s in items {
        a.push(s.into());
    }
    a
}
