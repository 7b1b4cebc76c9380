//! `[steady.NAME]`: steady motions, each a family in named steady parameters (such as the
//! forward speed v). A steady motion gives values to coordinates (`q`, the others 0 and the
//! dependent ones completed from the holonomic constraints) and to velocities (`velocities`,
//! the others solved from the constraints α(q)q̇ = 0), as expressions in the model's parameters
//! and its own. Whether it is steady is checked where it is used (`hamel linearize`).

use indexmap::IndexMap;
use toml::Spanned;

use crate::error::ModelError;
use crate::loader::{FieldKind, Item, Loader, Site, is_eta_name, is_identifier, is_reserved};
use crate::schema::{RawScalar, RawSteady};

/// A steady motion of the model.
#[derive(serde::Serialize, serde::Deserialize, Clone, Debug)]
pub struct Steady {
    /// Its name (`[steady.NAME]`).
    pub name: String,
    /// Free text.
    pub description: Option<String>,
    /// The steady parameters with their default values, in file order.
    pub parameters: IndexMap<String, f64>,
    /// Given coordinate values: (coordinate index, expression).
    pub q: Vec<(usize, Item)>,
    /// Given velocities der(q_k): (coordinate index, expression).
    pub velocities: Vec<(usize, Item)>,
    /// The table in the file.
    pub site: Site,
}

/// The steady motions of a file, with located errors (a parameter that shadows a name, a
/// value that is not a number, an unknown coordinate, an expression with velocities).
pub(crate) fn steady_of(
    raw: &IndexMap<String, Spanned<RawSteady>>,
    loader: &Loader,
) -> Result<Vec<Steady>, ModelError> {
    raw.iter()
        .map(|(name, table)| one(name, table, loader))
        .collect()
}

fn one(name: &str, table: &Spanned<RawSteady>, loader: &Loader) -> Result<Steady, ModelError> {
    let key = format!("steady.{name}");
    let t = table.get_ref();
    let parameters = steady_parameters(&key, &t.parameters, loader)?;
    let mut inner = loader.with_parameters(&parameters);
    let q = values(&format!("{key}.q"), &t.q, &mut inner)?;
    let velocities = values(&format!("{key}.velocities"), &t.velocities, &mut inner)?;
    Ok(Steady {
        name: name.to_string(),
        description: t.description.clone(),
        parameters,
        q,
        velocities,
        site: Site {
            key,
            span: table.span(),
        },
    })
}

fn steady_parameters(
    key: &str,
    raw: &IndexMap<String, Spanned<toml::Value>>,
    loader: &Loader,
) -> Result<IndexMap<String, f64>, ModelError> {
    let mut out = IndexMap::new();
    for (k, v) in raw {
        let key = format!("{key}.parameters.{k}");
        if !is_identifier(k) || is_reserved(k) || is_eta_name(k) {
            let msg = format!("`{k}` cannot be a parameter name (reserved or not an identifier)");
            return Err(loader.err(v.span(), &key, msg));
        }
        if loader.coordinates.contains(k) || loader.parameters.contains_key(k) {
            let msg = format!(
                "`{k}` is already a coordinate or a parameter of the model: a steady parameter needs a name of its own"
            );
            return Err(loader.err(v.span(), &key, msg));
        }
        let value = match v.get_ref() {
            toml::Value::Float(f) if f.is_finite() => *f,
            toml::Value::Integer(i) => *i as f64,
            other => {
                let msg = format!(
                    "a steady parameter's default must be a finite number, found {}",
                    other.type_str()
                );
                return Err(loader.err(v.span(), &key, msg));
            }
        };
        out.insert(k.clone(), value);
    }
    Ok(out)
}

fn values(
    key: &str,
    raw: &IndexMap<String, Spanned<RawScalar>>,
    loader: &mut Loader,
) -> Result<Vec<(usize, Item)>, ModelError> {
    let mut out = Vec::new();
    for (c, v) in raw {
        let key = format!("{key}.{c}");
        let Some(k) = loader.coordinates.iter().position(|x| x == c) else {
            let msg = format!(
                "`{c}` is not a coordinate of the model (coordinates: {})",
                loader.coordinates.join(", ")
            );
            return Err(loader.err(v.span(), &key, msg));
        };
        let text = Spanned::new(v.span(), v.get_ref().text());
        out.push((k, loader.item(&text, &key, FieldKind::Positional)?));
    }
    out.sort_by_key(|(k, _)| *k);
    Ok(out)
}

/// How the steady motion is known to be one (η̇ = 0 and the state's coordinates at rest).
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum SteadyCheck {
    /// Exactly: with the steady values substituted into the closed form of (11) and into
    /// α(q)q̇ = 0, every residual is zero on its canonical form, identically in the model's and
    /// the steady parameters (inputs at zero). Each point's numeric residual is still reported.
    Exact,
    /// Exactly refuted: these residuals are not identically zero, so the motion is steady at
    /// most for special parameter values; each point is checked numerically.
    NotIdentically {
        /// (the rate, its canonical form).
        residuals: Vec<(String, String)>,
    },
    /// Numerically at each point (1e-9 relative), because the exact check cannot be made.
    Numeric {
        /// Why not.
        why: String,
    },
}

impl SteadyCheck {
    /// One line for reports.
    pub fn text(&self) -> String {
        match self {
            SteadyCheck::Exact => {
                "proved exactly (canonical forms, identically in the parameters)".into()
            }
            SteadyCheck::NotIdentically { residuals } => {
                let r: Vec<String> = residuals
                    .iter()
                    .map(|(n, e)| format!("{n} = {e}"))
                    .collect();
                format!(
                    "not identically in the parameters ({}); checked numerically at each point",
                    r.join("; ")
                )
            }
            SteadyCheck::Numeric { why } => format!("checked numerically at each point ({why})"),
        }
    }
}
