//! The fluid's equivalent boxes (see [`crate::dynamics::fluid`]): per body
//! with mass, its principal axes and the sides of the box with its mass and
//! principal moments, computed when the model is compiled.

use nalgebra::{Matrix3, Vector3};

use super::tree::mass_properties;
use crate::dynamics::fluid::FluidBody;
use crate::model::{Param, Spec};
use crate::spatial::{lift, lift_matrix, Real, Transform};

/// MuJoCo's mjMINVAL: lighter bodies feel no fluid.
const MIN_MASS: f64 = crate::model::MINVAL;

/// The bodies of `spec` the fluid acts on (none without a medium), each
/// carried by node `frames[b]` at the offset given (the tree's body frames),
/// their mass, COM and inertia lifted by `lift_param` (see
/// [`crate::dynamics::Tree::build_with`]).
pub fn fluid_bodies<T: Real>(
    spec: &Spec,
    frames: &[(Option<usize>, Transform<T>)],
    lift_param: &impl Fn(Param, usize, f64) -> T,
) -> Vec<FluidBody<T>> {
    if !spec.opt.fluid.acts() {
        return vec![];
    }
    let mut out = vec![];
    for (b, body) in spec.bodies.iter().enumerate().skip(1) {
        let (Some(node), offset) = frames[b] else {
            continue;
        };
        if body.mass < MIN_MASS {
            continue;
        }
        let (mass, com, inertia) = mass_properties(b, body, lift_param);
        let axes: Matrix3<T> = lift_matrix(body.inertia_frame.matrix());
        let moments = (axes.transpose() * inertia * axes).diagonal();
        let side = |k: usize| {
            let (j, l) = ((k + 1) % 3, (k + 2) % 3);
            let excess = (moments[j] + moments[l] - moments[k]).max(lift(MIN_MASS));
            (excess / mass * lift(6.0)).sqrt()
        };
        out.push(FluidBody {
            node,
            offset,
            com,
            axes,
            sides: Vector3::new(side(0), side(1), side(2)),
        });
    }
    out
}
