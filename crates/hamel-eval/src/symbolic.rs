//! The expanded symbolic equations evaluated as they are ([`SymbolicCompiled`]): A_Γ, the
//! forcing and the Q⁽ⁱ⁾_rs of (11), true and the paper's, on one tape. For checking the
//! symbolic forms (in higher precision); the structured form ([`crate::Compiled`]) is what
//! runs.

use hamel_expr::Tape;
use hamel_runtime::{Lu, Scalar};
use indexmap::IndexMap;

use crate::NumericError;

/// Where each block sits among the symbolic tape's outputs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SymbolicLayout {
    /// σ
    pub sigma: usize,
    /// A_Γ (σ×σ, row-major).
    pub a_gamma: usize,
    /// The forcing Γᵀ∇U (σ).
    pub forcing: usize,
    /// Q⁽ⁱ⁾_rs of the true equations (σ blocks σ×σ).
    pub q: usize,
    /// Q⁽ⁱ⁾_rs of the paper's equations (σ blocks σ×σ).
    pub q_paper: usize,
}

/// The expanded symbolic equations compiled for evaluation (checks of the symbolic forms).
#[derive(Clone, Debug)]
pub struct SymbolicCompiled {
    tape: Tape,
    free: Vec<String>,
    parameters: IndexMap<String, f64>,
    layout: SymbolicLayout,
}

impl SymbolicCompiled {
    /// The blocks on `tape` (inputs: coordinates, parameters, η1…ησ, then the free-function
    /// values named by `free`).
    pub fn new(
        tape: Tape,
        free: Vec<String>,
        parameters: IndexMap<String, f64>,
        layout: SymbolicLayout,
    ) -> SymbolicCompiled {
        SymbolicCompiled {
            tape,
            free,
            parameters,
            layout,
        }
    }

    /// Names of the free-function inputs (values of free functions and derivatives at q).
    pub fn free_inputs(&self) -> &[String] {
        &self.free
    }

    /// η̇ (true and paper's) from the expanded symbolic equations, with the free-function
    /// inputs in the order of [`SymbolicCompiled::free_inputs`].
    pub fn eta_dot<S: Scalar>(
        &self,
        q: &[S],
        eta: &[S],
        params: &IndexMap<String, f64>,
        free: &[S],
    ) -> Result<(Vec<S>, Vec<S>), NumericError> {
        let l = self.layout;
        let sigma = l.sigma;
        let mut inputs: Vec<S> = q.to_vec();
        inputs.extend(
            self.parameters
                .iter()
                .map(|(k, v)| S::constant(params.get(k).copied().unwrap_or(*v))),
        );
        inputs.extend(eta.iter().copied());
        inputs.extend(free.iter().copied());
        let out = self.tape.eval(&inputs)?;
        let a_gamma = out[l.a_gamma..l.a_gamma + sigma * sigma]
            .chunks(sigma.max(1))
            .map(<[S]>::to_vec)
            .collect();
        let lu = Lu::new(a_gamma).ok_or(NumericError::SingularAGamma)?;
        let solve = |at: usize| -> Vec<S> {
            let rhs: Vec<S> = (0..sigma)
                .map(|i| {
                    let base = at + i * sigma * sigma;
                    let mut qi = S::constant(0.0);
                    for r in 0..sigma {
                        for s in 0..sigma {
                            qi = qi + out[base + r * sigma + s] * eta[r] * eta[s];
                        }
                    }
                    out[l.forcing + i] - qi
                })
                .collect();
            lu.solve(&rhs)
        };
        Ok((solve(l.q), solve(l.q_paper)))
    }
}
