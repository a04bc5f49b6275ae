//! The contact record both force laws produce: the smooth model's
//! ([`crate::dynamics::contact`]) and the constraint model's
//! ([`crate::dynamics::constraint::contact_forces`]).

use nalgebra::{Matrix3, Vector3};

use crate::spatial::Real;

/// One contact at a state, with its force, in MuJoCo's convention (see
/// [`super`]): geoms 1 and 2, the normal from geom 1 to geom 2, `dist` the
/// signed distance between the surfaces (negative: penetration); the force
/// is the one on geom 2, geom 1 feels its opposite (mj_contactForce's).
#[derive(Clone, Debug, PartialEq)]
pub struct Contact<T: Real> {
    /// Model indices of geoms 1 and 2, and of their bodies.
    pub geoms: [usize; 2],
    pub bodies: [usize; 2],
    /// Halfway between the surfaces along the normal (world coordinates).
    pub pos: Vector3<T>,
    /// Unit, world coordinates, from geom 1 to geom 2: the direction of the
    /// normal force on geom 2.
    pub normal: Vector3<T>,
    pub dist: T,
    /// N, along `normal` on geom 2 (N).
    pub normal_force: T,
    /// The tangential force on geom 2, world coordinates (N).
    pub friction: Vector3<T>,
    /// The torsional and rolling friction moments on geom 2, world
    /// coordinates (N m; the constraint model's condim 4 and 6, else zero).
    pub torque: Vector3<T>,
    /// The contact frame, rows: `normal` and two tangents (MuJoCo's frame:
    /// the collider's, or from the normal by MuJoCo's rule).
    pub frame: Matrix3<T>,
}

impl<T: Real> Contact<T> {
    /// The total force on geom 2 (world coordinates); geom 1 feels its opposite.
    pub fn force(&self) -> Vector3<T> {
        self.normal * self.normal_force + self.friction
    }

    /// Force and moment on geom 2 in the contact frame, as MuJoCo's
    /// mj_contactForce gives them: normal, the two tangential forces, the
    /// torsional moment and the two rolling moments.
    pub fn in_frame(&self) -> [T; 6] {
        let row = |k: usize| self.frame.row(k).transpose();
        [
            self.normal_force,
            row(1).dot(&self.friction),
            row(2).dot(&self.friction),
            row(0).dot(&self.torque),
            row(1).dot(&self.torque),
            row(2).dot(&self.torque),
        ]
    }
}

/// The net contact force on each body (world coordinates, N), from a list of
/// contacts; `nbody` is the model's number of bodies.
pub fn body_contact_forces<T: Real>(contacts: &[Contact<T>], nbody: usize) -> Vec<Vector3<T>> {
    let mut out = vec![Vector3::zeros(); nbody];
    for c in contacts {
        let f = c.force();
        out[c.bodies[1]] += f;
        out[c.bodies[0]] -= f;
    }
    out
}
