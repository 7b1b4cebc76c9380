//! States in, right-hand sides out (`hamel eval`): η̇ (true and the paper's), q̇ and the energy
//! at states given as JSON, each with the precision its evaluation needed.
//!
//! **Input**: one state object or a list of them,
//! `{"q": {"x": 0.1, …}, "eta": [1.0, 0.5], "params": {"m": 2.0}, "functions": {"z13": "…"}}`
//! (`functions` defines a choice's free functions as expressions of their arguments).
//! The file is read and checked by [`hamel_model::states`] (no computer algebra there).
//! **Output**: the same shape, one result per state. Errors name the file, the state and the
//! reason; nothing is returned for a file with one bad state.

use std::collections::BTreeMap;

use hamel_model::states::State;
use hamel_model::{Model, ModelError};
use indexmap::IndexMap;
use serde::Serialize;

#[derive(Serialize)]
struct Out {
    eta_dot: Vec<f64>,
    q_dot: IndexMap<String, f64>,
    energy: f64,
    eta_dot_paper: Vec<f64>,
    /// `f64`, or `double_double` where f64 would have lost digits (docs/stability.md).
    #[serde(serialize_with = "hamel_eval::serialize_precision")]
    precision: crate::Precision,
    /// The estimate that decided it: the relative error an f64 evaluation may have here.
    f64_error_estimate: f64,
    /// λ by row of α (kept, then dropped), R = αᵀλ the constraints' generalised force: for a
    /// wheel's `NAME_no_slip_x` row, the contact force's x component (`hamel_eval::ConstraintForce`).
    #[serde(skip_serializing_if = "IndexMap::is_empty")]
    constraint_multipliers: IndexMap<String, f64>,
    /// The constraints' forces in physical components: each wheel's `NAME.longitudinal`,
    /// `NAME.lateral`, `NAME.normal`, each blade's `NAME.lateral`, every other row's multiplier
    /// (`hamel_eval::Contacts`).
    #[serde(skip_serializing_if = "IndexMap::is_empty")]
    constraint_forces: IndexMap<String, f64>,
    /// The components the motion does not determine (dependent rows: the split of a shared
    /// force; more wheels on one frame than three), not reported above.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    undetermined_forces: Vec<String>,
}

/// Evaluate every state of `text` (the JSON of the file named `file`) with the quasi-velocities
/// `eta` of `model`, and return the result as pretty JSON. The derivation comes from the
/// derivation store ([`crate::store`]) unless `fresh` (`--no-store`): then it is made anew and
/// replaces the stored one.
pub fn evaluate_json(
    model: &Model,
    eta: Option<&str>,
    file: &str,
    text: &str,
    fresh: bool,
) -> Result<String, ModelError> {
    let read = hamel_model::states::read(model, eta, file, text)?;
    let choice = model.choice(eta)?.name.clone();
    let source = std::sync::Arc::new(text.to_string());
    let err = |msg: String| ModelError::new(file, source.clone(), None, None, msg);
    let states = read.states;
    // One derivation per distinct set of free-function definitions.
    let mut derivations: Derivations = BTreeMap::new();
    let mut results = Vec::new();
    for (i, s) in states.iter().enumerate() {
        let tag = |m: String| err(format!("state {}: {m}", i + 1));
        if !derivations.contains_key(&s.functions) {
            let derived = derive_with(model, &choice, &s.functions, fresh, &tag)?;
            derivations.insert(s.functions.clone(), derived);
        }
        let (d, compiled) = &derivations[&s.functions];
        results.push(evaluate_state(d, compiled, s, &tag)?);
    }
    let json = if read.list {
        serde_json::to_string_pretty(&results)
    } else {
        serde_json::to_string_pretty(&results[0])
    };
    Ok(json.expect("serialisable") + "\n")
}

/// The derivations made so far, by their free functions' definitions.
type Derivations = BTreeMap<BTreeMap<String, String>, (crate::Derivation, crate::Compiled)>;

/// Derive and compile the choice with its free functions defined by `functions`.
fn derive_with(
    model: &Model,
    choice: &str,
    functions: &BTreeMap<String, String>,
    fresh: bool,
    tag: &dyn Fn(String) -> ModelError,
) -> Result<(crate::Derivation, crate::Compiled), ModelError> {
    let defs = hamel_model::states::functions(functions).map_err(&tag)?;
    let m = model
        .with_free_functions(choice, &defs)
        .map_err(|e| tag(e.message().to_string()))?;
    let c = m.choice(Some(choice))?;
    if !c.free_functions.is_empty() {
        let names: Vec<String> = c
            .free_functions
            .iter()
            .map(|(n, a)| format!("{n}({})", a.join(", ")))
            .collect();
        return Err(tag(format!(
            "quasi-velocity choice `{choice}` has free functions {}: give them under \"functions\", e.g. {{\"{}\": \"0.5*sin({})\"}}",
            names.join(", "),
            c.free_functions[0].0,
            c.free_functions[0].1[0]
        )));
    }
    // from the derivation store when it holds this derivation: no computer algebra then
    let options = crate::store::Options {
        supports: true,
        fresh,
    };
    let d = crate::store::derive_stored(&m, choice, options)?;
    let c = (d.compile_with_constraint_forces()).map_err(|e| tag(e.to_string()))?;
    Ok((d, c))
}

/// Evaluate one state.
fn evaluate_state(
    d: &crate::Derivation,
    compiled: &crate::Compiled,
    s: &State,
    tag: &dyn Fn(String) -> ModelError,
) -> Result<Out, ModelError> {
    let q = &s.q;
    let params = d
        .parameters_with(&s.params)
        .map_err(|e| tag(e.to_string()))?;
    let at = |e: crate::NumericError| {
        let at: Vec<String> = d
            .coordinates
            .iter()
            .zip(q)
            .map(|(c, v)| format!("{c} = {v}"))
            .collect();
        tag(format!("{e} (at {})", at.join(", ")))
    };
    let ev = compiled.evaluate(q, &s.eta, &params).map_err(&at)?;
    let pushed = (compiled.constraint_forces_checked(q, &s.eta, &params)).map_err(&at)?;
    Ok(Out {
        eta_dot: ev.eta_dot,
        q_dot: d.coordinates.iter().cloned().zip(ev.q_dot).collect(),
        energy: ev.energy,
        eta_dot_paper: ev.eta_dot_paper,
        precision: ev.precision,
        f64_error_estimate: ev.f64_error_estimate,
        constraint_multipliers: (d.row_names().into_iter().map(str::to_string))
            .zip(pushed.multipliers)
            .collect(),
        constraint_forces: (pushed.forces.into_iter())
            .map(|f| (f.name, f.value))
            .collect(),
        undetermined_forces: compiled.undetermined_constraint_forces().to_vec(),
    })
}
