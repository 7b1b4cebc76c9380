//! A body's motion: what its share of the kinetic energy is built from (the velocity of its
//! centre of mass and its angular velocity per unit rate of each coordinate), for the
//! expansion's A and for the momenta of a released support.

use hamel_expr::Expr;
use hamel_expr::build::{add, mul};

use crate::vector::{Rate, dot};

/// A body's motion: its mass, the velocity of its centre of mass and its angular velocity per
/// unit q̇_k (in the axes it is carried to), its inertia there, and its height.
pub(crate) struct Motion {
    pub mass: Expr,
    pub v: Rate,
    pub omega: Rate,
    pub inertia: Option<crate::vector::M3>,
    pub height: Expr,
}

impl Motion {
    /// I·W_k, per coordinate (none for a point mass).
    fn inertia_times(&self, w: &[crate::vector::V3]) -> Option<Vec<crate::vector::V3>> {
        (self.inertia.as_ref()).map(|i| w.iter().map(|c| crate::vector::apply(i, c)).collect())
    }

    /// Its share of A: m V_iᵀV_j + W_iᵀ I W_j.
    pub(crate) fn mass_matrix(&self) -> Vec<Vec<Expr>> {
        let (v, w) = (&self.v.columns, &self.omega.columns);
        let iw = self.inertia_times(w);
        let entry = |i: usize, j: usize| {
            let translation = mul(self.mass.clone(), dot(&v[i], &v[j]));
            match &iw {
                Some(iw) => add(translation, dot(&w[i], &iw[j])),
                None => translation,
            }
        };
        let n = v.len();
        (0..n)
            .map(|i| (0..n).map(|j| entry(i, j)).collect())
            .collect()
    }
}
