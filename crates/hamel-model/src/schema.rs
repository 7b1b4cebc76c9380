//! The raw TOML schema (what serde reads), before names are resolved.

use indexmap::IndexMap;
use serde::Deserialize;
use toml::Spanned;

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct RawModel {
    pub name: Spanned<String>,
    pub title: Spanned<String>,
    #[serde(default)]
    pub description: Option<String>,
    pub coordinates: Spanned<Vec<Spanned<String>>>,
    #[serde(default)]
    pub parameters: IndexMap<String, Spanned<toml::Value>>,
    pub lagrangian: Spanned<RawLagrangian>,
    #[serde(default)]
    pub constraints: IndexMap<String, Spanned<String>>,
    #[serde(default)]
    pub quasi_velocities: IndexMap<String, Spanned<RawChoice>>,
}

/// A matrix of expressions as rows of strings, each with its place in the file.
pub(crate) type RawMatrix = Vec<Spanned<Vec<Spanned<String>>>>;

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct RawLagrangian {
    pub kinetic: Option<Spanned<String>>,
    pub mass_matrix: Option<Spanned<RawMatrix>>,
    pub potential: Option<Spanned<String>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct RawChoice {
    pub eta: Spanned<Vec<Spanned<String>>>,
    #[serde(default)]
    pub description: Option<String>,
}
