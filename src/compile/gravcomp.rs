//! The bodies gravity compensation acts on (see [`crate::dynamics::gravcomp`]),
//! placed in their nodes' frames when the model is compiled.

use super::tree::mass_properties;
use crate::dynamics::gravcomp::GravcompBody;
use crate::model::{Param, Spec};
use crate::spatial::{lift, Real, Transform};

/// Every jointed body of `spec` with a nonzero gravcomp, carried by node
/// `frames[b]` at the offset given (the tree's body frames), its mass and
/// COM lifted by `lift_param` (see [`crate::dynamics::Tree::build_with`]).
/// Bodies welded to the world have no dofs to push and are left out.
pub fn gravcomp_bodies<T: Real>(
    spec: &Spec,
    frames: &[(Option<usize>, Transform<T>)],
    lift_param: &impl Fn(Param, usize, f64) -> T,
) -> Vec<GravcompBody<T>> {
    let mut out = vec![];
    for (b, body) in spec.bodies.iter().enumerate().skip(1) {
        let (Some(node), offset) = frames[b] else {
            continue;
        };
        if body.gravcomp == 0.0 {
            continue;
        }
        let (mass, com, _) = mass_properties(b, body, lift_param);
        out.push(GravcompBody {
            node,
            offset,
            com,
            weight: mass * lift::<T>(body.gravcomp),
        });
    }
    out
}
