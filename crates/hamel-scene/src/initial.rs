//! The initial quasi-velocities of a scene: given, or projected from given velocities q̇.

use indexmap::IndexMap;
use serde::Serialize;

#[cfg(feature = "derive")]
use crate::file::{Initial, KeyedError};

/// The initial quasi-velocities: `eta` as given, or η = Z(q)w for the given q̇ projected onto
/// the constraints in the kinetic metric (w, [`hamel_oracle::project_kinetic`]), with the
/// projection's report. Errors: (the scene key, the reason).
#[cfg(feature = "derive")]
pub(crate) fn initial_eta(
    initial: &Initial,
    d: &hamel_derive::Derivation,
    numeric: &hamel_model::NumericModel<'_>,
    q: &[f64],
) -> Result<(Vec<f64>, Option<Projection>), KeyedError> {
    match (&initial.eta, &initial.q_dot) {
        (Some(eta), None) if eta.len() == d.sigma => Ok((eta.clone(), None)),
        (Some(eta), None) => Err((
            "initial.eta",
            format!("needs σ = {} values, found {}", d.sigma, eta.len()),
        )),
        (None, Some(v)) => {
            if let Some(extra) = v.keys().find(|k| !d.coordinates.contains(k)) {
                return Err((
                    "initial.q_dot",
                    format!("`{extra}` is not a coordinate of the model"),
                ));
            }
            let v: Vec<f64> = d
                .coordinates
                .iter()
                .map(|c| {
                    v.get(c).copied().ok_or((
                        "initial.q_dot",
                        format!("missing the velocity of `{c}` (give every coordinate's)"),
                    ))
                })
                .collect::<Result<_, _>>()?;
            let w = hamel_oracle::project_kinetic(numeric, q, &v)
                .map_err(|e| ("initial.q_dot", e.to_string()))?;
            let kinetic = |x: &[f64]| -> Result<f64, KeyedError> {
                let a = numeric
                    .mass_matrix::<f64>(q)
                    .map_err(|e| ("initial.q", e.to_string()))?;
                Ok(0.5
                    * (0..x.len())
                        .map(|i| (0..x.len()).map(|j| x[i] * a[i][j] * x[j]).sum::<f64>())
                        .sum::<f64>())
            };
            let z = numeric
                .quasi_velocity_matrix::<f64>(&d.eta_name, q)
                .map_err(|e| ("initial.q", e.to_string()))?;
            let eta = z
                .iter()
                .map(|row| row.iter().zip(&w).map(|(a, b)| a * b).sum())
                .collect();
            let projection = Projection {
                q_dot: d
                    .coordinates
                    .iter()
                    .cloned()
                    .zip(w.iter().copied())
                    .collect(),
                correction: v
                    .iter()
                    .zip(&w)
                    .map(|(a, b)| (a - b).abs())
                    .fold(0.0, f64::max),
                kinetic_before: kinetic(&v)?,
                kinetic_after: kinetic(&w)?,
            };
            Ok((eta, Some(projection)))
        }
        (Some(_), Some(_)) => Err((
            "initial",
            "give the initial velocities as `eta` or as `q_dot`, not both".into(),
        )),
        (None, None) => Err((
            "initial",
            "give the initial velocities as `eta = [...]` (σ values) or `q_dot = { ... }`".into(),
        )),
    }
}

/// How given initial velocities were made admissible.
#[derive(Clone, Debug, Serialize)]
pub struct Projection {
    /// The admissible velocities used (α(q)q̇ = 0).
    pub q_dot: IndexMap<String, f64>,
    /// max |q̇ given − q̇ used|.
    pub correction: f64,
    /// Kinetic energy of the given velocities.
    pub kinetic_before: f64,
    /// Kinetic energy of the ones used (never more).
    pub kinetic_after: f64,
}

/// A dependent coordinate of a holonomic constraint, completed from h(q) = 0 at the start.
#[derive(Clone, Debug, Serialize)]
pub struct Completed {
    /// The coordinate.
    pub coordinate: String,
    /// Its value in the scene (the Newton start), if given.
    pub given: Option<f64>,
    /// The value that satisfies the constraints with the other coordinates as given.
    pub value: f64,
}

/// Solve the model's holonomic constraints h(q) = 0 for their dependent coordinates (Newton,
/// from the values given, or 0), keeping the other coordinates of `q`. `given[k]`: whether the
/// scene gave q_k. Errors: which coordinates could not be completed, and why.
pub(crate) fn complete_initial(
    model: &hamel_model::Model,
    params: &IndexMap<String, f64>,
    q: &mut [f64],
    given: &[bool],
) -> Result<Vec<Completed>, String> {
    let c = &model.completion;
    if c.is_empty() {
        return Ok(Vec::new());
    }
    let start = q.to_vec();
    let names: Vec<&str> = c
        .dependent()
        .iter()
        .map(|&k| model.coordinates[k].as_str())
        .collect();
    c.complete(q, params).map_err(|e| {
        format!(
            "the holonomic constraints cannot be solved for {} from the coordinates given: {e}",
            names.join(", ")
        )
    })?;
    Ok(c.dependent()
        .iter()
        .map(|&k| Completed {
            coordinate: model.coordinates[k].clone(),
            given: given[k].then_some(start[k]),
            value: q[k],
        })
        .collect())
}
