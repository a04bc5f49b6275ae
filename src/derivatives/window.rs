//! The identification loss over a window of transitions (the paper's eq. 1-3):
//! L(mu) = sum_t ||(g_mu(x_t, tau_t) - x_{t+1}) / scale||^2, with g_mu our step
//! under the parameters mu maps to; its stacked residuals, their Jacobian
//! (for Gauss-Newton) and the gradient.
//!
//! Under semi-implicit Euler (the default) a transition costs one
//! articulated-body pass (the step itself, the same numbers as
//! [`Model::step`]) plus, per mu column, one sweep up the tree for dR/dmu
//! (see the module `derivatives`) and one solve with the articulated-body
//! factors that pass left behind: no mass matrix, no state Jacobian. The
//! inertia derivatives of a column are taken once per evaluation, not per
//! transition. Contact and limit forces depend on no inertial or joint
//! parameter, so they change the step but not dR/dmu. Under RK4, with ball
//! or free joints or fluid forces, or when mu moves a contact parameter,
//! each transition goes through [`step_jacobians`].
//! Buffers live in the [`Workspace`] and in the [`WindowFit`] filled, so an
//! evaluation into a reused fit allocates nothing.

use nalgebra::{DMatrix, DVector};

use super::params::{add_body_force, joint_derivative, node_inertia_derivative};
use super::step::{step_jacobians, Workspace, Wrt};
use crate::dynamics::actuation::idle_without_inputs;
use crate::dynamics::configuration::{subtract, tangent_rate};
use crate::dynamics::integrator;
use crate::dynamics::{acceleration, implicit_terms, integrate_euler, Data, StepError, Tree};
use crate::model::{Param, ParamError, ParamMap, PassiveMode, State};
use crate::spatial::{Force, Inertia, Motion};
use crate::Model;

/// One observed transition: from the state `start` under generalized forces
/// tau (nv) to the state `next`.
#[derive(Clone, Debug, PartialEq)]
pub struct Transition {
    pub start: State,
    pub tau: Vec<f64>,
    pub next: State,
}

impl Transition {
    /// The transition `model` takes from `start` under tau (a simulated
    /// observation: [`Model::step`]).
    pub fn simulated(
        model: &Model,
        data: &mut Data<f64>,
        start: State,
        tau: Vec<f64>,
    ) -> Result<Transition, StepError> {
        let next = model.step(data, &start, &crate::model::Inputs::tau(&tau))?;
        Ok(Transition { start, tau, next })
    }
}

#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum WindowError {
    #[error(transparent)]
    Param(#[from] ParamError),
    #[error("transition {t}: {source}")]
    Step { t: usize, source: StepError },
    #[error("transition {t}: {what} has length {got}, expected {expected}")]
    Length {
        t: usize,
        what: &'static str,
        got: usize,
        expected: usize,
    },
    #[error("transition {t}: {what}[{i}] = {value} is not finite")]
    NotFinite {
        t: usize,
        what: &'static str,
        i: usize,
        value: f64,
    },
    #[error("scale must hold 2 nv = {expected} positive values")]
    Scale { expected: usize },
    #[error("the force scale of unknown constraints must hold nv = {expected} positive values")]
    ForceScale { expected: usize },
    #[error("the margin of unknown constraints must be finite and >= 0, got {margin}")]
    Margin { margin: f64 },
    #[error("unknown constraints need the Euler integrator: their residual is the Euler step's")]
    NotEuler,
    #[error("unknown constraints: {0}")]
    Detection(String),
}

/// Residuals r (2 nv per transition: q then v, divided by `scale`), their
/// Jacobian dr/dmu, the loss sum r^2 and its gradient 2 J^T r. The q
/// residual is the tangent vector from the observed q' to the predicted one
/// (mj_differentiatePos: a ball or free joint's rotation as a body-frame
/// rotation vector), the plain difference for hinges and slides.
#[derive(Clone, Debug, PartialEq)]
pub struct WindowFit {
    pub residuals: DVector<f64>,
    pub jacobian: DMatrix<f64>,
    pub loss: f64,
    pub gradient: DVector<f64>,
}

impl WindowFit {
    /// A fit with no rows, for [`window_residuals_into`] to size and fill.
    pub fn empty() -> WindowFit {
        WindowFit {
            residuals: DVector::zeros(0),
            jacobian: DMatrix::zeros(0, 0),
            loss: 0.0,
            gradient: DVector::zeros(0),
        }
    }

    /// Sizes the buffers for `rows` residuals and `cols` Jacobian columns,
    /// reallocating only when a shape changes.
    pub(super) fn size(&mut self, rows: usize, cols: usize) {
        if self.residuals.len() != rows {
            self.residuals = DVector::zeros(rows);
        }
        if self.jacobian.shape() != (rows, cols) {
            self.jacobian = DMatrix::zeros(rows, cols);
        }
        if self.gradient.len() != cols {
            self.gradient = DVector::zeros(cols);
        }
    }

    /// The loss sum r^2 and, with a Jacobian, its gradient 2 J^T r, from the
    /// residuals and Jacobian written.
    pub(super) fn finish(&mut self) {
        self.loss = self.residuals.norm_squared();
        if self.jacobian.ncols() > 0 {
            self.gradient
                .gemv_tr(2.0, &self.jacobian, &self.residuals, 0.0);
        }
    }
}

/// Evaluates the window loss at mu, with its Jacobian. `model` is set to the
/// parameters of mu.
pub fn window_residuals(
    model: &mut Model,
    ws: &mut Workspace,
    map: &ParamMap,
    mu: &[f64],
    window: &[Transition],
    scale: &[f64],
) -> Result<WindowFit, WindowError> {
    let mut fit = WindowFit::empty();
    window_residuals_into(model, ws, (map, mu), (window, scale), true, &mut fit)?;
    Ok(fit)
}

/// [`window_residuals`] into the buffers of `fit` (resized only when the
/// window's shape changes). Without `jacobian` only the residuals and the
/// loss are computed; the Jacobian and the gradient are left with no columns.
pub fn window_residuals_into(
    model: &mut Model,
    ws: &mut Workspace,
    (map, mu): (&ParamMap, &[f64]),
    (window, scale): (&[Transition], &[f64]),
    jacobian: bool,
    fit: &mut WindowFit,
) -> Result<(), WindowError> {
    let (nq, n) = (model.nq(), model.nv());
    if scale.len() != 2 * n || scale.iter().any(|s| !(s.is_finite() && *s > 0.0)) {
        return Err(WindowError::Scale { expected: 2 * n });
    }
    map.apply(model, mu)?;
    ws.size_for(model);
    fit.size(2 * n * window.len(), if jacobian { map.nmu } else { 0 });
    // The contact parameters' columns need tau_soft's derivatives, the
    // constraint model's rows its solver's, and ball and free joints, fluid
    // forces and tendon parameters dual numbers: those windows go through
    // step_jacobians.
    let tree = model.tree();
    let euler = integrator::euler(&model.opt).is_some()
        && !tree.has_constraints()
        && idle_without_inputs(&tree.actuators)
        && !super::dual_only(model)
        && !map
            .targets
            .iter()
            .any(|(p, ..)| p.is_contact() || p.is_tendon());
    if jacobian && euler {
        directions(model, map, &mut ws.window.columns);
    }
    for (t, tr) in window.iter().enumerate() {
        check_transition(t, tr, (nq, n))?;
        let rows = 2 * n * t..2 * n * (t + 1);
        let step = if euler {
            euler_rows(model, ws, tr, scale, jacobian, fit, rows)
        } else {
            general_rows(model, ws, map, tr, scale, jacobian, fit, rows)
        };
        step.map_err(|source| WindowError::Step { t, source })?;
    }
    fit.finish();
    Ok(())
}

/// What one unit of a mu column changes in the residual R of a step: the
/// inertia a node carries, or a joint parameter (with its gain).
#[derive(Clone, Debug)]
pub(super) enum Term {
    Inertia { node: usize, di: Inertia<f64> },
    Joint { param: Param, gain: f64 },
}

/// The scratch the Euler rows keep: the terms of each mu column (for the
/// model's current parameters), the solve's sweeps, the predicted state.
#[derive(Clone, Debug)]
pub(super) struct WindowScratch {
    pub(super) columns: Vec<Vec<Term>>,
    forces: Vec<Force<f64>>,
    motions: Vec<Motion<f64>>,
    q_next: Vec<f64>,
    v_next: Vec<f64>,
}

impl WindowScratch {
    pub(super) fn new(n: usize) -> Self {
        WindowScratch {
            columns: vec![],
            forces: vec![Force::zero(); n],
            motions: vec![Motion::zero(); n],
            q_next: vec![0.0; n],
            v_next: vec![0.0; n],
        }
    }
}

/// The terms of every mu column at the model's current parameters: for a
/// body parameter the node inertia derivative along the column's gains
/// (summed per node), for a joint parameter the gain.
pub(super) fn directions(model: &Model, map: &ParamMap, columns: &mut Vec<Vec<Term>>) {
    columns.resize_with(map.nmu, Vec::new);
    for (j, column) in columns.iter_mut().enumerate() {
        column.clear();
        for (param, _, gain) in &map.targets {
            let weight = |c: usize| gain[(c, j)];
            if (0..param.size()).all(|c| weight(c) == 0.0) {
                continue;
            }
            match *param {
                Param::Mass(b) | Param::Com(b) | Param::Inertia(b) => {
                    let Some((node, di)) = node_inertia_derivative(model, b, *param, weight) else {
                        continue; // welded to the world
                    };
                    let same = column.iter_mut().find_map(|t| match t {
                        Term::Inertia { node: k, di } if *k == node => Some(di),
                        _ => None,
                    });
                    match same {
                        Some(sum) => *sum += di,
                        None => column.push(Term::Inertia { node, di }),
                    }
                }
                _ => column.push(Term::Joint {
                    param: *param,
                    gain: weight(0),
                }),
            }
        }
    }
}

/// One transition's rows under semi-implicit Euler: q' = q + h v',
/// v' = v + h qdd, so d v' = h d qdd and d q' = h^2 d qdd, with
/// d qdd / d mu_j = -(M + diag(extra))^-1 dR/d mu_j.
fn euler_rows(
    model: &Model,
    ws: &mut Workspace,
    tr: &Transition,
    scale: &[f64],
    jacobian: bool,
    fit: &mut WindowFit,
    rows: std::ops::Range<usize>,
) -> Result<(), StepError> {
    let n = model.nv();
    let tree = model.tree();
    let (mode, h) = (model.opt.passive, model.opt.timestep);
    let point = (&tr.start.q[..], &tr.start.v[..], &tr.tau[..]);
    acceleration(tree, &mut ws.data, (mode, h), point, &mut ws.qdd);
    let scratch = &mut ws.window;
    let next = (&mut scratch.q_next[..], &mut scratch.v_next[..]);
    integrate_euler(tree, h, (&tr.start.q, &tr.start.v, &ws.qdd), next);
    if !scratch
        .q_next
        .iter()
        .chain(&scratch.v_next)
        .all(|x| x.is_finite())
    {
        return Err(StepError::Diverged);
    }
    let predicted = (&scratch.q_next[..], &scratch.v_next[..]);
    put_residuals(tree, fit, rows.clone(), predicted, tr, scale);
    if !jacobian {
        return Ok(());
    }
    implicit_terms(
        tree,
        (mode, h),
        (&tr.start.q, &tr.start.v),
        &mut ws.stretch,
        &mut ws.extra,
    );
    let at = (&ws.stretch[..], &tr.start.v[..], &ws.qdd[..]);
    for (j, column) in scratch.columns.iter().enumerate() {
        let dr = &mut ws.tau;
        residual_column(tree, &ws.data, (mode, h), at, column, dr);
        let sweeps = (&mut scratch.forces[..], &mut scratch.motions[..]);
        articulated_solve(tree, &ws.data, dr, sweeps);
        let mut col = fit.jacobian.column_mut(j);
        for i in 0..n {
            let dv = -h * dr[i];
            col[rows.start + i] = h * dv / scale[i];
            col[rows.start + n + i] = dv / scale[n + i];
        }
    }
    Ok(())
}

/// dR / d mu_j into `dr` (zeroed first) at the point (stretch, v, a) whose
/// RNEA velocities and accelerations `data` holds: the column's body forces
/// and joint entries. Contact and constraint parameters add nothing: they
/// act through constraint forces, not through R.
pub(super) fn residual_column(
    tree: &Tree<f64>,
    data: &Data<f64>,
    (mode, h): (PassiveMode, f64),
    at: (&[f64], &[f64], &[f64]),
    column: &[Term],
    dr: &mut [f64],
) {
    dr.fill(0.0);
    for term in column {
        match term {
            Term::Inertia { node, di } => add_body_force(tree, data, *node, di, dr),
            Term::Joint { param, .. }
                if param.is_contact() || param.is_constraint() || param.is_actuator() => {}
            Term::Joint { param, gain } => {
                let (i, value) = joint_derivative((mode, h), at, *param);
                dr[i] += gain * value;
            }
        }
    }
}

/// Writes one transition's scaled residuals (predicted (-) observed) /
/// scale, q then v, into `rows` of the fit.
fn put_residuals(
    tree: &Tree<f64>,
    fit: &mut WindowFit,
    rows: std::ops::Range<usize>,
    (q_next, v_next): (&[f64], &[f64]),
    tr: &Transition,
    scale: &[f64],
) {
    let n = tree.nv();
    let r = &mut fit.residuals.as_mut_slice()[rows];
    subtract(tree, q_next, &tr.next.q, &mut r[..n]);
    for (r, (p, o)) in r[n..].iter_mut().zip(v_next.iter().zip(&tr.next.v)) {
        *r = p - o;
    }
    r.iter_mut().zip(scale).for_each(|(r, s)| *r /= s);
}

/// Solves (M + diag(extra)) x = b in place with the factors an
/// articulated-body pass left in `data` (transforms, U_i = I^A_i S_i and
/// D_i, extra included): that pass's last two sweeps with no velocity and
/// no gravity. `forces` and `motions` are scratch of length nv.
pub(super) fn articulated_solve(
    tree: &Tree<f64>,
    data: &Data<f64>,
    b: &mut [f64],
    (forces, motions): (&mut [Force<f64>], &mut [Motion<f64>]),
) {
    let n = tree.nv();
    forces.fill(Force::zero());
    for i in (0..n).rev() {
        b[i] -= tree.joint[i].s.dot(&forces[i]);
        if let Some(p) = tree.parent[i] {
            let passed = forces[i] + data.u_force[i] * (b[i] / data.d[i]);
            forces[p] += data.x_up[i].inverse_apply_force(&passed);
        }
    }
    for i in 0..n {
        let a = match tree.parent[i] {
            Some(p) => data.x_up[i].apply_motion(&motions[p]),
            None => Motion::zero(),
        };
        b[i] = (b[i] - a.dot(&data.u_force[i])) / data.d[i];
        motions[i] = a + tree.joint[i].s * b[i];
    }
}

/// One transition's rows through [`step_jacobians`] (any integrator).
#[allow(clippy::too_many_arguments)]
fn general_rows(
    model: &Model,
    ws: &mut Workspace,
    map: &ParamMap,
    tr: &Transition,
    scale: &[f64],
    jacobian: bool,
    fit: &mut WindowFit,
    rows: std::ops::Range<usize>,
) -> Result<(), StepError> {
    let n = model.nv();
    let params = if jacobian { map.params() } else { vec![] };
    let wrt = Wrt {
        params: &params,
        ..Wrt::default()
    };
    let j = step_jacobians(model, ws, (&tr.start.q, &tr.start.v, &tr.tau), &wrt)?;
    let tree = model.tree();
    put_residuals(tree, fit, rows.clone(), (&j.q_next, &j.v_next), tr, scale);
    if jacobian {
        let dp_dmu = map.jacobian();
        let mut dq = j.dq_dp() * &dp_dmu;
        if !model.one_dof_joints() {
            // The q residual r = log(q_obs^-1 q') moves by J_r(r)^-1 dq' when q'
            // turns by dq' about its own axes.
            let r: Vec<f64> = (0..n)
                .map(|i| fit.residuals[rows.start + i] * scale[i])
                .collect();
            let mut turned = vec![0.0; n];
            for mut column in dq.column_iter_mut() {
                tangent_rate(tree, &r, column.as_slice(), &mut turned);
                column.copy_from_slice(&turned);
            }
        }
        let mut block = fit.jacobian.rows_mut(rows.start, 2 * n);
        block.rows_mut(0, n).copy_from(&dq);
        block.rows_mut(n, n).copy_from(&(j.dv_dp() * &dp_dmu));
        for (i, s) in scale.iter().enumerate() {
            block.row_mut(i).unscale_mut(*s);
        }
    }
    Ok(())
}

/// Names a transition's field whose length is not (nq or nv) or that is not finite.
pub(crate) fn check_transition(
    t: usize,
    tr: &Transition,
    (nq, n): (usize, usize),
) -> Result<(), WindowError> {
    let fields = [
        ("q", &tr.start.q, nq),
        ("v", &tr.start.v, n),
        ("tau", &tr.tau, n),
        ("q_next", &tr.next.q, nq),
        ("v_next", &tr.next.v, n),
    ];
    for (what, x, expected) in fields {
        if x.len() != expected {
            return Err(WindowError::Length {
                t,
                what,
                got: x.len(),
                expected,
            });
        }
        if let Some((i, &value)) = x.iter().enumerate().find(|(_, x)| !x.is_finite()) {
            return Err(WindowError::NotFinite { t, what, i, value });
        }
    }
    Ok(())
}
