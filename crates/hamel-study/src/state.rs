//! The steady state at a point, in any scalar type: dual numbers in a steady parameter give the
//! steady family's tangent exactly.

use hamel_expr::{Env, Scalar};
use hamel_model::NumericModel;
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

impl Study {
    /// The steady state at the model's parameter values `params` and the steady parameters'
    /// `s`: the coordinates given (others 0), the dependent ones completed (Newton in f64,
    /// then their first-order dependence through the implicit function theorem, so that dual
    /// numbers carry it), the velocities given and the others from α(q)q̇ = 0, and η = Z(q)q̇.
    pub(crate) fn full_state<S: Scalar>(
        &self,
        params: &IndexMap<String, f64>,
        s: &[S],
    ) -> Result<Full<S>, StudyError> {
        let env = SteadyEnv {
            names: self.steady.parameters.keys().map(String::as_str).collect(),
            s,
            params,
        };
        let ell = self.model.coordinates.len();
        let mut q = vec![S::constant(0.0); ell];
        for (k, item) in &self.steady.q {
            q[*k] = value(&item.expr, &env, &item.site.key)?;
        }
        self.complete(&mut q, params)?;
        let numeric = NumericModel::new(&self.model, params)
            .map_err(|e| StudyError::Parameter(e.to_string()))?;
        let q_dot = self.velocities(&numeric, &q, &env)?;
        let z = numeric
            .quasi_velocity_matrix::<S>(&self.eta_name, &q)
            .map_err(|e| StudyError::Numeric(e.to_string()))?;
        let eta = z
            .iter()
            .map(|row| {
                row.iter()
                    .zip(&q_dot)
                    .fold(S::constant(0.0), |acc, (a, b)| acc + *a * *b)
            })
            .collect();
        Ok(Full { q, q_dot, eta })
    }

    /// Solve h(q) = 0 for the dependent coordinates (in f64), then give them the first-order
    /// dependence on the others: q_d + Σ_k ∂q_d/∂q_k (q_k − value(q_k)).
    fn complete<S: Scalar>(
        &self,
        q: &mut [S],
        params: &IndexMap<String, f64>,
    ) -> Result<(), StudyError> {
        let c = &self.model.completion;
        if c.is_empty() {
            return Ok(());
        }
        let failed = |e: hamel_model::CompletionError| StudyError::Completion {
            coordinates: self.dependent().join(", "),
            reason: e.to_string(),
        };
        let mut values: Vec<f64> = q.iter().map(Scalar::value).collect();
        c.complete(&mut values, params).map_err(failed)?;
        let sensitivity = c.sensitivity(&values, params).map_err(failed)?;
        let moved: Vec<S> = q.iter().map(|x| *x - S::constant(x.value())).collect();
        for (row, &d) in sensitivity.iter().zip(c.dependent()) {
            q[d] = row
                .iter()
                .zip(&moved)
                .fold(S::constant(values[d]), |acc, (a, m)| {
                    acc + S::constant(*a) * *m
                });
        }
        Ok(())
    }

    /// The velocities: those given, and the others solved from α(q)q̇ = 0.
    fn velocities<S: Scalar>(
        &self,
        numeric: &NumericModel<'_>,
        q: &[S],
        env: &SteadyEnv<'_, S>,
    ) -> Result<Vec<S>, StudyError> {
        let ell = q.len();
        let mut q_dot = vec![S::constant(0.0); ell];
        let mut given = vec![false; ell];
        for (k, item) in &self.steady.velocities {
            q_dot[*k] = value(&item.expr, env, &item.site.key)?;
            given[*k] = true;
        }
        let unknown: Vec<usize> = (0..ell).filter(|&k| !given[k]).collect();
        let alpha = numeric
            .constraint_matrix::<S>(q)
            .map_err(|e| StudyError::Numeric(e.to_string()))?;
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
