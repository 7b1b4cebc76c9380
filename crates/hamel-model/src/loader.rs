//! The pieces of a model as they are read: expressions with their places in the file
//! ([`Item`], [`Site`]), what the file gives of L and α ([`Kinetic`], [`Origin`]), and the
//! [`Loader`] that parses each expression and resolves its names.

use std::collections::BTreeMap;
use std::ops::Range;
use std::sync::Arc;

use hamel_bodies::{Completion, HolonomicConstraint};
use hamel_expr::{Expr, Func, Occurrence, OccurrenceKind};
use indexmap::IndexMap;
use toml::Spanned;

use crate::error::ModelError;
use crate::schema::{RawScalar, RawVector};

/// Where an expression (or a value) sits in the model file.
#[derive(serde::Serialize, serde::Deserialize, Clone, Debug, PartialEq, Eq)]
pub struct Site {
    /// Key path, such as `constraints.no_slip` or `quasi_velocities.paper.eta[1]`.
    pub key: String,
    /// Byte range of the value in the file.
    pub span: Range<usize>,
}

/// One expression of the model with its origin.
#[derive(serde::Serialize, serde::Deserialize, Clone, Debug)]
pub struct Item {
    /// The expression text as written.
    pub text: String,
    /// The parsed expression.
    pub expr: Expr,
    /// Where it is.
    pub site: Site,
    /// File offset of the first character of `text`, when the text maps one-to-one onto the
    /// file (no escapes), so that positions inside the expression can be reported exactly.
    text_offset: Option<usize>,
}

impl Item {
    /// An item not read from a file (built by a program, such as the `identity` choice).
    pub fn synthetic(key: &str, expr: Expr) -> Item {
        Item {
            text: expr.to_string(),
            expr,
            site: Site {
                key: key.to_string(),
                span: 0..0,
            },
            text_offset: None,
        }
    }

    /// An item expanded from other parts of the file (such as A from the bodies), shown at
    /// `span`.
    pub fn expanded(key: &str, expr: Expr, span: Range<usize>) -> Item {
        let mut item = Item::synthetic(key, expr);
        item.site.span = span;
        item
    }

    /// This item with its expression replaced by `expr` (a law put in), at the same place.
    pub fn replaced(&self, expr: Expr) -> Item {
        Item {
            text: expr.to_string(),
            expr,
            site: self.site.clone(),
            text_offset: None,
        }
    }

    /// The file span of a byte range inside the expression text (the whole value if the text
    /// does not map exactly).
    pub fn span_of(&self, inner: Range<usize>) -> Range<usize> {
        match self.text_offset {
            Some(o) => o + inner.start..o + inner.end.max(inner.start),
            None => self.site.span.clone(),
        }
    }
}

/// Where a model's L and α come from.
#[derive(serde::Serialize, serde::Deserialize, Clone, Copy, Debug, PartialEq, Eq)]
pub enum Origin {
    /// Typed in by hand: `[lagrangian]` and `[constraints]`.
    Lagrangian,
    /// Expanded from `[world]`, `[frames]`, `[bodies]`, `[wheels]`, `[blades]`.
    Bodies,
}

/// What a model file gives of L and α, by hand or from bodies.
pub(crate) struct Dynamics {
    pub kinetic: Kinetic,
    pub potential: Item,
    /// Rows of α that come before `[constraints]` (from bodies), and the holonomic rows after.
    pub rows: Vec<(String, Item)>,
    pub holonomic: Vec<HolonomicConstraint>,
    pub completion: Completion,
    pub origin: Origin,
    /// The generalised forces of the bodies' loads (empty for a model typed by hand).
    pub forces: Vec<Item>,
    pub notes: Vec<String>,
    pub symmetries: Vec<crate::Symmetry>,
    /// How the contacts' forces are read off the rows' multipliers (bodies only).
    pub contact_forces: hamel_bodies::ContactForces,
    /// The mechanism the bodies describe (bodies only), for what is derived from it on demand.
    pub mechanism: Option<std::sync::Arc<hamel_bodies::Mechanism>>,
}

/// The kinetic energy as given in the file.
#[derive(serde::Serialize, serde::Deserialize, Clone, Debug)]
pub enum Kinetic {
    /// T as an expression in the velocities.
    Energy(Item),
    /// The mass matrix A (T = ½ q̇ᵀAq̇), row by row.
    MassMatrix(Vec<Vec<Item>>),
}

const RESERVED: [&str; 3] = ["der", "t", "pi"];

pub(crate) fn is_identifier(s: &str) -> bool {
    let mut chars = s.chars();
    matches!(chars.next(), Some(c) if c.is_ascii_alphabetic() || c == '_')
        && chars.all(|c| c.is_ascii_alphanumeric() || c == '_')
}

pub(crate) fn is_reserved(s: &str) -> bool {
    Func::from_name(s).is_some() || RESERVED.contains(&s)
}

/// Levenshtein distance, for "did you mean" hints.
fn distance(a: &str, b: &str) -> usize {
    let b: Vec<char> = b.chars().collect();
    let mut prev: Vec<usize> = (0..=b.len()).collect();
    for (i, ca) in a.chars().enumerate() {
        let mut cur = vec![i + 1];
        for (j, cb) in b.iter().enumerate() {
            let sub = prev[j] + usize::from(ca != *cb);
            cur.push(sub.min(prev[j + 1] + 1).min(cur[j] + 1));
        }
        prev = cur;
    }
    prev[b.len()]
}

fn closest<'a>(name: &str, candidates: impl Iterator<Item = &'a String>) -> Option<&'a String> {
    candidates
        .map(|c| (distance(name, c), c))
        .filter(|(d, c)| *d <= 2.max(c.len() / 3))
        .min_by_key(|(d, _)| *d)
        .map(|(_, c)| c)
}

/// What an expression field may contain.
#[derive(Clone, Copy, PartialEq, Eq)]
pub(crate) enum FieldKind {
    /// T: velocities allowed.
    Kinetic,
    /// Entries of A and U: no velocities.
    Positional,
    /// Constraints: velocities allowed.
    Constraint,
    /// Generalised forces and loads: velocities allowed (viscous damping, drag), F(q, q̇).
    Force,
    /// Quasi-velocities: velocities and free functions allowed.
    Eta,
}

pub(crate) struct Loader<'a> {
    file: &'a str,
    source: Arc<String>,
    pub(crate) coordinates: Vec<String>,
    pub(crate) parameters: IndexMap<String, f64>,
    /// Free function name → (arguments, first use) across the whole model.
    free: BTreeMap<String, (Vec<String>, Range<usize>)>,
}

impl<'a> Loader<'a> {
    /// One scalar of a table field: its text parsed as an expression of the `kind` allowed.
    pub(crate) fn scalar(
        &mut self,
        v: &Spanned<RawScalar>,
        key: &str,
        kind: FieldKind,
    ) -> Result<Expr, ModelError> {
        let text = Spanned::new(v.span(), v.get_ref().text());
        Ok(self.item(&text, key, kind)?.expr)
    }

    /// Three scalars (`[a, b, c]`; zero when absent), each at its place (`KEY[i]`).
    pub(crate) fn vector(
        &mut self,
        v: Option<&RawVector>,
        key: &str,
        kind: FieldKind,
    ) -> Result<[Expr; 3], ModelError> {
        let Some(v) = v else {
            return Ok(hamel_bodies::vector::zero());
        };
        if v.get_ref().len() != 3 {
            let msg = format!("a vector needs 3 components, found {}", v.get_ref().len());
            return Err(self.err(v.span(), key, msg));
        }
        let mut c = |i: usize| self.scalar(&v.get_ref()[i], &format!("{key}[{}]", i + 1), kind);
        Ok([c(0)?, c(1)?, c(2)?])
    }

    /// A loader for the expressions of `file` (text `source`), with these names.
    pub(crate) fn new(
        file: &'a str,
        source: Arc<String>,
        coordinates: Vec<String>,
        parameters: IndexMap<String, f64>,
    ) -> Loader<'a> {
        Loader {
            file,
            source,
            coordinates,
            parameters,
            free: BTreeMap::new(),
        }
    }

    /// A loader for the same file whose expressions may also use the names of `extra` (such
    /// as a steady motion's parameters).
    pub(crate) fn with_parameters(&self, extra: &IndexMap<String, f64>) -> Loader<'a> {
        let mut parameters = self.parameters.clone();
        parameters.extend(extra.iter().map(|(k, v)| (k.clone(), *v)));
        Loader::new(
            self.file,
            self.source.clone(),
            self.coordinates.clone(),
            parameters,
        )
    }

    pub(crate) fn err(&self, span: Range<usize>, key: &str, msg: impl Into<String>) -> ModelError {
        ModelError::new(self.file, self.source.clone(), Some(span), Some(key), msg)
    }

    /// Parse the text of a `Spanned<String>` value into an [`Item`] and resolve its names.
    pub(crate) fn item(
        &mut self,
        value: &Spanned<String>,
        key: &str,
        kind: FieldKind,
    ) -> Result<Item, ModelError> {
        let span = value.span();
        let text = value.get_ref().clone();
        let text_offset = text_offset(&self.source, span.clone(), &text);
        let at = |inner: Range<usize>| match text_offset {
            Some(o) => o + inner.start..o + inner.end.max(inner.start),
            None => span.clone(),
        };
        let parsed = hamel_expr::parse(&text).map_err(|e| {
            self.err(
                at(e.span.clone()),
                key,
                format!("syntax error: {}", e.message),
            )
        })?;
        for occ in &parsed.occurrences {
            self.resolve(occ, key, kind, at(occ.span.clone()))?;
        }
        self.check_powers(&parsed.expr, key, span.clone())?;
        Ok(Item {
            text,
            expr: parsed.expr,
            site: Site {
                key: key.to_string(),
                span,
            },
            text_offset,
        })
    }

    fn resolve(
        &mut self,
        occ: &Occurrence,
        key: &str,
        kind: FieldKind,
        span: Range<usize>,
    ) -> Result<(), ModelError> {
        let name = &occ.name;
        let is_coord = self.coordinates.contains(name);
        match &occ.kind {
            OccurrenceKind::Symbol => {
                if is_coord || self.parameters.contains_key(name) {
                    return Ok(());
                }
                let mut e = self.err(span, key, format!("unknown symbol `{name}`"));
                let all: Vec<String> = self
                    .coordinates
                    .iter()
                    .chain(self.parameters.keys())
                    .cloned()
                    .collect();
                e = match closest(name, all.iter()) {
                    Some(c) => e.with_help(format!("did you mean `{c}`?")),
                    None => e.with_help(
                        "symbols must be coordinates or parameters declared in [parameters]",
                    ),
                };
                Err(e)
            }
            OccurrenceKind::Velocity => {
                if !is_coord {
                    let mut e = self.err(
                        span,
                        key,
                        format!("`der({name})`: `{name}` is not a coordinate"),
                    );
                    if let Some(c) = closest(name, self.coordinates.iter()) {
                        e = e.with_help(format!("did you mean `der({c})`?"));
                    }
                    return Err(e);
                }
                if kind == FieldKind::Positional {
                    return Err(self.err(
                        span,
                        key,
                        format!("velocity `der({name})` is not allowed here: this expression depends on the configuration only"),
                    ));
                }
                Ok(())
            }
            OccurrenceKind::FreeFunction(args) => {
                if kind != FieldKind::Eta {
                    return Err(self
                        .err(span, key, format!("`{name}` is not a built-in function"))
                        .with_help("free functions such as `z13(phi)` are allowed only in quasi-velocity expressions; built-ins are sin cos tan sqrt exp log"));
                }
                if is_coord || self.parameters.contains_key(name) || is_reserved(name) {
                    return Err(self.err(
                        span,
                        key,
                        format!("`{name}` is a symbol, not a function"),
                    ));
                }
                for a in args {
                    if !self.coordinates.contains(a) {
                        return Err(self.err(
                            span,
                            key,
                            format!("free function `{name}` must take coordinates as arguments; `{a}` is not a coordinate"),
                        ));
                    }
                }
                let mut sorted = args.clone();
                sorted.sort();
                sorted.dedup();
                if sorted.len() != args.len() {
                    return Err(self.err(
                        span,
                        key,
                        format!("free function `{name}` repeats an argument"),
                    ));
                }
                match self.free.get(name) {
                    Some((prev, _)) if prev != args => Err(self.err(
                        span,
                        key,
                        format!(
                            "free function `{name}` is called with ({}) here but with ({}) elsewhere",
                            args.join(", "),
                            prev.join(", ")
                        ),
                    )),
                    Some(_) => Ok(()),
                    None => {
                        self.free.insert(name.clone(), (args.clone(), span));
                        Ok(())
                    }
                }
            }
        }
    }

    /// `^` needs an integer exponent unless the base is a positive constant.
    fn check_powers(&self, e: &Expr, key: &str, span: Range<usize>) -> Result<(), ModelError> {
        let mut bad = None;
        e.visit(&mut |node| {
            if let Expr::Pow(base, exp) = node {
                let exp_const =
                    !exp.any(&mut |x| matches!(x, Expr::Sym(_) | Expr::Der(_) | Expr::Free { .. }));
                let base_const = !base.any(&mut |x| {
                    matches!(x, Expr::Sym(s) if self.coordinates.contains(s))
                        || matches!(x, Expr::Der(_) | Expr::Free { .. })
                });
                let integer = exp.as_integer().is_some();
                if bad.is_none() && !(integer || (exp_const && base_const)) {
                    bad = Some(node.to_string());
                }
            }
        });
        match bad {
            Some(p) => Err(self
                .err(
                    span,
                    key,
                    format!("`{p}`: the exponent must be an integer (or the base a constant)"),
                )
                .with_help("write square roots as sqrt(...)")),
            None => Ok(()),
        }
    }
}

/// File offset where the characters of a TOML string value start, if the value maps one-to-one.
fn text_offset(source: &str, span: Range<usize>, value: &str) -> Option<usize> {
    let raw = source.get(span.clone())?;
    let (skip, end_skip) = if raw.starts_with("\"\"\"") || raw.starts_with("'''") {
        let after = &raw[3..];
        let nl = if after.starts_with("\r\n") {
            2
        } else if after.starts_with('\n') {
            1
        } else {
            0
        };
        (3 + nl, 3)
    } else if raw.starts_with('"') || raw.starts_with('\'') {
        (1, 1)
    } else {
        return None;
    };
    let inner = raw.get(skip..raw.len().checked_sub(end_skip)?)?;
    (inner == value).then_some(span.start + skip)
}

pub(crate) fn is_eta_name(s: &str) -> bool {
    s.strip_prefix("eta")
        .is_some_and(|rest| !rest.is_empty() && rest.chars().all(|c| c.is_ascii_digit()))
}

/// Makes an error at a span and key of the model file.
pub(crate) type ErrorAt<'a> = dyn Fn(Range<usize>, &str, String) -> ModelError + 'a;
