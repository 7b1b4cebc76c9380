//! Numbers at the default parameters: evaluating the description's expressions for its checks,
//! and completing a configuration by solving the holonomic constraints for their dependent
//! coordinates (Newton's method on the exact Jacobian).

use hamel_expr::{Env, Expr, Scalar};
use indexmap::IndexMap;

use crate::error::Problem;

/// A configuration (and, when given, velocities) with parameter values: the environment a
/// model's expressions are evaluated in, over any scalar.
pub struct Point<'a, S = f64> {
    /// Coordinate names.
    pub coordinates: &'a [String],
    /// Their values.
    pub q: &'a [S],
    /// The velocities der(q), if the expressions may hold them.
    pub velocities: Option<&'a [S]>,
    /// Parameter values.
    pub values: &'a IndexMap<String, f64>,
}

impl<'a, S> Point<'a, S> {
    /// The configuration `q` of `coordinates`, without velocities.
    pub fn at(coordinates: &'a [String], q: &'a [S], values: &'a IndexMap<String, f64>) -> Self {
        Point {
            coordinates,
            q,
            velocities: None,
            values,
        }
    }
}

impl<S: Scalar> Env<S> for Point<'_, S> {
    fn symbol(&self, name: &str) -> Option<S> {
        match self.coordinates.iter().position(|c| c == name) {
            Some(i) => self.q.get(i).copied(),
            None => self.values.get(name).map(|&v| S::constant(v)),
        }
    }

    fn velocity(&self, coordinate: &str) -> Option<S> {
        let i = self.coordinates.iter().position(|c| c == coordinate)?;
        self.velocities.and_then(|v| v.get(i).copied())
    }
}

impl Point<'_> {
    /// The value of `e` here, finite.
    pub fn value(&self, e: &Expr) -> Result<f64, Problem> {
        let v = e
            .eval(self)
            .map_err(|err| Problem::Evaluation(err.to_string()))?;
        if v.is_finite() {
            Ok(v)
        } else {
            Err(Problem::Evaluation(format!("`{e}` is not finite")))
        }
    }
}

/// Holonomic constraints h_i(q) = 0 with the exact partial derivatives by their dependent
/// coordinates, ready for Newton's method.
#[derive(serde::Serialize, serde::Deserialize, Clone, Debug)]
pub struct Completion {
    coordinates: Vec<String>,
    h: Vec<Expr>,
    dependent: Vec<usize>,
    /// ∂h_i/∂q_{dependent[j]}
    jacobian: Vec<Vec<Expr>>,
}

/// Why a configuration could not be completed.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum CompletionError {
    /// Newton's method did not converge.
    #[error(
        "Newton's method did not converge in {iterations} iterations (residual {residual:.3e})"
    )]
    NoConvergence {
        /// Iterations made.
        iterations: usize,
        /// max |h_i| at the end.
        residual: f64,
    },
    /// The Jacobian by the dependent coordinates is singular.
    #[error("the constraints' Jacobian by the dependent coordinates is singular at q = {0:?}")]
    Singular(Vec<f64>),
    /// An expression could not be evaluated.
    #[error("{0}")]
    Evaluation(String),
}

impl Completion {
    /// The constraints `h` (functions of `coordinates` and parameters) for the coordinates
    /// `dependent` (indices, one per constraint).
    pub fn new(
        coordinates: &[String],
        h: Vec<Expr>,
        dependent: Vec<usize>,
    ) -> Result<Completion, Problem> {
        let jacobian = h
            .iter()
            .map(|hi| {
                dependent
                    .iter()
                    .map(|&j| hi.diff(&coordinates[j]))
                    .collect::<Result<Vec<_>, _>>()
            })
            .collect::<Result<Vec<_>, _>>()?;
        Ok(Completion {
            coordinates: coordinates.to_vec(),
            h,
            dependent,
            jacobian,
        })
    }

    /// The dependent coordinates' indices.
    pub fn dependent(&self) -> &[usize] {
        &self.dependent
    }

    /// Solve h(q) = 0 for the dependent coordinates of `q`, starting from their values in `q`
    /// and keeping the others; at most 50 iterations, to |h| ≤ 1e-14·(1 + scale).
    pub fn complete(
        &self,
        q: &mut [f64],
        values: &IndexMap<String, f64>,
    ) -> Result<(), CompletionError> {
        if self.h.is_empty() {
            return Ok(());
        }
        const ITERATIONS: usize = 50;
        let mut residual = f64::INFINITY;
        for _ in 0..ITERATIONS {
            let (h, jac) = self.linearise(q, values)?;
            residual = h.iter().fold(0.0_f64, |m, x| m.max(x.abs()));
            let step =
                hamel_expr::solve(jac, h).ok_or_else(|| CompletionError::Singular(q.to_vec()))?;
            let mut moved = 0.0_f64;
            for (&j, s) in self.dependent.iter().zip(&step) {
                q[j] -= s;
                moved = moved.max(s.abs() / (1.0 + q[j].abs()));
            }
            if moved <= 4.0 * f64::EPSILON && residual < 1e-10 {
                return Ok(());
            }
        }
        Err(CompletionError::NoConvergence {
            iterations: ITERATIONS,
            residual,
        })
    }

    /// The implicit function theorem at a point `q` on the constraints: ∂q_d/∂q_k =
    /// −(∂h/∂q_d)⁻¹ ∂h/∂q_k for every dependent coordinate d (rows, in the order of
    /// [`Completion::dependent`]) and every coordinate k (columns; 0 for the dependent ones).
    /// ∂h/∂q_k is exact (dual numbers).
    pub fn sensitivity(
        &self,
        q: &[f64],
        values: &IndexMap<String, f64>,
    ) -> Result<Vec<Vec<f64>>, CompletionError> {
        let (_, jac) = self.linearise(q, values)?;
        let ell = self.coordinates.len();
        let mut out = vec![vec![0.0; ell]; self.h.len()];
        for k in (0..ell).filter(|k| !self.dependent.contains(k)) {
            let dq: Vec<hamel_expr::Dual> = (0..ell)
                .map(|i| hamel_expr::Dual::new(q[i], f64::from(i == k)))
                .collect();
            let at = Point::at(&self.coordinates, &dq, values);
            let rhs = self
                .h
                .iter()
                .map(|h| h.eval(&at).map(|v| -v.d))
                .collect::<Result<Vec<_>, _>>()
                .map_err(|e| CompletionError::Evaluation(e.to_string()))?;
            let column = hamel_expr::solve(jac.clone(), rhs)
                .ok_or_else(|| CompletionError::Singular(q.to_vec()))?;
            for (row, x) in out.iter_mut().zip(column) {
                row[k] = x;
            }
        }
        Ok(out)
    }

    /// max |h_i(q)|: how far `q` is from the constraints (0 without constraints).
    pub fn residual(
        &self,
        q: &[f64],
        values: &IndexMap<String, f64>,
    ) -> Result<f64, CompletionError> {
        let at = Point::at(&self.coordinates, q, values);
        self.h.iter().try_fold(0.0_f64, |m, hi| {
            at.value(hi)
                .map(|v| m.max(v.abs()))
                .map_err(|p| CompletionError::Evaluation(p.to_string()))
        })
    }

    /// Whether some constraint depends on the coordinate `k`.
    pub fn mentions(&self, k: usize) -> bool {
        self.h.iter().any(|h| h.mentions(&self.coordinates[k]))
    }

    /// Whether there are constraints to solve.
    pub fn is_empty(&self) -> bool {
        self.h.is_empty()
    }

    /// h(q) and its Jacobian by the dependent coordinates.
    fn linearise(
        &self,
        q: &[f64],
        values: &IndexMap<String, f64>,
    ) -> Result<(Vec<f64>, Vec<Vec<f64>>), CompletionError> {
        let at = Point::at(&self.coordinates, q, values);
        let eval = |e: &Expr| {
            at.value(e)
                .map_err(|p| CompletionError::Evaluation(p.to_string()))
        };
        let h = self.h.iter().map(eval).collect::<Result<Vec<_>, _>>()?;
        let jac = self
            .jacobian
            .iter()
            .map(|row| row.iter().map(eval).collect::<Result<Vec<_>, _>>())
            .collect::<Result<Vec<_>, _>>()?;
        Ok((h, jac))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn newton_solves_a_circle_for_its_dependent_coordinate() {
        let coords = vec!["x".to_string(), "y".to_string()];
        let h = hamel_expr::parse("x^2 + y^2 - r^2").unwrap().expr;
        let c = Completion::new(&coords, vec![h], vec![1]).unwrap();
        let values = IndexMap::from([("r".to_string(), 2.0)]);
        let mut q = [1.2, 1.0];
        assert!((c.residual(&q, &values).unwrap() - 1.56).abs() < 1e-14);
        c.complete(&mut q, &values).unwrap();
        assert!((q[1] - (4.0_f64 - 1.44).sqrt()).abs() < 1e-14);
        assert!(c.residual(&q, &values).unwrap() < 1e-15);
        let mut q = [1.2, 0.0];
        assert!(matches!(
            c.complete(&mut q, &values),
            Err(CompletionError::Singular(_))
        ));
        let mut q = [3.0, 1.0];
        assert!(c.complete(&mut q, &values).is_err());
    }
}
