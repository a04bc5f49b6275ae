//! Forward kinematics: joint transforms and world poses of bodies.

use nalgebra::{Matrix3, Vector3};

use super::{Data, Tree};
use crate::spatial::{Real, Transform};

/// Fills `data.x_up[i]`, the transform from node i's parent frame to its frame.
pub fn update_transforms<T: Real>(tree: &Tree<T>, data: &mut Data<T>, q: &[T]) {
    for i in 0..tree.nv() {
        data.x_up[i] = tree.joint[i].transform(q).compose(&tree.x_tree[i]);
    }
}

/// World pose of every body at q: (axes as columns in world coordinates, origin).
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
    tree.body
        .iter()
        .map(|b| {
            let x = match b.node {
                Some(n) => b.offset.compose(&to_node[n]),
                None => b.offset,
            };
            (x.axes(), x.trans)
        })
        .collect()
}
