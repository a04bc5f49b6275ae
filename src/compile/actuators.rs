//! Actuator constants MuJoCo's compiler derives: a position servo's damping
//! from its damping ratio (`dampratio`).

use crate::dynamics::actuation::transmissions;
use crate::dynamics::{crba, ltdl_factor, ltdl_solve, Data, Tree};
use crate::model::{Bias, Gain, Spec};

/// Turns each damping ratio held in an affine bias ([`Bias`]: biasprm[1]
/// = -gainprm[0], biasprm[2] > 0) into the damping -kv it stands for, as
/// MuJoCo's compiler does: kv = ratio 2 sqrt(kp m), m = 1 / (r^T M^-1 r)
/// the mass the actuator sees, r its moment and M the mass matrix (armature
/// included) at the reference configuration (for a joint, r = gear on its
/// dof; [`transmissions`]).
/// Returns whether any changed.
pub(super) fn resolve_damp_ratios(spec: &mut Spec, tree: &Tree<f64>) -> bool {
    let has_ratio = |gain: Gain, bias: Bias| match (gain, bias) {
        (Gain::Fixed(kp) | Gain::Affine([kp, _, _]), Bias::Affine([_, b1, ratio])) => {
            (kp == -b1 && ratio > 0.0).then_some((kp, ratio))
        }
        _ => None,
    };
    if !spec
        .actuators
        .iter()
        .any(|a| has_ratio(a.gain, a.bias).is_some())
    {
        return false;
    }
    let mut data = Data::new(tree);
    let q0 = spec.reference_q();
    crba(tree, &mut data, &q0);
    transmissions(tree, &mut data, (&q0, &vec![0.0; tree.nv()]));
    let mut factor = data.mass_matrix.clone();
    ltdl_factor(tree, &mut factor);
    for i in 0..spec.actuators.len() {
        let a = &spec.actuators[i];
        let Some((kp, ratio)) = has_ratio(a.gain, a.bias) else {
            continue;
        };
        let moment = &data.actuator[i].moment;
        let mut column = moment.clone();
        ltdl_solve(tree, &factor, &mut column);
        let seen: f64 = moment.iter().zip(&column).map(|(r, x)| r * x).sum();
        let mass = if seen > 0.0 { 1.0 / seen } else { 0.0 };
        if let Bias::Affine(prm) = &mut spec.actuators[i].bias {
            prm[2] = -(ratio * 2.0 * (kp * mass).sqrt());
        }
    }
    true
}
