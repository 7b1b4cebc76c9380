//! Lines that fit the page: the width of rendered LaTeX estimated, long sums broken at their
//! terms, a factored sum broken inside its parentheses (`\left( … \right.` / `\left. … \right)`).

use crate::form::{Factor, Form, Latex, render, render_terms, unsigned_latex};
use crate::sheet::Sheet;

/// Widths, in the estimate of [`width`] (about one per printed glyph): what fits beside a
/// left-hand side on landscape A4 with 1 cm margins at 10 pt, with room to spare.
pub const LINE: usize = 110;

/// The printed width of LaTeX math, roughly: a control word is one glyph (`\sin`, `\cos` and
/// the like three; `\left`, `\right`, fractions' and fonts' commands none), braces, scripts'
/// markers and spaces nothing, subscripts and superscripts count.
pub fn width(tex: &str) -> usize {
    let mut n = 0;
    let mut chars = tex.char_indices();
    while let Some((i, c)) = chars.next() {
        match c {
            '\\' => {
                let rest = &tex[i + 1..];
                let len = rest
                    .bytes()
                    .position(|b| !b.is_ascii_alphabetic())
                    .unwrap_or(rest.len());
                let word = &rest[..len];
                let silent = ["left", "right", "tfrac", "frac", "mathrm", "dot", "quad"];
                let named = ["sin", "cos", "tan", "exp", "log", "sqrt"];
                if word.is_empty() {
                    chars.next();
                    n += 1;
                } else {
                    // The word is ASCII: skip its characters.
                    for _ in 0..len {
                        chars.next();
                    }
                    if named.contains(&word) {
                        n += 3;
                    } else if !silent.contains(&word) {
                        n += 1;
                    }
                }
            }
            '{' | '}' | '^' | '_' | ' ' | '&' => {}
            _ => n += 1,
        }
    }
    n
}

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
        factors: Vec::new(),
    };
    match f {
        Form::Sum(terms) => Some((empty(), terms, empty())),
        Form::Product { coef, factors } => {
            let k = factors
                .iter()
                .position(|x| matches!(x, Factor::Group(Form::Sum(_))))?;
            let Factor::Group(Form::Sum(terms)) = &factors[k] else {
                return None;
            };
            let lead = Form::Product {
                coef: coef.clone(),
                factors: factors[..k].to_vec(),
            };
            let tail = Form::Product {
                coef: crate::Q::one(),
                factors: factors[k + 1..].to_vec(),
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
