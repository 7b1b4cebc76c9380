//! `simulate --state FILE|- --t-end T [--outputs N] [--method M] [--rtol R] [--atol A]
//! [--step H] [--reduced]`: integrate from one state (the `eval` state format) and print the
//! trajectory as JSON (`{"t", "q": {name: [...]}, "eta": [[...]], "energy", "stats",
//! "complete"}`), with a one-line summary on stderr. `--reduced` integrates the reduced state
//! (kept coordinates and η) only, with the generated Jacobian for Gauss–Legendre; the
//! eliminated coordinates and the energy are then omitted.
//! A singularity stops the run: the rows computed so far are printed with `"complete": false`
//! and an `"error"`, and the exit status is 1.

use std::io::Read;

use hamel_generated::{
    COORDINATES, DIMS, KEPT, Parameters, Prepared, REDUCED_DIM, energy, energy_many, full_into_with,
    reduced_into_with, reduced_jacobian_with,
};
use hamel_sim::{Method, OdeSystem, Options, SystemError};
use serde::Deserialize;
use serde_json::{Map, Value, json};

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct State {
    q: Map<String, Value>,
    eta: Vec<f64>,
    #[serde(default)]
    params: Map<String, Value>,
}

struct Full(Prepared);
struct Reduced(Prepared);

impl OdeSystem for Full {
    fn dim(&self) -> usize {
        DIMS.ell + DIMS.sigma
    }
    fn rhs(&self, _t: f64, y: &[f64], dy: &mut [f64]) -> Result<(), SystemError> {
        full_into_with(y, dy, &self.0).map_err(|e| SystemError::new(e.to_string()))
    }
    fn energy(&self, _t: f64, y: &[f64]) -> Option<f64> {
        energy(&y[..DIMS.ell], &y[DIMS.ell..], &self.0.p).ok()
    }
    fn energies(&self, _t: &[f64], rows: &[f64], out: &mut [Option<f64>]) {
        energy_many(rows, &self.0.p, out);
    }
}

impl OdeSystem for Reduced {
    fn dim(&self) -> usize {
        REDUCED_DIM
    }
    fn rhs(&self, _t: f64, y: &[f64], dy: &mut [f64]) -> Result<(), SystemError> {
        reduced_into_with(y, dy, &self.0).map_err(|e| SystemError::new(e.to_string()))
    }
    /// The generated Jacobian (dual numbers), for the implicit Gauss–Legendre method.
    fn jacobian(&self, _t: f64, y: &[f64], jac: &mut [f64]) -> Option<Result<(), SystemError>> {
        Some(
            reduced_jacobian_with(y, &self.0)
                .map(|j| {
                    for (i, row) in j.iter().enumerate() {
                        jac[i * REDUCED_DIM..(i + 1) * REDUCED_DIM].copy_from_slice(row);
                    }
                })
                .map_err(|e| SystemError::new(e.to_string())),
        )
    }
}

fn flag<'a>(args: &'a [String], name: &str) -> Option<&'a str> {
    args.iter()
        .position(|a| a == name)
        .and_then(|i| args.get(i + 1))
        .map(String::as_str)
}

fn number(args: &[String], name: &str, default: Option<f64>) -> Result<f64, String> {
    match flag(args, name) {
        Some(v) => v
            .parse::<f64>()
            .ok()
            .filter(|x| x.is_finite())
            .ok_or_else(|| format!("{name} must be a finite number, got `{v}`")),
        None => default.ok_or_else(|| format!("{name} is required")),
    }
}

fn run() -> Result<(String, Option<String>), String> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let path = flag(&args, "--state").ok_or("usage: simulate --state FILE|- --t-end T [--outputs N] [--method dop853|dopri5|vern9|rk4|gauss-legendre] [--rtol R] [--atol A] [--step H] [--reduced]")?;
    let text = if path == "-" {
        let mut s = String::new();
        std::io::stdin()
            .read_to_string(&mut s)
            .map_err(|e| format!("<stdin>: cannot read: {e}"))?;
        s
    } else {
        std::fs::read_to_string(path).map_err(|e| format!("{path}: cannot read: {e}"))?
    };
    let s: State = serde_json::from_str(&text).map_err(|e| format!("{path}: {e}"))?;
    let mut p = Parameters::default();
    for (k, v) in &s.params {
        let v = v.as_f64().ok_or_else(|| format!("{path}: params.{k} must be a number"))?;
        p.set(k, v).map_err(|e| format!("{path}: {e}"))?;
    }
    let mut q = Vec::new();
    for c in COORDINATES {
        let v = s
            .q
            .get(c)
            .and_then(Value::as_f64)
            .ok_or_else(|| format!("{path}: missing coordinate `{c}` in \"q\""))?;
        q.push(v);
    }
    if s.eta.len() != DIMS.sigma {
        return Err(format!("{path}: \"eta\" must have σ = {} values", DIMS.sigma));
    }
    let t_end = number(&args, "--t-end", None)?;
    let n = number(&args, "--outputs", Some(101.0))? as usize;
    if n < 2 || t_end == 0.0 {
        return Err("need --outputs ≥ 2 and --t-end ≠ 0".into());
    }
    let times: Vec<f64> = (0..n).map(|i| t_end * i as f64 / (n - 1) as f64).collect();
    let method = match flag(&args, "--method").unwrap_or("dop853") {
        "dop853" => Method::Dop853,
        "dopri5" => Method::Dopri5,
        "vern9" => Method::Vern9,
        "taylor" => Method::Taylor,
        "rk4" => Method::Rk4 {
            step: number(&args, "--step", None)?,
        },
        "gauss-legendre" => Method::GaussLegendre {
            stages: 3,
            step: flag(&args, "--step").map(|_| number(&args, "--step", None)).transpose()?,
        },
        other => return Err(format!("unknown method `{other}`")),
    };
    let options = Options {
        rtol: number(&args, "--rtol", Some(1e-10))?,
        atol: number(&args, "--atol", Some(1e-12))?,
        ..Options::default()
    };
    let reduced = args.iter().any(|a| a == "--reduced");
    let (names, y0): (Vec<&str>, Vec<f64>) = if reduced {
        (
            KEPT.iter().map(|&k| COORDINATES[k]).collect(),
            KEPT.iter().map(|&k| q[k]).chain(s.eta.iter().copied()).collect(),
        )
    } else {
        (
            COORDINATES.to_vec(),
            q.iter().chain(&s.eta).copied().collect(),
        )
    };
    let p = Prepared::new(&p).map_err(|e| format!("{path}: {e}"))?;
    let result = if reduced {
        hamel_sim::integrate(&Reduced(p), method, 0.0, &y0, &times, &options)
    } else {
        hamel_sim::integrate(&Full(p), method, 0.0, &y0, &times, &options)
    };
    let (sol, error) = match result {
        Ok(sol) => (sol, None),
        Err(e) => (*e.partial.clone(), Some(e.to_string())),
    };
    let nq = names.len();
    let q_out: Map<String, Value> = names
        .iter()
        .enumerate()
        .map(|(i, c)| (c.to_string(), json!(sol.y.iter().map(|y| y[i]).collect::<Vec<_>>())))
        .collect();
    let out = json!({
        "t": sol.t,
        "q": q_out,
        "eta": sol.y.iter().map(|y| y[nq..].to_vec()).collect::<Vec<_>>(),
        "energy": if reduced { Value::Null } else { json!(sol.energy) },
        "stats": sol.stats,
        "complete": error.is_none() && sol.complete,
        "error": error,
    });
    eprintln!(
        "{} steps ({} rejected), {} RHS evaluations, energy drift {}",
        sol.stats.steps,
        sol.stats.rejected,
        sol.stats.rhs_evals,
        sol.stats.energy_drift.map_or("n/a".into(), |x| format!("{x:.2e}"))
    );
    Ok((
        serde_json::to_string_pretty(&out).map_err(|e| e.to_string())? + "\n",
        error,
    ))
}

fn main() {
    match run() {
        Ok((text, error)) => {
            print!("{text}");
            if let Some(e) = error {
                eprintln!("error: {e}");
                std::process::exit(1);
            }
        }
        Err(e) => {
            eprintln!("error: {e}");
            std::process::exit(1);
        }
    }
}
