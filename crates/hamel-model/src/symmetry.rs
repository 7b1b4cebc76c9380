//! `[symmetries.NAME]`: vector fields ξ = Σ_k ξ_k ∂/∂q_k on the coordinates, declared in the
//! file (one key per coordinate it moves, the value an expression of q and the parameters,
//! such as `x = "-y"`), and those a model of bodies has by its construction
//! ([`hamel_bodies::vertical_rotation`]). They are claims: `hamel reduce` uses one only after
//! checking exactly that it leaves A, U, the constraints and the quasi-velocities invariant.

use hamel_expr::Expr;
use indexmap::IndexMap;
use toml::Spanned;

use crate::error::ModelError;
use crate::loader::{FieldKind, Item, Loader};

/// A vector field on the coordinates.
#[derive(serde::Serialize, serde::Deserialize, Clone, Debug)]
pub struct Symmetry {
    /// Its name (`[symmetries.NAME]`, or `vertical_rotation` from bodies).
    pub name: String,
    /// ξ_k of the coordinates it moves, in coordinate order (the others are 0).
    pub components: Vec<(String, Item)>,
    /// Declared in the file (else suggested by the bodies).
    pub declared: bool,
}

impl Symmetry {
    /// ξ as text, e.g. `∂yaw − y ∂x + x ∂y` written `yaw: 1, x: -y, y: x`.
    pub fn text(&self) -> String {
        self.components
            .iter()
            .map(|(q, e)| format!("{q}: {}", e.expr))
            .collect::<Vec<_>>()
            .join(", ")
    }
}

/// The declared symmetries, with located errors (an unknown coordinate, a syntax error, a
/// velocity, an empty field).
pub(crate) fn declared(
    raw: &IndexMap<String, Spanned<IndexMap<String, Spanned<String>>>>,
    loader: &mut Loader,
) -> Result<Vec<Symmetry>, ModelError> {
    let mut out = Vec::new();
    for (name, table) in raw {
        let key = format!("symmetries.{name}");
        if table.get_ref().is_empty() {
            return Err(loader.err(
                table.span(),
                &key,
                "a symmetry needs at least one component (`coordinate = \"expression\"`)",
            ));
        }
        let mut components = Vec::new();
        for q in loader.coordinates.clone() {
            let Some(v) = table.get_ref().get(&q) else {
                continue;
            };
            let item = loader.item(v, &format!("{key}.{q}"), FieldKind::Positional)?;
            components.push((q, item));
        }
        if let Some((k, v)) = table
            .get_ref()
            .iter()
            .find(|(k, _)| !loader.coordinates.contains(k))
        {
            return Err(loader.err(
                v.span(),
                &format!("{key}.{k}"),
                format!(
                    "`{k}` is not a coordinate: a symmetry's keys are the coordinates it moves"
                ),
            ));
        }
        out.push(Symmetry {
            name: name.clone(),
            components,
            declared: true,
        });
    }
    Ok(out)
}

/// The symmetries a model of bodies suggests, as items located at `span`.
pub(crate) fn from_bodies(
    found: &[hamel_bodies::Symmetry],
    span: std::ops::Range<usize>,
) -> Vec<Symmetry> {
    found
        .iter()
        .map(|s| Symmetry {
            name: s.name.clone(),
            components: s
                .components
                .iter()
                .map(|(q, e): (&String, &Expr)| {
                    let key = format!("symmetries.{}.{q}", s.name);
                    (q.clone(), Item::expanded(&key, e.clone(), span.clone()))
                })
                .collect(),
            declared: false,
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use crate::Model;

    const KNIFE: &str = r#"
name = "knife"
title = "test"
coordinates = ["x", "y", "theta"]
[parameters]
m = 0.5
[lagrangian]
kinetic = "m/2*(der(x)^2 + der(y)^2) + m/24*der(theta)^2"
potential = "0"
[constraints]
no_slip = "sin(theta)*der(x) - cos(theta)*der(y)"
"#;

    #[test]
    fn a_declared_symmetry_is_read_in_coordinate_order_and_written_back() {
        let text = format!("{KNIFE}[symmetries.turn]\ntheta = \"1\"\ny = \"x\"\nx = \"-y\"\n");
        let m = Model::from_source("knife.toml", &text).unwrap();
        assert_eq!(m.symmetries.len(), 1);
        let s = &m.symmetries[0];
        assert!(s.declared);
        assert_eq!(s.text(), "x: -y, y: x, theta: 1");
        let again = Model::from_source("again.toml", &m.to_lagrangian_toml()).unwrap();
        assert_eq!(again.symmetries[0].text(), s.text());
    }

    #[test]
    fn a_symmetry_on_an_unknown_coordinate_is_a_located_error() {
        let text = format!("{KNIFE}[symmetries.turn]\nphi = \"1\"\n");
        let e = Model::from_source("bad.toml", &text)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("symmetries.turn.phi") && e.contains("`phi` is not a coordinate"),
            "{e}"
        );
        let text = format!("{KNIFE}[symmetries.turn]\nx = \"der(y)\"\n");
        let e = Model::from_source("bad.toml", &text)
            .unwrap_err()
            .to_string();
        assert!(e.contains("symmetries.turn.x"), "{e}");
    }
}
