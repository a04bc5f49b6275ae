//! Joint passive forces: viscous damping and linear springs.

use super::Tree;
use crate::spatial::Real;

/// tau_passive = -damping * v - stiffness * (q - springref), per joint.
pub fn passive_forces<T: Real>(tree: &Tree<T>, q: &[T], v: &[T], out: &mut [T]) {
    for i in 0..tree.nv() {
        out[i] = -tree.damping[i] * v[i] - tree.stiffness[i] * (q[i] - tree.springref[i]);
    }
}
