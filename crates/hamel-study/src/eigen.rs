//! Eigenvalues from nalgebra's real Schur form, with an iteration cap (its complex eigenvalue
//! routines can fail to converge: nalgebra issues 611, 764, 1528), and what the study derives
//! from them: stability, structural zeros, the characteristic polynomial's coefficients.

use nalgebra::DMatrix;

use crate::Stability;

/// Iterations of the Schur decomposition per row before it is declared a failure.
pub const ITERATIONS_PER_ROW: usize = 200;

/// Relative size under which a real part counts as zero (stability, crossings).
pub const ZERO_REAL_PART: f64 = 1e-9;

/// The eigenvalues of `a` as (re, im), sorted by real part then imaginary part; the
/// iteration cap when the Schur form does not converge.
pub fn eigenvalues(a: &DMatrix<f64>) -> Result<Vec<[f64; 2]>, usize> {
    let n = a.nrows();
    if n == 0 {
        return Ok(Vec::new());
    }
    let cap = ITERATIONS_PER_ROW * n;
    let schur = nalgebra::linalg::Schur::try_new(balanced(a), f64::EPSILON, cap).ok_or(cap)?;
    let mut out: Vec<[f64; 2]> = schur
        .complex_eigenvalues()
        .iter()
        .map(|z| [z.re, z.im])
        .collect();
    if out.iter().flatten().any(|x| !x.is_finite()) {
        return Err(cap);
    }
    out.sort_by(|x, y| x[0].total_cmp(&y[0]).then(x[1].total_cmp(&y[1])));
    Ok(out)
}

/// The `count` eigenvalues of smallest modulus, and the others (order kept).
pub fn split_smallest(lambda: Vec<[f64; 2]>, count: usize) -> (Vec<[f64; 2]>, Vec<[f64; 2]>) {
    let mut by_size: Vec<usize> = (0..lambda.len()).collect();
    by_size.sort_by(|&i, &k| {
        modulus(lambda[i])
            .total_cmp(&modulus(lambda[k]))
            .then(i.cmp(&k))
    });
    let small: Vec<usize> = by_size.into_iter().take(count).collect();
    let (mut zeros, mut rest) = (Vec::new(), Vec::new());
    for (i, z) in lambda.into_iter().enumerate() {
        if small.contains(&i) {
            zeros.push(z);
        } else {
            rest.push(z);
        }
    }
    (zeros, rest)
}

fn modulus(z: [f64; 2]) -> f64 {
    z[0].hypot(z[1])
}

/// `a` balanced (a diagonal similarity, Parlett–Reinsch): the same eigenvalues, computed more
/// accurately when the state's components have different units (angles and momenta).
pub fn balanced(a: &DMatrix<f64>) -> DMatrix<f64> {
    let mut b = a.clone();
    nalgebra::linalg::balancing::balance_parlett_reinsch(&mut b);
    b
}

/// The scale of a matrix for relative tolerances: the Frobenius norm of it balanced (1 when
/// zero), which does not depend on the units of the state.
pub fn scale(a: &DMatrix<f64>) -> f64 {
    let s = balanced(a).norm();
    if s > 0.0 { s } else { 1.0 }
}

/// Stability from the eigenvalues that are not structural: a real part above
/// [`ZERO_REAL_PART`]·scale is unstable.
pub fn stability(lambda: &[[f64; 2]], scale: f64) -> Stability {
    let tol = ZERO_REAL_PART * scale;
    let top = lambda
        .iter()
        .map(|z| z[0])
        .fold(f64::NEG_INFINITY, f64::max);
    if lambda.is_empty() {
        Stability::Marginal
    } else if top > tol {
        Stability::Unstable
    } else if top >= -tol {
        Stability::Marginal
    } else {
        Stability::Asymptotic
    }
}

/// The coefficients of det(λI − A) = Π(λ − λ_i), from λ⁰ up (real parts; the imaginary parts
/// cancel in pairs).
pub fn char_poly(lambda: &[[f64; 2]]) -> Vec<f64> {
    let mut c: Vec<[f64; 2]> = vec![[1.0, 0.0]];
    for z in lambda {
        let mut next = vec![[0.0, 0.0]; c.len() + 1];
        for (k, ck) in c.iter().enumerate() {
            next[k + 1][0] += ck[0];
            next[k + 1][1] += ck[1];
            next[k][0] -= ck[0] * z[0] - ck[1] * z[1];
            next[k][1] -= ck[0] * z[1] + ck[1] * z[0];
        }
        c = next;
    }
    c.into_iter().map(|z| z[0]).collect()
}

/// The coefficient of λ^s of det(λI − A): with s structural zeros, ± the product of the other
/// eigenvalues. It changes sign where a real eigenvalue passes through zero, whatever the
/// order in which the eigenvalues come (it is symmetric in them).
pub fn char_coefficient(lambda: &[[f64; 2]], s: usize) -> f64 {
    char_poly(lambda).get(s).copied().unwrap_or(0.0)
}

/// How many eigenvalues of `a` are zero to rounding: the number of trailing coefficients of
/// the characteristic polynomial c_k with |c_k| ≤ 1e-9·C(n, k)·‖A‖^(n−k) (robust where zeros
/// form a Jordan block, whose eigenvalues rounding spreads to ‖A‖·√ε).
pub fn zero_multiplicity(a: &DMatrix<f64>, lambda: &[[f64; 2]]) -> usize {
    let n = lambda.len();
    let rho = scale(a);
    let c = char_poly(lambda);
    let mut binomial = 1.0_f64;
    let mut k = 0;
    while k < n {
        if c[k].abs() > 1e-9 * binomial * rho.powi((n - k) as i32) {
            break;
        }
        binomial = binomial * (n - k) as f64 / (k + 1) as f64;
        k += 1;
    }
    k
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn eigenvalues_of_a_rotation_and_a_jordan_block() {
        let a = DMatrix::from_row_slice(3, 3, &[0.0, -2.0, 0.0, 2.0, 0.0, 0.0, 0.0, 0.0, -1.0]);
        let l = eigenvalues(&a).unwrap();
        assert_eq!(l.len(), 3);
        assert!((l[0][0] + 1.0).abs() < 1e-15 && l[0][1] == 0.0);
        assert!((l[1][1] + 2.0).abs() < 1e-14 && (l[2][1] - 2.0).abs() < 1e-14);
        let jordan = DMatrix::from_row_slice(3, 3, &[0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 3.0]);
        let l = eigenvalues(&jordan).unwrap();
        assert_eq!(zero_multiplicity(&jordan, &l), 2);
        assert_eq!(zero_multiplicity(&a, &eigenvalues(&a).unwrap()), 0);
    }

    #[test]
    fn the_characteristic_coefficient_is_the_product_of_the_others() {
        let l = [[0.0, 0.0], [-1.0, 2.0], [-1.0, -2.0], [3.0, 0.0]];
        let c = char_poly(&l);
        // (λ)(λ² + 2λ + 5)(λ − 3) = λ⁴ − λ³ − λ² − 15λ
        let want = [0.0, -15.0, -1.0, -1.0, 1.0];
        for (got, want) in c.iter().zip(want) {
            assert!((got - want).abs() < 1e-13, "{c:?}");
        }
        assert_eq!(char_coefficient(&l, 1), c[1]);
        let (zeros, rest) = split_smallest(l.to_vec(), 1);
        assert_eq!(zeros, vec![[0.0, 0.0]]);
        assert_eq!(rest.len(), 3);
    }
}
