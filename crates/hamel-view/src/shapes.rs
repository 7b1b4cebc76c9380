//! The solids a body is drawn as when the model gives no shape: the box and the ellipsoid of
//! uniform density with the body's mass and principal moments of inertia, on its principal
//! axes (what MuJoCo's viewer draws for a body without geometry).
//!
//! A uniform box of sides (a, b, c) has I₁ = m(b² + c²)/12 about its first axis, so
//! a² = 6(I₂ + I₃ − I₁)/m; a uniform ellipsoid of semi-axes (a, b, c) has I₁ = m(b² + c²)/5,
//! so a² = 5(I₂ + I₃ − I₁)/(2m). Moments that break the triangle inequality (I₁ > I₂ + I₃,
//! which no rigid body has, or a point mass) give a side of zero, drawn at a minimum size.

use nalgebra::{Matrix3, Rotation3, UnitQuaternion};

/// A solid equivalent to a body's inertia: its half-extents along its principal axes (a box's
/// half-sides, or an ellipsoid's semi-axes) and the rotation (w, x, y, z) from the body frame's
/// axes to the principal axes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Equivalent {
    /// Half-extents along the principal axes.
    pub half: [f64; 3],
    /// The principal axes in the frame's axes, as a unit quaternion (w, x, y, z).
    pub rotation: [f64; 4],
}

/// Which solid.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Solid {
    /// A uniform box.
    Box,
    /// A uniform ellipsoid.
    Ellipsoid,
}

/// The `solid` of mass `mass` whose inertia about its centre is `inertia` (symmetric, in the
/// frame's axes). None when the mass is not positive and finite or the inertia not finite.
pub fn equivalent(solid: Solid, mass: f64, inertia: [[f64; 3]; 3]) -> Option<Equivalent> {
    if !(mass > 0.0 && mass.is_finite()) || inertia.iter().flatten().any(|v| !v.is_finite()) {
        return None;
    }
    let m = Matrix3::from_fn(|i, j| 0.5 * (inertia[i][j] + inertia[j][i]));
    let eigen = m.symmetric_eigen();
    let mut axes = eigen.eigenvectors;
    if axes.determinant() < 0.0 {
        axes.set_column(2, &(-axes.column(2)));
    }
    let i = eigen.eigenvalues;
    let factor = match solid {
        Solid::Box => 6.0 / mass,
        Solid::Ellipsoid => 2.5 / mass,
    };
    let side = |k: usize| {
        let (a, b, c) = (i[k], i[(k + 1) % 3], i[(k + 2) % 3]);
        let squared = factor * (b + c - a);
        let full = squared.max(0.0).sqrt();
        match solid {
            Solid::Box => 0.5 * full,
            Solid::Ellipsoid => full,
        }
    };
    let q = UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(axes));
    Some(Equivalent {
        half: [side(0), side(1), side(2)],
        rotation: [q.w, q.i, q.j, q.k],
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The inertia of a uniform box of half-sides `h`, turned by `r`.
    fn box_inertia(mass: f64, h: [f64; 3], r: &Rotation3<f64>) -> [[f64; 3]; 3] {
        let s = h.map(|x| 4.0 * x * x);
        let d = Matrix3::from_diagonal(&nalgebra::Vector3::new(
            mass * (s[1] + s[2]) / 12.0,
            mass * (s[0] + s[2]) / 12.0,
            mass * (s[0] + s[1]) / 12.0,
        ));
        let m = r.matrix() * d * r.matrix().transpose();
        [0, 1, 2].map(|i| [0, 1, 2].map(|j| m[(i, j)]))
    }

    #[test]
    fn a_turned_box_is_found_again_with_its_axes() {
        let r = Rotation3::from_euler_angles(0.3, -0.7, 1.1);
        let half = [0.5, 0.2, 0.05];
        let e = equivalent(Solid::Box, 2.0, box_inertia(2.0, half, &r)).unwrap();
        let mut got = e.half;
        got.sort_by(f64::total_cmp);
        let mut want = half;
        want.sort_by(f64::total_cmp);
        for (g, w) in got.iter().zip(want) {
            assert!((g - w).abs() < 1e-12, "{got:?} vs {want:?}");
        }
        // The rotation takes the principal axes to the frame's: the inertia rebuilt from the
        // found half-sides along it is the given one.
        let q = UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(
            e.rotation[0],
            e.rotation[1],
            e.rotation[2],
            e.rotation[3],
        ));
        let rebuilt = box_inertia(2.0, e.half, &q.to_rotation_matrix());
        let given = box_inertia(2.0, half, &r);
        for i in 0..3 {
            for j in 0..3 {
                assert!((rebuilt[i][j] - given[i][j]).abs() < 1e-12);
            }
        }
    }

    #[test]
    fn an_ellipsoid_of_a_sphere_s_inertia_is_the_sphere() {
        let (m, a) = (3.0, 0.4);
        let i = 0.4 * m * a * a;
        let e = equivalent(
            Solid::Ellipsoid,
            m,
            [[i, 0.0, 0.0], [0.0, i, 0.0], [0.0, 0.0, i]],
        );
        for h in e.unwrap().half {
            assert!((h - a).abs() < 1e-12);
        }
        assert!(equivalent(Solid::Box, 0.0, [[1.0; 3]; 3]).is_none());
    }
}
