//! Vectors, matrices and linear forms in the velocities, with expression entries built by the
//! folding builders (structural zeros vanish as they arise).
//!
//! A velocity of a mechanism is linear in q̇: v = Σ_k v_k q̇_k. [`Rate`] keeps the columns v_k
//! (one 3-vector per coordinate), so that the kinetic energy's matrix A = Σ m V_kᵀV_j + … and
//! the constraint rows are read off without expanding anything.

use hamel_expr::Expr;
use hamel_expr::build::{add, mul, neg, sub, sum};

/// A 3-vector of expressions, in the axes of some frame.
pub type V3 = [Expr; 3];

/// A 3×3 matrix of expressions, row-major.
pub type M3 = [[Expr; 3]; 3];

/// The zero vector.
pub fn zero() -> V3 {
    [Expr::int(0), Expr::int(0), Expr::int(0)]
}

/// The unit vector along axis `i`, times `sign`.
pub fn unit(i: usize, sign: i64) -> V3 {
    let mut v = zero();
    v[i] = Expr::int(sign);
    v
}

/// The identity matrix.
pub fn identity() -> M3 {
    [unit(0, 1), unit(1, 1), unit(2, 1)]
}

/// a · b.
pub fn dot(a: &V3, b: &V3) -> Expr {
    sum((0..3).map(|i| mul(a[i].clone(), b[i].clone())))
}

/// a × b.
pub fn cross(a: &V3, b: &V3) -> V3 {
    let c = |i: usize, j: usize| {
        sub(
            mul(a[i].clone(), b[j].clone()),
            mul(a[j].clone(), b[i].clone()),
        )
    };
    [c(1, 2), c(2, 0), c(0, 1)]
}

/// a + b.
pub fn plus(a: &V3, b: &V3) -> V3 {
    std::array::from_fn(|i| add(a[i].clone(), b[i].clone()))
}

/// s·a.
pub fn scale(s: &Expr, a: &V3) -> V3 {
    std::array::from_fn(|i| mul(s.clone(), a[i].clone()))
}

/// −a.
pub fn negate(a: &V3) -> V3 {
    std::array::from_fn(|i| neg(a[i].clone()))
}

/// m·v.
pub fn apply(m: &M3, v: &V3) -> V3 {
    std::array::from_fn(|i| dot(&m[i], v))
}

/// mᵀ·v.
pub fn apply_transpose(m: &M3, v: &V3) -> V3 {
    std::array::from_fn(|i| sum((0..3).map(|j| mul(m[j][i].clone(), v[j].clone()))))
}

/// a·b.
pub fn compose(a: &M3, b: &M3) -> M3 {
    std::array::from_fn(|i| {
        std::array::from_fn(|j| sum((0..3).map(|k| mul(a[i][k].clone(), b[k][j].clone()))))
    })
}

/// A vector linear in the velocities, Σ_k v_k q̇_k: one column v_k per coordinate.
#[derive(serde::Serialize, serde::Deserialize, Clone, Debug, PartialEq)]
pub struct Rate {
    /// v_k, for k = 1..ℓ.
    pub columns: Vec<V3>,
}

impl Rate {
    /// Zero, for ℓ coordinates.
    pub fn zero(ell: usize) -> Rate {
        Rate {
            columns: vec![zero(); ell],
        }
    }

    /// The rate of a vector of expressions of q: Σ_k ∂p/∂q_k q̇_k.
    pub fn of(p: &V3, coordinates: &[String]) -> Result<Rate, hamel_expr::DiffError> {
        let columns = coordinates
            .iter()
            .map(|q| {
                let d = |i: usize| p[i].diff(q);
                Ok([d(0)?, d(1)?, d(2)?])
            })
            .collect::<Result<_, _>>()?;
        Ok(Rate { columns })
    }

    /// `w`·θ̇ where θ̇ = Σ_k ∂θ/∂q_k q̇_k: a fixed direction times the rate of an angle.
    pub fn along(
        w: &V3,
        angle: &Expr,
        coordinates: &[String],
    ) -> Result<Rate, hamel_expr::DiffError> {
        let columns = coordinates
            .iter()
            .map(|q| Ok(scale(&angle.diff(q)?, w)))
            .collect::<Result<_, _>>()?;
        Ok(Rate { columns })
    }

    /// self + other.
    pub fn plus(&self, other: &Rate) -> Rate {
        self.zip(other, plus)
    }

    /// m·self (each column).
    pub fn apply(&self, m: &M3) -> Rate {
        self.map(|c| apply(m, c))
    }

    /// mᵀ·self (each column).
    pub fn apply_transpose(&self, m: &M3) -> Rate {
        self.map(|c| apply_transpose(m, c))
    }

    /// s·self (each column), for s not depending on the velocities.
    pub fn scale(&self, s: &Expr) -> Rate {
        self.map(|c| scale(s, c))
    }

    /// self × r, for r not depending on the velocities.
    pub fn cross(&self, r: &V3) -> Rate {
        self.map(|c| cross(c, r))
    }

    /// The linear form e·self: one coefficient per velocity.
    pub fn dot(&self, e: &V3) -> Vec<Expr> {
        self.columns.iter().map(|c| dot(e, c)).collect()
    }

    fn map(&self, f: impl Fn(&V3) -> V3) -> Rate {
        Rate {
            columns: self.columns.iter().map(f).collect(),
        }
    }

    fn zip(&self, other: &Rate, f: impl Fn(&V3, &V3) -> V3) -> Rate {
        Rate {
            columns: self
                .columns
                .iter()
                .zip(&other.columns)
                .map(|(a, b)| f(a, b))
                .collect(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cross_products_of_the_axes_are_right_handed() {
        let (x, y, z) = (unit(0, 1), unit(1, 1), unit(2, 1));
        assert_eq!(cross(&x, &y), z);
        assert_eq!(cross(&y, &z), x);
        assert_eq!(cross(&z, &x), y);
        assert_eq!(dot(&x, &y), Expr::int(0));
        assert_eq!(apply(&identity(), &z), z);
    }
}
