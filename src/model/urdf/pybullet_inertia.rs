//! PyBullet's reading of a link's inertia ([`super::Inertials::PyBullet`]),
//! as its URDF importer computes it under loadURDF's
//! URDF_USE_INERTIA_FROM_FILE (BulletURDFImporter::getMassAndInertia; the
//! harness's flag, measured with pybullet 3.2.7's getDynamicsInfo):
//! - a link without `<inertial>` has mass 1, principal moments (1, 1, 1)
//!   and its COM at the link origin;
//! - a tensor with an off-diagonal term is brought to principal axes by
//!   Bullet's Jacobi iteration (btMatrix3x3::diagonalize, threshold 1e-6, at
//!   most 30 rotations, see [`principal`]), and what it leaves off the
//!   diagonal (up to ~6e-8 relative on the corpus) is dropped;
//! - principal moments that are negative or violate the triangle inequality
//!   (strictly, see [`physical`]) are zeroed; the mass stays.
//!
//! The tensor returned is `R diag(moments) R^T` in the axes the tensor was
//! given in, R the principal axes: PyBullet's link inertia to rounding.

use nalgebra::{Matrix3, Vector3};

/// Bullet's convergence threshold, relative to the sum of |diagonal|.
const THRESHOLD: f64 = 1e-6;
/// Bullet's cap on the number of rotations.
const MAX_ROTATIONS: usize = 30;

/// The inertia PyBullet gives a link without `<inertial>`.
pub(super) fn missing() -> Matrix3<f64> {
    Matrix3::identity()
}

/// PyBullet's principal moments and axes (columns) of a symmetric `tensor`:
/// the diagonal as written when every off-diagonal term is exactly 0, else
/// Bullet's cyclic-by-largest Jacobi iteration: each rotation zeroes the
/// largest off-diagonal term (the first of (0,1), (0,2), (1,2) on a tie);
/// it stops when that term is at most eps times the threshold bound, and
/// after one more rotation once it is below the bound.
pub(super) fn principal(tensor: &Matrix3<f64>) -> (Vector3<f64>, Matrix3<f64>) {
    let mut a = *tensor;
    let mut axes = Matrix3::identity();
    if [a[(0, 1)], a[(0, 2)], a[(1, 2)]] == [0.0; 3] {
        return (a.diagonal(), axes);
    }
    let mut left = MAX_ROTATIONS;
    while left > 0 {
        let (p, q, r) = largest_off_diagonal(&a);
        let bound = THRESHOLD * (a[(0, 0)].abs() + a[(1, 1)].abs() + a[(2, 2)].abs());
        if a[(p, q)].abs() <= bound {
            if a[(p, q)].abs() <= f64::EPSILON * bound {
                break;
            }
            left = 1;
        }
        rotate(&mut a, &mut axes, (p, q, r));
        left -= 1;
    }
    (a.diagonal(), axes)
}

/// (p, q, r): the largest off-diagonal term's row and column, and the
/// third index.
fn largest_off_diagonal(a: &Matrix3<f64>) -> (usize, usize, usize) {
    let mut best = (0, 1, 2);
    for candidate in [(0, 2, 1), (1, 2, 0)] {
        if a[(candidate.0, candidate.1)].abs() > a[(best.0, best.1)].abs() {
            best = candidate;
        }
    }
    best
}

/// One Jacobi rotation in the (p, q) plane that zeroes a[p][q]: a becomes
/// J^T a J and axes becomes axes J, with Bullet's tangent t (and its
/// series for a nearly diagonal pair).
fn rotate(a: &mut Matrix3<f64>, axes: &mut Matrix3<f64>, (p, q, r): (usize, usize, usize)) {
    let apq = a[(p, q)];
    let theta = (a[(q, q)] - a[(p, p)]) / (2.0 * apq);
    let theta2 = theta * theta;
    let (t, cos) = if theta2 * theta2 < 10.0 / f64::EPSILON {
        let root = (1.0 + theta2).sqrt();
        let t = if theta >= 0.0 {
            1.0 / (theta + root)
        } else {
            1.0 / (theta - root)
        };
        (t, 1.0 / (1.0 + t * t).sqrt())
    } else {
        let t = 1.0 / (theta * (2.0 + 0.5 / theta2));
        (t, 1.0 - 0.5 * t * t)
    };
    let sin = cos * t;
    a[(p, q)] = 0.0;
    a[(q, p)] = 0.0;
    a[(p, p)] -= t * apq;
    a[(q, q)] += t * apq;
    let (arp, arq) = (a[(r, p)], a[(r, q)]);
    a[(r, p)] = cos * arp - sin * arq;
    a[(p, r)] = a[(r, p)];
    a[(r, q)] = cos * arq + sin * arp;
    a[(q, r)] = a[(r, q)];
    for i in 0..3 {
        let (xp, xq) = (axes[(i, p)], axes[(i, q)]);
        axes[(i, p)] = cos * xp - sin * xq;
        axes[(i, q)] = cos * xq + sin * xp;
    }
}

/// PyBullet's test of principal moments: none negative, none larger than
/// the sum of the other two.
pub(super) fn physical(m: &Vector3<f64>) -> bool {
    (0..3).all(|i| {
        let others = m[(i + 1) % 3] + m[(i + 2) % 3];
        m[i] >= 0.0 && m[i] <= others
    })
}

/// `tensor` (symmetric, in some axes) as PyBullet holds it: principal
/// moments in principal axes, zeroed where not [`physical`]; returns the
/// tensor in the same axes and whether it was zeroed.
pub(super) fn reading(tensor: &Matrix3<f64>) -> (Matrix3<f64>, bool) {
    let (moments, axes) = principal(tensor);
    if !physical(&moments) {
        return (Matrix3::zeros(), true);
    }
    (
        axes * Matrix3::from_diagonal(&moments) * axes.transpose(),
        false,
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The principal moments and axes pybullet 3.2.7 reports
    /// (getDynamicsInfo: local inertia diagonal, inertial frame) for a link
    /// whose `<inertial>` has rpy 0: ixx .3, iyy .2, izz .25, ixy .01,
    /// ixz -.02, iyz .03; and the residue its iteration drops.
    #[test]
    fn principal_axes_are_bullets() {
        let tensor = Matrix3::new(0.3, 0.01, -0.02, 0.01, 0.2, 0.03, -0.02, 0.03, 0.25);
        let (moments, axes) = principal(&tensor);
        let pybullet = [
            0.307_018_290_198_224_74,
            0.183_258_853_421_063_57,
            0.259_722_856_380_711_7,
        ];
        for (m, p) in moments.iter().zip(pybullet) {
            assert!((m - p).abs() <= 1e-16, "{m} vs {p}");
        }
        let orthonormal = (axes.transpose() * axes - Matrix3::identity()).abs().max();
        assert!(orthonormal < 1e-15, "{orthonormal}");
        let residue = (reading(&tensor).0 - tensor).abs().max();
        assert!(residue > 0.0 && residue < 1e-7, "{residue}");
    }

    #[test]
    fn diagonal_tensors_are_kept_and_unphysical_ones_zeroed() {
        let go1_base = Matrix3::from_diagonal(&Vector3::new(0.0, 0.0, 3e-6));
        assert_eq!(reading(&go1_base), (Matrix3::zeros(), true));
        let diagonal = Matrix3::from_diagonal(&Vector3::new(1.0, 2.0, 3.0));
        assert_eq!(reading(&diagonal), (diagonal, false));
        // Romeo's body: an eigenvalue of -0.02.
        let romeo = Matrix3::new(0.05, 0.07, 0.0, 0.07, 0.05, 0.0, 0.0, 0.0, 0.1);
        assert!(reading(&romeo).1);
    }
}
