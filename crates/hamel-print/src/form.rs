//! The printing form: a tree of sums, products and groups over the atoms, rendered as text
//! (the model-file syntax, so that it parses back) or LaTeX.

use std::collections::BTreeMap;
use std::fmt::Write;
use std::sync::Arc;

use hamel_expr::{Expr, Func};

use crate::atoms::{Atom, Atoms, Kind, simple, text_of};
use crate::q::Q;

/// A node of a printing form.
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub enum Form {
    /// `coef · factors…` (factors in printing order).
    Product {
        /// The rational coefficient.
        coef: Q,
        /// The factors.
        factors: Factors,
    },
    /// A sum of terms.
    Sum(Vec<Form>),
    /// `num / den`.
    Quotient(Box<Form>, Box<Form>),
}

/// A product's factors: most products have a few, held inline (a product built during
/// collection is not an allocation).
pub type Factors = smallvec::SmallVec<[Factor; 4]>;

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
    /// A sum in parentheses, shared: a coefficient factored once is the same group wherever
    /// it occurs, and copying it copies a pointer.
    Group(Arc<Form>),
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
    /// The name with its arguments as text and as LaTeX (written where it is used).
    written: [String; 2],
}

impl Definition {
    /// The definition `name(args) = form`.
    pub(crate) fn new(name: String, args: Vec<String>, form: Form, given: bool) -> Definition {
        let size = args.iter().map(|a| a.len() + 2).sum::<usize>();
        let mut text = String::with_capacity(name.len() + size);
        text.push_str(&name);
        let mut latex = hamel_expr::latex_name(&name);
        latex.reserve(4 * size);
        for (k, a) in args.iter().enumerate() {
            let sep = if k == 0 { "(" } else { ", " };
            text.push_str(sep);
            text.push_str(a);
            latex.push_str(sep);
            latex.push_str(&hamel_expr::latex_name(a));
        }
        if !args.is_empty() {
            text.push(')');
            latex.push(')');
        }
        Definition {
            name,
            args,
            form,
            given,
            written: [text, latex],
        }
    }
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
            let mut v = vec![Expr::Num(coef.to_rational())];
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
fn atom(ctx: Ctx<'_>, index: usize, power: u32, s: &dyn Syntax, out: &mut String) {
    let Some(&name) = ctx.arguments.get(&index) else {
        return s.atom_power(ctx.atoms.get(index), power, out);
    };
    let mark = Expr::Sym(ARGUMENT.to_string());
    let marked = with_argument(&ctx.atoms.get(index).expr, mark.clone());
    let marked = if power == 1 {
        marked
    } else {
        Expr::powi(marked, i64::from(power))
    };
    out.push_str(
        &s.atom(&marked)
            .replace(&s.atom(&mark), s.name(&ctx.names[name])),
    );
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
    /// The magnitude of `r`.
    fn magnitude(&self, r: &Q, out: &mut String);
    fn atom(&self, e: &Expr) -> String;
    /// An atom to a power (its text at power one is kept with the atom).
    fn atom_power(&self, a: &Atom, power: u32, out: &mut String);
    fn times(&self) -> &'static str;
    /// What opens and closes a group.
    fn group(&self) -> (&'static str, &'static str);
    /// What is written before the numerator, between it and the denominator, and after the
    /// denominator; `bare` says which of them reads unambiguously without parentheses.
    fn quotient(&self, bare: (bool, bool)) -> [&'static str; 3];
    /// A name with its arguments.
    fn name<'d>(&self, d: &'d Definition) -> &'d str;
    /// The exponent after a group or a name: `^2`, `^{2}`.
    fn exponent(&self, n: u32, out: &mut String);
}

pub(crate) struct Text;
pub(crate) struct Latex;

/// Writes |r|: an integer as it is, a fraction by `fraction(out, numerator, denominator)`.
fn write_magnitude(
    r: &Q,
    out: &mut String,
    fraction: impl Fn(&mut String, &dyn std::fmt::Display, &dyn std::fmt::Display) -> std::fmt::Result,
) {
    let _ = match r {
        Q::Small(n, 1) => {
            out.push_str(itoa::Buffer::new().format(n.unsigned_abs()));
            Ok(())
        }
        Q::Small(n, d) => fraction(out, &n.unsigned_abs(), d),
        Q::Big(r) if r.is_integer() => write!(out, "{}", r.numer().magnitude()),
        Q::Big(r) => fraction(out, r.numer().magnitude(), r.denom()),
    };
}

impl Syntax for Text {
    fn magnitude(&self, r: &Q, out: &mut String) {
        write_magnitude(r, out, |out, n, d| write!(out, "{n}/{d}"));
    }
    fn atom(&self, e: &Expr) -> String {
        text_of(e)
    }
    fn atom_power(&self, a: &Atom, power: u32, out: &mut String) {
        if power == 1 {
            out.push_str(a.text());
        } else if simple(&a.expr) {
            out.push_str(a.text());
            self.exponent(power, out);
        } else {
            out.push_str(&self.atom(&Expr::powi(a.expr.clone(), i64::from(power))));
        }
    }
    fn times(&self) -> &'static str {
        "*"
    }
    fn group(&self) -> (&'static str, &'static str) {
        ("(", ")")
    }
    fn quotient(&self, bare: (bool, bool)) -> [&'static str; 3] {
        match bare {
            (true, true) => ["", "/", ""],
            (true, false) => ["", "/(", ")"],
            (false, true) => ["(", ")/", ""],
            (false, false) => ["(", ")/(", ")"],
        }
    }
    fn name<'d>(&self, d: &'d Definition) -> &'d str {
        &d.written[0]
    }
    fn exponent(&self, n: u32, out: &mut String) {
        out.push('^');
        out.push_str(itoa::Buffer::new().format(n));
    }
}

impl Syntax for Latex {
    fn magnitude(&self, r: &Q, out: &mut String) {
        write_magnitude(r, out, |out, n, d| write!(out, "\\tfrac{{{n}}}{{{d}}}"));
    }
    fn atom(&self, e: &Expr) -> String {
        e.to_latex()
    }
    fn atom_power(&self, a: &Atom, power: u32, out: &mut String) {
        if power == 1 {
            out.push_str(&a.latex);
            return;
        }
        // What `Expr::to_latex` writes for the power, from the atom's LaTeX: `\sin^{2} θ`
        // for a sine, cosine or tangent, `a^{2}` for another name or call.
        match &a.expr {
            Expr::Call(f @ (Func::Sin | Func::Cos | Func::Tan), _) => {
                let head = f.name().len() + 1;
                out.push_str(&a.latex[..head]);
                exponent(power, out);
                out.push_str(&a.latex[head..]);
            }
            e if simple(e) => {
                out.push_str(&a.latex);
                exponent(power, out);
            }
            e => out.push_str(&Expr::powi(e.clone(), i64::from(power)).to_latex()),
        }
    }
    fn times(&self) -> &'static str {
        " "
    }
    fn group(&self) -> (&'static str, &'static str) {
        ("\\left(", "\\right)")
    }
    fn quotient(&self, _: (bool, bool)) -> [&'static str; 3] {
        ["\\frac{", "}{", "}"]
    }
    fn name<'d>(&self, d: &'d Definition) -> &'d str {
        &d.written[1]
    }
    fn exponent(&self, n: u32, out: &mut String) {
        exponent(n, out);
    }
}

/// `^{power}`.
fn exponent(power: u32, out: &mut String) {
    out.push_str("^{");
    out.push_str(itoa::Buffer::new().format(power));
    out.push('}');
}

/// The terms of a sum as signed pieces: the first `-t` or `t`, the others ` - t` or ` + t`.
pub(crate) fn render_terms(terms: &[Form], ctx: Ctx<'_>) -> Vec<String> {
    terms
        .iter()
        .enumerate()
        .map(|(i, t)| {
            let mut out = String::new();
            write_term(i, t, ctx, &Latex, &mut out);
            out
        })
        .collect()
}

/// Term `i` of a sum with its sign.
fn write_term(i: usize, t: &Form, ctx: Ctx<'_>, s: &dyn Syntax, out: &mut String) {
    out.push_str(match (i, negative_term(t)) {
        (0, true) => "-",
        (0, false) => "",
        (_, true) => " - ",
        (_, false) => " + ",
    });
    write_unsigned(t, ctx, s, out);
}

/// A form's sign and magnitude in LaTeX.
pub(crate) fn unsigned_latex(f: &Form, ctx: Ctx<'_>) -> (bool, String) {
    let mut out = String::new();
    write_unsigned(f, ctx, &Latex, &mut out);
    (negative_term(f), out)
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
    // Room for a typical entry: growing a string from empty copies it at every doubling.
    let mut out = String::with_capacity(128);
    write(f, ctx, s, &mut out);
    out
}

/// [`render`] into `out`.
pub(crate) fn write(f: &Form, ctx: Ctx<'_>, s: &dyn Syntax, out: &mut String) {
    match f {
        Form::Sum(terms) => {
            for (i, t) in terms.iter().enumerate() {
                write_term(i, t, ctx, s, out);
            }
        }
        _ => write_term(0, f, ctx, s, out),
    }
}

/// Whether a term is written with a minus: a product with a negative coefficient (a sum or
/// a quotient is written in parentheses or as a fraction, its signs inside).
pub(crate) fn negative_term(f: &Form) -> bool {
    matches!(f, Form::Product { coef, .. } if coef.is_negative())
}

/// A term's magnitude: a negated product is written `- a b`, never `-(a b)`.
fn write_unsigned(f: &Form, ctx: Ctx<'_>, s: &dyn Syntax, out: &mut String) {
    match f {
        Form::Product { coef, factors } => {
            let one = coef.is_unit();
            let mut first = true;
            if !one || factors.is_empty() {
                s.magnitude(coef, out);
                first = false;
            }
            for (x, n) in powers(factors) {
                if !std::mem::take(&mut first) {
                    out.push_str(s.times());
                }
                match x {
                    Factor::Atom { index, power } => atom(ctx, *index, *power, s, out),
                    Factor::Group(g) => {
                        let (open, close) = s.group();
                        out.push_str(open);
                        write(g, ctx, s, out);
                        out.push_str(close);
                    }
                    Factor::Name { index } => out.push_str(s.name(&ctx.names[*index])),
                }
                if n > 1 {
                    s.exponent(n, out);
                }
            }
        }
        Form::Sum(_) => {
            let (open, close) = s.group();
            out.push_str(open);
            write(f, ctx, s, out);
            out.push_str(close);
        }
        Form::Quotient(a, b) => {
            let [before, between, after] = s.quotient((bare_numerator(a), bare_denominator(b)));
            out.push_str(before);
            write(a, ctx, s, out);
            out.push_str(between);
            write(b, ctx, s, out);
            out.push_str(after);
        }
    }
}

/// A numerator that needs no parentheses before `/`: a product with a positive coefficient
/// (`a*b/c` reads as `(a*b)/c`).
fn bare_numerator(f: &Form) -> bool {
    matches!(f, Form::Product { coef, .. } if coef.is_positive())
}

/// A denominator that needs no parentheses after `/`: one atom or name (to a power), or a
/// positive integer.
fn bare_denominator(f: &Form) -> bool {
    match f {
        Form::Product { coef, factors } if factors.is_empty() => {
            coef.is_integer() && coef.is_positive()
        }
        Form::Product { coef, factors } => {
            let mut runs = powers(factors);
            coef.is_one()
                && matches!(
                    (runs.next(), runs.next()),
                    (Some((Factor::Atom { .. } | Factor::Name { .. }, _)), None)
                )
        }
        _ => false,
    }
}

/// The kind order used to place factors: parameters, groups, then the state's atoms.
pub(crate) fn factor_rank(x: &Factor, atoms: &Atoms) -> (u8, u32) {
    match x {
        Factor::Atom { index, .. } => {
            let rank = if atoms.get(*index).kind == Kind::Parameter {
                0
            } else {
                2
            };
            (rank, atoms.rank(*index))
        }
        Factor::Group(_) | Factor::Name { .. } => (1, 0),
    }
}

/// A product's factors with each run of one group or name (a denominator's `δ²` is the
/// group repeated) as one factor and the run's length, the power it is written with.
pub(crate) fn powers(factors: &[Factor]) -> impl Iterator<Item = (&Factor, u32)> {
    let mut k = 0;
    std::iter::from_fn(move || {
        let x = factors.get(k)?;
        let n = match x {
            Factor::Atom { .. } => 1,
            _ => factors[k..].iter().take_while(|y| *y == x).count(),
        };
        k += n;
        Some((x, u32::try_from(n).expect("a short product")))
    })
}

/// Whether a form is the constant zero.
pub(crate) fn is_zero(f: &Form) -> bool {
    matches!(f, Form::Product { coef, .. } if coef.is_zero())
}
