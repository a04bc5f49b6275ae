//! Joint passive forces: viscous damping and linear springs.

use super::configuration::subtract;
use super::Tree;
use crate::spatial::Real;

/// tau_passive = -damping * v - stiffness * stretch, per dof.
pub fn passive_forces<T: Real>(tree: &Tree<T>, stretch: &[T], v: &[T], out: &mut [T]) {
    for i in 0..tree.nv() {
        out[i] = -tree.damping[i] * v[i] - tree.stiffness[i] * stretch[i];
    }
}

/// Each dof's spring stretch at q: its displacement from the rest
/// configuration in the tangent space (q - springref for a hinge or slide, a
/// ball's rotation vector from its rest orientation, MuJoCo's mju_subQuat).
pub fn stretch<T: Real>(tree: &Tree<T>, q: &[T], out: &mut [T]) {
    subtract(tree, q, &tree.spring_q, out);
}
