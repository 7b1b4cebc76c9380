//! The resolved model: reading a file into a [`Model`], and what a model answers.

use std::ops::Range;
use std::path::Path;
use std::sync::Arc;

use hamel_expr::Expr;
use indexmap::IndexMap;
use toml::Spanned;

use hamel_bodies::{Completion, HolonomicConstraint};

use crate::error::ModelError;
use crate::loader::{
    Dynamics, ErrorAt, FieldKind, Item, Kinetic, Loader, Origin, Site, is_eta_name, is_identifier,
    is_reserved,
};
use crate::schema::{RawChoice, RawLagrangian, RawModel};

/// A named choice of quasi-velocities η = Z(q) q̇.
#[derive(serde::Serialize, serde::Deserialize, Clone, Debug)]
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
#[derive(serde::Serialize, serde::Deserialize, Clone, Copy, Debug, PartialEq, Eq)]
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
#[derive(serde::Serialize, serde::Deserialize, Clone, Debug)]
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
    /// Parameters and their default values (derived ones included, with the values of their
    /// expressions).
    pub parameters: IndexMap<String, f64>,
    /// Derived parameters: their expressions in the other parameters.
    pub derived: IndexMap<String, Item>,
    /// T or A.
    pub kinetic: Kinetic,
    /// U (L = T + U).
    pub potential: Item,
    /// The generalised forces F_k of the applied loads that U does not give (non-conservative,
    /// or driven by inputs), one per coordinate (0 where none): the equations of motion are
    /// d/dt ∂T/∂q̇ − ∂T/∂q = ∇U + F + αᵀλ. Functions of q, the velocities der(q) (viscous
    /// damping, drag, rolling resistance), the parameters and the inputs.
    pub forces: Vec<Item>,
    /// The named inputs (`[inputs]`: steer torque, pedalling): parameters whose values drive
    /// the system, listed in `parameters` with their defaults.
    pub inputs: Vec<String>,
    /// Constraints, rows of α: from the bodies (wheels, blades), then `[constraints]` in file
    /// order, then dh/dt = 0 for each holonomic constraint.
    /// The kept rows only: a maximal set independent at generic configurations, the first in
    /// the model's order (`rank`); σ = ℓ − μ with μ their number.
    pub constraints: Vec<(String, Item)>,
    /// The rows of α that depend on the kept ones (two wheels on one axle), dropped from
    /// `constraints`; their exact dependence is decided by the derivation.
    pub dependent: Vec<crate::DependentRow>,
    /// Holonomic constraints h(q) = 0 with their dependent coordinates (their velocity rows are
    /// among `constraints`).
    pub holonomic: Vec<HolonomicConstraint>,
    /// Solves the holonomic constraints for their dependent coordinates.
    pub completion: Completion,
    /// Where L and α come from.
    pub origin: Origin,
    /// `[abbreviations]`: names for expressions in the parameters, which printed equations use
    /// wherever the expression occurs (as a paper writes m = m_d + m_f + m_r once); printing
    /// only, the derivation never sees them.
    pub abbreviations: IndexMap<String, Item>,
    /// `positive = [...]`: parameters declared positive (masses, lengths, radii), as SymPy's
    /// `positive=True`; printing multiplies an equation through by a denominator it proves
    /// positive from them. Each is a parameter whose default is positive.
    pub positive: Vec<String>,
    /// What the expansion of bodies simplified, and how.
    pub notes: Vec<String>,
    /// Quasi-velocity choices, in file order.
    pub choices: Vec<QuasiVelocityChoice>,
    /// Vector fields claimed to be symmetries (`[symmetries]`, and those a model of bodies
    /// suggests), checked exactly where they are used (`hamel reduce`).
    pub symmetries: Vec<crate::Symmetry>,
    /// Steady motions (`[steady.NAME]`), in file order.
    pub steady: Vec<crate::Steady>,
    /// Parameters set at every evaluation instead of once (the time `t` of a scene's control
    /// law, inputs read from tables): code never folds them into constants
    /// ([`Model::controlled`]); empty for a model read from a file.
    pub live: Vec<String>,
    /// The scene's control this model closes the loop with, as text ([`crate::Control::text`];
    /// part of the key of cached code); empty for a model read from a file.
    pub control: String,
    /// How the forces of the wheels and blades are read off the multipliers of their rows of α
    /// (issue 58; empty for a model typed by hand, whose rows' multipliers are its forces). The
    /// supports of the wheels the frames keep on the ground are computed on demand
    /// ([`Model::with_supports`]).
    pub contact_forces: hamel_bodies::ContactForces,
    /// The mechanism a model of bodies describes (None for a model typed by hand).
    pub mechanism: Option<Arc<hamel_bodies::Mechanism>>,
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
        let crate::parameters::Parameters {
            values: parameters,
            derived,
        } = crate::parameters::parameters_of(&raw, &coordinates, &err)?;
        let mut loader = Loader::new(
            file,
            source.clone(),
            coordinates.clone(),
            parameters.clone(),
        );
        let dynamics = if crate::bodies::describes_bodies(&raw) {
            let mut d = crate::bodies::dynamics(&raw, &mut loader, &err)?;
            crate::shapes::attach(&raw.shapes, &mut d, &mut loader, &err)?;
            d
        } else {
            lagrangian_dynamics(&raw, &mut loader, &err)?
        };
        let mut forces = forces_of(&raw, &mut loader, &coordinates)?;
        for (f, load) in forces.iter_mut().zip(&dynamics.forces) {
            if f.expr == Expr::int(0) {
                *f = load.clone();
            } else if load.expr != Expr::int(0) {
                f.expr = hamel_expr::build::add(f.expr.clone(), load.expr.clone());
                f.text = f.expr.to_string();
            }
        }
        let mut symmetries = dynamics.symmetries;
        symmetries.extend(crate::symmetry::declared(&raw.symmetries, &mut loader)?);
        let mut constraints = dynamics.rows;
        constraints.extend(constraints_of(&raw, &mut loader)?);
        let steady = crate::steady::steady_of(&raw.steady, &loader)?;
        let abbreviations = abbreviations_of(&raw, &mut loader)?;
        let positive = positive_of(&raw, &loader, &parameters)?;
        let mut model = Model {
            file: file.to_string(),
            source: source.clone(),
            name: raw.name.get_ref().clone(),
            title: raw.title.get_ref().clone(),
            description: raw.description.clone(),
            coordinates,
            parameters,
            derived,
            kinetic: dynamics.kinetic,
            potential: dynamics.potential,
            forces,
            inputs: raw.inputs.keys().cloned().collect(),
            constraints,
            dependent: Vec::new(),
            holonomic: dynamics.holonomic,
            completion: dynamics.completion,
            origin: dynamics.origin,
            abbreviations,
            positive,
            notes: dynamics.notes,
            symmetries,
            steady,
            choices: Vec::new(),
            live: Vec::new(),
            control: String::new(),
            contact_forces: dynamics.contact_forces,
            mechanism: dynamics.mechanism,
        };
        model.split_dependent_rows()?;
        check_count(&raw, &model, &err)?;
        model.choices = choices_of(&raw, &mut loader, &model, &err)?;
        if model.constraints.is_empty() && !model.choices.iter().any(|c| c.name == "identity") {
            model.choices.push(identity_choice(&model.coordinates));
        }
        model.check_mass_matrix_numerically()?;
        if model.choices.is_empty() {
            let default = model.independent_velocities()?;
            model.choices.push(default);
        }
        Ok(model)
    }

    /// This model with the supports its constraint forces need ([`hamel_bodies::supports`]):
    /// what `hamel eval` and `hamel linearize` report the normal forces of wheels kept on the
    /// ground by the frames from. A model whose supports are there (or needs none) comes back
    /// as it is. Not for a closed loop (its laws are in F, not in the mechanism's loads).
    pub fn with_supports(&self) -> Result<Model, ModelError> {
        let mut m = self.clone();
        if m.contact_forces.released {
            return Ok(m);
        }
        let Some(mechanism) = &self.mechanism else {
            return Ok(m);
        };
        if !self.control.is_empty() {
            return Err(self.error(
                "the constraint forces of a closed loop are not computed yet (its laws are in the forces, not in the mechanism's loads)",
            ));
        }
        let supports = hamel_bodies::supports(mechanism, &self.parameters)
            .map_err(|e| self.error(format!("the wheels' supports: {e}")))?;
        m.contact_forces.supports = supports;
        m.contact_forces.released = true;
        Ok(m)
    }

    /// Whether some generalised force F_k is given (not identically the literal 0).
    pub fn has_forces(&self) -> bool {
        self.forces.iter().any(|f| f.expr != Expr::int(0))
    }

    /// Whether some generalised force depends on the velocities der(q): F(q, q̇), which the
    /// equations take as Γᵀ F(q, Γη).
    pub fn has_velocity_forces(&self) -> bool {
        self.forces.iter().any(|f| f.expr.has_velocity())
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

    /// The steady motion `name` (`[steady.NAME]`), or an error that lists the model's.
    pub fn steady(&self, name: &str) -> Result<&crate::Steady, ModelError> {
        self.steady.iter().find(|s| s.name == name).ok_or_else(|| {
            let names: Vec<&str> = self.steady.iter().map(|s| s.name.as_str()).collect();
            let e = self.error(format!("no steady motion named `{name}`"));
            if names.is_empty() {
                e.with_help("declare one in the model file: [steady.NAME] with `parameters`, `q` and `velocities` (docs/linearisation.md)")
            } else {
                e.with_help(format!("the model defines: {}", names.join(", ")))
            }
        })
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

/// The most coordinates a model may have: far above a mechanism's needs (the bicycle has 8),
/// low enough that no derivation of a model read exhausts the machine.
pub const MAX_COORDINATES: usize = 64;

/// `coordinates`: identifiers, not reserved, each once, at least one, at most
/// [`MAX_COORDINATES`].
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
    if coordinates.len() > MAX_COORDINATES {
        return Err(err(
            raw.coordinates.span(),
            "coordinates",
            format!(
                "the model has {} coordinates; hamel takes at most {MAX_COORDINATES}",
                coordinates.len()
            ),
        ));
    }
    Ok(coordinates)
}

/// `[lagrangian]`: the kinetic energy T, or the mass matrix A (ℓ × ℓ).
fn kinetic_of(
    lagrangian: &Spanned<RawLagrangian>,
    loader: &mut Loader,
    err: &ErrorAt,
) -> Result<Kinetic, ModelError> {
    let ell = loader.coordinates.len();
    let RawLagrangian {
        kinetic,
        mass_matrix,
        ..
    } = lagrangian.get_ref();
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
                lagrangian.span(),
                "lagrangian",
                "missing the kinetic energy: give `kinetic` (T) or `mass_matrix` (A)".into(),
            ));
        }
    })
}

/// L and α typed in by hand: `[lagrangian]`, and the rows of `[holonomic]`.
fn lagrangian_dynamics(
    raw: &RawModel,
    loader: &mut Loader,
    err: &ErrorAt,
) -> Result<Dynamics, ModelError> {
    let Some(lagrangian) = &raw.lagrangian else {
        return Err(err(
            0..0,
            "lagrangian",
            "missing [lagrangian] (T and U), or the bodies ([world], [frames], [bodies]) to derive them from".into(),
        ));
    };
    let kinetic = kinetic_of(lagrangian, loader, err)?;
    let potential = match &lagrangian.get_ref().potential {
        Some(u) => loader.item(u, "lagrangian.potential", FieldKind::Positional)?,
        None => Item::synthetic("lagrangian.potential", Expr::int(0)),
    };
    let h = crate::bodies::holonomic_of(raw, loader, err)?;
    if let Some((name, l)) = raw.loads.first() {
        let msg =
            "loads act on frames: a model typed by hand gives its generalised forces in [forces]";
        return Err(err(l.span(), &format!("loads.{name}"), msg.into()));
    }
    if let Some((name, s)) = raw.shapes.first() {
        let msg = "shapes are drawn on frames: a model typed by hand has none (describe it by bodies and frames to draw it)";
        return Err(err(s.span(), &format!("shapes.{name}"), msg.into()));
    }
    Ok(Dynamics {
        kinetic,
        potential,
        rows: h.rows,
        holonomic: h.constraints,
        completion: h.completion,
        origin: Origin::Lagrangian,
        forces: Vec::new(),
        notes: Vec::new(),
        symmetries: Vec::new(),
        contact_forces: hamel_bodies::ContactForces {
            released: true,
            ..hamel_bodies::ContactForces::default()
        },
        mechanism: None,
    })
}

/// `[forces]`: the generalised force along each coordinate named (0 for the others).
fn forces_of(
    raw: &RawModel,
    loader: &mut Loader,
    coordinates: &[String],
) -> Result<Vec<Item>, ModelError> {
    if let Some((k, v)) = raw.forces.iter().find(|(k, _)| !coordinates.contains(k)) {
        let key = format!("forces.{k}");
        let msg = format!(
            "`{k}` is not a coordinate: [forces] gives the generalised force along each coordinate ({})",
            coordinates.join(", ")
        );
        return Err(loader.err(v.span(), &key, &msg));
    }
    coordinates
        .iter()
        .map(|c| {
            let key = format!("forces.{c}");
            match raw.forces.get(c) {
                Some(v) => loader.item(v, &key, FieldKind::Force),
                None => Ok(Item::synthetic(&key, Expr::int(0))),
            }
        })
        .collect()
}

/// `positive = [...]`: each a parameter, once, whose default value is positive.
fn positive_of(
    raw: &RawModel,
    loader: &Loader,
    parameters: &IndexMap<String, f64>,
) -> Result<Vec<String>, ModelError> {
    let Some(list) = &raw.positive else {
        return Ok(Vec::new());
    };
    let mut out: Vec<String> = Vec::new();
    for name in list.get_ref() {
        let n = name.get_ref();
        let why = match parameters.get(n) {
            None => Some(format!("`{n}` is not a parameter of this model")),
            Some(_) if out.contains(n) => Some(format!("`{n}` is named twice")),
            Some(v) if v.is_nan() || *v <= 0.0 => Some(format!(
                "`{n}` is declared positive, but its default value is {v}"
            )),
            Some(_) => None,
        };
        if let Some(why) = why {
            return Err(loader.err(name.span(), "positive", why));
        }
        out.push(n.clone());
    }
    Ok(out)
}

/// `[abbreviations]`: each a new name for an expression in the parameters (no coordinate,
/// velocity or free function).
fn abbreviations_of(
    raw: &RawModel,
    loader: &mut Loader,
) -> Result<IndexMap<String, Item>, ModelError> {
    let mut out = IndexMap::new();
    for (k, v) in &raw.abbreviations {
        let key = format!("abbreviations.{k}");
        let taken = loader.coordinates.contains(k)
            || loader.parameters.contains_key(k)
            || raw
                .abbreviations
                .keys()
                .take_while(|j| *j != k)
                .any(|j| j == k);
        if !is_identifier(k) || taken {
            return Err(loader.err(
                v.span(),
                &key,
                format!("`{k}` must be a new identifier: it names an expression in the parameters, and is not a coordinate or a parameter"),
            ));
        }
        let item = loader.item(v, &key, FieldKind::Positional)?;
        let mut state = false;
        item.expr.visit(&mut |e| match e {
            Expr::Sym(n) if loader.coordinates.contains(n) => state = true,
            Expr::Der(_) | Expr::Free { .. } => state = true,
            _ => {}
        });
        if state {
            return Err(loader.err(
                v.span(),
                &key,
                "an abbreviation is an expression in the parameters only (no coordinate, velocity or function of them)",
            ));
        }
        out.insert(k.clone(), item);
    }
    Ok(out)
}

/// `[constraints]`: each linear in the velocities.
fn constraints_of(raw: &RawModel, loader: &mut Loader) -> Result<Vec<(String, Item)>, ModelError> {
    let mut constraints = Vec::new();
    for (k, v) in &raw.constraints {
        let key = format!("constraints.{k}");
        let item = loader.item(v, &key, FieldKind::Constraint)?;
        if !item.expr.has_velocity() {
            return Err(loader.err(
                v.span(),
                &key,
                "a constraint must involve the velocities der(q): it is α(q) q̇ = 0",
            ));
        }
        constraints.push((k.clone(), item));
    }
    Ok(constraints)
}

/// Fewer independent constraints than coordinates (ℓ > μ = rank α).
fn check_count(raw: &RawModel, model: &Model, err: &ErrorAt) -> Result<(), ModelError> {
    let (ell, mu) = (model.ell(), model.mu());
    if mu < ell {
        return Ok(());
    }
    let span = raw
        .constraints
        .values()
        .next()
        .map_or(raw.coordinates.span(), |v| v.span());
    Err(err(
        span,
        "constraints",
        format!(
            "there are {} for {ell} coordinates: need fewer constraints than coordinates (ℓ > μ)",
            if model.dependent.is_empty() {
                format!("{mu} constraints")
            } else {
                format!("{} constraints of rank {mu}", mu + model.dependent.len())
            }
        ),
    ))
}

/// `[quasi_velocities.NAME]`: σ = ℓ − μ rows each, with the free functions they use.
fn choices_of(
    raw: &RawModel,
    loader: &mut Loader,
    model: &Model,
    err: &ErrorAt,
) -> Result<Vec<QuasiVelocityChoice>, ModelError> {
    let (ell, mu) = (model.ell(), model.mu());
    let sigma = ell - mu;
    let dropped = match model.dependent.len() {
        0 => String::new(),
        n => format!(
            " (μ = rank α: {} rows, {n} of them dependent on the others)",
            mu + n
        ),
    };
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
                    "wrong number of quasi-velocities: need ℓ − μ = {ell} − {mu} = {sigma}{dropped}, found {}",
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

    /// `[abbreviations]`: names for parameter expressions, kept for printing; a name that is
    /// a parameter, or an expression with a coordinate, is a located error.
    #[test]
    fn abbreviations_are_parameter_expressions_with_new_names() {
        let with = |table: &str| format!("{KNIFE}\n[abbreviations]\n{table}\n");
        let m = Model::from_source("knife.toml", &with("ml = \"m*l + 2*m\"")).unwrap();
        assert_eq!(m.abbreviations["ml"].text, "m*l + 2*m");
        let e = bad(&with("m = \"2*l\""));
        assert!(e.to_string().contains("abbreviations.m"), "{e}");
        assert!(e.to_string().contains("must be a new identifier"), "{e}");
        let e = bad(&with("s = \"m*sin(theta)\""));
        assert!(e.to_string().contains("parameters only"), "{e}");
        let e = bad(&with("s = \"m*q\""));
        assert!(e.to_string().contains("unknown symbol `q`"), "{e}");
    }

    /// `positive = [...]`: parameters with positive defaults, each once; otherwise a located
    /// error naming the entry. `hamel expand` keeps the list.
    #[test]
    fn positive_parameters_are_parameters_with_positive_defaults() {
        let with = |list: &str| {
            KNIFE.replace(
                "coordinates = [\"x\", \"y\", \"theta\"]",
                &format!("coordinates = [\"x\", \"y\", \"theta\"]\npositive = [{list}]"),
            )
        };
        let m = Model::from_source("knife.toml", &with("\"m\", \"l\"")).unwrap();
        assert_eq!(m.positive, ["m", "l"]);
        let back = Model::from_source("k.toml", &m.to_lagrangian_toml()).unwrap();
        assert_eq!(back.positive, ["m", "l"]);
        for (list, why) in [
            ("\"theta\"", "`theta` is not a parameter"),
            ("\"m\", \"m\"", "`m` is named twice"),
        ] {
            let e = bad(&with(list));
            assert!(e.to_string().contains(why), "{e}");
            assert!(e.line_col().is_some_and(|(line, _)| line == 5), "{e}");
        }
        let e = bad(&with("\"m\"").replace("m = 1.0", "m = -1.0"));
        assert!(e.to_string().contains("its default value is -1"), "{e}");
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
