//! The configuration space: positions q (nq coordinates) and their tangent,
//! the velocities (nv), as MuJoCo lays them out (module `model`).
//!
//! A ball or free joint's orientation is a unit quaternion (w, x, y, z); its
//! angular velocity w is in the body frame, so a motion by w over time h
//! multiplies the quaternion on the right by exp(w h / 2). Where MuJoCo
//! normalises, these functions do too: the rotation a quaternion stands for
//! is read from it normalised, and integration returns it normalised.

use nalgebra::{Matrix3, Vector3};

use super::Tree;
use crate::spatial::{lift, Real};

/// How node i's coordinates sit in q (see [`super::tree::NodeJoint`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Coordinates {
    /// One coordinate, `q[at]` (hinge, slide, a free joint's translations).
    Scalar { at: usize },
    /// Axis `axis` of a ball's rotation, whose quaternion is q[at..at + 4].
    Rotation { at: usize, axis: usize },
}

/// q normalised: the unit quaternion (w, x, y, z) of four coordinates.
pub fn normalized<T: Real>(q: &[T]) -> [T; 4] {
    let norm = (q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]).sqrt();
    if norm > T::zero() {
        [q[0] / norm, q[1] / norm, q[2] / norm, q[3] / norm]
    } else {
        [T::one(), T::zero(), T::zero(), T::zero()]
    }
}

/// The rotation matrix of a quaternion (normalised first): its columns are
/// the rotated frame's axes in the unrotated frame.
pub fn rotation_matrix<T: Real>(q: &[T]) -> Matrix3<T> {
    let [w, x, y, z] = normalized(q);
    let two = T::one() + T::one();
    Matrix3::new(
        T::one() - two * (y * y + z * z),
        two * (x * y - w * z),
        two * (x * z + w * y),
        two * (x * y + w * z),
        T::one() - two * (x * x + z * z),
        two * (y * z - w * x),
        two * (x * z - w * y),
        two * (y * z + w * x),
        T::one() - two * (x * x + y * y),
    )
}

/// The quaternion product a b.
pub fn multiply<T: Real>(a: &[T; 4], b: &[T; 4]) -> [T; 4] {
    [
        a[0] * b[0] - a[1] * b[1] - a[2] * b[2] - a[3] * b[3],
        a[0] * b[1] + a[1] * b[0] + a[2] * b[3] - a[3] * b[2],
        a[0] * b[2] - a[1] * b[3] + a[2] * b[0] + a[3] * b[1],
        a[0] * b[3] + a[1] * b[2] - a[2] * b[1] + a[3] * b[0],
    ]
}

/// The quaternion turned by the body-frame rotation vector r (axis times
/// angle): q exp(r / 2), normalised (MuJoCo's mju_quatIntegrate with h = 1).
pub fn rotate<T: Real>(q: &[T], r: &Vector3<T>) -> [T; 4] {
    let squared = r.norm_squared();
    // (cos(t/2), sin(t/2) / t), t = |r|; by their series below t = 1e-6 (exact
    // there in f64, and free of the square root's infinite slope at zero, so
    // dual numbers seeded along r from r = 0 carry the derivative)
    let (cos, scale) = if squared < lift(1e-12) {
        let (one, eighth) = (T::one(), lift::<T>(0.125));
        (
            one - squared * eighth,
            lift::<T>(0.5) * (one - squared / lift(24.0)),
        )
    } else {
        let angle = squared.sqrt();
        let half = angle / lift(2.0);
        (half.cos(), half.sin() / angle)
    };
    let turn = [cos, r.x * scale, r.y * scale, r.z * scale];
    normalized(&multiply(&normalized(q), &turn))
}

/// The body-frame rotation vector r with b exp(r / 2) = a, the shorter way
/// round (MuJoCo's mju_subQuat): a's orientation relative to b's.
pub fn difference<T: Real>(a: &[T], b: &[T]) -> Vector3<T> {
    let [bw, bx, by, bz] = normalized(b);
    let d = multiply(&[bw, -bx, -by, -bz], &normalized(a));
    let (w, v) = (d[0], Vector3::new(d[1], d[2], d[3]));
    let sin = v.norm();
    if sin == T::zero() {
        return Vector3::zeros();
    }
    let mut angle = (T::one() + T::one()) * sin.atan2(w);
    if angle > T::pi() {
        angle -= T::two_pi();
    }
    v * (angle / sin)
}

/// q' = q (+) h v: each joint's coordinates moved by its velocities over h
/// (MuJoCo's mj_integratePos; quaternions normalised).
pub fn integrate<T: Real>(tree: &Tree<T>, q: &[T], v: &[T], h: T, out: &mut [T]) {
    out.copy_from_slice(q);
    let mut i = 0;
    while i < tree.nv() {
        match tree.joint[i].coordinates {
            Coordinates::Scalar { at } => {
                out[at] = q[at] + h * v[i];
                i += 1;
            }
            Coordinates::Rotation { at, .. } => {
                let r = Vector3::new(v[i], v[i + 1], v[i + 2]) * h;
                out[at..at + 4].copy_from_slice(&rotate(&q[at..at + 4], &r));
                i += 3;
            }
        }
    }
}

/// The rate of the tangent coordinates theta of q (+) theta when the
/// velocity is v: v itself for hinges and slides; for a rotation, whose
/// body-frame angular velocity w relates to theta by the right Jacobian of
/// the exponential map, J_r(theta)^-1 w = w + theta x w / 2 +
/// c(t) theta x (theta x w), c(t) = 1/t^2 - (1 + cos t) / (2 t sin t),
/// t = |theta|.
/// MuJoCo's RK4 takes its stages in these coordinates (Munthe-Kaas), which
/// keeps it fourth-order on ball and free joints.
pub fn tangent_rate<T: Real>(tree: &Tree<T>, theta: &[T], v: &[T], out: &mut [T]) {
    let mut i = 0;
    while i < tree.nv() {
        match tree.joint[i].coordinates {
            Coordinates::Scalar { .. } => {
                out[i] = v[i];
                i += 1;
            }
            Coordinates::Rotation { .. } => {
                let t = Vector3::new(theta[i], theta[i + 1], theta[i + 2]);
                let w = Vector3::new(v[i], v[i + 1], v[i + 2]);
                let cross = t.cross(&w);
                let rate =
                    w + cross * lift::<T>(0.5) + t.cross(&cross) * second_order(t.norm_squared());
                out[i..i + 3].copy_from_slice(rate.as_slice());
                i += 3;
            }
        }
    }
}

/// 1/t^2 - (1 + cos t) / (2 t sin t) of t^2 = `squared`, by its series
/// 1/12 + t^2/720 below t = 1e-4 (where the difference cancels, and where
/// the square root's slope would be infinite for dual numbers at t = 0).
pub(crate) fn second_order<T: Real>(squared: T) -> T {
    if squared < lift(1e-8) {
        lift::<T>(1.0 / 12.0) + squared / lift(720.0)
    } else {
        let t = squared.sqrt();
        T::one() / squared - (T::one() + t.cos()) / (lift::<T>(2.0) * t * t.sin())
    }
}

/// The tangent vector d (nv) with b (+) d = a (MuJoCo's mj_differentiatePos
/// with h = 1).
pub fn subtract<T: Real>(tree: &Tree<T>, a: &[T], b: &[T], out: &mut [T]) {
    let mut i = 0;
    while i < tree.nv() {
        match tree.joint[i].coordinates {
            Coordinates::Scalar { at } => {
                out[i] = a[at] - b[at];
                i += 1;
            }
            Coordinates::Rotation { at, .. } => {
                let r = difference(&a[at..at + 4], &b[at..at + 4]);
                out[i..i + 3].copy_from_slice(r.as_slice());
                i += 3;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rotation_matches_nalgebra_and_ignores_scale() {
        let u = nalgebra::UnitQuaternion::from_euler_angles(0.3, -1.1, 2.0);
        let q = [2.0 * u.w, 2.0 * u.i, 2.0 * u.j, 2.0 * u.k];
        let expected = u.to_rotation_matrix().into_inner();
        assert!((rotation_matrix(&q) - expected).abs().max() < 1e-15);
    }

    #[test]
    fn rotate_then_difference_is_the_rotation_vector() {
        let q = normalized(&[0.9, -0.2, 0.3, 0.1]);
        for r in [
            Vector3::new(0.2, -0.5, 0.7),
            Vector3::new(3.0, 0.0, 0.0),
            Vector3::zeros(),
        ] {
            let moved = rotate(&q, &r);
            assert!((difference(&moved, &q) - r).norm() < 1e-14, "{r:?}");
            // the body-frame axis: R(moved) = R(q) exp(r)
            let turn = nalgebra::Rotation3::new(r).into_inner();
            let expected = rotation_matrix(&q) * turn;
            assert!((rotation_matrix(&moved) - expected).abs().max() < 1e-14);
        }
    }

    #[test]
    fn tangent_rate_is_the_derivative_of_the_tangent_coordinates() {
        // q(t) = q0 (+) theta(t) turning at body rate w: theta' = tangent_rate
        let path = concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/reference_models/free_ball.xml"
        );
        let model = crate::Model::load(path).unwrap();
        let tree = model.tree();
        let first = (0..tree.nv())
            .find(|i| matches!(tree.joint[*i].coordinates, Coordinates::Rotation { .. }))
            .unwrap();
        let q0 = normalized(&[0.8, 0.3, -0.4, 0.2]);
        let (theta, w) = (Vector3::new(0.4, -1.3, 0.9), Vector3::new(2.0, 0.5, -1.0));
        let (mut thetas, mut v) = (vec![0.0; tree.nv()], vec![0.0; tree.nv()]);
        thetas[first..first + 3].copy_from_slice(theta.as_slice());
        v[first..first + 3].copy_from_slice(w.as_slice());
        let mut out = vec![0.0; tree.nv()];
        tangent_rate(tree, &thetas, &v, &mut out);
        let rate = Vector3::from_column_slice(&out[first..first + 3]);
        // moving theta along the rate turns the body at w (to first order)
        let e = 1e-6;
        let ahead = rotate(&q0, &(theta + rate * e));
        let turned = rotate(&rotate(&q0, &theta), &(w * e));
        let gap = difference(&ahead, &turned).norm();
        assert!(gap < 1e-11, "{gap}");
    }

    #[test]
    fn difference_takes_the_shorter_way() {
        let q = [1.0, 0.0, 0.0, 0.0];
        let far = rotate(&q, &Vector3::new(0.0, 0.0, 3.5));
        let d = difference(&far, &q);
        assert!((d - Vector3::new(0.0, 0.0, 3.5 - std::f64::consts::TAU)).norm() < 1e-12);
        // -q is the same orientation
        let minus = far.map(|x| -x);
        assert!((difference(&minus, &q) - d).norm() < 1e-12);
    }
}
