//! One printing of a report: the entries its text shows, in one sheet, named and checked.

use std::cell::RefCell;
use std::collections::{BTreeSet, hash_map};

use foldhash::{HashMap, HashSet};
use std::fmt::Write;

use hamel_derive::{Entry, Printer};
use hamel_expr::Expr;

use crate::atoms::Vocabulary;
use crate::poly::PolyError;
use crate::read::Source;
use crate::sheet::Sheet;

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

/// What the model gives printing besides the entries: its abbreviations, the parameters it
/// declares positive, and which entries are equations (rows set to zero).
#[derive(Clone, Copy, Default)]
pub(crate) struct Given<'a> {
    pub(crate) abbreviations: &'a [(&'a str, &'a Expr)],
    pub(crate) positive: &'a [String],
    pub(crate) equations: &'a [&'a Entry],
}

/// One printing: every entry a report's text shows (a derivation's, a reduction's) in one
/// sheet, named once, each checked exactly; the text, the JSON and the LaTeX document are
/// written from it, so they use the same names.
pub(crate) struct Printing {
    pub(crate) sheet: Sheet,
    ids: HashMap<usize, usize>,
}

impl Printing {
    /// The entries that `show` writes (with the printer it is given), printed in one sheet
    /// with the model's `abbreviations`, named and checked; the `equations` among them (rows
    /// set to zero) multiplied through by their denominators where a sign is proved from the
    /// parameters declared `positive`.
    ///
    /// # Errors
    /// [`PrintError`]: an entry that cannot be printed exactly.
    pub(crate) fn of<'e>(
        vocabulary: &Vocabulary,
        model: Given<'_>,
        show: &dyn Fn(Printer<'_, 'e>) -> String,
    ) -> Result<Printing, PrintError> {
        // The entries shown, in order (by address: the printer is called with references into
        // the data shown).
        let shown: RefCell<Vec<&'e Entry>> = RefCell::new(Vec::new());
        show(&|e: &'e Entry, _| shown.borrow_mut().push(e));
        Printing::of_shown(vocabulary.clone(), model, shown.into_inner())
    }

    /// [`Printing::of`] for the entries `shown`, in the order shown (an entry as often as it
    /// is shown).
    ///
    /// # Errors
    /// [`PrintError`]: an entry that cannot be printed exactly.
    pub(crate) fn of_shown(
        vocabulary: Vocabulary,
        model: Given<'_>,
        shown: Vec<&Entry>,
    ) -> Result<Printing, PrintError> {
        let mut sheet = Sheet::of(vocabulary);
        for (name, e) in model.abbreviations {
            sheet.abbreviate(name, e)?;
        }
        // Equal entries (the same canonical text, both equations or neither) are printed
        // once, and counted as often as they are shown.
        let equation: HashSet<usize> = model.equations.iter().map(|e| address(e)).collect();
        let mut ids = HashMap::default();
        ids.reserve(shown.len());
        let mut by_text: HashMap<(&str, bool), usize> = HashMap::default();
        by_text.reserve(shown.len());
        let mut labels = Vec::with_capacity(shown.len());
        let mut exprs: Vec<(Source<'_>, usize)> = Vec::with_capacity(shown.len());
        for e in shown {
            let hash_map::Entry::Vacant(v) = ids.entry(address(e)) else {
                continue;
            };
            let key = (e.text.as_str(), equation.contains(&address(e)));
            let id = *by_text.entry(key).or_insert_with(|| {
                exprs.push((source(e), 0));
                labels.push(&e.text);
                exprs.len() - 1
            });
            exprs[id].1 += 1;
            v.insert(id);
        }
        sheet.add_counted(exprs)?;
        sheet.name_groups();
        let positive: BTreeSet<String> = model.positive.iter().cloned().collect();
        for e in model.equations {
            if let Some(&id) = ids.get(&address(e)) {
                sheet.multiply_through(id, &positive);
            }
        }
        if let Some(id) = sheet.first_mismatch() {
            return Err(PrintError::Mismatch(labels[id].clone()));
        }
        if !sheet.check_arguments() {
            return Err(PrintError::Mismatch("a named argument".into()));
        }
        Ok(Printing { sheet, ids })
    }

    /// `show`'s text with every entry in its printing form, and the where-list after it. An
    /// equation multiplied through is written whole, `num = 0   (multiplied by D > 0)`.
    pub(crate) fn text<'e>(&self, show: &dyn Fn(Printer<'_, 'e>) -> String) -> String {
        // Every entry of a large sheet written first, on printing's pool; an entry shown
        // twice (a symmetric matrix's, equal ones) is written once, and copied from where it
        // was kept.
        let ids: Vec<usize> = (0..self.sheet.entries.len()).collect();
        let ahead: Vec<RefCell<Option<String>>> = if self.sheet.parallel {
            crate::par::map_ref(&ids, true, |&id| {
                let mut text = String::new();
                self.write_entry(id, &mut text);
                text
            })
            .into_iter()
            .map(|t| RefCell::new(Some(t)))
            .collect()
        } else {
            Vec::new()
        };
        let kept: RefCell<Kept> = RefCell::new(Kept {
            text: String::with_capacity(1024),
            at: vec![None; ids.len()],
        });
        let mut out = show(&|e, out| {
            let id = self.id(e);
            let mut kept = kept.borrow_mut();
            if let Some(r) = kept.at[id].clone() {
                out.push_str(&kept.text[r]);
                return;
            }
            let start = out.len();
            match ahead.get(id).and_then(|t| t.borrow_mut().take()) {
                Some(text) => out.push_str(&text),
                None => self.write_entry(id, out),
            }
            if self.sheet.shown(id) > 1 {
                let from = kept.text.len();
                kept.text.push_str(&out[start..]);
                kept.at[id] = Some(from..kept.text.len());
            }
        });
        let used: Vec<usize> = self.used().into_iter().collect();
        if !used.is_empty() {
            out.push_str("\nwhere\n");
            let definitions = crate::par::map_ref(&used, self.sheet.parallel, |&j| {
                self.sheet.definition_text(j)
            });
            for (name, definition) in definitions {
                let _ = writeln!(out, "  {name} = {definition}");
            }
        }
        out
    }

    /// Entry `id` as the text writes it, appended to `out`: an equation multiplied through
    /// is written whole, `num = 0   (multiplied by D > 0)`.
    fn write_entry(&self, id: usize, out: &mut String) {
        self.sheet.write_text(id, out);
        if let Some(d) = self.sheet.multipliers.get(&id) {
            out.push_str(" = 0   (multiplied by ");
            self.sheet.write_form(d, out);
            out.push_str(" > 0)");
        }
    }

    /// The names the entries use (a model's abbreviation that none uses is left out).
    pub(crate) fn used(&self) -> BTreeSet<usize> {
        // Every entry of the sheet is one shown.
        let ids: Vec<usize> = (0..self.sheet.entries.len()).collect();
        self.sheet.names_used(&ids)
    }

    /// The sheet's id of an entry of the derivation.
    pub(crate) fn id(&self, e: &Entry) -> usize {
        self.ids[&address(e)]
    }
}

/// The texts of the entries shown more than once, each written once: entry ↦ its range.
struct Kept {
    text: String,
    at: Vec<Option<std::ops::Range<usize>>>,
}

/// What an entry is read from: the polynomials the computer algebra exported, when it kept
/// them, else its tree.
fn source(e: &Entry) -> Source<'_> {
    e.canonical
        .as_deref()
        .map_or(Source::Tree(&e.expr), Source::Canonical)
}

/// Where an entry lives: which of the derivation's entries it is.
fn address(e: &Entry) -> usize {
    std::ptr::from_ref(e) as usize
}
