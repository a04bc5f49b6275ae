//! Mocap bodies' poses: an input of the step, as MuJoCo's mocap_pos and
//! mocap_quat are (not part of the state). Mocap body k (in body order,
//! [`crate::model::Spec::mocap_bodies`]) sits at position pos[3k..3k + 3]
//! with orientation quat[4k..4k + 4] (w x y z, normalised where it is read,
//! as MuJoCo's mj_kinematics normalises it) in world coordinates. It has no
//! dofs: its geoms collide with a velocity of zero and its contacts move
//! only the other body; its pose is a constant for the derivatives (no
//! Jacobian columns in it).
//!
//! The step reads the poses from [`Data::mocap`]; [`set_mocap`] places them
//! there (empty inputs: the compiled poses, which [`Data::new`] starts with).

use super::configuration::rotation_matrix;
use super::step::check;
use super::{Data, StepError, Tree};
use crate::spatial::{lift, lift_vector, Real, Transform};
use nalgebra::Vector3;

/// Places the mocap bodies at (pos, quat) (3 and 4 entries per mocap body;
/// either empty: the compiled poses, [`Tree::mocap_pos`], [`Tree::mocap_quat`])
/// for the next evaluations on `data`.
pub fn set_mocap<T: Real>(
    tree: &Tree<T>,
    data: &mut Data<T>,
    (pos, quat): (&[f64], &[f64]),
) -> Result<(), StepError> {
    let pos = given("mocap_pos", pos, &tree.mocap_pos)?;
    let quat = given("mocap_quat", quat, &tree.mocap_quat)?;
    for (x, (p, w_xyz)) in data.mocap.iter_mut().zip(placements(pos, quat)) {
        *x = pose(p, w_xyz);
    }
    Ok(())
}

/// The world-to-body transforms of mocap bodies at (pos, quat).
pub(super) fn poses<T: Real>(pos: &[f64], quat: &[f64]) -> Vec<Transform<T>> {
    placements(pos, quat)
        .map(|(p, w_xyz)| pose(p, w_xyz))
        .collect()
}

/// Each mocap body's position and quaternion.
fn placements<'a>(
    pos: &'a [f64],
    quat: &'a [f64],
) -> impl Iterator<Item = (&'a [f64], &'a [f64])> + 'a {
    pos.chunks_exact(3).zip(quat.chunks_exact(4))
}

/// From the world to the frame at position `p` turned by `w_xyz`.
fn pose<T: Real>(p: &[f64], w_xyz: &[f64]) -> Transform<T> {
    let q: [T; 4] = std::array::from_fn(|k| lift(w_xyz[k]));
    let origin = lift_vector(&Vector3::from_column_slice(p));
    Transform::from_pose(&rotation_matrix(&q), &origin)
}

/// `x` checked against the default's length and finite, or the default if empty.
fn given<'a>(name: &'static str, x: &'a [f64], default: &'a [f64]) -> Result<&'a [f64], StepError> {
    if x.is_empty() {
        return Ok(default);
    }
    check(name, x, default.len()).map(|()| x)
}
