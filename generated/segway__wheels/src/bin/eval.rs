//! `eval --state FILE|-`: the right-hand side at the given states, as `hamel eval` prints it.
//! Input: a state object `{"q": {name: value, …}, "eta": [..], "params": {name: value}}` or a
//! list of them. Output (stdout): `{"eta_dot", "q_dot", "energy", "eta_dot_paper",
//! "precision", "f64_error_estimate", "constraint_forces", "undetermined_forces"}` per state
//! (the last two when the core has the constraint forces' map, as `hamel eval` prints them).
//! A bad state is an error on stderr naming the state and the reason; nothing is printed.

use std::io::Read;

use hamel_generated::{
    CONSTRAINT_FORCES, COORDINATES, DIMS, Parameters, UNDETERMINED_FORCES, constraint_forces, full_rhs,
};
use serde::{Deserialize, Serialize};
use serde_json::{Map, Value};

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct State {
    q: Map<String, Value>,
    eta: Vec<f64>,
    #[serde(default)]
    params: Map<String, Value>,
}

#[derive(Serialize)]
struct Out {
    eta_dot: Vec<f64>,
    q_dot: InOrder,
    energy: f64,
    eta_dot_paper: Vec<f64>,
    precision: &'static str,
    f64_error_estimate: f64,
    #[serde(skip_serializing_if = "is_empty")]
    constraint_forces: InOrder,
    #[serde(skip_serializing_if = "<[_]>::is_empty")]
    undetermined_forces: &'static [&'static str],
}

fn is_empty(v: &InOrder) -> bool {
    v.0.is_empty()
}

/// q̇ by coordinate name, in the model's coordinate order (as `hamel eval` prints it).
struct InOrder(Vec<(&'static str, f64)>);

impl Serialize for InOrder {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        use serde::ser::SerializeMap;
        let mut m = s.serialize_map(Some(self.0.len()))?;
        for (k, v) in &self.0 {
            m.serialize_entry(k, v)?;
        }
        m.end()
    }
}

fn number(v: &Value, what: &str) -> Result<f64, String> {
    v.as_f64()
        .filter(|x| x.is_finite())
        .ok_or_else(|| format!("{what} must be a finite number"))
}

fn one(i: usize, v: Value) -> Result<Out, String> {
    let tag = |m: String| format!("state {}: {m}", i + 1);
    let s: State = serde_json::from_value(v).map_err(|e| tag(e.to_string()))?;
    let mut q = Vec::new();
    for c in COORDINATES {
        let v = s
            .q
            .get(c)
            .ok_or_else(|| tag(format!("missing coordinate `{c}` in \"q\"")))?;
        q.push(number(v, &format!("q.{c}")).map_err(tag)?);
    }
    if let Some(extra) = s.q.keys().find(|k| !COORDINATES.contains(&k.as_str())) {
        return Err(tag(format!("`{extra}` in \"q\" is not a coordinate of the model")));
    }
    if s.eta.len() != DIMS.sigma {
        return Err(tag(format!(
            "\"eta\" must have σ = {} values, found {}",
            DIMS.sigma,
            s.eta.len()
        )));
    }
    let mut p = Parameters::default();
    for (k, v) in &s.params {
        p.set(k, number(v, &format!("params.{k}")).map_err(tag)?)
            .map_err(|e| tag(e.to_string()))?;
    }
    let at = |e: hamel_generated::runtime::EvalError| {
        let at: Vec<String> = COORDINATES
            .iter()
            .zip(&q)
            .map(|(c, v)| format!("{c} = {v}"))
            .collect();
        tag(format!("{e} (at {})", at.join(", ")))
    };
    let r = full_rhs(&q, &s.eta, &p).map_err(at)?;
    let forces = constraint_forces(&q, &s.eta, &p).map_err(at)?;
    Ok(Out {
        eta_dot: r.eta_dot,
        q_dot: InOrder(COORDINATES.iter().copied().zip(r.q_dot).collect()),
        energy: r.energy,
        eta_dot_paper: r.eta_dot_paper,
        precision: r.precision.name(),
        f64_error_estimate: r.f64_error_estimate,
        constraint_forces: InOrder(CONSTRAINT_FORCES.iter().copied().zip(forces).collect()),
        undetermined_forces: &UNDETERMINED_FORCES,
    })
}

fn run() -> Result<String, String> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let path = match args.as_slice() {
        [flag, path] if flag == "--state" => path.clone(),
        _ => return Err("usage: eval --state FILE|-".into()),
    };
    let (name, text) = if path == "-" {
        let mut s = String::new();
        std::io::stdin()
            .read_to_string(&mut s)
            .map_err(|e| format!("<stdin>: cannot read: {e}"))?;
        ("<stdin>".to_string(), s)
    } else {
        let s = std::fs::read_to_string(&path).map_err(|e| format!("{path}: cannot read: {e}"))?;
        (path.clone(), s)
    };
    let value: Value = serde_json::from_str(&text)
        .map_err(|e| format!("{name}:{}:{}: invalid JSON: {e}", e.line(), e.column()))?;
    let (list, items) = match value {
        Value::Array(v) => (true, v),
        v @ Value::Object(_) => (false, vec![v]),
        _ => return Err(format!("{name}: expected a state object or a list of them")),
    };
    let mut out = Vec::new();
    for (i, v) in items.into_iter().enumerate() {
        out.push(one(i, v).map_err(|e| format!("{name}: {e}"))?);
    }
    let json = if list {
        serde_json::to_string_pretty(&out)
    } else {
        serde_json::to_string_pretty(&out[0])
    };
    Ok(json.map_err(|e| e.to_string())? + "\n")
}

fn main() {
    match run() {
        Ok(text) => print!("{text}"),
        Err(e) => {
            eprintln!("error: {e}");
            std::process::exit(1);
        }
    }
}
