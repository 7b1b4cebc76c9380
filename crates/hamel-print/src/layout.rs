//! Lines that fit the page: the width of rendered LaTeX estimated, long sums broken at their
//! terms, a factored sum broken inside its parentheses (`\left( … \right.` / `\left. … \right)`).

use crate::atoms::simple;
use crate::form::{
    Ctx, Factor, Factors, Form, Latex, Syntax, negative_term, powers, render, render_terms,
    unsigned_latex,
};
use crate::q::Q;
use crate::sheet::Sheet;
pub use crate::tex_width::width;

/// Widths, in the estimate of [`width`] (about one per printed glyph): what fits beside a
/// left-hand side on landscape A4 with 1 cm margins at 10 pt, with room to spare.
pub const LINE: usize = 110;

impl Sheet {
    /// Entry `i` in LaTeX, as lines of at most `budget` (estimated) wide where its shape
    /// allows: a sum broken between terms; `c (sum)` and a quotient of a sum, written
    /// `1/den (sum)`, broken inside the parentheses. Later lines begin with their sign.
    pub fn latex_lines(&self, i: usize, budget: usize) -> Vec<String> {
        self.form_lines(self.form(i), budget)
    }

    /// The definition of name `j` in LaTeX, as lines (as [`Sheet::latex_lines`]).
    pub fn definition_lines(&self, j: usize, budget: usize) -> Vec<String> {
        self.form_lines(&self.names[j].form, budget)
    }

    fn form_lines(&self, f: &Form, budget: usize) -> Vec<String> {
        let ctx = self.ctx();
        let whole = render(f, ctx, &Latex);
        if width(&whole) <= budget {
            return vec![whole];
        }
        let (lead, terms, tail, over) = match f {
            Form::Sum(terms) => return pack(render_terms(terms, ctx), budget, "", ""),
            Form::Quotient(num, den) => {
                let over = format!("\\frac{{1}}{{{}}} ", render(den, ctx, &Latex));
                match split(num) {
                    Some((lead, terms, tail)) => (lead, terms, tail, over),
                    None => return vec![whole],
                }
            }
            product => match split(product) {
                Some((lead, terms, tail)) => (lead, terms, tail, String::new()),
                None => return vec![whole],
            },
        };
        let (negative, c) = unsigned_latex(&lead, ctx);
        let c = if c == "1" { String::new() } else { c + " " };
        let sign = if negative { "-" } else { "" };
        let open = format!("{sign}{c}{over}{}", Latex.open());
        let (_, t) = unsigned_latex(&tail, ctx);
        let close = if t == "1" {
            Latex.close()
        } else {
            format!("{} {t}", Latex.close())
        };
        pack(render_terms(terms, ctx), budget, &open, &close)
    }
}

/// A sum, or a product with a sum among its factors: the factors before the sum (as a
/// product with the coefficient), the sum's terms, and the factors after it.
fn split(f: &Form) -> Option<(Form, &[Form], Form)> {
    let empty = || Form::Product {
        coef: crate::Q::one(),
        factors: Factors::new(),
    };
    match f {
        Form::Sum(terms) => Some((empty(), terms, empty())),
        Form::Product { coef, factors } => {
            let k = factors
                .iter()
                .position(|x| matches!(x, Factor::Group(g) if matches!(**g, Form::Sum(_))))?;
            let Factor::Group(g) = &factors[k] else {
                return None;
            };
            let Form::Sum(terms) = &**g else {
                return None;
            };
            let lead = Form::Product {
                coef: coef.clone(),
                factors: Factors::from(&factors[..k]),
            };
            let tail = Form::Product {
                coef: crate::Q::one(),
                factors: Factors::from(&factors[k + 1..]),
            };
            Some((lead, terms, tail))
        }
        Form::Quotient(..) => None,
    }
}

/// Signed terms packed into lines; `open` before the first, `close` after the last, and
/// `\right.`/`\left.` around the breaks when `open` opened a parenthesis.
fn pack(terms: Vec<String>, budget: usize, open: &str, close: &str) -> Vec<String> {
    let grouped = !open.is_empty();
    let mut lines: Vec<String> = Vec::new();
    let mut line = open.to_string();
    for (k, t) in terms.into_iter().enumerate() {
        let piece = if k == 0 {
            t.trim_start_matches(" + ").to_string()
        } else {
            t
        };
        if k > 0 && width(&line) + width(&piece) > budget {
            if grouped {
                line.push_str(" \\right.");
            }
            lines.push(line);
            line = if grouped {
                "\\left.".to_string()
            } else {
                String::new()
            };
        }
        line.push_str(&piece);
    }
    line.push_str(close);
    lines.push(line);
    lines
}

/// A lower bound of [`width`] of `f` rendered in LaTeX, found without rendering it: every atom, name and coefficient
/// shows one glyph at least, and terms are joined by a sign (a quotient counts both its
/// parts, as `width` does).
pub fn width_at_least(f: &Form) -> usize {
    match f {
        Form::Product { factors, .. } => factors
            .iter()
            .map(|x| match x {
                Factor::Group(g) => width_at_least(g),
                Factor::Atom { .. } | Factor::Name { .. } => 1,
            })
            .sum(),
        Form::Sum(terms) => {
            terms.iter().map(width_at_least).sum::<usize>() + terms.len().saturating_sub(1)
        }
        Form::Quotient(a, b) => width_at_least(a) + width_at_least(b),
    }
}

/// [`width`] of `f` rendered in LaTeX, found without rendering it: the widths of its pieces
/// added (an atom's LaTeX and a power's exponent, a coefficient's digits, a name, a sign, a
/// group's parentheses), which is the width of their concatenation, as no piece ends in a
/// letter that the next could extend into a longer control word. None where it is not known
/// without rendering: an atom whose argument is printed by name, a power of an atom that
/// is not a name or a call, a big coefficient.
///
/// Found up to `cap`: as soon as the pieces so far are wider than `cap`, their width is
/// returned (what telling whether a group is wider than `cap` needs: the pieces after them
/// only add to it, and none of them is looked at).
pub(crate) fn latex_width_upto(f: &Form, ctx: Ctx<'_>, cap: usize) -> Option<usize> {
    match f {
        Form::Sum(terms) => {
            let mut n = 0;
            for (i, t) in terms.iter().enumerate() {
                n += usize::from(i > 0 || negative_term(t)) + unsigned_width(t, ctx, cap)?;
                if n > cap {
                    break;
                }
            }
            Some(n)
        }
        _ => Some(usize::from(negative_term(f)) + unsigned_width(f, ctx, cap)?),
    }
}

/// [`latex_width_upto`] of a term without its sign (as `write_unsigned` writes it).
fn unsigned_width(f: &Form, ctx: Ctx<'_>, cap: usize) -> Option<usize> {
    match f {
        Form::Product { coef, factors } => {
            let mut n = if !coef.is_unit() || factors.is_empty() {
                magnitude_width(coef)?
            } else {
                0
            };
            for (x, k) in powers(factors) {
                n += match x {
                    Factor::Atom { index, power } => atom_width(*index, *power, ctx)?,
                    // `\left(` and `\right)`: one each.
                    Factor::Group(g) => 2 + latex_width_upto(g, ctx, cap)?,
                    Factor::Name { index } => width(Latex.name(&ctx.names[*index])),
                };
                if k > 1 {
                    n += digits(u64::from(k));
                }
                if n > cap {
                    break;
                }
            }
            Some(n)
        }
        Form::Sum(_) => Some(2 + latex_width_upto(f, ctx, cap)?),
        Form::Quotient(a, b) => {
            let a = latex_width_upto(a, ctx, cap)?;
            if a > cap {
                return Some(a);
            }
            Some(a + latex_width_upto(b, ctx, cap)?)
        }
    }
}

/// An atom to a power: a name or a call takes its exponent without parentheses (`m^{2}`,
/// `\sin^{2} \theta`).
fn atom_width(index: usize, power: u32, ctx: Ctx<'_>) -> Option<usize> {
    if ctx.arguments.contains_key(&index) {
        return None;
    }
    let a = ctx.atoms.get(index);
    match power {
        1 => Some(a.latex_width),
        _ if simple(&a.expr) => Some(a.latex_width + digits(u64::from(power))),
        _ => None,
    }
}

/// The width of a coefficient's magnitude (`\tfrac{n}{d}` counts its digits); None for a
/// big one.
fn magnitude_width(c: &Q) -> Option<usize> {
    match c {
        Q::Small(n, 1) => Some(digits(n.unsigned_abs())),
        Q::Small(n, d) => Some(digits(n.unsigned_abs()) + digits(d.unsigned_abs())),
        Q::Big(_) => None,
    }
}

fn digits(n: u64) -> usize {
    n.checked_ilog10().map_or(1, |k| k as usize + 1)
}
