//! Composite-rigid-body algorithm: the joint-space mass matrix M(q).

use super::{update_transforms, Data, Tree};
use crate::spatial::Real;

/// Fills `data.mass_matrix` with M(q), armature included on the diagonal.
pub fn crba<T: Real>(tree: &Tree<T>, data: &mut Data<T>, q: &[T]) {
    update_transforms(tree, data, q);
    crba_with_transforms(tree, data);
}

/// [`crba`] with `data.x_up` already at q.
pub fn crba_with_transforms<T: Real>(tree: &Tree<T>, data: &mut Data<T>) {
    data.composite.copy_from_slice(&tree.inertia);
    // Entries between dofs on different branches stay zero.
    data.mass_matrix.fill(T::zero());
    // Children have larger indices, so a reverse sweep sees each composite
    // inertia complete before it is used and passed to the parent.
    for i in (0..tree.nv()).rev() {
        let mut f = data.composite[i].mul_motion(&tree.joint[i].s);
        data.mass_matrix[(i, i)] = tree.joint[i].s.dot(&f) + tree.armature[i];
        let mut j = i;
        while let Some(p) = tree.parent[j] {
            f = data.x_up[j].inverse_apply_force(&f);
            j = p;
            let m = tree.joint[j].s.dot(&f);
            data.mass_matrix[(i, j)] = m;
            data.mass_matrix[(j, i)] = m;
        }
        if let Some(p) = tree.parent[i] {
            let to_parent = data.composite[i].to_source(&data.x_up[i]);
            data.composite[p] += to_parent;
        }
    }
}
