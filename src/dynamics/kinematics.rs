//! Forward kinematics: joint transforms, world poses of bodies, the nodes'
//! world frames and velocities, point Jacobians, and the joint forces of a
//! force on a body.

use nalgebra::{DMatrix, Matrix3, Vector3};

use super::{Data, Tree};
use crate::spatial::{Force, Motion, Real, Transform};

/// Fills `data.x_up[i]`, the transform from node i's parent frame to its frame.
pub fn update_transforms<T: Real>(tree: &Tree<T>, data: &mut Data<T>, q: &[T]) {
    for i in 0..tree.nv() {
        data.x_up[i] = tree.joint[i].transform(q).compose(&tree.x_tree[i]);
    }
}

/// World pose of every body at q: (axes as columns in world coordinates,
/// origin), the mocap bodies at their compiled poses.
pub fn body_poses<T: Real>(tree: &Tree<T>, q: &[T]) -> Vec<(Matrix3<T>, Vector3<T>)> {
    // to_node[i]: from world coordinates to node i's frame.
    let mut to_node: Vec<Transform<T>> = Vec::with_capacity(tree.nv());
    for i in 0..tree.nv() {
        let up = tree.joint[i].transform(q).compose(&tree.x_tree[i]);
        let x = match tree.parent[i] {
            Some(p) => up.compose(&to_node[p]),
            None => up,
        };
        to_node.push(x);
    }
    let mocap: Vec<Transform<T>> = super::mocap::poses(&tree.mocap_pos, &tree.mocap_quat);
    tree.body
        .iter()
        .map(|b| {
            let x = match (b.node, b.mocap) {
                (Some(n), _) => b.offset.compose(&to_node[n]),
                (None, Some(k)) => b.offset.compose(&mocap[k]),
                (None, None) => b.offset,
            };
            (x.axes(), x.trans)
        })
        .collect()
}

/// From the world to body `body`'s frame at the frames `data` holds
/// ([`world_frames`]; a mocap body at the step's mocap pose).
pub fn body_pose<T: Real>(tree: &Tree<T>, data: &Data<T>, body: usize) -> Transform<T> {
    let frame = tree.body[body];
    match (frame.node, frame.mocap) {
        (Some(n), _) => frame.offset.compose(&data.world[n]),
        (None, Some(k)) => frame.offset.compose(&data.mocap[k]),
        (None, None) => frame.offset,
    }
}

/// Fills `data.world`, `data.world_axis` and `data.world_vel` (see [`Data`])
/// from `data.x_up`.
pub fn world_frames<T: Real>(tree: &Tree<T>, data: &mut Data<T>, v: &[T]) {
    for i in 0..tree.nv() {
        let parent = tree.parent[i].map(|p| (data.world[p], data.world_vel[p]));
        let (world, vel) = parent.unwrap_or((Transform::identity(), Motion::zero()));
        data.world[i] = data.x_up[i].compose(&world);
        data.world_axis[i] = data.world[i].inverse_apply_motion(&tree.joint[i].s);
        data.world_vel[i] = vel + data.world_axis[i] * v[i];
    }
}

/// The translational and rotational Jacobians (3 x nv, world coordinates)
/// of the point `p` (world coordinates) fixed to node `node` (none: the world).
pub fn point_jacobian<T: Real>(
    tree: &Tree<T>,
    data: &Data<T>,
    node: usize,
    p: &Vector3<T>,
) -> (DMatrix<T>, DMatrix<T>) {
    let n = tree.nv();
    let (mut jp, mut jr) = (DMatrix::zeros(3, n), DMatrix::zeros(3, n));
    let mut k = Some(node);
    while let Some(i) = k {
        let s = &data.world_axis[i];
        jp.set_column(i, &(s.lin + s.ang.cross(p)));
        jr.set_column(i, &s.ang);
        k = tree.parent[i];
    }
    (jp, jr)
}

/// Adds the joint forces S_k . F_k that a force `f` on node `node` (in its
/// frame) causes along its path to the root, with the transforms `x_up`.
pub fn body_force_to_joints<T: Real>(
    tree: &Tree<T>,
    x_up: &[Transform<T>],
    node: usize,
    f: Force<T>,
    out: &mut [T],
) {
    let mut f = f;
    let mut k = node;
    loop {
        out[k] += tree.joint[k].s.dot(&f);
        let Some(p) = tree.parent[k] else { break };
        f = x_up[k].inverse_apply_force(&f);
        k = p;
    }
}
