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
use serde::{Deserialize, Serialize};

/// What `hamel eval` evaluates at states: the equations compiled with their constraint forces'
/// map, and the names of α's rows (kept, then dependent), as plain data: the derivation store
/// keeps it beside the derivation, so that a stored evaluation decodes no expression tree.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Evaluator {
    compiled: hamel_eval::CompiledData,
    row_names: Vec<String>,
}

impl Evaluator {
    /// The evaluator of `d` (its constraint forces' map where its supports are released).
    pub fn of(d: &crate::Derivation) -> Result<Evaluator, crate::NumericError> {
        Ok(Evaluator {
            compiled: d.compile_with_constraint_forces()?.to_data_with_contacts(),
            row_names: d.row_names().into_iter().map(str::to_string).collect(),
        })
    }
}

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
/// `eta` of `model`, and return the result as pretty JSON. `derive` makes the [`Evaluator`] of
/// a model (its free functions defined) for a choice, with the supports of its wheels released
/// (`hamel eval` takes it from the derivation store: `hamel_reduce::pass::obtain`).
pub fn evaluate_json(
    model: &Model,
    eta: Option<&str>,
    file: &str,
    text: &str,
    derive: &Derive,
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
            let derived = derive_with(model, &choice, &s.functions, derive, &tag)?;
            derivations.insert(s.functions.clone(), derived);
        }
        results.push(evaluate_state(&derivations[&s.functions], s, &tag)?);
    }
    let json = if read.list {
        serde_json::to_string_pretty(&results)
    } else {
        serde_json::to_string_pretty(&results[0])
    };
    Ok(json.expect("serialisable") + "\n")
}

/// The derivations made so far, by their free functions' definitions.
/// How [`evaluate_json`] gets an evaluator: of the model, for the choice, supports released.
pub type Derive = dyn Fn(&Model, &str) -> Result<Evaluator, ModelError>;

/// A compiled evaluator and its rows' names.
struct Ready {
    compiled: crate::Compiled,
    row_names: Vec<String>,
}

type Derivations = BTreeMap<BTreeMap<String, String>, Ready>;

/// Derive and compile the choice with its free functions defined by `functions`.
fn derive_with(
    model: &Model,
    choice: &str,
    functions: &BTreeMap<String, String>,
    derive: &Derive,
    tag: &dyn Fn(String) -> ModelError,
) -> Result<Ready, ModelError> {
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
    let Evaluator {
        compiled,
        row_names,
    } = derive(&m, choice)?;
    let compiled = crate::Compiled::from_data(compiled).map_err(|e| tag(e.to_string()))?;
    Ok(Ready {
        compiled,
        row_names,
    })
}

/// Evaluate one state.
fn evaluate_state(
    ready: &Ready,
    s: &State,
    tag: &dyn Fn(String) -> ModelError,
) -> Result<Out, ModelError> {
    let (compiled, q) = (&ready.compiled, &s.q);
    let params = (compiled.parameters_with(&s.params)).map_err(|e| tag(e.to_string()))?;
    let coordinates = compiled.coordinates();
    let at = |e: crate::NumericError| {
        let at: Vec<String> = (coordinates.iter().zip(q))
            .map(|(c, v)| format!("{c} = {v}"))
            .collect();
        tag(format!("{e} (at {})", at.join(", ")))
    };
    let ev = compiled.evaluate(q, &s.eta, &params).map_err(&at)?;
    let pushed = (compiled.constraint_forces_checked(q, &s.eta, &params)).map_err(&at)?;
    Ok(Out {
        eta_dot: ev.eta_dot,
        q_dot: coordinates.iter().cloned().zip(ev.q_dot).collect(),
        energy: ev.energy,
        eta_dot_paper: ev.eta_dot_paper,
        precision: ev.precision,
        f64_error_estimate: ev.f64_error_estimate,
        constraint_multipliers: (ready.row_names.iter().cloned())
            .zip(pushed.multipliers)
            .collect(),
        constraint_forces: (pushed.forces.into_iter())
            .map(|f| (f.name, f.value))
            .collect(),
        undetermined_forces: compiled.undetermined_constraint_forces().to_vec(),
    })
}
