//! The resolved model and its loader.

use std::collections::BTreeMap;
use std::ops::Range;
use std::path::Path;
use std::sync::Arc;

use hamel_expr::{Expr, Func, Occurrence, OccurrenceKind};
use indexmap::IndexMap;
use toml::Spanned;

use crate::error::ModelError;
use crate::schema::{RawChoice, RawLagrangian, RawModel};

/// Where an expression (or a value) sits in the model file.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Site {
    /// Key path, such as `constraints.no_slip` or `quasi_velocities.paper.eta[1]`.
    pub key: String,
    /// Byte range of the value in the file.
    pub span: Range<usize>,
}

/// One expression of the model with its origin.
#[derive(Clone, Debug)]
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

    /// The file span of a byte range inside the expression text (the whole value if the text
    /// does not map exactly).
    pub fn span_of(&self, inner: Range<usize>) -> Range<usize> {
        match self.text_offset {
            Some(o) => o + inner.start..o + inner.end.max(inner.start),
            None => self.site.span.clone(),
        }
    }
}

/// The kinetic energy as given in the file.
#[derive(Clone, Debug)]
pub enum Kinetic {
    /// T as an expression in the velocities.
    Energy(Item),
    /// The mass matrix A (T = ½ q̇ᵀAq̇), row by row.
    MassMatrix(Vec<Vec<Item>>),
}

/// A named choice of quasi-velocities η = Z(q) q̇.
#[derive(Clone, Debug)]
pub struct QuasiVelocityChoice {
    /// Its name (the key under `[quasi_velocities]`).
    pub name: String,
    /// Free text.
    pub description: Option<String>,
    /// The rows of Z as expressions linear in the velocities.
    pub eta: Vec<Item>,
    /// Free functions it uses, with their coordinate arguments, sorted by name.
    pub free_functions: Vec<(String, Vec<String>)>,
    /// Where it comes from.
    pub origin: ChoiceOrigin,
}

/// Where a quasi-velocity choice comes from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ChoiceOrigin {
    /// A `[quasi_velocities.NAME]` table of the file.
    File,
    /// Z = I, added to every model without constraints.
    Holonomic,
    /// The independent velocities hamel takes when the file names no choice
    /// (`default_choice`).
    Independent,
    /// A candidate built by `hamel search`.
    Search,
}

/// A model read from a file, with names resolved and counts checked.
#[derive(Clone, Debug)]
pub struct Model {
    /// The file name as given (used in messages).
    pub file: String,
    /// The file text.
    pub source: Arc<String>,
    /// Identifier of the model.
    pub name: String,
    /// One-line title.
    pub title: String,
    /// Longer description, if any.
    pub description: Option<String>,
    /// Coordinates q₁..q_ℓ.
    pub coordinates: Vec<String>,
    /// Parameters and their default values.
    pub parameters: IndexMap<String, f64>,
    /// T or A.
    pub kinetic: Kinetic,
    /// U (L = T + U).
    pub potential: Item,
    /// Constraints, in file order (rows of α).
    pub constraints: Vec<(String, Item)>,
    /// Quasi-velocity choices, in file order.
    pub choices: Vec<QuasiVelocityChoice>,
}

const RESERVED: [&str; 3] = ["der", "t", "pi"];

fn is_identifier(s: &str) -> bool {
    let mut chars = s.chars();
    matches!(chars.next(), Some(c) if c.is_ascii_alphabetic() || c == '_')
        && chars.all(|c| c.is_ascii_alphanumeric() || c == '_')
}

fn is_reserved(s: &str) -> bool {
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
enum FieldKind {
    /// T: velocities allowed.
    Kinetic,
    /// Entries of A and U: no velocities.
    Positional,
    /// Constraints: velocities allowed.
    Constraint,
    /// Quasi-velocities: velocities and free functions allowed.
    Eta,
}

struct Loader<'a> {
    file: &'a str,
    source: Arc<String>,
    coordinates: Vec<String>,
    parameters: IndexMap<String, f64>,
    /// Free function name → (arguments, first use) across the whole model.
    free: BTreeMap<String, (Vec<String>, Range<usize>)>,
}

impl Loader<'_> {
    fn err(&self, span: Range<usize>, key: &str, msg: impl Into<String>) -> ModelError {
        ModelError::new(self.file, self.source.clone(), Some(span), Some(key), msg)
    }

    /// Parse the text of a `Spanned<String>` value into an [`Item`] and resolve its names.
    fn item(
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

impl Model {
    /// Read and check a model file.
    pub fn load(path: impl AsRef<Path>) -> Result<Model, ModelError> {
        let path = path.as_ref();
        let name = path.display().to_string();
        let text = std::fs::read_to_string(path).map_err(|e| {
            ModelError::new(
                &name,
                Arc::new(String::new()),
                None,
                None,
                format!("cannot read the file: {e}"),
            )
        })?;
        Model::from_source(&name, &text)
    }

    /// Check a model given as text; `file` is the name used in messages.
    pub fn from_source(file: &str, text: &str) -> Result<Model, ModelError> {
        let source = Arc::new(text.to_string());
        let raw: RawModel = toml::from_str(text).map_err(|e| {
            ModelError::new(
                file,
                source.clone(),
                e.span(),
                None,
                e.message().trim().to_string(),
            )
        })?;
        let err = |span: Range<usize>, key: &str, msg: String| {
            ModelError::new(file, source.clone(), Some(span), Some(key), msg)
        };
        if !is_identifier(raw.name.get_ref()) {
            return Err(err(
                raw.name.span(),
                "name",
                format!(
                    "`{}` is not an identifier (letters, digits, `_`)",
                    raw.name.get_ref()
                ),
            ));
        }
        let coordinates = coordinates_of(&raw, &err)?;
        let parameters = parameters_of(&raw, &coordinates, &err)?;
        let mut loader = Loader {
            file,
            source: source.clone(),
            coordinates: coordinates.clone(),
            parameters: parameters.clone(),
            free: BTreeMap::new(),
        };
        let kinetic = kinetic_of(&raw, &mut loader, &err)?;
        let potential = match &raw.lagrangian.get_ref().potential {
            Some(u) => loader.item(u, "lagrangian.potential", FieldKind::Positional)?,
            None => Item::synthetic("lagrangian.potential", Expr::int(0)),
        };
        let constraints = constraints_of(&raw, &mut loader, &err)?;
        let mut choices = choices_of(&raw, &mut loader, constraints.len(), &err)?;
        if constraints.is_empty() && !choices.iter().any(|c| c.name == "identity") {
            choices.push(identity_choice(&coordinates));
        }
        let mut model = Model {
            file: file.to_string(),
            source,
            name: raw.name.get_ref().clone(),
            title: raw.title.get_ref().clone(),
            description: raw.description.clone(),
            coordinates,
            parameters,
            kinetic,
            potential,
            constraints,
            choices,
        };
        model.check_mass_matrix_numerically()?;
        if model.choices.is_empty() {
            let default = model.independent_velocities()?;
            model.choices.push(default);
        }
        Ok(model)
    }

    /// Number of coordinates ℓ.
    pub fn ell(&self) -> usize {
        self.coordinates.len()
    }

    /// Number of constraints μ.
    pub fn mu(&self) -> usize {
        self.constraints.len()
    }

    /// Number of quasi-velocities σ = ℓ − μ.
    pub fn sigma(&self) -> usize {
        self.ell() - self.mu()
    }

    /// The named choice, or the first one when `name` is `None`.
    pub fn choice(&self, name: Option<&str>) -> Result<&QuasiVelocityChoice, ModelError> {
        match name {
            None => self.choices.first().ok_or_else(|| {
                self.error("the model has no [quasi_velocities.NAME] choice")
                    .with_help("add one, e.g. [quasi_velocities.mine] eta = [...]")
            }),
            Some(n) => self.choices.iter().find(|c| c.name == n).ok_or_else(|| {
                let names: Vec<&str> = self.choices.iter().map(|c| c.name.as_str()).collect();
                self.error(format!("no quasi-velocity choice named `{n}`"))
                    .with_help(format!("the model defines: {}", names.join(", ")))
            }),
        }
    }

    /// An error located at `site`.
    pub fn error_at(&self, site: &Site, message: impl Into<String>) -> ModelError {
        let span = (site.span.end > site.span.start).then(|| site.span.clone());
        ModelError::new(
            &self.file,
            self.source.clone(),
            span,
            Some(&site.key),
            message,
        )
    }

    /// An error about the model as a whole.
    pub fn error(&self, message: impl Into<String>) -> ModelError {
        ModelError::new(&self.file, self.source.clone(), None, None, message)
    }

    /// A copy whose choice `choice` has its free functions replaced by the given expressions of
    /// their arguments (for numeric evaluation of a parametrised choice).
    pub fn with_free_functions(
        &self,
        choice: &str,
        defs: &[(String, Expr)],
    ) -> Result<Model, ModelError> {
        let mut m = self.clone();
        let c = m
            .choices
            .iter_mut()
            .find(|c| c.name == choice)
            .ok_or_else(|| self.error(format!("no quasi-velocity choice named `{choice}`")))?;
        for (name, by) in defs {
            let Some((_, args)) = c.free_functions.iter().find(|(f, _)| f == name) else {
                return Err(self.error(format!("choice `{choice}` has no free function `{name}`")));
            };
            let mut stray = None;
            by.visit(&mut |n| match n {
                Expr::Sym(s) if !args.contains(s) && !self.parameters.contains_key(s) => {
                    stray = Some(s.clone())
                }
                Expr::Der(_) | Expr::Free { .. } => stray = Some(n.to_string()),
                _ => {}
            });
            if let Some(s) = stray {
                return Err(self.error(format!(
                    "the definition of `{name}` may use only its arguments ({}) and parameters, not `{s}`",
                    args.join(", ")
                )));
            }
            for item in &mut c.eta {
                item.expr = item
                    .expr
                    .substitute_free(name, by)
                    .map_err(|e| self.error(e.to_string()))?;
            }
            c.free_functions.retain(|(f, _)| f != name);
        }
        Ok(m)
    }
}

fn is_eta_name(s: &str) -> bool {
    s.strip_prefix("eta")
        .is_some_and(|rest| !rest.is_empty() && rest.chars().all(|c| c.is_ascii_digit()))
}

fn identity_choice(coordinates: &[String]) -> QuasiVelocityChoice {
    QuasiVelocityChoice {
        name: "identity".to_string(),
        description: Some(
            "Z = I: the quasi-velocities are the generalized velocities (holonomic case)"
                .to_string(),
        ),
        eta: coordinates
            .iter()
            .enumerate()
            .map(|(i, q)| {
                Item::synthetic(
                    &format!("quasi_velocities.identity.eta[{}]", i + 1),
                    Expr::Der(q.clone()),
                )
            })
            .collect(),
        free_functions: Vec::new(),
        origin: ChoiceOrigin::Holonomic,
    }
}

/// Makes an error at a span and key of the model file.
type ErrorAt<'a> = dyn Fn(Range<usize>, &str, String) -> ModelError + 'a;

/// `coordinates`: identifiers, not reserved, each once, at least one.
fn coordinates_of(raw: &RawModel, err: &ErrorAt) -> Result<Vec<String>, ModelError> {
    let mut coordinates: Vec<String> = Vec::new();
    for c in raw.coordinates.get_ref() {
        let n = c.get_ref();
        if !is_identifier(n) {
            return Err(err(
                c.span(),
                "coordinates",
                format!("`{n}` is not an identifier"),
            ));
        }
        if is_reserved(n) || is_eta_name(n) {
            return Err(err(
                c.span(),
                "coordinates",
                format!("`{n}` is a reserved name"),
            ));
        }
        if coordinates.contains(n) {
            return Err(err(
                c.span(),
                "coordinates",
                format!("coordinate `{n}` is listed twice"),
            ));
        }
        coordinates.push(n.clone());
    }
    if coordinates.is_empty() {
        return Err(err(
            raw.coordinates.span(),
            "coordinates",
            "the model needs at least one coordinate".into(),
        ));
    }
    Ok(coordinates)
}

/// `[parameters]`: names that are not coordinates, with finite numeric defaults.
fn parameters_of(
    raw: &RawModel,
    coordinates: &[String],
    err: &ErrorAt,
) -> Result<IndexMap<String, f64>, ModelError> {
    let mut parameters = IndexMap::new();
    for (k, v) in &raw.parameters {
        let key = format!("parameters.{k}");
        if !is_identifier(k) || is_reserved(k) || is_eta_name(k) {
            return Err(err(
                v.span(),
                &key,
                format!("`{k}` cannot be a parameter name (reserved or not an identifier)"),
            ));
        }
        if coordinates.contains(k) {
            return Err(err(
                v.span(),
                &key,
                format!("`{k}` is already a coordinate"),
            ));
        }
        let value = match v.get_ref() {
            toml::Value::Float(f) => *f,
            toml::Value::Integer(i) => *i as f64,
            other => {
                return Err(err(
                    v.span(),
                    &key,
                    format!(
                        "a parameter's default must be a number, found {}",
                        other.type_str()
                    ),
                ));
            }
        };
        if !value.is_finite() {
            return Err(err(
                v.span(),
                &key,
                "a parameter's default must be finite".into(),
            ));
        }
        parameters.insert(k.clone(), value);
    }

    Ok(parameters)
}

/// `[lagrangian]`: the kinetic energy T, or the mass matrix A (ℓ × ℓ).
fn kinetic_of(raw: &RawModel, loader: &mut Loader, err: &ErrorAt) -> Result<Kinetic, ModelError> {
    let ell = loader.coordinates.len();
    let RawLagrangian {
        kinetic,
        mass_matrix,
        ..
    } = raw.lagrangian.get_ref();
    Ok(match (kinetic, mass_matrix) {
        (Some(t), None) => {
            Kinetic::Energy(loader.item(t, "lagrangian.kinetic", FieldKind::Kinetic)?)
        }
        (None, Some(m)) => {
            if m.get_ref().len() != ell {
                return Err(err(
                    m.span(),
                    "lagrangian.mass_matrix",
                    format!(
                        "the mass matrix must have {ell} rows (one per coordinate), found {}",
                        m.get_ref().len()
                    ),
                ));
            }
            let mut rows = Vec::new();
            for (i, row) in m.get_ref().iter().enumerate() {
                if row.get_ref().len() != ell {
                    return Err(err(
                        row.span(),
                        "lagrangian.mass_matrix",
                        format!(
                            "row {} must have {ell} entries, found {}",
                            i + 1,
                            row.get_ref().len()
                        ),
                    ));
                }
                let mut r = Vec::new();
                for (j, e) in row.get_ref().iter().enumerate() {
                    let key = format!("lagrangian.mass_matrix[{}][{}]", i + 1, j + 1);
                    r.push(loader.item(e, &key, FieldKind::Positional)?);
                }
                rows.push(r);
            }
            Kinetic::MassMatrix(rows)
        }
        (Some(t), Some(_)) => {
            return Err(err(
                t.span(),
                "lagrangian",
                "give either `kinetic` or `mass_matrix`, not both".into(),
            ));
        }
        (None, None) => {
            return Err(err(
                raw.lagrangian.span(),
                "lagrangian",
                "missing the kinetic energy: give `kinetic` (T) or `mass_matrix` (A)".into(),
            ));
        }
    })
}

/// `[constraints]`: each linear in the velocities, fewer than the coordinates (ℓ > μ).
fn constraints_of(
    raw: &RawModel,
    loader: &mut Loader,
    err: &ErrorAt,
) -> Result<Vec<(String, Item)>, ModelError> {
    let ell = loader.coordinates.len();
    let mut constraints = Vec::new();
    for (k, v) in &raw.constraints {
        let key = format!("constraints.{k}");
        let item = loader.item(v, &key, FieldKind::Constraint)?;
        if !item.expr.has_velocity() {
            return Err(err(
                v.span(),
                &key,
                "a constraint must involve the velocities der(q): it is α(q) q̇ = 0".into(),
            ));
        }
        constraints.push((k.clone(), item));
    }
    let mu = constraints.len();
    if mu >= ell {
        let span = raw
            .constraints
            .values()
            .next()
            .map_or(raw.coordinates.span(), |v| v.span());
        return Err(err(
            span,
            "constraints",
            format!(
                "there are {mu} constraints for {ell} coordinates: need fewer constraints than coordinates (ℓ > μ)"
            ),
        ));
    }
    Ok(constraints)
}

/// `[quasi_velocities.NAME]`: σ = ℓ − μ rows each, with the free functions they use.
fn choices_of(
    raw: &RawModel,
    loader: &mut Loader,
    mu: usize,
    err: &ErrorAt,
) -> Result<Vec<QuasiVelocityChoice>, ModelError> {
    let ell = loader.coordinates.len();
    let sigma = ell - mu;
    let mut choices = Vec::new();
    for (name, choice) in &raw.quasi_velocities {
        let RawChoice { eta, description } = choice.get_ref();
        let key = format!("quasi_velocities.{name}");
        if !is_identifier(name) {
            return Err(err(
                choice.span(),
                &key,
                format!("`{name}` is not an identifier"),
            ));
        }
        if eta.get_ref().len() != sigma {
            return Err(err(
                eta.span(),
                &format!("{key}.eta"),
                format!(
                    "wrong number of quasi-velocities: need ℓ − μ = {ell} − {mu} = {sigma}, found {}",
                    eta.get_ref().len()
                ),
            ));
        }
        let mut items = Vec::new();
        for (i, e) in eta.get_ref().iter().enumerate() {
            let item = loader.item(e, &format!("{key}.eta[{}]", i + 1), FieldKind::Eta)?;
            if !item.expr.has_velocity() {
                return Err(err(
                    e.span(),
                    &format!("{key}.eta[{}]", i + 1),
                    "a quasi-velocity must be linear in the velocities der(q)".into(),
                ));
            }
            items.push(item);
        }
        let mut free: Vec<(String, Vec<String>)> = Vec::new();
        for item in &items {
            item.expr.visit(&mut |n| {
                if let Expr::Free { name, args, .. } = n
                    && !free.iter().any(|(f, _)| f == name)
                {
                    free.push((name.clone(), args.clone()));
                }
            });
        }
        free.sort();
        choices.push(QuasiVelocityChoice {
            name: name.clone(),
            description: description.clone(),
            eta: items,
            free_functions: free,
            origin: ChoiceOrigin::File,
        });
    }
    Ok(choices)
}

#[cfg(test)]
mod tests {
    use super::*;

    const KNIFE: &str = r#"
name = "knife"
title = "Knife edge on a horizontal plane"
coordinates = ["x", "y", "theta"]
[parameters]
m = 1.0
l = 0.8
[lagrangian]
kinetic = "m/2*(der(x)^2 + der(y)^2) + m*l^2/24*der(theta)^2"
potential = "0"
[constraints]
no_slip = "sin(theta)*der(x) - cos(theta)*der(y)"
[quasi_velocities.paper]
eta = ["cos(theta)*der(x) + sin(theta)*der(y)", "der(theta)"]
"#;

    fn bad(text: &str) -> ModelError {
        Model::from_source("bad.toml", text).unwrap_err()
    }

    #[test]
    fn reads_the_knife() {
        let m = Model::from_source("knife.toml", KNIFE).unwrap();
        assert_eq!((m.ell(), m.mu(), m.sigma()), (3, 1, 2));
        assert_eq!(m.choices[0].name, "paper");
        assert_eq!(m.parameters["l"], 0.8);
    }

    #[test]
    fn unknown_symbol_is_located_with_a_hint() {
        let e = bad(&KNIFE.replace("sin(theta)*der(x) -", "sin(thta)*der(x) -"));
        let s = e.to_string();
        assert!(
            s.starts_with("bad.toml:12:16: constraints.no_slip: unknown symbol `thta`"),
            "{s}"
        );
        assert!(s.contains("did you mean `theta`?"), "{s}");
    }

    #[test]
    fn syntax_error_is_located_inside_the_expression() {
        let e = bad(&KNIFE.replace("\"der(theta)\"]", "\"der(theta) +\"]"));
        let (line, col) = e.line_col().unwrap();
        assert_eq!(line, 14);
        assert!(col > 50, "column {col}");
        assert!(e.message().contains("syntax error"), "{e}");
    }

    #[test]
    fn wrong_number_of_quasi_velocities() {
        let e = bad(&KNIFE.replace("\"der(theta)\"]", "\"der(theta)\", \"der(x)\"]"));
        assert!(
            e.to_string()
                .contains("wrong number of quasi-velocities: need ℓ − μ = 3 − 1 = 2, found 3"),
            "{e}"
        );
    }

    #[test]
    fn too_many_constraints() {
        let text = KNIFE.replace(
            "no_slip = \"sin(theta)*der(x) - cos(theta)*der(y)\"",
            "a = \"der(x)\"\nb = \"der(y)\"\nc = \"der(theta)\"",
        );
        assert!(
            bad(&text)
                .to_string()
                .contains("need fewer constraints than coordinates")
        );
    }

    #[test]
    fn velocity_in_potential_is_rejected() {
        let e = bad(&KNIFE.replace("potential = \"0\"", "potential = \"m*der(x)\""));
        assert!(
            e.to_string()
                .contains("lagrangian.potential: velocity `der(x)` is not allowed here"),
            "{e}"
        );
    }

    #[test]
    fn free_function_outside_eta_is_rejected() {
        let e = bad(&KNIFE.replace("potential = \"0\"", "potential = \"f(x)\""));
        assert!(
            e.to_string().contains("`f` is not a built-in function"),
            "{e}"
        );
    }

    #[test]
    fn toml_errors_are_located() {
        let e = bad("name = \"k\"\ntitle = 3\n");
        assert!(e.line_col().is_some(), "{e}");
        let e = bad(&KNIFE.replace("[constraints]", "[constraint]"));
        assert!(e.to_string().contains("unknown field"), "{e}");
    }

    #[test]
    fn mass_matrix_must_be_positive_definite() {
        let e = bad(&KNIFE.replace("m*l^2/24*der(theta)^2", "0*der(theta)^2"));
        assert!(e.to_string().contains("not positive definite"), "{e}");
    }

    #[test]
    fn substituting_free_functions() {
        let text = KNIFE.replace(
            "[quasi_velocities.paper]",
            "[quasi_velocities.general]\neta = [\"z11(theta)*der(x) + z12(theta)*der(y)\", \"der(theta)\"]\n[quasi_velocities.paper]",
        );
        let m = Model::from_source("k.toml", &text).unwrap();
        assert_eq!(m.choices[0].free_functions.len(), 2);
        let defs = vec![
            (
                "z11".to_string(),
                hamel_expr::parse("cos(theta)").unwrap().expr,
            ),
            (
                "z12".to_string(),
                hamel_expr::parse("sin(theta)").unwrap().expr,
            ),
        ];
        let m2 = m.with_free_functions("general", &defs).unwrap();
        assert!(m2.choices[0].free_functions.is_empty());
        assert_eq!(
            m2.choices[0].eta[0].expr.to_string(),
            "cos(theta)*der(x) + sin(theta)*der(y)"
        );
        let bad_def = vec![("z11".to_string(), hamel_expr::parse("x").unwrap().expr)];
        assert!(m.with_free_functions("general", &bad_def).is_err());
    }

    #[test]
    fn holonomic_models_get_the_identity_choice() {
        let text = r#"
name = "pendulum"
title = "Planar pendulum"
coordinates = ["th"]
[parameters]
m = 1
l = 2
g = 9.81
[lagrangian]
kinetic = "m*l^2/2*der(th)^2"
potential = "m*g*l*cos(th)"
"#;
        let m = Model::from_source("p.toml", text).unwrap();
        assert_eq!(m.choices.len(), 1);
        assert_eq!(m.choices[0].name, "identity");
    }
}
