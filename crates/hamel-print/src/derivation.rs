//! A derivation as a LaTeX document (`hamel derive --format latex`): A, α, Z, the kinematic
//! equations q̇ = Γη, A_Γ and the equations of motion, in one sheet with one where-list.

use std::cell::RefCell;
use std::collections::{BTreeMap, HashMap, hash_map};
use std::fmt::Write;

use hamel_derive::{Derivation, Entry, Printer};
use hamel_expr::Expr;

use crate::atoms::Vocabulary;
use crate::document;
use crate::poly::PolyError;
use crate::sheet::Sheet;

/// What `hamel derive --format latex` writes.
#[derive(Clone, Copy, Debug, Default)]
pub struct Options {
    /// The equation blocks alone, without the document around them.
    pub fragment: bool,
    /// One object alone (with the names it uses), instead of all of them.
    pub only: Option<Object>,
}

/// An object of the LaTeX document.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Object {
    /// The mass matrix A of T = ½q̇ᵀAq̇.
    A,
    /// The constraints α of αq̇ = 0.
    Alpha,
    /// The quasi-velocities' matrix Z of η = Zq̇.
    Z,
    /// The kinematic equations (6), q̇ = Γη.
    Kinematics,
    /// A_Γ = ΓᵀAΓ (8).
    AGamma,
    /// The equations of motion A_Γη̇ + Q − Γᵀ∇U = 0.
    Equations,
}

/// Why a derivation could not be printed.
#[derive(Debug, thiserror::Error)]
pub enum PrintError {
    /// An entry has no rational form over its atoms.
    #[error("{0}")]
    Poly(#[from] PolyError),
    /// A printed form is not its canonical form (a bug in printing; nothing is written).
    #[error("the printed form of {0} differs from its canonical form")]
    Mismatch(String),
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

/// One printing of a derivation: every entry its text shows in one sheet, named once, each
/// checked exactly; the text, the JSON and the LaTeX document are written from it, so they
/// use the same names.
pub(crate) struct Printing {
    pub(crate) sheet: Sheet,
    ids: HashMap<usize, usize>,
}

impl Printing {
    /// The entries of `d`'s text, printed and checked.
    ///
    /// # Errors
    /// [`PrintError`]: an entry that cannot be printed exactly.
    pub(crate) fn new(d: &Derivation) -> Result<Printing, PrintError> {
        let abbreviations: Vec<(&str, &Expr)> = d
            .abbreviations
            .iter()
            .map(|(k, e)| (k.as_str(), &e.expr))
            .collect();
        Printing::of(&vocabulary(d), &abbreviations, &|p| d.to_text_with(p))
    }

    /// The entries that `show` writes (with the printer it is given), printed in one sheet
    /// with the model's `abbreviations`, named and checked.
    ///
    /// # Errors
    /// [`PrintError`]: an entry that cannot be printed exactly.
    pub(crate) fn of(
        vocabulary: &Vocabulary,
        abbreviations: &[(&str, &Expr)],
        show: &dyn Fn(Printer<'_>) -> String,
    ) -> Result<Printing, PrintError> {
        // The entries shown, in order, each once (by address: the printer is called with
        // references into the data shown).
        let shown = RefCell::new(Vec::new());
        show(&|e| {
            shown
                .borrow_mut()
                .push((address(e), e.expr.clone(), e.text.clone()));
            String::new()
        });
        let mut sheet = Sheet::new(vocabulary);
        for (name, e) in abbreviations {
            sheet.abbreviate(name, e)?;
        }
        let mut ids = HashMap::new();
        let mut labels = Vec::new();
        let mut exprs = Vec::new();
        for (at, expr, label) in shown.into_inner() {
            if let hash_map::Entry::Vacant(v) = ids.entry(at) {
                v.insert(exprs.len());
                exprs.push(expr);
                labels.push(label);
            }
        }
        sheet.add_all(&exprs)?;
        sheet.name_groups();
        for (id, label) in labels.into_iter().enumerate() {
            if !sheet.check(id) {
                return Err(PrintError::Mismatch(label));
            }
        }
        if !sheet.check_arguments() {
            return Err(PrintError::Mismatch("a named argument".into()));
        }
        Ok(Printing { sheet, ids })
    }

    /// `show`'s text with every entry in its printing form, and the where-list after it.
    pub(crate) fn text(&self, show: &dyn Fn(Printer<'_>) -> String) -> String {
        let mut out = show(&|e| self.sheet.text(self.id(e)));
        let used = self.used();
        let defs = self.sheet.definitions_text();
        if !used.is_empty() {
            out.push_str("\nwhere\n");
            for (j, (name, definition)) in defs.into_iter().enumerate() {
                if used.contains(&j) {
                    let _ = writeln!(out, "  {name} = {definition}");
                }
            }
        }
        out
    }

    /// The names the entries use (a model's abbreviation that none uses is left out).
    pub(crate) fn used(&self) -> std::collections::BTreeSet<usize> {
        let ids: Vec<usize> = self.ids.values().copied().collect();
        self.sheet.names_used(&ids)
    }

    /// The sheet's id of an entry of the derivation.
    pub(crate) fn id(&self, e: &Entry) -> usize {
        self.ids[&address(e)]
    }
}

/// Where an entry lives: which of the derivation's entries it is.
fn address(e: &Entry) -> usize {
    std::ptr::from_ref(e) as usize
}

/// The derivation as LaTeX: a complete document (landscape A4, 1 cm margins) or, with
/// `fragment`, its equation blocks alone; the where-list holds the names they use (numbered
/// as in the text and the JSON).
///
/// # Errors
/// [`PrintError`]: an entry that cannot be printed exactly; nothing is returned then.
pub fn latex(d: &Derivation, options: Options) -> Result<String, PrintError> {
    let p = Printing::new(d)?;
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
    Ok(Printing::new(d)?.text(&|p| d.to_text_with(p)))
}

/// What `hamel derive --format json` adds to the derivation (whose entries stay canonical):
/// each entry's printed text, keyed by its canonical text, and the where-list.
#[derive(Clone, Debug, serde::Serialize)]
pub struct PrintedJson {
    /// The named groups, in order: name, arguments (none for a parameter group), definition.
    pub names: Vec<NameJson>,
    /// Canonical text ↦ printed text, for every entry of the text output.
    pub entries: BTreeMap<String, String>,
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
    let p = Printing::new(d)?;
    let entries = RefCell::new(BTreeMap::new());
    d.to_text_with(&|e| {
        let printed = p.sheet.text(p.id(e));
        entries.borrow_mut().insert(e.text.clone(), printed);
        String::new()
    });
    let used = p.used();
    let names = p
        .sheet
        .definitions()
        .iter()
        .zip(p.sheet.definitions_text())
        .enumerate()
        .filter(|(j, _)| used.contains(j))
        .map(|(_, (d, (_, definition)))| NameJson {
            name: d.name.clone(),
            args: d.args.clone(),
            definition,
        })
        .collect();
    Ok(PrintedJson {
        names,
        entries: entries.into_inner(),
    })
}
