//! A derivation printed: `hamel derive`'s text, the `printed` part of its JSON, and its LaTeX
//! document (A, α, Z, the kinematic equations q̇ = Γη, A_Γ and the equations of motion), all
//! from one printing, so they use the same names.

use std::cell::RefCell;
use std::collections::BTreeMap;
use std::fmt::Write;

use hamel_derive::Derivation;
use hamel_expr::Expr;

use crate::atoms::Vocabulary;
use crate::document;
pub use crate::document::Object;
pub use crate::printing::PrintError;
use crate::printing::{Given, Printing};

/// What `hamel derive --format latex` writes.
#[derive(Clone, Copy, Debug, Default)]
pub struct Options {
    /// The equation blocks alone, without the document around them.
    pub fragment: bool,
    /// One object alone (with the names it uses), instead of all of them.
    pub only: Option<Object>,
}

/// The names a derivation's expressions are written in.
pub fn vocabulary(d: &Derivation) -> Vocabulary {
    Vocabulary {
        parameters: d.parameters.keys().cloned().collect(),
        coordinates: d.coordinates.clone(),
        velocities: (1..=d.sigma)
            .flat_map(|i| [format!("eta{i}"), format!("eta{i}_dot")])
            .collect(),
    }
}

/// The entries of `d`'s text, printed and checked.
///
/// # Errors
/// [`PrintError`]: an entry that cannot be printed exactly.
fn printing(d: &Derivation) -> Result<Printing, PrintError> {
    let abbreviations: Vec<(&str, &Expr)> = d
        .abbreviations
        .iter()
        .map(|(k, e)| (k.as_str(), &e.expr))
        .collect();
    let equations: Vec<&hamel_derive::Entry> = match &d.form {
        hamel_derive::Form::Closed(c) => c.equations.iter().chain(&c.equations_paper).collect(),
        hamel_derive::Form::Structured(_) => Vec::new(),
    };
    let given = Given {
        abbreviations: &abbreviations,
        positive: &d.positive,
        equations: &equations,
    };
    Printing::of_shown(vocabulary(d), given, d.shown())
}

/// The derivation as LaTeX: a complete document (landscape A4, 1 cm margins) or, with
/// `fragment`, its equation blocks alone; the where-list holds the names they use (numbered
/// as in the text and the JSON).
///
/// # Errors
/// [`PrintError`]: an entry that cannot be printed exactly; nothing is returned then.
pub fn latex(d: &Derivation, options: Options) -> Result<String, PrintError> {
    let p = printing(d)?;
    let blocks: Vec<document::Block> = document::blocks(d, &p)
        .into_iter()
        .filter(|(object, _)| options.only.is_none_or(|o| o == *object))
        .map(|(_, b)| b)
        .collect();
    let shown: Vec<usize> = blocks.iter().flat_map(|b| b.ids()).collect();
    let used = p.sheet.names_used(&shown);
    let mut body = String::new();
    let _ = writeln!(
        body,
        "% hamel derive: model {}, quasi-velocities {}",
        d.model, d.eta_name
    );
    for b in &blocks {
        b.write(&p.sheet, &mut body);
    }
    document::where_list(&p.sheet, &used, &mut body);
    Ok(if options.fragment {
        body
    } else {
        document::document(d, &body)
    })
}

/// The derivation as plain text (`hamel derive`'s default output), every entry in its
/// printing form, the where-list at the end, in the model syntax (each entry and definition
/// parses back).
///
/// # Errors
/// [`PrintError`]: an entry that cannot be printed exactly; nothing is returned then.
pub fn text(d: &Derivation) -> Result<String, PrintError> {
    Ok(printing(d)?.text(&|p| d.to_text_with(p)))
}

/// What `hamel derive --format json` adds to the derivation (whose entries stay canonical):
/// each entry's printed text, keyed by its canonical text, and the where-list.
#[derive(Clone, Debug, serde::Serialize)]
pub struct PrintedJson {
    /// The named groups, in order: name, arguments (none for a parameter group), definition.
    pub names: Vec<NameJson>,
    /// Canonical text ↦ printed text, for every entry of the text output.
    pub entries: BTreeMap<String, String>,
    /// Canonical text of an equation ↦ the positive denominator it was multiplied through
    /// by: its printed text is that multiple of the canonical row.
    #[serde(skip_serializing_if = "BTreeMap::is_empty")]
    pub multiplied_by: BTreeMap<String, String>,
}

/// One name of the where-list.
#[derive(Clone, Debug, serde::Serialize)]
pub struct NameJson {
    /// `kappa1`, `F2`.
    pub name: String,
    /// The coordinates a function depends on.
    pub args: Vec<String>,
    /// Its definition, in the model syntax.
    pub definition: String,
}

/// The printed forms for `hamel derive --format json`, with the text's names.
///
/// # Errors
/// [`PrintError`]: an entry that cannot be printed exactly.
pub fn json(d: &Derivation) -> Result<PrintedJson, PrintError> {
    let p = printing(d)?;
    let entries = RefCell::new(BTreeMap::new());
    let multiplied_by = RefCell::new(BTreeMap::new());
    d.to_text_with(&|e, _| {
        let id = p.id(e);
        entries
            .borrow_mut()
            .insert(e.text.clone(), p.sheet.text(id));
        if let Some(m) = p.sheet.multiplier_text(id) {
            multiplied_by.borrow_mut().insert(e.text.clone(), m);
        }
    });
    let used = p.used();
    let names = used
        .into_iter()
        .map(|j| {
            let d = &p.sheet.definitions()[j];
            NameJson {
                name: d.name.clone(),
                args: d.args.clone(),
                definition: p.sheet.definition_text(j).1,
            }
        })
        .collect();
    Ok(PrintedJson {
        names,
        entries: entries.into_inner(),
        multiplied_by: multiplied_by.into_inner(),
    })
}
