//! The printing form: a tree of sums, products and groups over the atoms, rendered as text
//! (the model-file syntax, so that it parses back) or LaTeX.

use hamel_expr::{Expr, Rational};
use num_traits::{One, Signed, Zero};

use crate::atoms::{Atoms, Kind, Vocabulary};
use crate::collect;
use crate::poly::{Fraction, PolyError};

/// A node of a printing form.
#[derive(Clone, Debug, PartialEq)]
pub enum Form {
    /// `coef · factors…` (factors in printing order).
    Product {
        /// The rational coefficient.
        coef: Rational,
        /// The factors.
        factors: Vec<Factor>,
    },
    /// A sum of terms.
    Sum(Vec<Form>),
    /// `num / den`.
    Quotient(Box<Form>, Box<Form>),
}

/// A factor of a product.
#[derive(Clone, Debug, PartialEq)]
pub enum Factor {
    /// Atom `index` to a power ≥ 1.
    Atom {
        /// The atom's index.
        index: usize,
        /// Its exponent.
        power: u32,
    },
    /// A sum in parentheses.
    Group(Form),
}

/// An expression in its printing form, with the atoms it is written in.
#[derive(Clone, Debug)]
pub struct Printed {
    form: Form,
    atoms: Atoms,
    canonical: Fraction,
}

impl Printed {
    /// The printing form of the canonical expression `e`.
    ///
    /// # Errors
    /// An expression with no polynomial or rational form over its atoms (a non-integer power
    /// of a sum, a division by zero).
    pub fn new(e: &Expr, vocabulary: &Vocabulary) -> Result<Printed, PolyError> {
        let mut atoms = Atoms::new(vocabulary.clone());
        let canonical = Fraction::from_expr(e, &mut atoms)?.normalised();
        let form = collect::fraction(&canonical, &atoms);
        Ok(Printed {
            form,
            atoms,
            canonical,
        })
    }

    /// The form's tree.
    pub fn form(&self) -> &Form {
        &self.form
    }

    /// The form as an expression (for evaluation and checks).
    pub fn to_expr(&self) -> Expr {
        to_expr(&self.form, &self.atoms)
    }

    /// Whether the printed form expands to the canonical form it came from: exact.
    pub fn check(&self) -> bool {
        let mut atoms = self.atoms.clone();
        Fraction::from_expr(&self.to_expr(), &mut atoms).is_ok_and(|f| f.same(&self.canonical))
    }

    /// The form in the model-file syntax (it parses back to the same function).
    pub fn text(&self) -> String {
        render(&self.form, &self.atoms, &Text)
    }

    /// The form in LaTeX.
    pub fn latex(&self) -> String {
        render(&self.form, &self.atoms, &Latex)
    }
}

fn to_expr(f: &Form, atoms: &Atoms) -> Expr {
    match f {
        Form::Product { coef, factors } => {
            let mut v = vec![Expr::Num(coef.clone())];
            v.extend(factors.iter().map(|x| match x {
                Factor::Atom { index, power } => power_of(atoms, *index, *power),
                Factor::Group(g) => to_expr(g, atoms),
            }));
            Expr::Mul(v)
        }
        Form::Sum(v) => Expr::Add(v.iter().map(|t| to_expr(t, atoms)).collect()),
        Form::Quotient(a, b) => Expr::Div(Box::new(to_expr(a, atoms)), Box::new(to_expr(b, atoms))),
    }
}

fn power_of(atoms: &Atoms, index: usize, power: u32) -> Expr {
    let e = atoms.get(index).expr.clone();
    if power == 1 {
        e
    } else {
        Expr::powi(e, i64::from(power))
    }
}

/// How a syntax writes the pieces.
trait Syntax {
    fn rational(&self, r: &Rational) -> String;
    fn atom(&self, e: &Expr) -> String;
    fn times(&self) -> &'static str;
    fn group(&self, inner: &str) -> String;
    fn quotient(&self, num: &str, den: &str) -> String;
}

struct Text;
struct Latex;

impl Syntax for Text {
    fn rational(&self, r: &Rational) -> String {
        r.to_string()
    }
    fn atom(&self, e: &Expr) -> String {
        match e {
            Expr::Sym(_) | Expr::Der(_) | Expr::Call(..) | Expr::Free { .. } => e.to_string(),
            Expr::Pow(b, n) if matches!(**b, Expr::Sym(_) | Expr::Der(_) | Expr::Call(..)) => {
                format!("{b}^{n}")
            }
            _ => format!("({e})"),
        }
    }
    fn times(&self) -> &'static str {
        "*"
    }
    fn group(&self, inner: &str) -> String {
        format!("({inner})")
    }
    fn quotient(&self, num: &str, den: &str) -> String {
        format!("({num})/({den})")
    }
}

impl Syntax for Latex {
    fn rational(&self, r: &Rational) -> String {
        if r.is_integer() {
            r.to_string()
        } else {
            format!("\\tfrac{{{}}}{{{}}}", r.numer(), r.denom())
        }
    }
    fn atom(&self, e: &Expr) -> String {
        e.to_latex()
    }
    fn times(&self) -> &'static str {
        " "
    }
    fn group(&self, inner: &str) -> String {
        format!("\\left({inner}\\right)")
    }
    fn quotient(&self, num: &str, den: &str) -> String {
        format!("\\frac{{{num}}}{{{den}}}")
    }
}

fn render(f: &Form, atoms: &Atoms, s: &dyn Syntax) -> String {
    match f {
        Form::Sum(terms) => {
            let mut out = String::new();
            for (i, t) in terms.iter().enumerate() {
                let (negative, body) = unsigned(t, atoms, s);
                out.push_str(match (i, negative) {
                    (0, true) => "-",
                    (0, false) => "",
                    (_, true) => " - ",
                    (_, false) => " + ",
                });
                out.push_str(&body);
            }
            out
        }
        _ => {
            let (negative, body) = unsigned(f, atoms, s);
            if negative { format!("-{body}") } else { body }
        }
    }
}

/// A term's sign and the text of its magnitude: a negated product is written `- a b`, never
/// `-(a b)`.
fn unsigned(f: &Form, atoms: &Atoms, s: &dyn Syntax) -> (bool, String) {
    match f {
        Form::Product { coef, factors } => {
            let mut parts: Vec<String> = Vec::new();
            let magnitude = coef.abs();
            if !magnitude.is_one() || factors.is_empty() {
                parts.push(s.rational(&magnitude));
            }
            for x in factors {
                parts.push(match x {
                    Factor::Atom { index, power } => s.atom(&power_of(atoms, *index, *power)),
                    Factor::Group(g) => s.group(&render(g, atoms, s)),
                });
            }
            (coef.is_negative(), parts.join(s.times()))
        }
        Form::Sum(_) => (false, s.group(&render(f, atoms, s))),
        Form::Quotient(a, b) => (
            false,
            s.quotient(&render(a, atoms, s), &render(b, atoms, s)),
        ),
    }
}

/// The kind order used to place factors: parameters, groups, then the state's atoms.
pub(crate) fn factor_rank(x: &Factor, atoms: &Atoms) -> (u8, Kind, usize, String) {
    match x {
        Factor::Atom { index, .. } => {
            let (kind, pos, key) = atoms.order(*index);
            let rank = if kind == Kind::Parameter { 0 } else { 2 };
            (rank, kind, pos, key.to_string())
        }
        Factor::Group(_) => (1, Kind::Parameter, 0, String::new()),
    }
}

/// Whether a form is the constant zero.
pub(crate) fn is_zero(f: &Form) -> bool {
    matches!(f, Form::Product { coef, .. } if coef.is_zero())
}
