//! The printing form: a tree of sums, products and groups over the atoms, rendered as text
//! (the model-file syntax, so that it parses back) or LaTeX.

use std::collections::BTreeMap;
use std::hash::{Hash, Hasher};

use hamel_expr::{Expr, Rational};
use num_traits::{One, Signed, Zero};

use crate::atoms::{Atoms, Kind};

/// A node of a printing form.
#[derive(Clone, Debug, PartialEq, Eq)]
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

/// Hashed by the coefficients' numerators and denominators (a rational is always kept in
/// lowest terms with a positive denominator, so equal values hash alike), not by
/// `Ratio`'s own hash, which divides to stay consistent with unreduced ratios: forms are
/// hashed by the thousand when recurring groups are counted.
impl Hash for Form {
    fn hash<H: Hasher>(&self, h: &mut H) {
        std::mem::discriminant(self).hash(h);
        match self {
            Form::Product { coef, factors } => {
                coef.numer().hash(h);
                coef.denom().hash(h);
                factors.hash(h);
            }
            Form::Sum(terms) => terms.hash(h),
            Form::Quotient(a, b) => {
                a.hash(h);
                b.hash(h);
            }
        }
    }
}

/// A factor of a product.
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
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
    /// A named group: definition `index` of the sheet's where-list.
    Name {
        /// The definition's index.
        index: usize,
    },
}

/// A named group of the where-list: `κ₁ = m_d R + …` (parameters only) or
/// `F₁(θ, θ₁) = κ₁ sin θ + …` (a function of coordinates).
#[derive(Clone, Debug, PartialEq)]
pub struct Definition {
    /// The name in text (`kappa1`, `F1`).
    pub name: String,
    /// The coordinates it depends on (empty for a parameter group).
    pub args: Vec<String>,
    /// Its printing form (in earlier names).
    pub form: Form,
    /// Whether the model gave it (`[abbreviations]`), rather than printing named it.
    pub given: bool,
}

/// What rendering needs besides the form: the atoms and the where-list.
#[derive(Clone, Copy)]
pub(crate) struct Ctx<'a> {
    pub(crate) atoms: &'a Atoms,
    pub(crate) names: &'a [Definition],
    /// Atoms printed with their argument by name (atom ↦ name): `\sqrt{F_7(θ)}`.
    pub(crate) arguments: &'a BTreeMap<usize, usize>,
}

/// The form as an expression, names expanded.
pub(crate) fn to_expr(f: &Form, ctx: Ctx<'_>) -> Expr {
    match f {
        Form::Product { coef, factors } => {
            let mut v = vec![Expr::Num(coef.clone())];
            v.extend(factors.iter().map(|x| match x {
                Factor::Atom { index, power } => power_of(ctx.atoms, *index, *power),
                Factor::Group(g) => to_expr(g, ctx),
                Factor::Name { index } => to_expr(&ctx.names[*index].form, ctx),
            }));
            Expr::Mul(v)
        }
        Form::Sum(v) => Expr::Add(v.iter().map(|t| to_expr(t, ctx)).collect()),
        Form::Quotient(a, b) => Expr::Div(Box::new(to_expr(a, ctx)), Box::new(to_expr(b, ctx))),
    }
}

/// Atom `index` to `power`, its argument by name where the sheet named it.
fn atom(ctx: Ctx<'_>, index: usize, power: u32, s: &dyn Syntax) -> String {
    let e = power_of(ctx.atoms, index, power);
    let Some(&name) = ctx.arguments.get(&index) else {
        return s.atom(&e);
    };
    let mark = Expr::Sym(ARGUMENT.to_string());
    let marked = with_argument(&ctx.atoms.get(index).expr, mark.clone());
    let marked = if power == 1 {
        marked
    } else {
        Expr::powi(marked, i64::from(power))
    };
    s.atom(&marked)
        .replace(&s.atom(&mark), &s.name(&ctx.names[name]))
}

/// A symbol no model uses, standing for a named argument while an atom is rendered.
const ARGUMENT: &str = "hamelNamedArgument";

/// The argument of a function or of a power with a non-integer exponent (what
/// [`crate::Sheet::name_wide`] names), if `e` is one.
pub(crate) fn argument(e: &Expr) -> Option<&Expr> {
    match e {
        Expr::Call(_, a) => Some(a),
        Expr::Pow(b, n) if n.as_integer().is_none() => Some(b),
        _ => None,
    }
}

/// `e` with its argument replaced by `by`.
fn with_argument(e: &Expr, by: Expr) -> Expr {
    match e {
        Expr::Call(f, _) => Expr::Call(*f, Box::new(by)),
        Expr::Pow(_, n) => Expr::Pow(Box::new(by), n.clone()),
        other => other.clone(),
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
pub(crate) trait Syntax {
    fn rational(&self, r: &Rational) -> String;
    fn atom(&self, e: &Expr) -> String;
    fn times(&self) -> &'static str;
    fn group(&self, inner: &str) -> String;
    /// `num / den`; `bare` says which of them reads unambiguously without parentheses.
    fn quotient(&self, num: &str, den: &str, bare: (bool, bool)) -> String;
    fn name(&self, d: &Definition) -> String;
}

pub(crate) struct Text;
pub(crate) struct Latex;

impl Syntax for Text {
    fn rational(&self, r: &Rational) -> String {
        r.to_string()
    }
    fn atom(&self, e: &Expr) -> String {
        match e {
            Expr::Sym(_) | Expr::Der(_) | Expr::Call(..) | Expr::Free { .. } => e.to_string(),
            Expr::Pow(b, n)
                if matches!(
                    **b,
                    Expr::Sym(_) | Expr::Der(_) | Expr::Call(..) | Expr::Free { .. }
                ) =>
            {
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
    fn quotient(&self, num: &str, den: &str, (num_bare, den_bare): (bool, bool)) -> String {
        let num = if num_bare {
            num.to_string()
        } else {
            format!("({num})")
        };
        let den = if den_bare {
            den.to_string()
        } else {
            format!("({den})")
        };
        format!("{num}/{den}")
    }
    fn name(&self, d: &Definition) -> String {
        if d.args.is_empty() {
            d.name.clone()
        } else {
            format!("{}({})", d.name, d.args.join(", "))
        }
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
    fn quotient(&self, num: &str, den: &str, _: (bool, bool)) -> String {
        format!("\\frac{{{num}}}{{{den}}}")
    }
    fn name(&self, d: &Definition) -> String {
        let name = hamel_expr::latex_name(&d.name);
        if d.args.is_empty() {
            name
        } else {
            let args: Vec<String> = d.args.iter().map(|a| hamel_expr::latex_name(a)).collect();
            format!("{name}({})", args.join(", "))
        }
    }
}

/// The terms of a sum as signed pieces: the first `-t` or `t`, the others ` - t` or ` + t`.
pub(crate) fn render_terms(terms: &[Form], ctx: Ctx<'_>) -> Vec<String> {
    signed_terms(terms, ctx, &Latex)
}

fn signed_terms(terms: &[Form], ctx: Ctx<'_>, s: &dyn Syntax) -> Vec<String> {
    terms
        .iter()
        .enumerate()
        .map(|(i, t)| {
            let (negative, body) = unsigned(t, ctx, s);
            let sign = match (i, negative) {
                (0, true) => "-",
                (0, false) => "",
                (_, true) => " - ",
                (_, false) => " + ",
            };
            format!("{sign}{body}")
        })
        .collect()
}

/// A form's sign and magnitude in LaTeX.
pub(crate) fn unsigned_latex(f: &Form, ctx: Ctx<'_>) -> (bool, String) {
    unsigned(f, ctx, &Latex)
}

impl Latex {
    /// An opening parenthesis that may close on a later line.
    pub(crate) fn open(&self) -> &'static str {
        "\\left("
    }

    /// Its closing.
    pub(crate) fn close(&self) -> String {
        "\\right)".to_string()
    }
}

pub(crate) fn render(f: &Form, ctx: Ctx<'_>, s: &dyn Syntax) -> String {
    match f {
        Form::Sum(terms) => signed_terms(terms, ctx, s).concat(),
        _ => {
            let (negative, body) = unsigned(f, ctx, s);
            if negative { format!("-{body}") } else { body }
        }
    }
}

/// A term's sign and the text of its magnitude: a negated product is written `- a b`, never
/// `-(a b)`.
fn unsigned(f: &Form, ctx: Ctx<'_>, s: &dyn Syntax) -> (bool, String) {
    match f {
        Form::Product { coef, factors } => {
            let mut parts: Vec<String> = Vec::new();
            let magnitude = coef.abs();
            if !magnitude.is_one() || factors.is_empty() {
                parts.push(s.rational(&magnitude));
            }
            for x in factors {
                parts.push(match x {
                    Factor::Atom { index, power } => atom(ctx, *index, *power, s),
                    Factor::Group(g) => s.group(&render(g, ctx, s)),
                    Factor::Name { index } => s.name(&ctx.names[*index]),
                });
            }
            (coef.is_negative(), parts.join(s.times()))
        }
        Form::Sum(_) => (false, s.group(&render(f, ctx, s))),
        Form::Quotient(a, b) => {
            let bare = (bare_numerator(a), bare_denominator(b));
            (
                false,
                s.quotient(&render(a, ctx, s), &render(b, ctx, s), bare),
            )
        }
    }
}

/// A numerator that needs no parentheses before `/`: a product with a positive coefficient
/// (`a*b/c` reads as `(a*b)/c`).
fn bare_numerator(f: &Form) -> bool {
    matches!(f, Form::Product { coef, .. } if coef.is_positive())
}

/// A denominator that needs no parentheses after `/`: one atom or name, or a positive integer.
fn bare_denominator(f: &Form) -> bool {
    match f {
        Form::Product { coef, factors } if factors.is_empty() => {
            coef.is_integer() && coef.is_positive()
        }
        Form::Product { coef, factors } => {
            coef.is_one()
                && matches!(
                    factors.as_slice(),
                    [Factor::Atom { .. } | Factor::Name { .. }]
                )
        }
        _ => false,
    }
}

/// The kind order used to place factors: parameters, groups, then the state's atoms.
pub(crate) fn factor_rank<'a>(x: &Factor, atoms: &'a Atoms) -> (u8, Kind, usize, &'a str) {
    match x {
        Factor::Atom { index, .. } => {
            let (kind, pos, key) = atoms.order(*index);
            let rank = if kind == Kind::Parameter { 0 } else { 2 };
            (rank, kind, pos, key)
        }
        Factor::Group(_) | Factor::Name { .. } => (1, Kind::Parameter, 0, ""),
    }
}

/// Whether a form is the constant zero.
pub(crate) fn is_zero(f: &Form) -> bool {
    matches!(f, Form::Product { coef, .. } if coef.is_zero())
}
