//! The initial quasi-velocities of a scene: given, or projected from given velocities q̇ (with
//! the scene language's report of the projection, [`Projection`]).

pub use hamel_scene::initial::*;

use hamel_scene::file::{Initial, KeyedError};

/// The initial quasi-velocities: `eta` as given, or η = Z(q)w for the given q̇ projected onto
/// the constraints in the kinetic metric (w, [`hamel_oracle::project_kinetic`]), with the
/// projection's report. Errors: (the scene key, the reason).
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
