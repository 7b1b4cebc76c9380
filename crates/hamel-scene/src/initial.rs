//! A scene's initial state: the configuration completed on the holonomic constraints, and the
//! report of a projection of given velocities q̇ (made by the run engine, which derives).

use indexmap::IndexMap;
use serde::Serialize;

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
pub fn complete_initial(
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
