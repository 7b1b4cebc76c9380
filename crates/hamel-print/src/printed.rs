//! One expression in its printing form: a [`Sheet`] of one entry, without names.

use hamel_expr::Expr;

use crate::atoms::Vocabulary;
use crate::form::Form;
use crate::poly::PolyError;
use crate::sheet::Sheet;

/// An expression in its printing form, with the atoms it is written in.
#[derive(Clone, Debug)]
pub struct Printed {
    sheet: Sheet,
}

impl Printed {
    /// The printing form of the canonical expression `e`.
    ///
    /// # Errors
    /// An expression with no polynomial or rational form over its atoms (a non-integer power
    /// of a sum, a division by zero).
    pub fn new(e: &Expr, vocabulary: &Vocabulary) -> Result<Printed, PolyError> {
        let mut sheet = Sheet::new(vocabulary);
        sheet.add(e)?;
        Ok(Printed { sheet })
    }

    /// The form's tree.
    pub fn form(&self) -> &Form {
        self.sheet.form(0)
    }

    /// The form as an expression (for evaluation and checks).
    pub fn to_expr(&self) -> Expr {
        self.sheet.to_expr(0)
    }

    /// Whether the printed form expands to the canonical form it came from: exact.
    pub fn check(&self) -> bool {
        self.sheet.check(0)
    }

    /// The form in the model-file syntax (it parses back to the same function).
    pub fn text(&self) -> String {
        self.sheet.text(0)
    }

    /// The form in LaTeX.
    pub fn latex(&self) -> String {
        self.sheet.latex(0)
    }
}
