//! MuJoCo's `springdamper` (mjCModel::AutoSpringDamper): a joint's
//! stiffness and damping from a time constant tc and a damping ratio z,
//! as a solref is read: with m = ndof / sum of its dofs' dof_invweight0
//! ([`super::invweight::invweight0`]), stiffness = m / (tc z)^2 and
//! damping = 2 m / tc (the products and tc at least MINVAL).

use super::invweight::invweight0;
use crate::dynamics::Tree;
use crate::model::{Spec, MINVAL};

/// Replaces the stiffness and damping of every joint with a springdamper
/// (then cleared) for the tree built from `spec`. Returns whether any.
pub(super) fn resolve_spring_dampers(spec: &mut Spec, tree: &Tree<f64>) -> bool {
    if spec.joints.iter().all(|j| j.springdamper.is_none()) {
        return false;
    }
    let (_, dof_invweight, _) = invweight0(tree, spec, &|_, _, x| x);
    for (k, joint) in spec.joints.iter_mut().enumerate() {
        let Some([timeconst, dampratio]) = joint.springdamper.take() else {
            continue;
        };
        let dofs = (0..tree.nv()).filter(|&i| tree.node_joint[i] == k);
        let (count, sum) = dofs.fold((0.0, 0.0), |(c, s), i| (c + 1.0, s + dof_invweight[i]));
        let inertia = count / f64::max(MINVAL, sum);
        joint.stiffness = inertia / f64::max(MINVAL, timeconst * timeconst * dampratio * dampratio);
        joint.damping = 2.0 * inertia / f64::max(MINVAL, timeconst);
    }
    true
}
