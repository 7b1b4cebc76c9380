//! Verner's 9(8) pair against DOP853 where it should win: tight tolerances on a fast motion
//! (the unicycle with rider falling, the generated right-hand side of `crates/hamel-models`).
//! Evaluation counts and errors are deterministic; times are not asserted.

use hamel_models::{Core, MODELS};
use hamel_sim::{Method, OdeSystem, Options, Solution, SystemError, integrate};

/// The unicycle's full state (q, η) and its solved form.
struct Unicycle(&'static Core);

impl OdeSystem for Unicycle {
    fn dim(&self) -> usize {
        self.0.dims.ell + self.0.dims.sigma
    }
    fn rhs(&self, _t: f64, y: &[f64], dy: &mut [f64]) -> Result<(), SystemError> {
        (self.0.full_into)(y, dy).map_err(|e| SystemError::new(e.to_string()))
    }
}

fn run(method: Method, tol: f64) -> Solution {
    let core = MODELS
        .iter()
        .find(|c| c.model == "unicycle_rider" && c.eta == "velocities")
        .expect("the unicycle's core");
    let y0 = [0.0, 0.0, 0.0, 0.0, 0.2, 0.1, 0.5, 3.0, 0.0, 0.0];
    let times: Vec<f64> = (0..41).map(|k| 0.05 * f64::from(k)).collect();
    let options = Options {
        rtol: tol,
        atol: tol,
        ..Options::default()
    };
    integrate(&Unicycle(core), method, 0.0, &y0, &times, &options).unwrap()
}

/// Largest difference over all outputs and components.
fn error(run: &Solution, reference: &Solution) -> f64 {
    run.y
        .iter()
        .zip(reference.y.iter())
        .flat_map(|(a, b)| a.iter().zip(b).map(|(x, y)| (x - y).abs()))
        .fold(0.0, f64::max)
}

#[test]
fn vern9_reaches_dop853s_error_with_fewer_evaluations() {
    let reference = run(Method::Dop853, 3e-15);
    // Observed: DOP853 at 1e-12 8.4e-10 in 7,349 evaluations; Vern9 at 1e-11 2.3e-10 in 5,540.
    let dop853 = run(Method::Dop853, 1e-12);
    let vern9 = run(Method::Vern9, 1e-11);
    let (e_dop, e_vern) = (error(&dop853, &reference), error(&vern9, &reference));
    let (n_dop, n_vern) = (dop853.stats.rhs_evals, vern9.stats.rhs_evals);
    assert!(
        e_vern <= e_dop,
        "errors: Vern9 {e_vern:e}, DOP853 {e_dop:e}"
    );
    assert!(
        (n_vern as f64) < 0.8 * n_dop as f64,
        "evaluations: Vern9 {n_vern}, DOP853 {n_dop}"
    );
}
