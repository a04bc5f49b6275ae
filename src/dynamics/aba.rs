//! Articulated-body algorithm: forward dynamics in O(n).

use super::{update_transforms, Data, Tree};
use crate::spatial::{Motion, Real};

/// Solves (M(q) + diag(extra)) qdd = tau - c(q, v) for qdd.
///
/// `extra` adds to the joint-space inertia on the diagonal beyond the armature
/// already in M; the implicit passive-force modes use it for h*damping and
/// h^2*stiffness.
pub fn aba<T: Real>(
    tree: &Tree<T>,
    data: &mut Data<T>,
    q: &[T],
    v: &[T],
    tau: &[T],
    extra: Option<&[T]>,
    qdd: &mut [T],
) {
    update_transforms(tree, data, q);
    aba_with_transforms(tree, data, v, tau, extra, qdd);
}

/// [`aba`] with `data.x_up` already at q ([`update_transforms`]).
pub fn aba_with_transforms<T: Real>(
    tree: &Tree<T>,
    data: &mut Data<T>,
    v: &[T],
    tau: &[T],
    extra: Option<&[T]>,
    qdd: &mut [T],
) {
    let n = tree.nv();
    for i in 0..n {
        let s = tree.joint[i].s;
        let joint_vel = s * v[i];
        let vel = match tree.parent[i] {
            Some(p) => data.x_up[i].apply_motion(&data.vel[p]) + joint_vel,
            None => joint_vel,
        };
        let inertia = &tree.inertia[i];
        data.vel[i] = vel;
        data.bias_acc[i] = tree.crossed_velocity(i, vel, v).cross_motion(&joint_vel);
        data.art_inertia[i] = (*inertia).into();
        data.art_bias[i] = vel.cross_force(&inertia.mul_motion(&vel));
    }
    for i in (0..n).rev() {
        let s = tree.joint[i].s;
        let u_force = data.art_inertia[i].mul_motion(&s);
        let d = s.dot(&u_force) + tree.armature[i] + extra.map_or(T::zero(), |e| e[i]);
        let u = tau[i] - s.dot(&data.art_bias[i]);
        data.u_force[i] = u_force;
        data.d[i] = d;
        data.u[i] = u;
        if let Some(p) = tree.parent[i] {
            let ia = data.art_inertia[i].sub_outer(&u_force, d);
            let pa = data.art_bias[i] + ia.mul_motion(&data.bias_acc[i]) + u_force * (u / d);
            let x = &data.x_up[i];
            let ia_parent = ia.to_source(x);
            let pa_parent = x.inverse_apply_force(&pa);
            data.art_inertia[p] += ia_parent;
            data.art_bias[p] += pa_parent;
        }
    }
    // Gravity as a fictitious upward acceleration of the world.
    let a_world = Motion::new(nalgebra::Vector3::zeros(), -tree.gravity);
    for i in 0..n {
        let a_parent = match tree.parent[i] {
            Some(p) => data.acc[p],
            None => a_world,
        };
        let a = data.x_up[i].apply_motion(&a_parent) + data.bias_acc[i];
        qdd[i] = (data.u[i] - a.dot(&data.u_force[i])) / data.d[i];
        data.acc[i] = a + tree.joint[i].s * qdd[i];
    }
}
