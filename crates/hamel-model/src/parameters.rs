//! `[parameters]`: names that are not coordinates, each with a finite default value, or with an
//! expression of other parameters (a derived parameter, such as `d1 = "(w + c)*cos(lambda) -
//! rR*sin(lambda)"`), evaluated in dependency order. `pi` is π in these expressions.

use std::ops::Range;

use hamel_expr::{Env, Expr};
use indexmap::IndexMap;
use toml::Spanned;

use crate::error::ModelError;
use crate::loader::{ErrorAt, Item, Site, is_eta_name, is_identifier, is_reserved};
use crate::schema::RawModel;

/// The parameters of a file.
pub(crate) struct Parameters {
    /// Every parameter's value, derived ones computed, in file order.
    pub values: IndexMap<String, f64>,
    /// The derived parameters' expressions.
    pub derived: IndexMap<String, Item>,
}

/// The parameters' values (derived ones computed) and the derived parameters' expressions.
pub(crate) fn parameters_of(
    raw: &RawModel,
    coordinates: &[String],
    err: &ErrorAt,
) -> Result<Parameters, ModelError> {
    let mut values = IndexMap::new();
    let mut pending: IndexMap<String, (Item, Range<usize>)> = IndexMap::new();
    for (k, v) in &raw.parameters {
        let key = format!("parameters.{k}");
        check_name(k, &key, v, coordinates, err)?;
        match v.get_ref() {
            toml::Value::Float(f) => values.insert(k.clone(), finite(*f, &key, v, err)?),
            toml::Value::Integer(i) => values.insert(k.clone(), *i as f64),
            toml::Value::String(text) => {
                let expr = hamel_expr::parse(text)
                    .map_err(|e| err(v.span(), &key, format!("syntax error: {}", e.message)))?
                    .expr;
                pending.insert(
                    k.clone(),
                    (derived_item(&key, text, expr, v.span()), v.span()),
                );
                None
            }
            other => {
                let found = other.type_str();
                let msg = format!(
                    "a parameter's default must be a number or an expression of other parameters, found {found}"
                );
                return Err(err(v.span(), &key, msg));
            }
        };
    }
    let derived: IndexMap<String, Item> = pending
        .iter()
        .map(|(k, (i, _))| (k.clone(), i.clone()))
        .collect();
    evaluate_in_order(&mut values, pending, raw, err)?;
    let mut ordered: IndexMap<String, f64> = raw
        .parameters
        .keys()
        .map(|k| (k.clone(), values[k]))
        .collect();
    for (k, v) in &raw.inputs {
        let key = format!("inputs.{k}");
        check_name(k, &key, v, coordinates, err)?;
        if ordered.contains_key(k) {
            return Err(err(v.span(), &key, format!("`{k}` is already a parameter")));
        }
        let value = match v.get_ref() {
            toml::Value::Float(f) => finite(*f, &key, v, err)?,
            toml::Value::Integer(i) => *i as f64,
            other => {
                let msg = format!(
                    "an input's default value must be a number, found {}",
                    other.type_str()
                );
                return Err(err(v.span(), &key, msg));
            }
        };
        ordered.insert(k.clone(), value);
    }
    Ok(Parameters {
        values: ordered,
        derived,
    })
}

fn check_name(
    k: &str,
    key: &str,
    v: &Spanned<toml::Value>,
    coordinates: &[String],
    err: &ErrorAt,
) -> Result<(), ModelError> {
    if !is_identifier(k) || is_reserved(k) || is_eta_name(k) {
        return Err(err(
            v.span(),
            key,
            format!("`{k}` cannot be a parameter name (reserved or not an identifier)"),
        ));
    }
    if coordinates.iter().any(|c| c == k) {
        return Err(err(v.span(), key, format!("`{k}` is already a coordinate")));
    }
    Ok(())
}

fn finite(f: f64, key: &str, v: &Spanned<toml::Value>, err: &ErrorAt) -> Result<f64, ModelError> {
    if f.is_finite() {
        Ok(f)
    } else {
        Err(err(
            v.span(),
            key,
            "a parameter's default must be finite".into(),
        ))
    }
}

fn derived_item(key: &str, text: &str, expr: Expr, span: Range<usize>) -> Item {
    let mut item = Item::synthetic(key, expr);
    item.text = text.to_string();
    item.site = Site {
        key: key.to_string(),
        span,
    };
    item
}

/// The values known so far, and π.
struct Known<'a>(&'a IndexMap<String, f64>);

impl Env<f64> for Known<'_> {
    fn symbol(&self, name: &str) -> Option<f64> {
        match name {
            "pi" => Some(std::f64::consts::PI),
            _ => self.0.get(name).copied(),
        }
    }
}

/// Evaluate the derived parameters, each once the ones it uses are known; an unknown name or a
/// cycle is an error at the first parameter that cannot be evaluated.
fn evaluate_in_order(
    values: &mut IndexMap<String, f64>,
    mut pending: IndexMap<String, (Item, Range<usize>)>,
    raw: &RawModel,
    err: &ErrorAt,
) -> Result<(), ModelError> {
    while !pending.is_empty() {
        let ready = pending.iter().position(|(_, (item, _))| {
            uses(&item.expr)
                .iter()
                .all(|n| n == "pi" || values.contains_key(n))
        });
        let Some(i) = ready else {
            let (k, (item, span)) = pending.first().expect("pending is not empty");
            let unknown: Vec<String> = uses(&item.expr)
                .into_iter()
                .filter(|n| n != "pi" && !values.contains_key(n))
                .collect();
            let why = if unknown.iter().all(|n| raw.parameters.contains_key(n)) {
                format!(
                    "the derived parameters depend on one another in a cycle (through {})",
                    unknown.join(", ")
                )
            } else {
                format!(
                    "unknown name(s) {}: a derived parameter may use only other parameters and pi",
                    unknown.join(", ")
                )
            };
            return Err(err(span.clone(), &format!("parameters.{k}"), why));
        };
        let (k, (item, span)) = pending.shift_remove_index(i).expect("index from position");
        let v = item
            .expr
            .eval(&Known(values))
            .map_err(|e| err(span.clone(), &format!("parameters.{k}"), e.to_string()))?;
        if !v.is_finite() {
            return Err(err(
                span,
                &format!("parameters.{k}"),
                format!("`{}` is not finite", item.text),
            ));
        }
        values.insert(k, v);
    }
    Ok(())
}

/// The symbols an expression uses (velocities and free functions count as unknown names).
fn uses(e: &Expr) -> Vec<String> {
    let mut names = Vec::new();
    e.visit(&mut |n| match n {
        Expr::Sym(s) => names.push(s.clone()),
        Expr::Der(q) => names.push(format!("der({q})")),
        Expr::Free { name, .. } => names.push(format!("{name}(…)")),
        _ => {}
    });
    names.sort();
    names.dedup();
    names
}

/// `NAME=VALUE` as given to `--set`: the name and a finite value, or why not.
pub fn parse_assignment(s: &str) -> Result<(String, f64), String> {
    let (name, value) = s
        .split_once('=')
        .ok_or_else(|| format!("`{s}`: write NAME=VALUE, such as v=5.0"))?;
    let v: f64 = value
        .trim()
        .parse()
        .map_err(|e| format!("`{s}`: the value `{value}` is not a number ({e})"))?;
    if !v.is_finite() {
        return Err(format!("`{s}`: the value must be finite"));
    }
    Ok((name.trim().to_string(), v))
}

/// Why parameter values could not be set.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum SetError {
    /// A name the model does not have.
    #[error("`{0}` is not a parameter or input of the model (they are: {1})")]
    Unknown(String, String),
    /// A derived parameter: its value follows from others.
    #[error("`{0}` is derived from other parameters (`{1}`): set those instead")]
    Derived(String, String),
    /// A value that is not finite, given or derived.
    #[error("`{0}` would be {1}")]
    NotFinite(String, f64),
}

impl crate::Model {
    /// The parameter values with `overrides` set (parameters or inputs by name) and every
    /// derived parameter evaluated again from them, in dependency order: what `--set` and a
    /// scene's `[parameters]` give. Setting a derived parameter is an error, unless its
    /// expression uses no other parameter (a constant written as an expression, such as the
    /// bicycle's `lambda = "pi/10"`): that one is a default like any number.
    pub fn parameter_values(
        &self,
        overrides: &IndexMap<String, f64>,
    ) -> Result<IndexMap<String, f64>, SetError> {
        let mut values = self.parameters.clone();
        let constant = |item: &Item| uses(&item.expr).iter().all(|n| n == "pi");
        for (k, &v) in overrides {
            if let Some(item) = self.derived.get(k).filter(|i| !constant(i)) {
                return Err(SetError::Derived(k.clone(), item.text.clone()));
            }
            if !values.contains_key(k) {
                let names = values.keys().cloned().collect::<Vec<_>>().join(", ");
                return Err(SetError::Unknown(k.clone(), names));
            }
            if !v.is_finite() {
                return Err(SetError::NotFinite(k.clone(), v));
            }
            values[k] = v;
        }
        if overrides.is_empty() {
            return Ok(values);
        }
        let set = |k: &String| overrides.contains_key(k);
        let mut pending: Vec<(&String, &Item)> =
            self.derived.iter().filter(|(k, _)| !set(k)).collect();
        let mut known: IndexMap<String, f64> = values
            .iter()
            .filter(|(k, _)| !self.derived.contains_key(*k) || set(k))
            .map(|(k, v)| (k.clone(), *v))
            .collect();
        while let Some(i) = pending.iter().position(|(_, item)| {
            uses(&item.expr)
                .iter()
                .all(|n| n == "pi" || known.contains_key(n))
        }) {
            let (k, item) = pending.remove(i);
            let v = item.expr.eval(&Known(&known)).unwrap_or(f64::NAN);
            if !v.is_finite() {
                return Err(SetError::NotFinite(k.clone(), v));
            }
            known.insert(k.clone(), v);
            values[k] = v;
        }
        Ok(values)
    }
}

#[cfg(test)]
mod set_tests {
    use super::SetError;
    use indexmap::IndexMap;

    const MODEL: &str = r#"
name = "m"
title = "t"
coordinates = ["x"]
[parameters]
a = 2.0
b = "2*a + c + k"
c = "a^2"
k = "3/4"
[lagrangian]
kinetic = "der(x)^2/2"
"#;

    #[test]
    fn setting_a_parameter_evaluates_the_derived_ones_again() {
        let m = crate::Model::from_source("m.toml", MODEL).unwrap();
        let k = 0.75;
        assert_eq!((m.parameters["b"], m.parameters["c"]), (8.0 + k, 4.0));
        let v = m
            .parameter_values(&IndexMap::from([("a".to_string(), 3.0)]))
            .unwrap();
        assert_eq!((v["a"], v["b"], v["c"]), (3.0, 15.0 + k, 9.0));
        // A constant written as an expression is a default like a number: it can be set, and
        // what uses it follows.
        let v = m
            .parameter_values(&IndexMap::from([("k".to_string(), 0.5)]))
            .unwrap();
        assert_eq!((v["k"], v["b"]), (0.5, 8.5));
        let set = |k: &str, x: f64| m.parameter_values(&IndexMap::from([(k.to_string(), x)]));
        assert!(matches!(set("c", 1.0), Err(SetError::Derived(..))));
        assert!(matches!(set("d", 1.0), Err(SetError::Unknown(..))));
        assert!(matches!(set("a", f64::NAN), Err(SetError::NotFinite(..))));
    }
}
