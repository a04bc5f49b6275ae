//! The identification loss when the target's constraint forces are unknown:
//! its contact law, joint limits and dry friction may be anyone's (another
//! engine's), so their impulses are unknowns of the fit, eliminated in
//! closed form.
//!
//! Per transition (q, v) --tau--> (q', v'), with a = (v' - v) / h, the
//! generalized force our smooth dynamics leaves unexplained is the residual
//! a semi-implicit Euler step zeroes (module `derivatives`):
//!   R = ID(q, v, a) + extra a - tau - tau_passive(q_spring, v)
//! (armature inside ID; extra and q_spring from the model's passive mode).
//! Whatever the constraint law, R = G lambda for some lambda, G's columns
//! being the generalized forces of
//! - any wrench (6 columns) on a body with a geom within `margin` of
//!   touching another at q or at q' (a contact anywhere on the body, with
//!   any normal, friction, torsional or rolling law);
//! - any force on a dof within `margin` (m or rad) of an end of its range
//!   at q or q', and on a dof with dry friction.
//!
//! The residual is the part of R no such impulse explains, in the force
//! scale s (nv values, N or N m):
//!   r = P (R / s),  P = I - B B^+,  B = diag(1 / s) G,
//! that is min over lambda of |(R - G lambda) / s|^2. G depends on q and q'
//! alone, so dr / dmu = P (dR / dmu) / s exactly, with dR / dmu as the
//! Euler window computes it. Our own Euler step, under either contact
//! model, has r = 0 at its parameters; where nothing can touch, r = R / s.
//! Contacts are found by the constraint model's colliders with every geom's
//! margin raised by `margin` (a pair without a collider is not seen). The
//! residual is the Euler step's, so the model must integrate with Euler.

use nalgebra::DVector;

use super::params::{add_body_force, joint_derivative};
use super::step::Workspace;
use super::window::{check_transition, directions, Term, Transition, WindowError, WindowFit};
use crate::dynamics::collision::{ConstraintContact, Pre};
use crate::dynamics::constraint::{contacts, world_frames};
use crate::dynamics::{implicit_terms, passive_forces, rnea, update_transforms};
use crate::model::{ContactModel, Integrator, Model, ParamMap};

/// Below this fraction of its own norm, what is left of a constraint
/// direction after the ones before it are taken out adds nothing new.
const INDEPENDENT: f64 = 1e-9;

/// How the constraint impulses of a model's transitions are eliminated: the
/// margin, the force scale, and the colliders that find what may touch.
#[derive(Clone, Debug)]
pub struct Elimination {
    margin: f64,
    scale: Vec<f64>,
    /// The model under the constraint model's colliders, contacts on, every
    /// geom's margin raised by `margin`.
    detect: Model,
    contacts: Vec<ConstraintContact<f64>>,
    pre: Vec<Pre<f64>>,
    /// The nodes a wrench may act on, and an orthonormal basis of the scaled
    /// constraint directions (one vector of nv per direction).
    nodes: Vec<usize>,
    basis: Vec<DVector<f64>>,
}

impl Elimination {
    /// Refuses a margin that is not finite and >= 0, a scale that is not nv
    /// positive values, and a model that does not integrate with Euler.
    pub fn new(model: &Model, margin: f64, scale: &[f64]) -> Result<Elimination, WindowError> {
        if !(margin.is_finite() && margin >= 0.0) {
            return Err(WindowError::Margin { margin });
        }
        if scale.len() != model.nv() || scale.iter().any(|s| !(s.is_finite() && *s > 0.0)) {
            return Err(WindowError::ForceScale {
                expected: model.nv(),
            });
        }
        if model.opt.integrator != Integrator::Euler {
            return Err(WindowError::NotEuler);
        }
        let detect = model
            .edited(|s| {
                s.opt.contact = true;
                s.opt.contact_model = ContactModel::Constraint;
                for g in &mut s.geoms {
                    g.contact.margin += margin;
                }
            })
            .map_err(|e| WindowError::Detection(e.to_string()))?;
        Ok(Elimination {
            margin,
            scale: scale.to_vec(),
            detect,
            contacts: vec![],
            pre: vec![],
            nodes: vec![],
            basis: vec![],
        })
    }

    pub fn margin(&self) -> f64 {
        self.margin
    }

    /// The force scale s (nv values, N or N m).
    pub fn scale(&self) -> &[f64] {
        &self.scale
    }

    /// Adds the nodes carrying a body that may touch something at the state
    /// whose world frames `data` holds.
    fn touching(&mut self, data: &crate::dynamics::Data<f64>) {
        let tree = self.detect.tree();
        contacts(tree, data, (&mut self.contacts, &mut self.pre));
        for c in &self.contacts {
            for b in c.bodies {
                if let Some(node) = tree.body[b].node {
                    if !self.nodes.contains(&node) {
                        self.nodes.push(node);
                    }
                }
            }
        }
    }

    /// Adds a scaled constraint direction to the basis if it is new.
    fn add_direction(&mut self, mut g: DVector<f64>) {
        g.component_div_assign(&DVector::from_column_slice(&self.scale));
        let norm = g.norm();
        if norm == 0.0 {
            return;
        }
        for _ in 0..2 {
            for b in &self.basis {
                g.axpy(-b.dot(&g), b, 1.0);
            }
        }
        let left = g.norm();
        if left > INDEPENDENT * norm {
            self.basis.push(g / left);
        }
    }

    /// Takes the basis's directions out of `x` (P x).
    fn project(&self, mut x: DVector<f64>) -> DVector<f64> {
        for b in &self.basis {
            x.axpy(-b.dot(&x), b, 1.0);
        }
        x
    }
}

/// The window's residuals with the constraint impulses eliminated (nv per
/// transition, see the module docs), their Jacobian d r / d mu with
/// `jacobian`, the loss and the gradient, into `fit`. `model` is set to the
/// parameters of mu.
pub fn eliminated_residuals_into(
    model: &mut Model,
    ws: &mut Workspace,
    (map, mu): (&ParamMap, &[f64]),
    (window, elimination): (&[Transition], &mut Elimination),
    jacobian: bool,
    fit: &mut WindowFit,
) -> Result<(), WindowError> {
    let n = model.nv();
    map.apply(model, mu)?;
    ws.size_for(model);
    let (rows, cols) = (n * window.len(), if jacobian { map.nmu } else { 0 });
    if fit.residuals.len() != rows {
        fit.residuals = DVector::zeros(rows);
    }
    if fit.jacobian.shape() != (rows, cols) {
        fit.jacobian = nalgebra::DMatrix::zeros(rows, cols);
    }
    if fit.gradient.len() != cols {
        fit.gradient = DVector::zeros(cols);
    }
    if jacobian {
        directions(model, map, &mut ws.window.columns);
    }
    for (t, tr) in window.iter().enumerate() {
        check_transition(t, tr, n)?;
        transition_rows(model, ws, tr, elimination, jacobian, fit, n * t);
    }
    fit.loss = fit.residuals.norm_squared();
    if jacobian {
        fit.gradient
            .gemv_tr(2.0, &fit.jacobian, &fit.residuals, 0.0);
    }
    Ok(())
}

/// One transition's nv rows, from row `first` on.
fn transition_rows(
    model: &Model,
    ws: &mut Workspace,
    tr: &Transition,
    elim: &mut Elimination,
    jacobian: bool,
    fit: &mut WindowFit,
    first: usize,
) {
    let n = model.nv();
    let tree = model.tree();
    let (mode, h) = (model.opt.passive, model.opt.timestep);
    // What may touch at q', then at q (whose frames RNEA leaves in `data`).
    elim.nodes.clear();
    update_transforms(tree, &mut ws.data, &tr.q_next);
    world_frames(tree, &mut ws.data, &tr.v_next);
    elim.touching(&ws.data);
    for i in 0..n {
        ws.qdd[i] = (tr.v_next[i] - tr.v[i]) / h;
    }
    rnea(tree, &mut ws.data, &tr.q, &tr.v, &ws.qdd, &mut ws.tau);
    world_frames(tree, &mut ws.data, &tr.v);
    elim.touching(&ws.data);
    // R = ID + extra a - tau - tau_passive.
    implicit_terms(
        tree,
        (mode, h),
        (&tr.q, &tr.v),
        &mut ws.q_spring,
        &mut ws.extra,
    );
    let mut passive = vec![0.0; n];
    passive_forces(tree, &ws.q_spring, &tr.v, &mut passive);
    let r = DVector::from_fn(n, |i, _| {
        ws.tau[i] + ws.extra[i] * ws.qdd[i] - tr.tau[i] - passive[i]
    });
    // The constraint directions: a wrench on each touching body (the world
    // axes of the dofs on its path), a force on each limited or rubbing dof.
    elim.basis.clear();
    for k in 0..elim.nodes.len() {
        for c in 0..6 {
            let mut g = DVector::zeros(n);
            let mut i = Some(elim.nodes[k]);
            while let Some(d) = i {
                let s = &ws.data.world_axis[d];
                g[d] = if c < 3 { s.ang[c] } else { s.lin[c - 3] };
                i = tree.parent[d];
            }
            elim.add_direction(g);
        }
    }
    for (d, joint) in model.joints.iter().enumerate() {
        let near = |x: f64| {
            joint
                .range
                .is_some_and(|(lo, hi)| x < lo + elim.margin || x > hi - elim.margin)
        };
        if joint.frictionloss > 0.0 || near(tr.q[d]) || near(tr.q_next[d]) {
            let mut g = DVector::zeros(n);
            g[d] = 1.0;
            elim.add_direction(g);
        }
    }
    let scaled = |x: DVector<f64>| x.component_div(&DVector::from_column_slice(&elim.scale));
    let residual = elim.project(scaled(r));
    fit.residuals.rows_mut(first, n).copy_from(&residual);
    if !jacobian {
        return;
    }
    let at = (&ws.q_spring[..], &tr.v[..], &ws.qdd[..]);
    for (j, column) in ws.window.columns.iter().enumerate() {
        let mut dr = DVector::zeros(n);
        for term in column {
            match term {
                Term::Inertia { node, di } => {
                    add_body_force(tree, &ws.data, *node, di, dr.as_mut_slice())
                }
                // Contact and constraint parameters act through the
                // eliminated impulses alone.
                Term::Joint { param, .. } if param.is_contact() || param.is_constraint() => {}
                Term::Joint { param, gain } => {
                    let (i, value) = joint_derivative(tree, (mode, h), at, *param);
                    dr[i] += gain * value;
                }
            }
        }
        let column = elim.project(scaled(dr));
        fit.jacobian.view_mut((first, j), (n, 1)).copy_from(&column);
    }
}
