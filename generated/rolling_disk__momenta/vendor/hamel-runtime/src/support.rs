//! The normal forces of the wheels a frame carries on the ground (issue 58).
//!
//! A wheel the frames keep on the ground has no row of α for its height: its normal force is
//! the multiplier of a constraint the coordinates eliminated. hamel-bodies releases it: the
//! root frame of the wheel's chain gets a virtual heave and two tilts p, whose Lagrange
//! equations at p = ṗ = p̈ = 0 read G N = b with
//! b = A_pq q̈ + bias(q, q̇) − Σ_i α_ip λ_i and G_pw the rate of wheel w's contact height along
//! p (the heave's row of G is all ones). Their coefficients come from a tape (interpreted, or
//! straight-line generated code) laid out as [`SupportLayout`] says; q̈ and λ from the
//! structured evaluation ([`crate::Structured::constraint_force`]). Nothing is allocated.

use crate::Scalar;
use crate::lu::{self, Pivot};

/// Where one support's coefficients lie in a vector of values `v`: from `at`, A_pq (3×ℓ,
/// row-major), the bias (3), α_ip for each of its rows of α (3 each), G (3 × the wheels,
/// row-major).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SupportLayout {
    /// The first value.
    pub at: usize,
    /// ℓ.
    pub ell: usize,
    /// The number of rows of α with a part in its equations.
    pub rows: usize,
    /// The number of wheels (unknowns).
    pub wheels: usize,
}

impl SupportLayout {
    /// The number of values it takes.
    pub const fn len(&self) -> usize {
        3 * self.ell + 3 + 3 * self.rows + 3 * self.wheels
    }

    /// Whether it takes none (never: three equations at least).
    pub const fn is_empty(&self) -> bool {
        false
    }

    const fn bias(&self) -> usize {
        self.at + 3 * self.ell
    }

    const fn heights(&self) -> usize {
        self.bias() + 3 + 3 * self.rows
    }
}

/// b = A_pq q̈ + bias − Σ_k α_{p,k} λ_{rows[k]} for p = heave, tilt, tilt: the right side of the
/// support's equations G N = b (b₀, the heave's, is the sum of its wheels' normal forces).
pub fn support_equations<S: Scalar>(
    lay: SupportLayout,
    rows: &[usize],
    v: &[S],
    multipliers: &[S],
    q_ddot: &[S],
) -> [S; 3] {
    let mut b = [S::constant(0.0); 3];
    let alpha = lay.bias() + 3;
    for (p, bp) in b.iter_mut().enumerate() {
        let mut x = v[lay.bias() + p];
        for (j, qdd) in q_ddot.iter().enumerate().take(lay.ell) {
            x = x + v[lay.at + p * lay.ell + j] * *qdd;
        }
        for (k, &i) in rows.iter().enumerate() {
            x = x - v[alpha + 3 * k + p] * multipliers[i];
        }
        *bp = x;
    }
    b
}

/// The normal forces N (one per wheel, into `out`) with G N = b, solved on the rows the
/// pivoting selects (the system is consistent: the released motion is one the other
/// constraints do not hold). `false` when the wheels are more than three or G loses rank
/// (their contacts on one line): their forces are not determined one by one there.
pub fn support_normals<S: Scalar>(
    lay: SupportLayout,
    rows: &[usize],
    v: &[S],
    multipliers: &[S],
    q_ddot: &[S],
    out: &mut [S],
) -> bool {
    let n = lay.wheels;
    if n == 0 || n > 3 || out.len() < n {
        return false;
    }
    let mut b = support_equations(lay, rows, v, multipliers, q_ddot);
    let mut g = [S::constant(0.0); 9];
    g[..3 * n].copy_from_slice(&v[lay.heights()..lay.heights() + 3 * n]);
    let mut perm = [0; 3];
    if !lu::factor_rows(3, n, &mut g[..3 * n], &mut perm, Pivot::Relative(1e-12)) {
        return false;
    }
    let mut tmp = [S::constant(0.0); 3];
    lu::solve(n, &g[..3 * n], &perm, &mut b, &mut tmp[..n]);
    out[..n].copy_from_slice(&b[..n]);
    true
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A frame on two wheels at lateral offsets ±1 (heave, roll about the axle's line, pitch):
    /// G = [[1, 1], [1, −1], [0, 0]], weight 10 and a roll moment 2 split 6 and 4.
    #[test]
    fn two_wheels_share_a_weight_by_their_moment() {
        let lay = SupportLayout {
            at: 0,
            ell: 1,
            rows: 0,
            wheels: 2,
        };
        // A_pq (3×1), bias, G (3×2)
        let v = [0.0, 0.0, 0.0, 10.0, 2.0, 0.0, 1.0, 1.0, 1.0, -1.0, 0.0, 0.0];
        let mut n = [0.0; 2];
        assert!(support_normals(lay, &[], &v, &[], &[0.0], &mut n));
        assert!(
            (n[0] - 6.0).abs() < 1e-14 && (n[1] - 4.0).abs() < 1e-14,
            "{n:?}"
        );
    }

    /// Four wheels on one frame: not determined one by one.
    #[test]
    fn four_wheels_are_not_determined_one_by_one() {
        let lay = SupportLayout {
            at: 0,
            ell: 1,
            rows: 0,
            wheels: 4,
        };
        let v = [0.0; 3 + 3 + 12];
        assert!(!support_normals(lay, &[], &v, &[], &[0.0], &mut [0.0; 4]));
    }
}
