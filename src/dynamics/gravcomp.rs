//! Gravity compensation (MuJoCo's body attribute `gravcomp`, mj_gravcomp):
//! a body with gravcomp c and mass m feels the force -c m g at its centre
//! of mass (g the model's gravity, world frame), a passive force evaluated
//! at q in every integrator (MuJoCo adds it to qfrc_passive). c = 1
//! cancels the body's weight; any real c is allowed, as in MuJoCo.

use nalgebra::Vector3;

use super::{body_force_to_joints, Data, Tree};
use crate::spatial::{Force, Real, Transform};

/// A body with gravity compensation, in its node's frame.
#[derive(Clone, Debug, PartialEq)]
pub struct GravcompBody<T: Real> {
    pub node: usize,
    /// From the node's frame to the body's.
    pub offset: Transform<T>,
    /// Centre of mass in body coordinates.
    pub com: Vector3<T>,
    /// gravcomp times the body's mass (kg).
    pub weight: T,
}

/// Adds the compensating forces to `out` (`data.world` filled by
/// [`super::world_frames`], `data.x_up` at q).
pub fn add_gravcomp_forces<T: Real>(tree: &Tree<T>, data: &Data<T>, out: &mut [T]) {
    for b in &tree.gravcomp {
        // world -> body
        let to_body = b.offset.compose(&data.world[b.node]);
        let force = to_body.rot * (tree.gravity * -b.weight);
        let in_body = Force::new(b.com.cross(&force), force);
        let in_node = b.offset.inverse_apply_force(&in_body);
        body_force_to_joints(tree, &data.x_up, b.node, in_node, out);
    }
}
