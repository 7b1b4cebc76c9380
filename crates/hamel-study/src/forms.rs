//! The linear equations in the forms users of the field read: the second-order form
//! M q̈ + C q̇ + K q = B u (the benchmark bicycle's), and its dependence on a swept steady
//! parameter v as matrix polynomials (M q̈ + v C1 q̇ + (g K0 + v² K2) q = B u).

use std::collections::BTreeMap;

use hamel_expr::Expr;
use nalgebra::DMatrix;
use serde::Serialize;

use crate::mat::{matrix, rows};
use crate::{Point, Study, StudyError};

/// Rounding allowed in the kinematic rows when recognising q̇ = η.
const KINEMATIC_TOLERANCE: f64 = 1e-13;

/// M q̈ + C q̇ + K q = B u on the kept coordinates q whose rates are quasi-velocities.
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct SecondOrder {
    /// The coordinates q.
    pub q: Vec<String>,
    /// The quasi-velocities equal to their rates, in the same order.
    pub speeds: Vec<String>,
    /// M: A_Γ on those speeds.
    pub m: Vec<Vec<f64>>,
    /// C.
    pub c: Vec<Vec<f64>>,
    /// K.
    pub k: Vec<Vec<f64>>,
    /// B: the generalised forces per unit input.
    pub b: Vec<Vec<f64>>,
}

/// The second-order form, when the reduced state is coordinates and quasi-velocities with
/// q̇_i = η_π(i) exactly (to rounding) and nothing else: M is A_Γ on those η, and
/// C = −M·(∂η̇/∂η), K = −M·(∂η̇/∂q), B = M·(∂η̇/∂u) on the reduced state.
pub(crate) fn second_order(
    reduced: &[String],
    state: &[String],
    a: &DMatrix<f64>,
    b: &DMatrix<f64>,
    a_gamma: &DMatrix<f64>,
) -> Option<SecondOrder> {
    let eta_of = |n: &str| n.strip_prefix("eta").and_then(|i| i.parse::<usize>().ok());
    let sigma = a_gamma.nrows();
    let nq = state.len() - sigma;
    let qs: Vec<usize> = (0..reduced.len())
        .filter(|&i| state[..nq].contains(&reduced[i]))
        .collect();
    let es: Vec<usize> = (0..reduced.len())
        .filter(|&i| eta_of(&reduced[i]).is_some())
        .collect();
    if qs.len() != es.len() || qs.len() + es.len() != reduced.len() || qs.is_empty() {
        return None;
    }
    let small = |x: f64| x.abs() <= KINEMATIC_TOLERANCE * (1.0 + a.norm());
    if qs.iter().any(|&i| qs.iter().any(|&k| !small(a[(i, k)]))) {
        return None;
    }
    let mut speeds = Vec::new();
    for &i in &qs {
        let ones: Vec<usize> = es
            .iter()
            .copied()
            .filter(|&e| small(a[(i, e)] - 1.0))
            .collect();
        let zeros = es.iter().filter(|&&e| small(a[(i, e)])).count();
        if ones.len() != 1 || zeros != es.len() - 1 || speeds.contains(&ones[0]) {
            return None;
        }
        speeds.push(ones[0]);
    }
    let ag: Vec<usize> = speeds
        .iter()
        .map(|&e| eta_of(&reduced[e]).unwrap_or(1) - 1)
        .collect();
    let m = DMatrix::from_fn(ag.len(), ag.len(), |i, k| a_gamma[(ag[i], ag[k])]);
    let y_q = DMatrix::from_fn(speeds.len(), qs.len(), |i, k| a[(speeds[i], qs[k])]);
    let y_e = DMatrix::from_fn(speeds.len(), speeds.len(), |i, k| a[(speeds[i], speeds[k])]);
    let y_b = DMatrix::from_fn(speeds.len(), b.ncols(), |i, k| b[(speeds[i], k)]);
    Some(SecondOrder {
        q: qs.iter().map(|&i| reduced[i].clone()).collect(),
        speeds: speeds.iter().map(|&e| reduced[e].clone()).collect(),
        c: rows(&-(&m * y_e)),
        k: rows(&-(&m * y_q)),
        b: rows(&(&m * y_b)),
        m: rows(&m),
    })
}

/// A matrix polynomial Σ_k p^k P_k in a parameter: the coefficients that are not zero.
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct Polynomial {
    /// The parameter.
    pub parameter: String,
    /// P_k by power k (zero coefficients left out).
    pub coefficients: BTreeMap<usize, Vec<Vec<f64>>>,
}

/// The gravity part of the stiffness: K(0) = g K0 + (the rest).
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct Gravity {
    /// The parameter (g), which enters only through U, linearly.
    pub parameter: String,
    /// K0.
    pub k0: Vec<Vec<f64>>,
    /// The rest of K's constant term, when not zero.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub rest: Option<Vec<Vec<f64>>>,
}

/// The linear equations as polynomials in a swept steady parameter, when the steady
/// coordinates are free of it and its velocities are polynomials in it (of degree d): then M
/// and B are constant, C has degree ≤ d, K and A degree ≤ 2d (A_Γ depends on q only, Q is
/// quadratic in η). The coefficients are interpolated at p = 0, 1, …, 2d and checked at 2d + 1.
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct Symbolic {
    /// The swept parameter.
    pub parameter: String,
    /// ẋ = A(p) x + B u on the reduced state.
    pub a: Polynomial,
    /// B.
    pub b: Vec<Vec<f64>>,
    /// The second-order form's M, when it exists.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub m: Option<Vec<Vec<f64>>>,
    /// C(p).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub c: Option<Polynomial>,
    /// K(p).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub k: Option<Polynomial>,
    /// Its B (generalised forces per unit input).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub b_forces: Option<Vec<Vec<f64>>>,
    /// K's constant term split by the gravity parameter.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub gravity: Option<Gravity>,
}

/// An upper bound on the degree of `e` in `p`: the number of derivatives after which `p` no
/// longer occurs (exact: a derivative that does not mention p is free of it); `None` when six
/// do not get there.
pub(crate) fn degree(e: &Expr, p: &str) -> Option<usize> {
    let mut d = e.clone();
    for k in 0..=6 {
        if !d.mentions(p) {
            return Some(k);
        }
        d = d.diff(p).ok()?;
    }
    None
}

impl Study {
    /// The linear equations as polynomials in the steady parameter `p` about `base`, or why
    /// not: `p` is not a steady parameter, the steady coordinates depend on it, or its
    /// velocities are not polynomials in it.
    pub fn symbolic(&self, base: &Point, p: &str) -> Result<Result<Symbolic, String>, StudyError> {
        let Some(d) = self.velocity_degree(p) else {
            return Ok(Err(format!(
                "not polynomial in `{p}`: it must be a steady parameter that the steady coordinates do not use and the velocities use polynomially"
            )));
        };
        let at = |x: f64, extra: &[(&str, f64)]| {
            let mut point = base.clone();
            point.0.insert(p.to_string(), x);
            for (k, v) in extra {
                point.0.insert(k.to_string(), *v);
            }
            self.linearise(&point, 0)
        };
        let nodes: Vec<f64> = (0..=2 * d + 1).map(|k| k as f64).collect();
        let lin = nodes
            .iter()
            .map(|&x| at(x, &[]))
            .collect::<Result<Vec<_>, _>>()?;
        // Matrices of different shapes (a family direction that vanishes at a node) are no
        // polynomial.
        let fit = |get: &dyn Fn(&crate::Linearisation) -> Option<Vec<Vec<f64>>>, degree: usize| {
            let values: Option<Vec<DMatrix<f64>>> =
                lin.iter().map(|l| get(l).map(|m| matrix(&m))).collect();
            values
                .filter(|v| v.iter().all(|m| m.shape() == v[0].shape()))
                .and_then(|v| interpolate(p, &nodes, &v, degree))
        };
        let Some(a) = fit(&|l| Some(l.a.clone()), 2 * d) else {
            return Ok(Err(format!(
                "A is not a polynomial of degree {} in `{p}` (internal check)",
                2 * d
            )));
        };
        let second = |f: fn(&crate::SecondOrder) -> Vec<Vec<f64>>| {
            move |l: &crate::Linearisation| l.second_order.as_ref().map(f)
        };
        let c = fit(&second(|s| s.c.clone()), d);
        let k = fit(&second(|s| s.k.clone()), 2 * d);
        let so = lin[0].second_order.clone();
        let gravity = match (&self.gravity, &so, &k) {
            (Some(g), Some(_), Some(k)) => {
                let value = self.values(&base.0)?.0[g.as_str()];
                self.gravity_split(g, value, k, &|v| at(0.0, &[(g, v)]))?
            }
            _ => None,
        };
        Ok(Ok(Symbolic {
            parameter: p.to_string(),
            a,
            b: lin[0].b.clone(),
            m: so.as_ref().map(|s| s.m.clone()),
            c,
            k,
            b_forces: so.map(|s| s.b),
            gravity,
        }))
    }

    /// The degree bound of the steady velocities in `p`, when `p` is a steady parameter the
    /// coordinates do not use.
    fn velocity_degree(&self, p: &str) -> Option<usize> {
        if !self.steady.parameters.contains_key(p)
            || self.steady.q.iter().any(|(_, i)| i.expr.mentions(p))
        {
            return None;
        }
        self.steady
            .velocities
            .iter()
            .map(|(_, i)| degree(&i.expr, p))
            .try_fold(0, |m, d| d.map(|d| m.max(d)))
    }

    /// K's constant term K(0) = g K0 + rest, from K(0) at g and at g = 0.
    fn gravity_split(
        &self,
        g: &str,
        value: f64,
        k: &Polynomial,
        at: &dyn Fn(f64) -> Result<crate::Linearisation, StudyError>,
    ) -> Result<Option<Gravity>, StudyError> {
        let Some(k_0) = k.coefficients.get(&0).map(|m| matrix(m)) else {
            return Ok(None);
        };
        let without = at(0.0)?;
        let Some(rest) = without.second_order.map(|s| matrix(&s.k)) else {
            return Ok(None);
        };
        if value == 0.0 || rest.shape() != k_0.shape() {
            return Ok(None);
        }
        let k0 = (&k_0 - &rest) / value;
        let negligible = rest.norm() <= 1e-14 * k_0.norm();
        Ok(Some(Gravity {
            parameter: g.to_string(),
            k0: rows(&k0),
            rest: (!negligible).then(|| rows(&rest)),
        }))
    }
}

/// The polynomial of degree ≤ `degree` through the first degree + 1 of `values` at `nodes`,
/// checked against the others (to 1e-9 of their size); `None` when the check fails.
fn interpolate(
    p: &str,
    nodes: &[f64],
    values: &[DMatrix<f64>],
    degree: usize,
) -> Option<Polynomial> {
    let n = degree + 1;
    let v = DMatrix::from_fn(n, n, |i, k| nodes[i].powi(k as i32));
    let lu = v.lu();
    let (r, c) = values[0].shape();
    let mut coefficients = vec![DMatrix::zeros(r, c); n];
    for i in 0..r {
        for k in 0..c {
            let y = nalgebra::DVector::from_fn(n, |m, _| values[m][(i, k)]);
            let x = lu.solve(&y)?;
            for (power, coefficient) in coefficients.iter_mut().enumerate() {
                coefficient[(i, k)] = x[power];
            }
        }
    }
    for (node, value) in nodes.iter().zip(values).skip(n) {
        let fitted = coefficients
            .iter()
            .enumerate()
            .fold(DMatrix::zeros(r, c), |acc, (k, m)| {
                acc + m * node.powi(k as i32)
            });
        if (&fitted - value).norm() > 1e-9 * (1.0 + value.norm()) {
            return None;
        }
    }
    let size = values.iter().map(|m| m.norm()).fold(0.0, f64::max);
    Some(Polynomial {
        parameter: p.to_string(),
        coefficients: coefficients
            .iter()
            .enumerate()
            .filter(|(_, m)| m.norm() > 1e-13 * size)
            .map(|(k, m)| (k, rows(m)))
            .collect(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn degrees_of_polynomials_and_of_other_expressions() {
        let e = |s: &str| hamel_expr::parse(s).unwrap().expr;
        assert_eq!(degree(&e("-v/rR"), "v"), Some(1));
        assert_eq!(degree(&e("3*v^2 + v*w"), "v"), Some(2));
        assert_eq!(degree(&e("rR"), "v"), Some(0));
        assert_eq!(degree(&e("sin(v)"), "v"), None);
    }
}
