//! Numeric evaluation of the model's own expressions (T or A, U, α), without computer algebra.
//!
//! This is what the independent oracle and the positive-definiteness check stand on: A, α and U
//! are read straight from the file's expressions at a point, never from a derivation.

use hamel_expr::{EvalError, Expr, Scalar};
use indexmap::IndexMap;
use nalgebra::DMatrix;

use crate::error::ModelError;
use hamel_bodies::Point;

use crate::loader::Kinetic;
use crate::model::Model;

/// A model with parameter values fixed, ready to evaluate A(q), α(q), U(q) at points.
#[derive(Clone, Debug)]
pub struct NumericModel<'m> {
    model: &'m Model,
    params: IndexMap<String, f64>,
}

impl<'m> NumericModel<'m> {
    /// The model at its default parameters, with `overrides` applied (unknown names are errors).
    pub fn new(
        model: &'m Model,
        overrides: &IndexMap<String, f64>,
    ) -> Result<NumericModel<'m>, ModelError> {
        let mut params = model.parameters.clone();
        for (k, v) in overrides {
            match params.get_mut(k) {
                Some(slot) => *slot = *v,
                None => return Err(model.error(format!("unknown parameter `{k}`"))),
            }
        }
        Ok(NumericModel { model, params })
    }

    /// The model it evaluates.
    pub fn model(&self) -> &'m Model {
        self.model
    }

    /// The parameter values in use.
    pub fn params(&self) -> &IndexMap<String, f64> {
        &self.params
    }

    fn eval<S: Scalar>(&self, e: &Expr, q: &[S], v: Option<&[S]>) -> Result<S, EvalError> {
        let point = Point {
            coordinates: &self.model.coordinates,
            q,
            velocities: v,
            values: &self.params,
        };
        e.eval(&point)
    }

    /// A(q). From T by polarisation: A_ii = 2 T(e_i), A_ij = T(e_i + e_j) − T(e_i) − T(e_j),
    /// exact for a quadratic form.
    pub fn mass_matrix<S: Scalar>(&self, q: &[S]) -> Result<Vec<Vec<S>>, EvalError> {
        let ell = self.model.ell();
        match &self.model.kinetic {
            Kinetic::MassMatrix(rows) => rows
                .iter()
                .map(|r| r.iter().map(|e| self.eval(&e.expr, q, None)).collect())
                .collect(),
            Kinetic::Energy(t) => {
                let unit = |idx: &[usize]| -> Vec<S> {
                    (0..ell)
                        .map(|k| S::constant(if idx.contains(&k) { 1.0 } else { 0.0 }))
                        .collect()
                };
                let mut diag = Vec::with_capacity(ell);
                for i in 0..ell {
                    diag.push(self.eval(&t.expr, q, Some(&unit(&[i])))?);
                }
                let mut a = vec![vec![S::constant(0.0); ell]; ell];
                for i in 0..ell {
                    a[i][i] = diag[i] * S::constant(2.0);
                    for j in 0..i {
                        let tij = self.eval(&t.expr, q, Some(&unit(&[i, j])))?;
                        let aij = tij - diag[i] - diag[j];
                        a[i][j] = aij;
                        a[j][i] = aij;
                    }
                }
                Ok(a)
            }
        }
    }

    /// Numeric pre-screen: T(q, 2v) = 4 T(q, v) and T(q, −v) = T(q, v) at sample points (true
    /// for every quadratic form; the exact check is made by the symbolic stage).
    pub fn kinetic_looks_quadratic(&self) -> bool {
        let Kinetic::Energy(t) = &self.model.kinetic else {
            return true;
        };
        let ell = self.model.ell();
        let qs = sample_configurations(ell, 4, 11);
        let vs = sample_configurations(ell, 4, 13);
        qs.iter().zip(&vs).all(|(q, v)| {
            let v2: Vec<f64> = v.iter().map(|x| 2.0 * x).collect();
            let vm: Vec<f64> = v.iter().map(|x| -x).collect();
            match (
                self.eval::<f64>(&t.expr, q, Some(v)),
                self.eval::<f64>(&t.expr, q, Some(&v2)),
                self.eval::<f64>(&t.expr, q, Some(&vm)),
            ) {
                (Ok(a), Ok(b), Ok(c)) => {
                    let scale = a.abs().max(1e-300);
                    (b - 4.0 * a).abs() <= 1e-9 * scale * 4.0 && (c - a).abs() <= 1e-9 * scale
                }
                _ => true,
            }
        })
    }

    /// α(q): α_mj is the coefficient of der(q_j) in constraint m (the kept rows, μ of them).
    pub fn constraint_matrix<S: Scalar>(&self, q: &[S]) -> Result<Vec<Vec<S>>, EvalError> {
        self.rows_at(self.model.constraints.iter().map(|(_, c)| c), q)
    }

    /// Every row of the model's constraints at q, the dependent ones among the kept ones in
    /// the model's order ([`Model::all_rows`]): μ + (dropped rows) rows of rank μ.
    pub fn all_constraint_rows<S: Scalar>(&self, q: &[S]) -> Result<Vec<Vec<S>>, EvalError> {
        let rows = self.model.all_rows();
        self.rows_at(rows.iter().map(|(_, c, _)| *c), q)
    }

    fn rows_at<'i, S: Scalar>(
        &self,
        items: impl Iterator<Item = &'i crate::loader::Item>,
        q: &[S],
    ) -> Result<Vec<Vec<S>>, EvalError> {
        let ell = self.model.ell();
        let zero = vec![S::constant(0.0); ell];
        items
            .map(|c| {
                let at0 = self.eval(&c.expr, q, Some(&zero))?;
                (0..ell)
                    .map(|j| {
                        let mut e = zero.clone();
                        e[j] = S::constant(1.0);
                        Ok(self.eval(&c.expr, q, Some(&e))? - at0)
                    })
                    .collect()
            })
            .collect()
    }

    /// U(q).
    pub fn potential<S: Scalar>(&self, q: &[S]) -> Result<S, EvalError> {
        self.eval(&self.model.potential.expr, q, None)
    }

    /// The generalised forces F(q, q̇) of `[forces]` (the loads U does not give), at the
    /// velocities `q_dot`.
    pub fn forces<S: Scalar>(&self, q: &[S], q_dot: &[S]) -> Result<Vec<S>, EvalError> {
        self.model
            .forces
            .iter()
            .map(|f| self.eval(&f.expr, q, Some(q_dot)))
            .collect()
    }

    /// Z(q) of a choice: Z_ij is the coefficient of der(q_j) in η_i (free functions must have
    /// been substituted).
    pub fn quasi_velocity_matrix<S: Scalar>(
        &self,
        choice: &str,
        q: &[S],
    ) -> Result<Vec<Vec<S>>, EvalError> {
        let ell = self.model.ell();
        let c = self
            .model
            .choices
            .iter()
            .find(|c| c.name == choice)
            .ok_or_else(|| EvalError::Unbound(format!("quasi-velocity choice `{choice}`")))?;
        let zero = vec![S::constant(0.0); ell];
        c.eta
            .iter()
            .map(|row| {
                let at0 = self.eval(&row.expr, q, Some(&zero))?;
                (0..ell)
                    .map(|j| {
                        let mut e = zero.clone();
                        e[j] = S::constant(1.0);
                        Ok(self.eval(&row.expr, q, Some(&e))? - at0)
                    })
                    .collect()
            })
            .collect()
    }
}

/// A fixed-seed xorshift: numbers uniform in [0, 1), the same sequence for the same seed.
pub(crate) fn uniform(seed: u64) -> impl FnMut() -> f64 {
    let mut state = seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1;
    move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        (state >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// `n` deterministic pseudo-random configurations in [−3, 3]^ℓ (a fixed-seed xorshift, so that
/// checks are reproducible).
pub fn sample_configurations(ell: usize, n: usize, seed: u64) -> Vec<Vec<f64>> {
    let mut next = uniform(seed);
    (0..n)
        .map(|_| (0..ell).map(|_| 6.0 * next() - 3.0).collect())
        .collect()
}

impl Model {
    /// A must be symmetric positive definite at the default parameters, at sample configurations.
    pub(crate) fn check_mass_matrix_numerically(&self) -> Result<(), ModelError> {
        let site = match &self.kinetic {
            Kinetic::Energy(t) => t.site.clone(),
            Kinetic::MassMatrix(rows) => {
                let mut s = rows[0][0].site.clone();
                s.key = "lagrangian.mass_matrix".into();
                s.span =
                    rows[0][0].site.span.start..rows.last().unwrap().last().unwrap().site.span.end;
                s
            }
        };
        let nm = NumericModel::new(self, &IndexMap::new())?;
        let ell = self.ell();
        if !nm.kinetic_looks_quadratic() {
            // Polarisation is meaningless for a T that is not a quadratic form: leave the
            // verdict to the exact check of the symbolic stage, which names the problem.
            return Ok(());
        }
        let mut evaluated = 0;
        for q in sample_configurations(ell, 8, 7) {
            let a = match nm.mass_matrix::<f64>(&q) {
                Ok(a) => a,
                Err(EvalError::Domain(_)) => continue, // a pole of A at this sample: try others
                Err(e) => return Err(self.error_at(&site, format!("cannot evaluate A: {e}"))),
            };
            evaluated += 1;
            let m = DMatrix::from_fn(ell, ell, |i, j| a[i][j]);
            let scale = m
                .iter()
                .fold(0.0_f64, |s, x| s.max(x.abs()))
                .max(f64::MIN_POSITIVE);
            let asym = (&m - m.transpose())
                .iter()
                .fold(0.0_f64, |s, x| s.max(x.abs()));
            let at = format_point(&self.coordinates, &q);
            if asym > 1e-12 * scale {
                return Err(
                    self.error_at(&site, format!("the mass matrix A is not symmetric at {at}"))
                );
            }
            let eig = m.clone().symmetric_eigen().eigenvalues;
            let min = eig.iter().cloned().fold(f64::INFINITY, f64::min);
            if min <= 1e-12 * scale {
                return Err(self
                    .error_at(&site, format!(
                        "the mass matrix A is not positive definite at the default parameters at {at} (smallest eigenvalue {min:.3e})"
                    ))
                    .with_help("T must be a positive definite quadratic form in all the velocities der(q)"));
            }
        }
        if evaluated == 0 {
            return Err(self.error_at(
                &site,
                "A could not be evaluated at any sample configuration",
            ));
        }
        Ok(())
    }
}

fn format_point(coordinates: &[String], q: &[f64]) -> String {
    let parts: Vec<String> = coordinates
        .iter()
        .zip(q)
        .map(|(c, v)| format!("{c} = {v:.4}"))
        .collect();
    format!("({})", parts.join(", "))
}
