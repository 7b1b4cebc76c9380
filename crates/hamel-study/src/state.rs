//! The steady state at a point, in any scalar type: dual numbers in a steady parameter give the
//! steady family's tangent exactly.

use hamel_expr::{Env, Scalar};
use indexmap::IndexMap;

use crate::{Study, StudyError};

/// The steady parameters (in the scalar type) and the model's parameters (constants).
struct SteadyEnv<'a, S> {
    names: Vec<&'a str>,
    s: &'a [S],
    params: &'a IndexMap<String, f64>,
}

impl<S: Scalar> Env<S> for SteadyEnv<'_, S> {
    fn symbol(&self, name: &str) -> Option<S> {
        match self.names.iter().position(|n| *n == name) {
            Some(i) => Some(self.s[i]),
            None => self.params.get(name).map(|&v| S::constant(v)),
        }
    }
}

/// The full steady state: every coordinate, every velocity, η.
#[derive(Clone, Debug)]
pub(crate) struct Full<S> {
    pub q: Vec<S>,
    pub q_dot: Vec<S>,
    pub eta: Vec<S>,
}

/// The steady configuration in f64 with the holonomic constraints solved, and the dependent
/// coordinates' first-order dependence on the others there (∂q_d/∂q_k, the implicit function
/// theorem): computed once per point, used by every scalar type.
#[derive(Clone, Debug)]
pub(crate) struct Completed {
    pub q: Vec<f64>,
    pub sensitivity: Vec<Vec<f64>>,
}

impl Study {
    fn env<'a, S: Scalar>(
        &'a self,
        params: &'a IndexMap<String, f64>,
        s: &'a [S],
    ) -> SteadyEnv<'a, S> {
        SteadyEnv {
            names: self.steady.parameters.keys().map(String::as_str).collect(),
            s,
            params,
        }
    }

    /// The coordinates given (others 0), in the scalar type.
    fn given_q<S: Scalar>(&self, env: &SteadyEnv<'_, S>) -> Result<Vec<S>, StudyError> {
        let mut q = vec![S::constant(0.0); self.model.coordinates.len()];
        for (k, item) in &self.steady.q {
            q[*k] = value(&item.expr, env, &item.site.key)?;
        }
        Ok(q)
    }

    /// Solve h(q) = 0 for the dependent coordinates at the steady parameters `s` (Newton, from
    /// the values given or 0), and the sensitivity there.
    pub(crate) fn completed(
        &self,
        params: &IndexMap<String, f64>,
        s: &[f64],
    ) -> Result<Completed, StudyError> {
        let mut q = self.given_q(&self.env(params, s))?;
        let c = &self.model.completion;
        if c.is_empty() {
            return Ok(Completed {
                q,
                sensitivity: Vec::new(),
            });
        }
        let failed = |e: hamel_model::CompletionError| StudyError::Completion {
            coordinates: self.dependent().join(", "),
            reason: e.to_string(),
        };
        c.complete(&mut q, params).map_err(failed)?;
        let sensitivity = c.sensitivity(&q, params).map_err(failed)?;
        Ok(Completed { q, sensitivity })
    }

    /// The steady coordinates at the steady parameters `s`, with the constraints solved at `at`
    /// ([`Study::completed`] at the values of `s`): the coordinates given (others 0), the
    /// dependent ones q_d + Σ_k ∂q_d/∂q_k (q_k − q_k(at)), so that dual numbers carry their
    /// dependence.
    pub(crate) fn steady_q<S: Scalar>(
        &self,
        params: &IndexMap<String, f64>,
        s: &[S],
        at: &Completed,
    ) -> Result<Vec<S>, StudyError> {
        let mut q = self.given_q(&self.env(params, s))?;
        let moved: Vec<S> = q
            .iter()
            .zip(&at.q)
            .map(|(x, v)| *x - S::constant(*v))
            .collect();
        for (row, &d) in at.sensitivity.iter().zip(self.model.completion.dependent()) {
            q[d] = row
                .iter()
                .zip(&moved)
                .fold(S::constant(at.q[d]), |acc, (a, m)| {
                    acc + S::constant(*a) * *m
                });
        }
        Ok(q)
    }

    /// The steady state at the coordinates `q` (from [`Study::steady_q`]) with [Z; α] there as
    /// rows (`map`, from the compiled equations): the velocities given and the others from
    /// α(q)q̇ = 0, and η = Z(q)q̇.
    pub(crate) fn full_state<S: Scalar>(
        &self,
        params: &IndexMap<String, f64>,
        s: &[S],
        q: Vec<S>,
        map: &[Vec<S>],
    ) -> Result<Full<S>, StudyError> {
        let env = self.env(params, s);
        let sigma = self.eta.len();
        let q_dot = self.velocities(&map[sigma..], &env)?;
        let eta = map[..sigma]
            .iter()
            .map(|row| {
                row.iter()
                    .zip(&q_dot)
                    .fold(S::constant(0.0), |acc, (a, b)| acc + *a * *b)
            })
            .collect();
        Ok(Full { q, q_dot, eta })
    }

    /// The velocities: those given, and the others solved from α(q)q̇ = 0.
    fn velocities<S: Scalar>(
        &self,
        alpha: &[Vec<S>],
        env: &SteadyEnv<'_, S>,
    ) -> Result<Vec<S>, StudyError> {
        let ell = self.model.coordinates.len();
        let mut q_dot = vec![S::constant(0.0); ell];
        let mut given = vec![false; ell];
        for (k, item) in &self.steady.velocities {
            q_dot[*k] = value(&item.expr, env, &item.site.key)?;
            given[*k] = true;
        }
        let unknown: Vec<usize> = (0..ell).filter(|&k| !given[k]).collect();
        let names = |ix: &[usize]| {
            let n: Vec<&str> = ix
                .iter()
                .map(|&k| self.model.coordinates[k].as_str())
                .collect();
            n.join(", ")
        };
        if unknown.len() != alpha.len() {
            return Err(StudyError::Velocities(format!(
                "`velocities` must give all but μ = {} velocities (the constraints determine the rest); not given: {}",
                alpha.len(),
                if unknown.is_empty() {
                    "(none)".into()
                } else {
                    names(&unknown)
                }
            )));
        }
        if unknown.is_empty() {
            return Ok(q_dot);
        }
        let a: Vec<Vec<S>> = alpha
            .iter()
            .map(|row| unknown.iter().map(|&k| row[k]).collect())
            .collect();
        let b: Vec<S> = alpha
            .iter()
            .map(|row| {
                (0..ell)
                    .filter(|&k| given[k])
                    .fold(S::constant(0.0), |acc, k| acc - row[k] * q_dot[k])
            })
            .collect();
        let solved = hamel_expr::solve(a, b).ok_or_else(|| {
            StudyError::Velocities(format!(
                "the constraints do not determine the velocities of {} from those given: give others",
                names(&unknown)
            ))
        })?;
        for (k, v) in unknown.into_iter().zip(solved) {
            q_dot[k] = v;
        }
        Ok(q_dot)
    }
}

fn value<S: Scalar>(
    e: &hamel_expr::Expr,
    env: &SteadyEnv<'_, S>,
    key: &str,
) -> Result<S, StudyError> {
    let v = e.eval(env).map_err(|err| StudyError::Value {
        key: key.to_string(),
        reason: err.to_string(),
    })?;
    if v.value().is_finite() {
        Ok(v)
    } else {
        Err(StudyError::Value {
            key: key.to_string(),
            reason: "the value is not finite".into(),
        })
    }
}
