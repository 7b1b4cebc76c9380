//! How hard the equations are to evaluate at a state, and where they become singular: the
//! yardsticks of the stability checks (docs/stability.md), used by the code generator to
//! choose a solved form and by the stability tests.
//!
//! * [`problem_condition`]: κ = ‖ Σ_j |∂η̇/∂x_j|·|x_j| ‖∞ / ‖η̇‖∞ over the inputs x = (q, η),
//!   exact derivatives by dual numbers over double-double. No f64 evaluation can promise a
//!   relative error below (κ + 1)·ε; hamel's evaluators promise [`STATED_MULTIPLE`] times that.
//! * [`singular_points`]: for each factor g of δ = det[Z; α] that depends on the coordinates,
//!   a configuration with g = 0, reached by Newton's method in double-double along the first
//!   coordinate g contains, from pseudo-random starts (deterministic).

use hamel_expr::{DD, Dual, Expr};
use indexmap::IndexMap;

use crate::derivation::Derivation;
use hamel_eval::{Compiled, NumericError};

/// The bound hamel states near singular configurations: a relative error of η̇ of at most
/// 32 (κ + 1)·ε, κ from [`problem_condition`].
pub const STATED_MULTIPLE: f64 = 32.0;

/// The problem's own condition number at (q, η) (see the module doc).
pub fn problem_condition(
    c: &Compiled,
    q: &[f64],
    eta: &[f64],
    params: &IndexMap<String, f64>,
) -> Result<f64, NumericError> {
    let x: Vec<f64> = q.iter().chain(eta).copied().collect();
    let mut sensitivity = vec![0.0_f64; eta.len()];
    let mut value = vec![0.0_f64; eta.len()];
    for j in 0..x.len() {
        let seeded: Vec<Dual<DD>> = x
            .iter()
            .enumerate()
            .map(|(i, &v)| Dual::new(DD::from_f64(v), DD::from_f64(f64::from(i == j))))
            .collect();
        let r = c.rhs::<Dual<DD>>(&seeded[..q.len()], &seeded[q.len()..], params)?;
        for (s, e) in sensitivity.iter_mut().zip(&r.eta_dot) {
            *s += e.d.to_f64().abs() * x[j].abs();
        }
        value = r.eta_dot.iter().map(|e| e.v.to_f64()).collect();
    }
    let max = |v: &[f64]| v.iter().fold(0.0_f64, |m, x| m.max(x.abs()));
    Ok(max(&sensitivity) / max(&value).max(f64::MIN_POSITIVE))
}

/// A configuration on the singular set of the quasi-velocities.
#[derive(Clone, Debug, PartialEq)]
pub struct SingularPoint {
    /// Index of the factor of δ in [`Derivation::singular_set`] (the closed form's).
    pub factor: usize,
    /// The configuration (every |q_k| < 10).
    pub q: Vec<f64>,
    /// The coordinate moved to reach it (and to leave it: [`SingularPoint::approach`]).
    pub coordinate: usize,
}

impl SingularPoint {
    /// Configurations at distance 10⁻ᵉ from it along its coordinate, on both sides, for each e.
    pub fn approach(&self, exponents: impl Iterator<Item = i32> + Clone) -> Vec<Vec<f64>> {
        [1.0, -1.0]
            .iter()
            .flat_map(|side| {
                exponents.clone().map(move |e| {
                    let mut q = self.q.clone();
                    q[self.coordinate] += side * 10f64.powi(-e);
                    q
                })
            })
            .collect()
    }
}

/// One point of each factor of δ that depends on the coordinates and has a real zero found
/// from up to 20 starts in (−3, 3)ℓ (`seed` fixes them); parameters at `params`.
pub fn singular_points(
    d: &Derivation,
    params: &IndexMap<String, f64>,
    seed: u64,
) -> Vec<SingularPoint> {
    let mut state = seed ^ 0x9e37_79b9_7f4a_7c15;
    let mut uniform = move || {
        // xorshift64*
        state ^= state >> 12;
        state ^= state << 25;
        state ^= state >> 27;
        (state.wrapping_mul(0x2545_f491_4f6c_dd1d) >> 11) as f64 / (1u64 << 53) as f64
    };
    let mut points = Vec::new();
    for (factor, g) in d.singular_set().iter().enumerate() {
        let Some(k) = d.coordinates.iter().position(|c| mentions(&g.expr, c)) else {
            continue;
        };
        for _ in 0..20 {
            let start: Vec<f64> = (0..d.ell).map(|_| 6.0 * uniform() - 3.0).collect();
            if let Some(q) = newton(&g.expr, &d.coordinates, params, start, k) {
                points.push(SingularPoint {
                    factor,
                    q,
                    coordinate: k,
                });
                break;
            }
        }
    }
    points
}

fn mentions(e: &Expr, name: &str) -> bool {
    e.any(&mut |x| matches!(x, Expr::Sym(s) if s == name))
}

/// Newton's method on g(q) = 0 in q_k, in double-double (80 steps at most); the root, if the
/// step fell below 1e-30 and the configuration stayed within |q| < 10.
fn newton(
    g: &Expr,
    coordinates: &[String],
    params: &IndexMap<String, f64>,
    start: Vec<f64>,
    k: usize,
) -> Option<Vec<f64>> {
    let mut q: Vec<DD> = start.into_iter().map(DD::from_f64).collect();
    for _ in 0..80 {
        let env = |name: &str| -> Option<Dual<DD>> {
            if let Some(i) = coordinates.iter().position(|c| c == name) {
                return Some(Dual::new(q[i], DD::from_f64(f64::from(i == k))));
            }
            params
                .get(name)
                .map(|&v| Dual::new(DD::from_f64(v), DD::from_f64(0.0)))
        };
        let v = g.eval::<Dual<DD>>(&env).ok()?;
        if v.d.to_f64() == 0.0 {
            return None;
        }
        let step = v.v / v.d;
        q[k] = q[k] - step;
        if step.to_f64().abs() < 1e-30 {
            let q: Vec<f64> = q.iter().map(|x| x.to_f64()).collect();
            return q.iter().all(|x| x.abs() < 10.0).then_some(q);
        }
    }
    None
}
