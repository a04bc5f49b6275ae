//! Spatial vector algebra (Featherstone, *Rigid Body Dynamics Algorithms*, ch. 2),
//! generic over the scalar so that dual numbers flow through it.
//!
//! Conventions:
//! - A 6-vector is (angular; linear). A [`Motion`] is (w, v_O): the angular
//!   velocity and the velocity of the body-fixed point at the frame origin O.
//!   A [`Force`] is (n_O, f): the moment about O and the resultant force.
//! - A [`Transform`] `X` maps coordinates in a frame A to a frame B. It stores `rot`
//!   = E, the rotation taking A coordinates to B coordinates (the transpose of
//!   B's axes written in A), and `trans` = r, B's origin in A coordinates.
//!   As a 6x6 matrix X = [E 0; -E r^ E].
//! - A rigid-body [`Inertia`] about a frame origin O is (m, h = m c, I_O), with c
//!   the COM and I_O the rotational inertia about O, in that frame's axes.

use nalgebra::{Matrix3, RealField, Rotation3, Vector3};
use std::ops::{Add, AddAssign, Mul, Neg, Sub};

/// The scalar the dynamics are generic over: f64, or a dual number.
pub trait Real: RealField + Copy {}
impl<T: RealField + Copy> Real for T {}

/// Lifts an f64 constant into the scalar type.
#[inline]
pub fn lift<T: Real>(x: f64) -> T {
    T::from_subset(&x)
}

pub fn lift_vector<T: Real>(v: &Vector3<f64>) -> Vector3<T> {
    v.map(lift)
}

pub fn lift_matrix<T: Real>(m: &Matrix3<f64>) -> Matrix3<T> {
    m.map(lift)
}

/// The cross-product matrix: skew(a) * b = a x b.
#[inline]
pub fn skew<T: Real>(a: &Vector3<T>) -> Matrix3<T> {
    Matrix3::new(
        T::zero(),
        -a.z,
        a.y,
        a.z,
        T::zero(),
        -a.x,
        -a.y,
        a.x,
        T::zero(),
    )
}

/// A spatial motion vector (w, v_O).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Motion<T: Real> {
    pub ang: Vector3<T>,
    pub lin: Vector3<T>,
}

/// A spatial force vector (n_O, f).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Force<T: Real> {
    pub ang: Vector3<T>,
    pub lin: Vector3<T>,
}

macro_rules! vector_ops {
    ($t:ident) => {
        impl<T: Real> $t<T> {
            pub fn new(ang: Vector3<T>, lin: Vector3<T>) -> Self {
                $t { ang, lin }
            }
            pub fn zero() -> Self {
                $t {
                    ang: Vector3::zeros(),
                    lin: Vector3::zeros(),
                }
            }
        }
        impl<T: Real> Default for $t<T> {
            fn default() -> Self {
                $t::zero()
            }
        }
        impl<T: Real> Add for $t<T> {
            type Output = Self;
            #[inline]
            fn add(self, o: Self) -> Self {
                $t::new(self.ang + o.ang, self.lin + o.lin)
            }
        }
        impl<T: Real> Sub for $t<T> {
            type Output = Self;
            #[inline]
            fn sub(self, o: Self) -> Self {
                $t::new(self.ang - o.ang, self.lin - o.lin)
            }
        }
        impl<T: Real> AddAssign for $t<T> {
            #[inline]
            fn add_assign(&mut self, o: Self) {
                self.ang += o.ang;
                self.lin += o.lin;
            }
        }
        impl<T: Real> Neg for $t<T> {
            type Output = Self;
            #[inline]
            fn neg(self) -> Self {
                $t::new(-self.ang, -self.lin)
            }
        }
        impl<T: Real> Mul<T> for $t<T> {
            type Output = Self;
            #[inline]
            fn mul(self, s: T) -> Self {
                $t::new(self.ang * s, self.lin * s)
            }
        }
    };
}
vector_ops!(Motion);
vector_ops!(Force);

impl<T: Real> Motion<T> {
    /// The motion cross product self x m (Featherstone's crm).
    #[inline]
    pub fn cross_motion(&self, m: &Motion<T>) -> Motion<T> {
        Motion::new(
            self.ang.cross(&m.ang),
            self.ang.cross(&m.lin) + self.lin.cross(&m.ang),
        )
    }

    /// The force cross product self x* f (Featherstone's crf).
    #[inline]
    pub fn cross_force(&self, f: &Force<T>) -> Force<T> {
        Force::new(
            self.ang.cross(&f.ang) + self.lin.cross(&f.lin),
            self.ang.cross(&f.lin),
        )
    }

    /// The power of a force on this motion.
    #[inline]
    pub fn dot(&self, f: &Force<T>) -> T {
        self.ang.dot(&f.ang) + self.lin.dot(&f.lin)
    }
}

/// A coordinate transform between two frames; see the module documentation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Transform<T: Real> {
    pub rot: Matrix3<T>,
    pub trans: Vector3<T>,
}

impl<T: Real> Transform<T> {
    pub fn identity() -> Self {
        Transform {
            rot: Matrix3::identity(),
            trans: Vector3::zeros(),
        }
    }

    /// The transform into a frame whose axes are the columns of `axes` and whose
    /// origin is `origin`, both written in the current frame.
    pub fn from_pose(axes: &Matrix3<T>, origin: &Vector3<T>) -> Self {
        Transform {
            rot: axes.transpose(),
            trans: *origin,
        }
    }

    /// A pose in f64 (rotation of the new frame, origin) lifted into T.
    pub fn from_pose_f64(axes: &Rotation3<f64>, origin: &Vector3<f64>) -> Self {
        Self::from_pose(&lift_matrix(axes.matrix()), &lift_vector(origin))
    }

    /// The axes of the target frame in source coordinates (E^T).
    pub fn axes(&self) -> Matrix3<T> {
        self.rot.transpose()
    }

    /// Composition: `(self * other)` maps A to C when `other` maps A to B and
    /// `self` maps B to C.
    #[inline]
    pub fn compose(&self, other: &Transform<T>) -> Transform<T> {
        Transform {
            rot: self.rot * other.rot,
            trans: other.trans + other.rot.tr_mul(&self.trans),
        }
    }

    /// X m: a motion from source to target coordinates.
    #[inline]
    pub fn apply_motion(&self, m: &Motion<T>) -> Motion<T> {
        Motion::new(
            self.rot * m.ang,
            self.rot * (m.lin - self.trans.cross(&m.ang)),
        )
    }

    /// X^-1 m: a motion from target to source coordinates.
    #[inline]
    pub fn inverse_apply_motion(&self, m: &Motion<T>) -> Motion<T> {
        let ang = self.rot.tr_mul(&m.ang);
        Motion::new(ang, self.rot.tr_mul(&m.lin) + self.trans.cross(&ang))
    }

    /// X^* f: a force from source to target coordinates.
    #[inline]
    pub fn apply_force(&self, f: &Force<T>) -> Force<T> {
        Force::new(
            self.rot * (f.ang - self.trans.cross(&f.lin)),
            self.rot * f.lin,
        )
    }

    /// X^T f: a force from target to source coordinates.
    #[inline]
    pub fn inverse_apply_force(&self, f: &Force<T>) -> Force<T> {
        let lin = self.rot.tr_mul(&f.lin);
        Force::new(self.rot.tr_mul(&f.ang) + self.trans.cross(&lin), lin)
    }
}

/// A rigid-body spatial inertia (m, h, I_O); see the module documentation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Inertia<T: Real> {
    pub mass: T,
    /// First mass moment m c about the frame origin.
    pub h: Vector3<T>,
    /// Rotational inertia about the frame origin.
    pub rot: Matrix3<T>,
}

impl<T: Real> Inertia<T> {
    pub fn zero() -> Self {
        Inertia {
            mass: T::zero(),
            h: Vector3::zeros(),
            rot: Matrix3::zeros(),
        }
    }

    /// From mass, COM and the inertia tensor about the COM (parallel axis theorem).
    pub fn from_com(mass: T, com: &Vector3<T>, inertia_com: &Matrix3<T>) -> Self {
        let cx = skew(com);
        Inertia {
            mass,
            h: com * mass,
            rot: inertia_com - cx * cx * mass,
        }
    }

    /// I m: the momentum of a body moving with `m`.
    #[inline]
    pub fn mul_motion(&self, m: &Motion<T>) -> Force<T> {
        Force::new(
            self.rot * m.ang + self.h.cross(&m.lin),
            m.lin * self.mass - self.h.cross(&m.ang),
        )
    }

    /// The rate of change of this inertia while its body moves with the twist
    /// v = (w, u): v x* I - I v x, itself an inertia of zero mass, with
    /// h' = m u + w x h and I_O' = \[w] I_O - I_O \[w] - \[u] \[h] - \[h] \[u],
    /// formed as A + A^T - (u h^T + h u^T) + 2 (u . h) 1 with A = \[w] I_O
    /// (I_O symmetric, \[a] \[b] = b a^T - (a . b) 1).
    pub fn rate(&self, v: &Motion<T>) -> Inertia<T> {
        let a = skew(&v.ang) * self.rot;
        let uh = v.lin * self.h.transpose();
        let two_dot = v.lin.dot(&self.h) * lift(2.0);
        Inertia {
            mass: T::zero(),
            h: v.lin * self.mass + v.ang.cross(&self.h),
            rot: a + a.transpose() - uh - uh.transpose() + Matrix3::from_diagonal_element(two_dot),
        }
    }

    /// X^T I X: this inertia, given in the target frame of `x`, expressed in
    /// its source frame. With E^T h = h', E^T I_O E = R' and r the target's
    /// origin: h = h' + m r and I = R' - \[r]\[h'] - \[h']\[r] - m \[r]\[r],
    /// formed as R' - (h' r^T + r h'^T) + 2 (r . h') 1 - m (r r^T - (r . r) 1).
    pub fn to_source(&self, x: &Transform<T>) -> Inertia<T> {
        let e = &x.rot;
        let (r, m) = (&x.trans, self.mass);
        let h = e.tr_mul(&self.h);
        let hr = h * r.transpose();
        let rr = r * r.transpose() * m;
        let diagonal = r.dot(&h) * lift(2.0) + r.dot(r) * m;
        Inertia {
            mass: m,
            h: h + r * m,
            rot: e.tr_mul(&(self.rot * e)) - hr - hr.transpose() - rr
                + Matrix3::from_diagonal_element(diagonal),
        }
    }
}

impl<T: Real> Add for Inertia<T> {
    type Output = Self;
    fn add(self, o: Self) -> Self {
        Inertia {
            mass: self.mass + o.mass,
            h: self.h + o.h,
            rot: self.rot + o.rot,
        }
    }
}

impl<T: Real> AddAssign for Inertia<T> {
    fn add_assign(&mut self, o: Self) {
        *self = *self + o;
    }
}

/// A symmetric 6x6 articulated-body inertia [A B; B^T C] (angular-angular,
/// angular-linear, linear-linear blocks).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ArticulatedInertia<T: Real> {
    pub a: Matrix3<T>,
    pub b: Matrix3<T>,
    pub c: Matrix3<T>,
}

impl<T: Real> From<Inertia<T>> for ArticulatedInertia<T> {
    fn from(i: Inertia<T>) -> Self {
        ArticulatedInertia {
            a: i.rot,
            b: skew(&i.h),
            c: Matrix3::identity() * i.mass,
        }
    }
}

impl<T: Real> ArticulatedInertia<T> {
    #[inline]
    pub fn mul_motion(&self, m: &Motion<T>) -> Force<T> {
        Force::new(
            self.a * m.ang + self.b * m.lin,
            self.b.tr_mul(&m.ang) + self.c * m.lin,
        )
    }

    /// self - u u^T / d, with u a force-like 6-vector.
    #[inline]
    pub fn sub_outer(&self, u: &Force<T>, d: T) -> Self {
        let ua = u.ang / d;
        let ul = u.lin / d;
        ArticulatedInertia {
            a: self.a - ua * u.ang.transpose(),
            b: self.b - ua * u.lin.transpose(),
            c: self.c - ul * u.lin.transpose(),
        }
    }

    /// X^T I X: this inertia, given in the target frame of `x`, expressed in
    /// its source frame.
    pub fn to_source(&self, x: &Transform<T>) -> Self {
        let e = &x.rot;
        let a = e.tr_mul(&(self.a * e));
        let b = e.tr_mul(&(self.b * e));
        let c = e.tr_mul(&(self.c * e));
        let r = skew(&x.trans);
        let b_rc = b + r * c;
        ArticulatedInertia {
            a: a + r * b.transpose() - b_rc * r,
            b: b_rc,
            c,
        }
    }
}

impl<T: Real> AddAssign for ArticulatedInertia<T> {
    fn add_assign(&mut self, o: Self) {
        self.a += o.a;
        self.b += o.b;
        self.c += o.c;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Matrix6, Vector6};

    fn x_matrix(x: &Transform<f64>) -> Matrix6<f64> {
        let mut m = Matrix6::zeros();
        m.fixed_view_mut::<3, 3>(0, 0).copy_from(&x.rot);
        m.fixed_view_mut::<3, 3>(3, 3).copy_from(&x.rot);
        m.fixed_view_mut::<3, 3>(3, 0)
            .copy_from(&(-x.rot * skew(&x.trans)));
        m
    }

    fn inertia_matrix(i: &ArticulatedInertia<f64>) -> Matrix6<f64> {
        let mut m = Matrix6::zeros();
        m.fixed_view_mut::<3, 3>(0, 0).copy_from(&i.a);
        m.fixed_view_mut::<3, 3>(0, 3).copy_from(&i.b);
        m.fixed_view_mut::<3, 3>(3, 0).copy_from(&i.b.transpose());
        m.fixed_view_mut::<3, 3>(3, 3).copy_from(&i.c);
        m
    }

    fn six(ang: Vector3<f64>, lin: Vector3<f64>) -> Vector6<f64> {
        Vector6::new(ang.x, ang.y, ang.z, lin.x, lin.y, lin.z)
    }

    fn sample() -> (Transform<f64>, Motion<f64>, Force<f64>, Inertia<f64>) {
        let rot = Rotation3::from_euler_angles(0.3, -1.1, 2.0);
        let x = Transform::from_pose_f64(&rot, &Vector3::new(0.4, -0.2, 1.5));
        let m = Motion::new(Vector3::new(0.1, 2.0, -0.7), Vector3::new(1.0, 0.3, -2.0));
        let f = Force::new(Vector3::new(-0.5, 0.8, 1.2), Vector3::new(0.2, -1.0, 0.6));
        let i = Inertia::from_com(
            2.5,
            &Vector3::new(0.1, 0.2, -0.3),
            &Matrix3::new(0.3, 0.01, 0.02, 0.01, 0.4, 0.03, 0.02, 0.03, 0.5),
        );
        (x, m, f, i)
    }

    #[test]
    fn inertia_rate_is_the_commutator_with_the_motion() {
        let (_, v, _, i) = sample();
        let m = Motion::new(Vector3::new(0.7, -0.4, 1.1), Vector3::new(-0.3, 0.9, 0.2));
        let expected = v.cross_force(&i.mul_motion(&m)) - i.mul_motion(&v.cross_motion(&m));
        let got = i.rate(&v).mul_motion(&m);
        assert!((got - expected).ang.norm() + (got - expected).lin.norm() < 1e-12);
    }

    #[test]
    fn transforms_match_their_matrices() {
        let (x, m, f, _) = sample();
        let xm = x_matrix(&x);
        let mv = six(m.ang, m.lin);
        let fv = six(f.ang, f.lin);
        let close = |a: Vector6<f64>, b: Force<f64>| (a - six(b.ang, b.lin)).norm() < 1e-12;
        let closem = |a: Vector6<f64>, b: Motion<f64>| (a - six(b.ang, b.lin)).norm() < 1e-12;
        assert!(closem(xm * mv, x.apply_motion(&m)));
        assert!(closem(
            xm.try_inverse().unwrap() * mv,
            x.inverse_apply_motion(&m)
        ));
        assert!(close(xm.transpose() * fv, x.inverse_apply_force(&f)));
        assert!(close(
            xm.transpose().try_inverse().unwrap() * fv,
            x.apply_force(&f)
        ));
    }

    #[test]
    fn composition_matches_matrix_product() {
        let (x, ..) = sample();
        let y = Transform::from_pose_f64(
            &Rotation3::from_euler_angles(-0.4, 0.2, 0.9),
            &Vector3::new(-1.0, 0.5, 0.25),
        );
        let diff = x_matrix(&y.compose(&x)) - x_matrix(&y) * x_matrix(&x);
        assert!(diff.norm() < 1e-12);
    }

    #[test]
    fn inertia_transform_is_congruence() {
        let (x, m, _, i) = sample();
        let full = inertia_matrix(&i.into());
        let want = x_matrix(&x).transpose() * full * x_matrix(&x);
        assert!((inertia_matrix(&i.to_source(&x).into()) - want).norm() < 1e-12);
        let ai: ArticulatedInertia<f64> = i.into();
        assert!((inertia_matrix(&ai.to_source(&x)) - want).norm() < 1e-12);
        let f = i.mul_motion(&m);
        assert!((full * six(m.ang, m.lin) - six(f.ang, f.lin)).norm() < 1e-12);
    }

    #[test]
    fn cross_products_are_dual() {
        // (v x m) . f = -m . (v x* f) for all v, m, f.
        let (_, m, f, _) = sample();
        let v = Motion::new(Vector3::new(0.3, -0.1, 0.9), Vector3::new(-0.6, 0.4, 0.2));
        let lhs = v.cross_motion(&m).dot(&f);
        let rhs = -m.dot(&v.cross_force(&f));
        assert!((lhs - rhs).abs() < 1e-12);
    }
}
