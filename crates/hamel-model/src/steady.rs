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
#[derive(Clone, Debug)]
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
