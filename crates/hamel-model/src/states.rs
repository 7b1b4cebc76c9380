//! State files, the input of `hamel eval`: one state object or a list of them,
//! `{"q": {"x": 0.1, …}, "eta": [1.0, 0.5], "params": {"m": 2.0}, "functions": {"z13": "…"}}`,
//! read and checked against a model and one of its quasi-velocity choices. `functions` defines
//! the choice's free functions as expressions of their arguments.
//!
//! Every error names the file, the state (by number) and the reason; a file with one bad state
//! gives no states. Nothing here needs the computer algebra: `hamel_derive::states` evaluates
//! what this reads.

use std::collections::BTreeMap;
use std::sync::Arc;

use indexmap::IndexMap;
use serde::Deserialize;

use crate::{Model, ModelError, QuasiVelocityChoice};

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawState {
    q: IndexMap<String, f64>,
    eta: Vec<f64>,
    #[serde(default)]
    params: IndexMap<String, f64>,
    #[serde(default)]
    functions: BTreeMap<String, String>,
}

/// One state, checked.
#[derive(Clone, Debug, PartialEq)]
pub struct State {
    /// Every coordinate's value, in the model's order.
    pub q: Vec<f64>,
    /// η, σ values.
    pub eta: Vec<f64>,
    /// Parameter values the state sets (each a parameter of the model).
    pub params: IndexMap<String, f64>,
    /// The choice's free functions as given (text, parsed and checked).
    pub functions: BTreeMap<String, String>,
}

/// The states of a file, and whether the file held a list (or one object).
#[derive(Clone, Debug, PartialEq)]
pub struct States {
    /// The file is a list of states.
    pub list: bool,
    /// The states, in order.
    pub states: Vec<State>,
}

/// Read the states of `text` (the JSON of the file named `file`) for the choice `eta` of
/// `model` (its first when `None`).
pub fn read(
    model: &Model,
    eta: Option<&str>,
    file: &str,
    text: &str,
) -> Result<States, ModelError> {
    let source = Arc::new(text.to_string());
    let err = |span: Option<std::ops::Range<usize>>, msg: String| {
        ModelError::new(file, source.clone(), span, None, msg)
    };
    let value: serde_json::Value = serde_json::from_str(text).map_err(|e| {
        let off = offset_of(text, e.line(), e.column());
        err(Some(off..off + 1), format!("invalid JSON: {e}"))
    })?;
    let (list, items) = match value {
        serde_json::Value::Array(v) => (true, v),
        v @ serde_json::Value::Object(_) => (false, vec![v]),
        _ => {
            return Err(err(
                None,
                "expected a state object or a list of state objects".into(),
            ));
        }
    };
    if items.is_empty() {
        return Err(err(None, "the list of states is empty".into()));
    }
    let choice = model.choice(eta)?;
    let mut states = Vec::with_capacity(items.len());
    for (i, v) in items.into_iter().enumerate() {
        let tag = |m: String| err(None, format!("state {}: {m}", i + 1));
        let raw: RawState = serde_json::from_value(v).map_err(|e| tag(e.to_string()))?;
        states.push(check(model, choice, raw).map_err(tag)?);
    }
    Ok(States { list, states })
}

/// One state against the model and the choice.
fn check(model: &Model, choice: &QuasiVelocityChoice, s: RawState) -> Result<State, String> {
    let q = model
        .coordinates
        .iter()
        .map(|c| {
            s.q.get(c)
                .copied()
                .ok_or_else(|| format!("missing coordinate `{c}` in \"q\""))
        })
        .collect::<Result<Vec<f64>, _>>()?;
    if let Some(extra) = s.q.keys().find(|k| !model.coordinates.contains(k)) {
        return Err(format!(
            "`{extra}` in \"q\" is not a coordinate of the model"
        ));
    }
    let sigma = choice.eta.len();
    if s.eta.len() != sigma {
        return Err(format!(
            "\"eta\" must have σ = {sigma} values, found {}",
            s.eta.len()
        ));
    }
    if let Some(k) = s.params.keys().find(|k| !model.parameters.contains_key(*k)) {
        return Err(format!("unknown parameter `{k}` in \"params\""));
    }
    model
        .with_free_functions(&choice.name, &functions(&s.functions)?)
        .map_err(|e| e.message().to_string())?;
    Ok(State {
        q,
        eta: s.eta,
        params: s.params,
        functions: s.functions,
    })
}

/// The free functions' definitions, parsed.
pub fn functions(
    defs: &BTreeMap<String, String>,
) -> Result<Vec<(String, hamel_expr::Expr)>, String> {
    defs.iter()
        .map(|(name, body)| {
            hamel_expr::parse(body)
                .map(|p| (name.clone(), p.expr))
                .map_err(|e| format!("functions.{name}: {}", e.message))
        })
        .collect()
}

fn offset_of(text: &str, line: usize, column: usize) -> usize {
    let mut off = 0;
    for (i, l) in text.split_inclusive('\n').enumerate() {
        if i + 1 == line {
            return off + column.saturating_sub(1).min(l.len());
        }
        off += l.len();
    }
    text.len()
}
