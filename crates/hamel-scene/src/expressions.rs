//! A scene's `[expressions]`: named outputs defined as expressions of the coordinates, the
//! parameters and η, parsed and checked against the model, then compiled with the scene's
//! parameter values substituted exactly.

use hamel_model::{Coord, Model};
use indexmap::IndexMap;

/// One of the scene's requested `[expressions]`, its parameters substituted: its name and a
/// tape over (the ℓ coordinates, η).
pub struct OutputExpression {
    /// The expression's name (its key in `[expressions]`).
    pub name: String,
    /// Compiled over (the ℓ coordinates, η, then any parameters left free).
    pub tape: hamel_expr::Tape,
}

/// The full state an expression is evaluated on: the model's coordinates, then eta1…etaσ.
pub struct StateNames<'a> {
    /// The coordinates, in the model's order.
    pub coordinates: &'a [String],
    /// σ, the number of quasi-velocities.
    pub sigma: usize,
}

/// An expression parsed and checked against the model, before the parameters are substituted.
pub struct ParsedExpression {
    /// Its name (its key in `[expressions]`).
    pub name: String,
    expr: hamel_expr::Expr,
    /// The coordinates it uses.
    pub coordinates: Vec<Coord>,
}

/// Names a scene's outputs already use; an expression may not take one.
const RESERVED: [&str; 4] = ["eta", "energy", "constraint_residual", "t"];

/// Parse `[expressions]`: each a name (an identifier not already an output, coordinate or
/// parameter) and an expression of the coordinates, the parameters and eta1…etaσ, with the
/// model's grammar. Errors: (key, reason).
pub fn parse_expressions(
    table: &IndexMap<String, String>,
    model: &Model,
) -> Result<Vec<ParsedExpression>, (String, String)> {
    let sigma = model.coordinates.len() - model.constraints.len();
    let etas: Vec<String> = (1..=sigma).map(|i| format!("eta{i}")).collect();
    table
        .iter()
        .map(|(name, text)| {
            let key = format!("expressions.{name}");
            let identifier = name.chars().next().is_some_and(|c| c.is_ascii_alphabetic())
                && name.chars().all(|c| c.is_ascii_alphanumeric() || c == '_');
            if !identifier {
                return Err((key, format!("`{name}` is not a name (letters, digits, _; a letter first)")));
            }
            if RESERVED.contains(&name.as_str())
                || etas.contains(name)
                || model.coordinates.contains(name)
                || model.parameters.contains_key(name)
            {
                return Err((
                    key,
                    format!("`{name}` is already a coordinate, parameter or output of this scene: choose another name"),
                ));
            }
            let parsed = hamel_expr::parse(text).map_err(|e| {
                (key.clone(), format!("cannot parse `{text}`: {e}"))
            })?;
            for o in &parsed.occurrences {
                let known = model.coordinates.contains(&o.name)
                    || model.parameters.contains_key(&o.name)
                    || etas.contains(&o.name);
                match &o.kind {
                    hamel_expr::OccurrenceKind::Symbol if known => {}
                    hamel_expr::OccurrenceKind::Symbol => {
                        return Err((
                            key,
                            format!(
                                "unknown name `{}` in `{text}`: an expression may use the coordinates ({}), the parameters ({}) and {}",
                                o.name,
                                model.coordinates.join(", "),
                                model.parameters.keys().cloned().collect::<Vec<_>>().join(", "),
                                if sigma == 1 { "eta1".to_string() } else { format!("eta1..eta{sigma}") }
                            ),
                        ));
                    }
                    hamel_expr::OccurrenceKind::Velocity => {
                        return Err((
                            key,
                            format!("`der({})` in `{text}`: an output expression takes coordinates, parameters and η (velocities are η's business: write them with eta1…)", o.name),
                        ));
                    }
                    hamel_expr::OccurrenceKind::FreeFunction(_) => {
                        return Err((
                            key,
                            format!("`{}` in `{text}` is not a built-in function", o.name),
                        ));
                    }
                }
            }
            let coordinates = (model.coords())
                .filter(|&k| {
                    (parsed.occurrences.iter()).any(|o| o.name == model.coordinate_name(k))
                })
                .collect();
            Ok(ParsedExpression {
                name: name.clone(),
                expr: parsed.expr,
                coordinates,
            })
        })
        .collect()
}

impl ParsedExpression {
    /// The names of the coordinates the expression uses (of the model's `coordinates`).
    pub fn coordinate_names(&self, coordinates: &[String]) -> Vec<String> {
        self.coordinates
            .iter()
            .map(|&k| coordinates[k.index()].clone())
            .collect()
    }

    /// Substitute the scene's parameter values (exact: dyadic rationals, constants folded)
    /// and compile over (the coordinates, eta1…).
    pub fn specialised(
        &self,
        params: &IndexMap<String, f64>,
        state: &StateNames,
    ) -> Result<OutputExpression, (String, String)> {
        self.specialised_over(params, &[], state)
    }

    /// [`Self::specialised`] with the parameters `free` left as inputs, after the coordinates
    /// and eta1… (an ensemble's members that vary them).
    pub fn specialised_over(
        &self,
        params: &IndexMap<String, f64>,
        free: &[String],
        state: &StateNames,
    ) -> Result<OutputExpression, (String, String)> {
        let key = format!("expressions.{}", self.name);
        let mut values = std::collections::HashMap::new();
        for (name, &v) in params.iter().filter(|(n, _)| !free.contains(n)) {
            let r = hamel_expr::rational_of_f64(v).ok_or_else(|| {
                (
                    key.clone(),
                    format!("parameter `{name}` = {v} is not finite"),
                )
            })?;
            values.insert(name.clone(), r);
        }
        let expr = self.expr.specialise(&values);
        let inputs: Vec<String> = state
            .coordinates
            .iter()
            .cloned()
            .chain((1..=state.sigma).map(|i| format!("eta{i}")))
            .chain(free.iter().cloned())
            .collect();
        let tape = hamel_expr::Tape::compile(&[&expr], &inputs)
            .map_err(|e| (key, format!("cannot compile: {e}")))?;
        Ok(OutputExpression {
            name: self.name.clone(),
            tape,
        })
    }
}
