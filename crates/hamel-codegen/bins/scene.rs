//! `scene`: the integration job of `hamel simulate`, run on this compiled core.
//!
//! Reads one job (JSON) on stdin: `{"t0", "times", "y0", "method", "options", "reference",
//! "energy", "residual", "repeat", "params"}` where `y0` is the reduced state (the kept coordinates in
//! model order, then η), `reference` the value at which the eliminated coordinates are held
//! when the energy needs a full configuration (the equations are free of them), and `repeat`
//! how many times to integrate for timing. Writes `{"solution", "error", "seconds"}` on
//! stdout: the solution of the last run (the part computed before a failure, if any), the
//! failure, and the median wall time of one integration. The parameters are those the core
//! was generated with (a scene's core is specialised for them).

use std::io::Read;
use std::time::Instant;

use hamel_generated::{
    COORDINATES, DIMS, ELIMINATED, HOLONOMIC, HOLONOMIC_USES, KEPT, Parameters, Prepared, REDUCED_DIM,
    energy, project, reduced_into_with, reduced_jacobian_with, residual_max,
};
use hamel_sim::{Method, OdeSystem, Options, SystemError};
use serde::Deserialize;
use serde_json::json;

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct Job {
    t0: f64,
    times: Vec<f64>,
    y0: Vec<f64>,
    method: Method,
    options: Options,
    reference: f64,
    energy: bool,
    residual: bool,
    #[serde(default = "one")]
    repeat: usize,
    /// Parameter values other than the defaults the core was generated with.
    #[serde(default)]
    params: std::collections::BTreeMap<String, f64>,
}

fn one() -> usize {
    1
}

struct Reduced {
    prep: Prepared,
    reference: f64,
    energy: bool,
    residual: bool,
}

impl Reduced {
    /// The full configuration: the kept coordinates from the state, the eliminated ones at
    /// the reference value.
    fn full_q(&self, y: &[f64]) -> [f64; DIMS.ell] {
        let mut q = [self.reference; DIMS.ell];
        for (i, &k) in KEPT.iter().enumerate() {
            q[k] = y[i];
        }
        q
    }
}

impl OdeSystem for Reduced {
    fn dim(&self) -> usize {
        REDUCED_DIM
    }
    fn rhs(&self, _t: f64, y: &[f64], dy: &mut [f64]) -> Result<(), SystemError> {
        reduced_into_with(y, dy, &self.prep).map_err(|e| SystemError::new(e.to_string()))
    }
    fn energy(&self, _t: f64, y: &[f64]) -> Option<f64> {
        if !self.energy {
            return None;
        }
        energy(&self.full_q(y), &y[KEPT.len()..], &self.prep.p).ok()
    }
    /// ‖α(q)q̇‖∞; requested, every coordinate is in the state (nothing eliminated).
    fn constraint_residual(&self, _t: f64, y: &[f64]) -> Option<f64> {
        if !self.residual || !ELIMINATED.is_empty() {
            return None;
        }
        residual_max(&self.full_q(y), &y[KEPT.len()..], &self.prep.p).ok()
    }
    /// Back onto the holonomic constraints, when the state holds every coordinate they
    /// mention (their dependent coordinates among them).
    fn project(&self, _t: f64, y: &mut [f64]) -> Option<Result<f64, SystemError>> {
        if HOLONOMIC == 0 || !HOLONOMIC_USES.iter().all(|k| KEPT.contains(k)) {
            return None;
        }
        let mut q = self.full_q(y);
        Some(
            project(&mut q, &self.prep.p)
                .map(|before| {
                    for (i, &k) in KEPT.iter().enumerate() {
                        y[i] = q[k];
                    }
                    before
                })
                .map_err(|e| SystemError::new(format!("projection onto the holonomic constraints: {e}"))),
        )
    }
    fn jacobian(&self, _t: f64, y: &[f64], jac: &mut [f64]) -> Option<Result<(), SystemError>> {
        Some(
            reduced_jacobian_with(y, &self.prep)
                .map(|j| {
                    for (i, row) in j.iter().enumerate() {
                        jac[i * REDUCED_DIM..(i + 1) * REDUCED_DIM].copy_from_slice(row);
                    }
                })
                .map_err(|e| SystemError::new(e.to_string())),
        )
    }
}

fn run() -> Result<String, String> {
    let mut text = String::new();
    std::io::stdin()
        .read_to_string(&mut text)
        .map_err(|e| format!("cannot read the job: {e}"))?;
    let job: Job = serde_json::from_str(&text).map_err(|e| format!("bad job: {e}"))?;
    if job.y0.len() != REDUCED_DIM {
        return Err(format!(
            "bad job: y0 has {} values, the state ({} kept of {:?}, then η) has {REDUCED_DIM}",
            job.y0.len(),
            KEPT.len(),
            COORDINATES
        ));
    }
    let mut p = Parameters::default();
    for (k, &v) in &job.params {
        p.set(k, v).map_err(|e| format!("bad job: {e}"))?;
    }
    let system = Reduced {
        prep: Prepared::new(&p).map_err(|e| e.to_string())?,
        reference: job.reference,
        energy: job.energy,
        residual: job.residual,
    };
    let mut seconds = Vec::new();
    let mut last = None;
    for _ in 0..job.repeat.max(1) {
        let start = Instant::now();
        let result =
            hamel_sim::integrate(&system, job.method, job.t0, &job.y0, &job.times, &job.options);
        seconds.push(start.elapsed().as_secs_f64());
        last = Some(result);
    }
    seconds.sort_by(f64::total_cmp);
    let (solution, error) = match last.expect("at least one run") {
        Ok(s) => (s, None),
        Err(e) => (*e.partial.clone(), Some(e.to_string())),
    };
    serde_json::to_string(&json!({
        "solution": solution,
        "error": error,
        "seconds": seconds[seconds.len() / 2],
    }))
    .map_err(|e| e.to_string())
}

fn main() {
    match run() {
        Ok(text) => println!("{text}"),
        Err(e) => {
            eprintln!("error: {e}");
            std::process::exit(2);
        }
    }
}
