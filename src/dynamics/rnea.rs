//! Recursive Newton-Euler: inverse dynamics tau = M(q) a + c(q, v).

use super::{update_transforms, Data, Tree};
use crate::spatial::{Motion, Real};

/// tau = M(q) a + c(q, v) (M with armature; no passive forces).
pub fn rnea<T: Real>(tree: &Tree<T>, data: &mut Data<T>, q: &[T], v: &[T], a: &[T], tau: &mut [T]) {
    update_transforms(tree, data, q);
    newton_euler(tree, data, v, |i| a[i], tau);
}

/// [`rnea`] with `data.x_up` already at q.
pub fn rnea_with_transforms<T: Real>(
    tree: &Tree<T>,
    data: &mut Data<T>,
    v: &[T],
    a: &[T],
    tau: &mut [T],
) {
    newton_euler(tree, data, v, |i| a[i], tau);
}

/// c(q, v): Coriolis, centrifugal and gravity forces (RNEA at zero acceleration).
pub fn bias_forces<T: Real>(tree: &Tree<T>, data: &mut Data<T>, q: &[T], v: &[T], c: &mut [T]) {
    update_transforms(tree, data, q);
    bias_forces_with_transforms(tree, data, v, c);
}

/// [`bias_forces`] with `data.x_up` already at q.
pub fn bias_forces_with_transforms<T: Real>(
    tree: &Tree<T>,
    data: &mut Data<T>,
    v: &[T],
    c: &mut [T],
) {
    newton_euler(tree, data, v, |_| T::zero(), c);
}

fn newton_euler<T: Real>(
    tree: &Tree<T>,
    data: &mut Data<T>,
    v: &[T],
    a: impl Fn(usize) -> T,
    tau: &mut [T],
) {
    // Gravity as a fictitious upward acceleration of the world.
    let a_world = Motion::new(nalgebra::Vector3::zeros(), -tree.gravity);
    for i in 0..tree.nv() {
        let s = tree.joint[i].s;
        let x = &data.x_up[i];
        let (v_parent, a_parent) = match tree.parent[i] {
            Some(p) => (x.apply_motion(&data.vel[p]), x.apply_motion(&data.acc[p])),
            None => (Motion::zero(), x.apply_motion(&a_world)),
        };
        let vel = v_parent + s * v[i];
        let crossed = tree.crossed_velocity(i, vel, v);
        let acc = a_parent + s * a(i) + crossed.cross_motion(&(s * v[i]));
        let inertia = &tree.inertia[i];
        data.force[i] = inertia.mul_motion(&acc) + vel.cross_force(&inertia.mul_motion(&vel));
        data.vel[i] = vel;
        data.acc[i] = acc;
    }
    for i in (0..tree.nv()).rev() {
        tau[i] = tree.joint[i].s.dot(&data.force[i]) + tree.armature[i] * a(i);
        if let Some(p) = tree.parent[i] {
            let f = data.x_up[i].inverse_apply_force(&data.force[i]);
            data.force[p] += f;
        }
    }
}
