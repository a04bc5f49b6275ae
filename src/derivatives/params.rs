//! dR/dp for one scalar of a named parameter, where
//! R(q, v, a, tau; p) = ID(q, v, a) + extra * a - tau - tau_passive(q_spring, v)
//! is the residual a step's acceleration zeroes (see the module `derivatives`).
//!
//! A body parameter changes one node's spatial inertia by dI, so it adds the
//! body force dI a_n + v_n x* (dI v_n) at that node (with RNEA's velocity and
//! acceleration, gravity included), felt by the node and its ancestors. dI is
//! the derivative of the body's inertia placed in the node frame, taken with
//! dual numbers through the same generic code that builds the tree. A joint
//! parameter enters only its own joint's row.

use num_dual::Dual64;

use crate::dynamics::{body_inertia, Data, Tree};
use crate::model::{Body, Model, Param, PassiveMode};
use crate::spatial::{Force, Inertia, Transform};

/// Writes dR/d(param component) into `out` (length nv). `data` holds RNEA's
/// velocities and accelerations at (q, v, a).
pub fn residual_derivative(
    model: &Model,
    data: &Data<f64>,
    (mode, h): (PassiveMode, f64),
    (q_spring, v, a): (&[f64], &[f64], &[f64]),
    (param, component): (Param, usize),
    out: &mut [f64],
) {
    out.fill(0.0);
    let tree = model.tree();
    match param {
        Param::Mass(b) | Param::Com(b) | Param::Inertia(b) => {
            let frame = tree.body[b];
            let Some(node) = frame.node else {
                return; // welded to the world: no effect on the dynamics
            };
            let di = inertia_derivative(b, &model.bodies[b], (param, component), &frame.offset);
            let (vel, acc) = (&data.vel[node], &data.acc[node]);
            let df = di.mul_motion(acc) + vel.cross_force(&di.mul_motion(vel));
            body_force_to_joints(tree, data, node, df, out);
        }
        Param::Damping(i) => {
            let implicit = if mode == PassiveMode::Explicit {
                0.0
            } else {
                h
            };
            out[i] = implicit * a[i] + v[i];
        }
        Param::Stiffness(i) => {
            let implicit = if mode == PassiveMode::ImplicitDampingStiffness {
                h * h
            } else {
                0.0
            };
            out[i] = implicit * a[i] + q_spring[i] - tree.springref[i];
        }
        Param::Armature(i) => out[i] = a[i],
    }
}

/// The joint forces S_k . F_k that a force `f` on node `node` adds along its
/// path to the root.
fn body_force_to_joints(
    tree: &Tree<f64>,
    data: &Data<f64>,
    node: usize,
    f: Force<f64>,
    out: &mut [f64],
) {
    let mut f = f;
    let mut k = node;
    loop {
        out[k] = tree.joint[k].s.dot(&f);
        let Some(p) = tree.parent[k] else { break };
        f = data.x_up[k].inverse_apply_force(&f);
        k = p;
    }
}

/// d(spatial inertia of body `index`, in its node's frame) / d(param component),
/// for a body parameter (mass, COM or inertia).
fn inertia_derivative(
    index: usize,
    body: &Body,
    (param, component): (Param, usize),
    offset: &Transform<f64>,
) -> Inertia<f64> {
    let seed = |p: Param, c: usize, x: f64| {
        Dual64::new(
            x,
            if (p, c) == (param, component) {
                1.0
            } else {
                0.0
            },
        )
    };
    let offset = Transform {
        rot: offset.rot.map(Dual64::from),
        trans: offset.trans.map(Dual64::from),
    };
    let placed = body_inertia(index, body, seed).to_source(&offset);
    Inertia {
        mass: placed.mass.eps,
        h: placed.h.map(|x| x.eps),
        rot: placed.rot.map(|x| x.eps),
    }
}
