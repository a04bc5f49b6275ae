//! dR/dp for one scalar of a named parameter, where
//! R(q, v, a, tau; p) = ID(q, v, a) + extra * a - tau - tau_passive(stretch, v)
//! is the residual a step's acceleration zeroes (see the module `derivatives`).
//!
//! A body parameter changes one node's spatial inertia by dI, so it adds the
//! body force dI a_n + v_n x* (dI v_n) at that node (with RNEA's velocity and
//! acceleration, gravity included), felt by the node and its ancestors. dI is
//! the derivative of the body's inertia placed in the node frame, by hand:
//! a spatial inertia (m, m c, I_c - m [c]x[c]x) is simple in mass, COM and
//! tensor, and placing it in another frame is linear in it. A joint
//! parameter enters only its own joint's row. Both pieces take a direction
//! (one weight per scalar of the parameter), so a mu column that moves
//! several scalars at once costs one pass.

use nalgebra::{Matrix3, Vector3};

use crate::dynamics::body_force_to_joints;
use crate::dynamics::integrator::ImplicitPassive;
use crate::dynamics::{Data, Tree};
use crate::model::params::inertia_from_six;
use crate::model::{Body, Param, PassiveMode};
use crate::spatial::{skew, Inertia};
use crate::Model;

/// Writes dR/d(param component) into `out` (length nv). `data` holds RNEA's
/// velocities and accelerations at (q, v, a).
pub fn residual_derivative(
    model: &Model,
    data: &Data<f64>,
    (mode, h): (PassiveMode, f64),
    (stretch, v, a): (&[f64], &[f64], &[f64]),
    (param, component): (Param, usize),
    out: &mut [f64],
) {
    out.fill(0.0);
    let unit = |c: usize| if c == component { 1.0 } else { 0.0 };
    match param {
        Param::Mass(b) | Param::Com(b) | Param::Inertia(b) => {
            if let Some((node, di)) = node_inertia_derivative(model, b, param, unit) {
                add_body_force(model.tree(), data, node, &di, out);
            }
        }
        // Contact parameters act through the soft forces alone, added by
        // `soft_derivatives`; the constraint model's act through its rows
        // (derivatives/constrained.rs), never through this residual.
        Param::ContactStiffness | Param::ContactDamping | Param::ContactFriction => {}
        p if p.is_constraint() => {}
        // An actuator's gain and bias act through its force, which joins
        // tau: the chain rule adds them (derivatives/actuation.rs).
        p if p.is_actuator() => {}
        _ => {
            let (i, value) = joint_derivative((mode, h), (stretch, v, a), param);
            out[i] = value;
        }
    }
}

/// Adds d(M(q) y)/d(param component) to `out`, `accelerations` the node
/// accelerations of M(q) y ([`crate::derivatives::Sweep::mass_product`]):
/// a body parameter's inertia change felt at its node, an armature on its
/// own diagonal entry; other parameters leave M alone.
pub fn mass_product_derivative(
    model: &Model,
    x_up: &[crate::spatial::Transform<f64>],
    (accelerations, y): (&[crate::spatial::Motion<f64>], &[f64]),
    (param, component): (Param, usize),
    out: &mut [f64],
) {
    let unit = |c: usize| if c == component { 1.0 } else { 0.0 };
    match param {
        Param::Mass(b) | Param::Com(b) | Param::Inertia(b) => {
            if let Some((node, di)) = node_inertia_derivative(model, b, param, unit) {
                let df = di.mul_motion(&accelerations[node]);
                body_force_to_joints(model.tree(), x_up, node, df, out);
            }
        }
        Param::Armature(i) => out[i] += y[i],
        _ => {}
    }
}

/// dR_i / d(joint parameter) for the joint i it belongs to: (i, value).
/// Panics on a body parameter.
pub fn joint_derivative(
    (mode, h): (PassiveMode, f64),
    (stretch, v, a): (&[f64], &[f64], &[f64]),
    param: Param,
) -> (usize, f64) {
    // The implicit diagonal's change times a, and the explicit force's.
    let implicit = ImplicitPassive::new(mode, h);
    match param {
        Param::Damping(i) => {
            let de = implicit.damping_weight().unwrap_or(0.0);
            (i, de * a[i] + v[i])
        }
        Param::Stiffness(i) => {
            let de = implicit.stiffness_weight().unwrap_or(0.0);
            (i, de * a[i] + stretch[i])
        }
        Param::Armature(i) => (i, a[i]),
        _ => unreachable!("{param:?} is not a joint parameter"),
    }
}

/// The node carrying body `b` and the derivative of the inertia it adds
/// there along `direction` (a weight per scalar of the body parameter
/// `param`); None for a body welded to the world.
pub fn node_inertia_derivative(
    model: &Model,
    b: usize,
    param: Param,
    direction: impl Fn(usize) -> f64,
) -> Option<(usize, Inertia<f64>)> {
    let frame = model.tree().body[b];
    let node = frame.node?;
    let di = inertia_derivative(&model.bodies[b], param, direction);
    Some((node, di.to_source(&frame.offset)))
}

/// Adds to `out` the joint forces S_k . dF_k of the body force
/// dF = dI a_n + v_n x* (dI v_n) on node `node`, along its path to the root.
/// `data` holds the velocities and accelerations (gravity included) at the point.
pub fn add_body_force(
    tree: &Tree<f64>,
    data: &Data<f64>,
    node: usize,
    di: &Inertia<f64>,
    out: &mut [f64],
) {
    let (vel, acc) = (&data.vel[node], &data.acc[node]);
    let df = di.mul_motion(acc) + vel.cross_force(&di.mul_motion(vel));
    body_force_to_joints(tree, &data.x_up, node, df, out);
}

/// d(spatial inertia of `body` about its own frame) along `direction` (a
/// weight per scalar of the body parameter `param`: mass, COM or inertia),
/// from I = (m, m c, I_c - m [c]x[c]x).
fn inertia_derivative(body: &Body, param: Param, direction: impl Fn(usize) -> f64) -> Inertia<f64> {
    let (m, c) = (body.mass, &body.com);
    match param {
        Param::Mass(_) => Inertia::from_com(direction(0), c, &Matrix3::zeros()),
        Param::Com(_) => {
            let d = Vector3::from_fn(|r, _| direction(r));
            let (cx, dx) = (skew(c), skew(&d));
            Inertia {
                mass: 0.0,
                h: d * m,
                rot: -(dx * cx + cx * dx) * m,
            }
        }
        Param::Inertia(_) => {
            let six: [f64; 6] = std::array::from_fn(direction);
            Inertia {
                mass: 0.0,
                h: Vector3::zeros(),
                rot: inertia_from_six(&six),
            }
        }
        _ => unreachable!("{param:?} is a joint parameter"),
    }
}
