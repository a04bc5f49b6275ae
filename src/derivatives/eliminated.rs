//! The identification loss when the target's constraint forces are unknown:
//! its contact law, joint limits and dry friction may be anyone's (another
//! engine's), so their impulses are unknowns of the fit, eliminated in
//! closed form.
//!
//! Per transition (q, v) --tau--> (q', v'), with a = (v' - v) / h, the
//! generalized force our smooth dynamics leaves unexplained is the residual
//! a semi-implicit Euler step zeroes (module `derivatives`):
//!   R = ID(q, v, a) + extra a - tau - tau_passive(stretch, v)
//! (armature inside ID; extra and stretch from the model's passive mode).
//! Whatever the constraint law, R = G lambda for some lambda, G's columns
//! being the generalized forces of
//! - any wrench (6 columns) on a body with a geom within `margin` of
//!   touching another at q or at q' (a contact anywhere on the body, with
//!   any normal, friction, torsional or rolling law);
//! - any force on a dof within `margin` (m or rad) of an end of its range
//!   at q or q', and on a dof with dry friction;
//! - any wrench on a body a connect or weld holds, any force on a joint of
//!   a joint equality.
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
//!
//! How an impulse moves the velocity is the target's convention
//! ([`Impulses`]). MuJoCo's Euler step (and ours) solves its constraints with
//! the implicit passive diagonal E: (M + E)(v' - v) / h = f + G lambda, so R
//! itself is G lambda. DART takes its implicit spring and damper terms at the
//! free velocity v_f, (M + E)(v_f - v) / h = f, and applies the impulse
//! through M alone, M (v' - v_f) / h = G lambda: there the residual is
//!   R_M = M (a - qdd_free) = R - E (a - qdd_free),  (M + E) qdd_free = f,
//! whose derivative adds E d qdd_free / d mu - dE / d mu (a - qdd_free), with
//! d qdd_free / d mu = -(M + E)^-1 dR / d mu at qdd_free.

use nalgebra::{DMatrix, DVector};

use super::step::Workspace;
use super::window::{
    articulated_solve, check_transition, directions, residual_column, Term, Transition,
    WindowError, WindowFit,
};
use crate::dynamics::collision::{ConstraintContact, Pre};
use crate::dynamics::constraint::{contacts, ConstraintKind, Held};
use crate::dynamics::integrator::{euler, ImplicitPassive};
use crate::dynamics::world_frames;
use crate::dynamics::{
    aba_with_transforms, implicit_terms, passive_forces, rnea, update_transforms, Data,
};
use crate::model::{ContactModel, Joint, ParamMap, PassiveMode};
use crate::spatial::{Force, Motion};
use crate::Model;

/// Below this fraction of its own norm, what is left of a constraint
/// direction after the ones before it are taken out adds nothing new.
const INDEPENDENT: f64 = 1e-9;

/// How the target applies a constraint impulse (see the module docs).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Impulses {
    /// Through M + E, E the model's implicit passive diagonal: MuJoCo's and
    /// our Euler step (the default).
    #[default]
    Model,
    /// Through M alone, the implicit passive terms taken before it: DART's.
    Mass,
}

/// How the constraint impulses of a model's transitions are eliminated: the
/// margin, the force scale, the impulses' convention, and the colliders that
/// find what may touch.
#[derive(Clone, Debug)]
pub struct Elimination {
    margin: f64,
    scale: Vec<f64>,
    impulses: Impulses,
    /// The model under the constraint model's colliders, contacts on, every
    /// geom's margin raised by `margin`.
    detect: Model,
    contacts: Vec<ConstraintContact<f64>>,
    pre: Vec<Pre<f64>>,
    /// The nodes a wrench may act on (scratch of [`Elimination::refresh`]).
    nodes: Vec<usize>,
    /// Per position in the last window: the transition's q and q', and an
    /// orthonormal basis of its scaled constraint directions (one vector of
    /// nv per direction). They depend on q and q' alone, so the evaluations
    /// of one identification find them here.
    bases: Vec<Basis>,
}

#[derive(Clone, Debug, Default)]
struct Basis {
    q: Vec<f64>,
    q_next: Vec<f64>,
    directions: Vec<DVector<f64>>,
}

impl Elimination {
    /// Refuses a margin that is not finite and >= 0, a scale that is not nv
    /// positive values, and a model that does not integrate with Euler.
    pub fn new(
        model: &Model,
        margin: f64,
        scale: &[f64],
        impulses: Impulses,
    ) -> Result<Elimination, WindowError> {
        if !(margin.is_finite() && margin >= 0.0) {
            return Err(WindowError::Margin { margin });
        }
        if scale.len() != model.nv() || scale.iter().any(|s| !(s.is_finite() && *s > 0.0)) {
            return Err(WindowError::ForceScale {
                expected: model.nv(),
            });
        }
        if euler(&model.opt).is_none() {
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
            impulses,
            detect,
            contacts: vec![],
            pre: vec![],
            nodes: vec![],
            bases: vec![],
        })
    }

    /// Adds the nodes carrying a body that may touch something at the state
    /// whose world frames `data` holds, or that a connect or weld holds.
    fn touching(&mut self, data: &Data<f64>) {
        let tree = self.detect.tree();
        contacts(tree, data, (&mut self.contacts, &mut self.pre));
        let held = tree
            .constraint
            .equalities
            .iter()
            .filter_map(|e| match e.held {
                Held::Points { bodies, .. } => Some(bodies),
                Held::Joints { .. } | Held::Tendons { .. } => None,
            });
        for bodies in self.contacts.iter().map(|c| c.bodies).chain(held) {
            for b in bodies {
                if let Some(node) = tree.body[b].node {
                    if !self.nodes.contains(&node) {
                        self.nodes.push(node);
                    }
                }
            }
        }
    }

    /// The basis of transition `t`'s constraint directions, found again only
    /// when the window's transition there is another: what may touch at q'
    /// and at q, then the directions from the world axes at q.
    fn refresh(&mut self, t: usize, model: &Model, data: &mut Data<f64>, tr: &Transition) {
        if self.bases.len() <= t {
            self.bases.resize_with(t + 1, Basis::default);
        }
        if self.bases[t].q == tr.start.q && self.bases[t].q_next == tr.next.q {
            return;
        }
        let tree = model.tree();
        self.nodes.clear();
        for (q, v) in [(&tr.next.q, &tr.next.v), (&tr.start.q, &tr.start.v)] {
            update_transforms(tree, data, q);
            world_frames(tree, data, v);
            self.touching(data);
        }
        let directions = self.constraint_directions(model, data, tr);
        self.bases[t] = Basis {
            q: tr.start.q.clone(),
            q_next: tr.next.q.clone(),
            directions,
        };
    }

    /// The orthonormal basis of the scaled constraint directions at a
    /// transition whose frames at q `data` holds (world axes), by the kinds
    /// of the constraint rows ([`ConstraintKind`]): a wrench on each touching
    /// body (contacts), then dof by dof a force on each dof a constraint may
    /// push ([`Elimination::pushes_dof`]).
    fn constraint_directions(
        &self,
        model: &Model,
        data: &Data<f64>,
        tr: &Transition,
    ) -> Vec<DVector<f64>> {
        let (n, tree) = (model.nv(), model.tree());
        let scale = DVector::from_column_slice(&self.scale);
        let mut basis = vec![];
        for &node in &self.nodes {
            for c in 0..6 {
                let mut g = DVector::zeros(n);
                let mut i = Some(node);
                while let Some(d) = i {
                    let s = &data.world_axis[d];
                    g[d] = if c < 3 { s.ang[c] } else { s.lin[c - 3] };
                    i = tree.parent[d];
                }
                add_direction(&mut basis, g.component_div(&scale));
            }
        }
        for (d, joint) in model.joints.iter().enumerate() {
            let at = (tr.start.q[d], tr.next.q[d]);
            let pushes = |kind: &ConstraintKind| self.pushes_dof(*kind, (d, joint), at);
            if ConstraintKind::ORDER.iter().any(pushes) {
                let mut g = DVector::zeros(n);
                g[d] = 1.0 / scale[d];
                add_direction(&mut basis, g);
            }
        }
        basis
    }

    /// Whether a constraint of `kind` may push on the dof of `joint` at a
    /// transition taking its coordinate from x to x_next: dry friction
    /// always, a limit within `margin` of an end of its range at x or
    /// x_next, a joint equality on its joints; contacts, connects and welds
    /// push on bodies ([`Elimination::touching`]).
    fn pushes_dof(
        &self,
        kind: ConstraintKind,
        (d, joint): (usize, &Joint),
        (x, x_next): (f64, f64),
    ) -> bool {
        let near = |x: f64| {
            joint
                .range
                .is_some_and(|(lo, hi)| x < lo + self.margin || x > hi - self.margin)
        };
        let tree = self.detect.tree();
        let tendon_moves = |t: usize| tree.tendons[t].dofs().contains(&d);
        match kind {
            ConstraintKind::Equality => {
                let equalities = &tree.constraint.equalities;
                equalities.iter().any(|e| match e.held {
                    Held::Joints { first, second, .. } => {
                        first.1 == d || second.is_some_and(|s| s.1 == d)
                    }
                    Held::Tendons { first, second, .. } => {
                        tendon_moves(first) || second.is_some_and(tendon_moves)
                    }
                    Held::Points { .. } => false,
                })
            }
            ConstraintKind::TendonFriction => (0..tree.tendons.len())
                .any(|t| tree.tendons[t].frictionloss.0 > 0.0 && tendon_moves(t)),
            ConstraintKind::TendonLimit => {
                (0..tree.tendons.len()).any(|t| tree.tendons[t].limit.is_some() && tendon_moves(t))
            }
            ConstraintKind::DofFriction => joint.frictionloss > 0.0,
            ConstraintKind::JointLimit => near(x) || near(x_next),
            ConstraintKind::Contact => false,
        }
    }

    /// Takes transition `t`'s directions out of `x` (P x).
    fn project(&self, t: usize, mut x: DVector<f64>) -> DVector<f64> {
        for b in &self.bases[t].directions {
            x.axpy(-b.dot(&x), b, 1.0);
        }
        x
    }
}

/// Adds direction `g` to the orthonormal `basis` if it is new (twice
/// orthogonalised against it).
fn add_direction(basis: &mut Vec<DVector<f64>>, mut g: DVector<f64>) {
    let norm = g.norm();
    if norm == 0.0 {
        return;
    }
    for _ in 0..2 {
        for b in basis.iter() {
            g.axpy(-b.dot(&g), b, 1.0);
        }
    }
    let left = g.norm();
    if left > INDEPENDENT * norm {
        basis.push(g / left);
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
    super::one_dof_joints(model).map_err(|source| WindowError::Step { t: 0, source })?;
    if map.targets.iter().any(|(p, ..)| p.is_tendon()) {
        let source = crate::dynamics::StepError::NoTendonDerivatives;
        return Err(WindowError::Step { t: 0, source });
    }
    if !crate::dynamics::actuation::idle_without_inputs(&model.tree().actuators) {
        let source = crate::dynamics::StepError::NoActuatorDerivatives;
        return Err(WindowError::Step { t: 0, source });
    }
    map.apply(model, mu)?;
    ws.size_for(model);
    fit.size(n * window.len(), if jacobian { map.nmu } else { 0 });
    if jacobian {
        directions(model, map, &mut ws.window.columns);
    }
    for (t, tr) in window.iter().enumerate() {
        check_transition(t, tr, (n, n))?;
        transition_rows(model, ws, (t, tr), elimination, jacobian, fit);
    }
    fit.finish();
    Ok(())
}

/// One transition's nv rows, from row `first` on.
fn transition_rows(
    model: &Model,
    ws: &mut Workspace,
    (t, tr): (usize, &Transition),
    elim: &mut Elimination,
    jacobian: bool,
    fit: &mut WindowFit,
) {
    let (n, first) = (model.nv(), model.nv() * t);
    let tree = model.tree();
    let (mode, h) = (model.opt.passive, model.opt.timestep);
    elim.refresh(t, model, &mut ws.data, tr);
    implicit_terms(
        tree,
        (mode, h),
        (&tr.start.q, &tr.start.v),
        &mut ws.stretch,
        &mut ws.extra,
    );
    let mut force = vec![0.0; n];
    passive_forces(tree, &ws.stretch, &tr.start.v, &mut force);
    for (f, t) in force.iter_mut().zip(&tr.tau) {
        *f += t;
    }
    let a = DVector::from_fn(n, |i, _| (tr.next.v[i] - tr.start.v[i]) / h);
    // Under `Impulses::Mass`: the free acceleration, and its derivatives.
    let free = (elim.impulses == Impulses::Mass).then(|| {
        free_acceleration(
            tree,
            ws,
            (mode, h),
            (&tr.start.q, &tr.start.v),
            &force,
            jacobian,
        )
    });
    // R = ID(q, v, a) + extra a - (tau + tau_passive).
    ws.qdd.copy_from_slice(a.as_slice());
    rnea(
        tree,
        &mut ws.data,
        &tr.start.q,
        &tr.start.v,
        &ws.qdd,
        &mut ws.tau,
    );
    let extra = DVector::from_column_slice(&ws.extra);
    let mut r = DVector::from_fn(n, |i, _| ws.tau[i] + extra[i] * a[i] - force[i]);
    if let Some((qdd, _)) = &free {
        r -= extra.component_mul(&(&a - qdd));
    }
    let scale = DVector::from_column_slice(&elim.scale);
    fit.residuals
        .rows_mut(first, n)
        .copy_from(&elim.project(t, r.component_div(&scale)));
    if !jacobian {
        return;
    }
    let at = (&ws.stretch[..], &tr.start.v[..], &ws.qdd[..]);
    let mut dr = DVector::zeros(n);
    for (j, column) in ws.window.columns.iter().enumerate() {
        residual_column(tree, &ws.data, (mode, h), at, column, dr.as_mut_slice());
        if let Some((qdd, dqdd)) = &free {
            dr += extra.component_mul(&dqdd.column(j));
            for (i, de) in implicit_diagonal(column, (mode, h)) {
                dr[i] -= de * (a[i] - qdd[i]);
            }
        }
        let col = elim.project(t, dr.component_div(&scale));
        fit.jacobian.view_mut((first, j), (n, 1)).copy_from(&col);
    }
}

/// qdd_free solving (M + E) qdd_free = tau + tau_passive (`force`), and with
/// `jacobian` its derivative along every mu column, -(M + E)^-1 dR / d mu_j
/// at qdd_free (one RNEA and one articulated solve per column).
fn free_acceleration(
    tree: &crate::dynamics::Tree<f64>,
    ws: &mut Workspace,
    (mode, h): (PassiveMode, f64),
    (q, v): (&[f64], &[f64]),
    force: &[f64],
    jacobian: bool,
) -> (DVector<f64>, DMatrix<f64>) {
    let n = tree.nv();
    let implicit = ImplicitPassive::new(mode, h)
        .acts()
        .then_some(&ws.extra[..]);
    update_transforms(tree, &mut ws.data, q);
    aba_with_transforms(tree, &mut ws.data, v, force, implicit, &mut ws.qdd);
    let qdd = DVector::from_column_slice(&ws.qdd);
    let columns = &ws.window.columns;
    let mut dqdd = DMatrix::zeros(n, if jacobian { columns.len() } else { 0 });
    if jacobian {
        // RNEA at qdd_free for the body terms; ABA's factors stay in `data`.
        rnea(tree, &mut ws.data, q, v, &ws.qdd, &mut ws.tau);
        let at = (&ws.stretch[..], v, &ws.qdd[..]);
        let mut sweeps = (vec![Force::zero(); n], vec![Motion::zero(); n]);
        let mut dr = vec![0.0; n];
        for (j, column) in columns.iter().enumerate() {
            residual_column(tree, &ws.data, (mode, h), at, column, &mut dr);
            articulated_solve(tree, &ws.data, &mut dr, (&mut sweeps.0, &mut sweeps.1));
            dqdd.set_column(j, &-DVector::from_column_slice(&dr));
        }
    }
    (qdd, dqdd)
}

/// The implicit diagonal's change along a mu column: (dof, dE_i / d mu_j).
fn implicit_diagonal(column: &[Term], (mode, h): (PassiveMode, f64)) -> Vec<(usize, f64)> {
    let implicit = ImplicitPassive::new(mode, h);
    column
        .iter()
        .filter_map(|term| match term {
            Term::Joint { param, gain } => implicit.partial(*param).map(|(i, de)| (i, gain * de)),
            Term::Inertia { .. } => None,
        })
        .collect()
}
