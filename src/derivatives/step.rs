//! Step Jacobians: d(q', v') / d(q, v), d(q', v') / d tau and d(q', v') / d p:
//! analytic through the articulated dynamics, the smooth model and the
//! constraint model's solver ([`super::constraint`]); by dual numbers for the
//! constraint model's contact parameters ([`super::constrained`]).

use nalgebra::{DMatrix, DMatrixView};

use super::constrained::{dual_columns, DualTrees};
use super::constraint::{add_invweight_partials, add_row_partials, differentiable, Scratch};
use super::gemm::gemm;
use super::params::{mass_product_derivative, residual_derivative};
use super::rnea::{rnea_derivatives, Sweep};
use super::soft::{subtract_soft_derivatives, Columns};
use super::tangent::{add_rotation_springs, is_rotation, rotate_rows, rotations, Rotation};
use super::window::WindowScratch;
use crate::dynamics::actuation::idle_without_inputs;
use crate::dynamics::cholesky;
use crate::dynamics::constraint::solver::add_quadratic_rows;
use crate::dynamics::integrator::{euler, tableau, weighted_sum, ImplicitPassive, Tableau};
use crate::dynamics::mocap::set_mocap;
use crate::dynamics::world_frames;
use crate::dynamics::{
    acceleration, check_colliders, check_inputs, crba, implicit_terms, integrate_euler,
    ltdl_factor, ltdl_inverse, ltdl_solve_columns, rnea, rnea_with_transforms, step_applied,
};
use crate::dynamics::{Constrained, Data, StepError};
use crate::model::{Param, PassiveMode};
use crate::Model;

/// Which Jacobian blocks to compute; blocks not asked for cost nothing.
#[derive(Clone, Copy, Debug, Default)]
pub struct Wrt<'a> {
    /// d(q', v') / d(q, v)
    pub state: bool,
    /// d(q', v') / d tau
    pub control: bool,
    /// d(q', v') / d p, columns in the order of the flattened parameters.
    pub params: &'a [Param],
}

/// The next state and the step's Jacobian in mjd_transitionFD's layout:
/// 2 nv rows, d q' (in the tangent space at q') above d v'; columns the
/// blocks [`Wrt`] asks for, in order: the state (q in the tangent space at
/// q, then v: 2 nv), tau (nv), the parameters (their total length). A block
/// not asked for has no columns. The named views ([`StepJacobians::dq_dq`],
/// ...) are its blocks.
#[derive(Clone, Debug, PartialEq)]
pub struct StepJacobians {
    pub q_next: Vec<f64>,
    pub v_next: Vec<f64>,
    pub jacobian: DMatrix<f64>,
    /// The first column and the width of the q, v, tau and parameter blocks.
    columns: [(usize, usize); 4],
}

/// The column blocks of [`StepJacobians`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Block {
    Q,
    V,
    Tau,
    Params,
}

impl StepJacobians {
    /// The rows of q' (`next_v` false) or v' against the columns of `block`.
    fn block(&self, next_v: bool, block: Block) -> DMatrixView<'_, f64> {
        let n = self.v_next.len();
        let (start, len) = self.columns[block as usize];
        self.jacobian
            .view((if next_v { n } else { 0 }, start), (n, len))
    }

    pub fn dq_dq(&self) -> DMatrixView<'_, f64> {
        self.block(false, Block::Q)
    }

    pub fn dq_dv(&self) -> DMatrixView<'_, f64> {
        self.block(false, Block::V)
    }

    pub fn dv_dq(&self) -> DMatrixView<'_, f64> {
        self.block(true, Block::Q)
    }

    pub fn dv_dv(&self) -> DMatrixView<'_, f64> {
        self.block(true, Block::V)
    }

    pub fn dq_dtau(&self) -> DMatrixView<'_, f64> {
        self.block(false, Block::Tau)
    }

    pub fn dv_dtau(&self) -> DMatrixView<'_, f64> {
        self.block(true, Block::Tau)
    }

    /// Columns in the order of the flattened parameters.
    pub fn dq_dp(&self) -> DMatrixView<'_, f64> {
        self.block(false, Block::Params)
    }

    pub fn dv_dp(&self) -> DMatrixView<'_, f64> {
        self.block(true, Block::Params)
    }

    /// d(q', v') / d(q, v): the state columns, 2 nv x 2 nv (mjd_transitionFD's A).
    pub fn state(&self) -> DMatrixView<'_, f64> {
        let (start, len) = self.columns[Block::Q as usize];
        self.jacobian.columns(start, 2 * len)
    }

    /// d(q', v') / d tau: the tau columns, 2 nv x nv (mjd_transitionFD's B).
    pub fn tau(&self) -> DMatrixView<'_, f64> {
        let (start, len) = self.columns[Block::Tau as usize];
        self.jacobian.columns(start, len)
    }

    /// The column of state entry k (q's tangent k < nv, then v's), if the
    /// state was asked for.
    pub(super) fn state_column(&self, k: usize) -> Option<usize> {
        let (start, len) = self.columns[Block::Q as usize];
        (k < 2 * len).then_some(start + k)
    }

    /// The column of the flattened parameters' scalar k.
    pub(super) fn param_column(&self, k: usize) -> usize {
        self.columns[Block::Params as usize].0 + k
    }

    /// Without its tau columns (those a caller did not ask for).
    pub(super) fn without_tau(mut self) -> StepJacobians {
        let (start, len) = self.columns[Block::Tau as usize];
        if len == 0 {
            return self;
        }
        self.jacobian = self.jacobian.remove_columns(start, len);
        self.columns[Block::Tau as usize].1 = 0;
        let params = &mut self.columns[Block::Params as usize];
        params.0 -= len;
        self
    }

    /// The name of the first block with an entry that is not finite.
    fn not_finite(&self) -> Option<&'static str> {
        let blocks = [Block::Q, Block::V, Block::Tau, Block::Params];
        let named = |next_v: bool, names: [&'static str; 4]| {
            blocks
                .into_iter()
                .zip(names)
                .map(move |(b, name)| (next_v, b, name))
        };
        named(false, ["dq_dq", "dq_dv", "dq_dtau", "dq_dp"])
            .chain(named(true, ["dv_dq", "dv_dv", "dv_dtau", "dv_dp"]))
            .find(|&(next_v, b, _)| self.block(next_v, b).iter().any(|x| !x.is_finite()))
            .map(|(.., name)| name)
    }
}

/// Buffers reused across calls; sized for a model's nv (and resized by
/// [`step_jacobians`] if used with a model of another size).
#[derive(Clone, Debug)]
pub struct Workspace {
    pub(super) data: Data<f64>,
    sweep: Sweep,
    /// Scratch of length nv: inverse dynamics, spring position, implicit
    /// diagonal, a column of an inverse.
    pub(super) tau: Vec<f64>,
    pub(super) stretch: Vec<f64>,
    pub(super) extra: Vec<f64>,
    column: Vec<f64>,
    /// The constraint model's a - qdd (solver's minus implicit acceleration).
    y: Vec<f64>,
    /// The acceleration at the last point, and its derivatives: n x (columns),
    /// columns [q, v] if the state was asked for, then tau, then parameters.
    pub(super) qdd: Vec<f64>,
    pub(super) dqdd: DMatrix<f64>,
    /// dR/d(columns) before the solve, and M^-1 for wide solves ((M + E)^-1
    /// under the constraint model).
    r: DMatrix<f64>,
    inverse: DMatrix<f64>,
    /// The constraint model's gain G and an n x n scratch.
    gain: DMatrix<f64>,
    matrix: DMatrix<f64>,
    /// The constraint rows' derivative's buffers.
    rows: Scratch,
    /// The constraint model's d(M y) - dE qdd columns (implicit passive forces).
    dmy: DMatrix<f64>,
    /// What the window evaluation keeps between transitions.
    pub(super) window: WindowScratch,
    /// The constraint model's dual-number trees, per model.
    pub(super) duals: DualTrees,
}

impl Workspace {
    pub fn new(model: &Model) -> Self {
        let n = model.nv();
        Workspace {
            data: model.data(),
            sweep: Sweep::new(n),
            tau: vec![0.0; n],
            stretch: vec![0.0; n],
            extra: vec![0.0; n],
            column: vec![0.0; n],
            y: vec![0.0; n],
            qdd: vec![0.0; n],
            dqdd: DMatrix::zeros(n, 0),
            r: DMatrix::zeros(n, 0),
            inverse: DMatrix::zeros(n, n),
            dmy: DMatrix::zeros(n, n),
            gain: DMatrix::zeros(n, n),
            matrix: DMatrix::zeros(n, n),
            rows: Scratch::default(),
            window: WindowScratch::new(n),
            duals: DualTrees::default(),
        }
    }

    /// Places the mocap bodies for the next Jacobians (3 and 4 entries per
    /// mocap body; empty: the compiled poses, which a new workspace holds),
    /// in this workspace's f64 and dual-number data alike. The poses are
    /// constants of the Jacobians (no columns in them).
    pub fn set_mocap(
        &mut self,
        model: &Model,
        (pos, quat): (&[f64], &[f64]),
    ) -> Result<(), StepError> {
        self.size_for(model);
        set_mocap(model.tree(), &mut self.data, (pos, quat))?;
        self.duals.mocap = (model.stamp(), pos.to_vec(), quat.to_vec());
        Ok(())
    }

    /// Rebuilt for `model` if it was sized for another nv.
    pub(super) fn size_for(&mut self, model: &Model) {
        if self.qdd.len() != model.nv() {
            *self = Workspace::new(model);
        }
    }
}

/// One step of `model` from (q, v) under tau (ctrl = 0 and act = 0, as
/// [`crate::dynamics::step`]), with the Jacobians in `wrt`; the actuators'
/// forces and their partials in q and v are in when they act at zero
/// control ([`super::input_jacobians`] has the ctrl and act blocks).
pub fn step_jacobians(
    model: &Model,
    ws: &mut Workspace,
    (q, v, tau): (&[f64], &[f64], &[f64]),
    wrt: &Wrt,
) -> Result<StepJacobians, StepError> {
    if idle_without_inputs(&model.tree().actuators) {
        return applied_jacobians(model, ws, (q, v, tau), wrt);
    }
    super::input_jacobians(model, ws, (q, v, &[]), (&[], tau), wrt).map(|j| j.step)
}

/// The Jacobians of [`step_applied`]: under tau alone, the actuators left out.
pub(super) fn applied_jacobians(
    model: &Model,
    ws: &mut Workspace,
    (q, v, tau): (&[f64], &[f64], &[f64]),
    wrt: &Wrt,
) -> Result<StepJacobians, StepError> {
    let n = model.nv();
    let tree = model.tree();
    check_inputs(tree, (q, v, tau))?;
    ws.size_for(model);
    // A pair within reach without a collider: refused as the step refuses it.
    check_colliders(tree, &mut ws.data, (q, v))?;
    let (mut q_next, mut v_next) = (vec![0.0; model.nq()], vec![0.0; n]);
    // Under the constraint model the columns are analytic but the contact
    // parameters' (friction, solref, solimp, dry friction), which are dual
    // and interleaved back in order; where the zones defeat the analytic
    // derivative (an elliptic cone in its middle zone), every column is dual.
    // With ball or free joints the joint parameters' columns are dual too
    // (the analytic ones index a joint's dofs as one).
    let turning = !model.one_dof_joints();
    let is_dual = |p: Param| {
        tree.has_constraints() && p.is_constraint()
            || turning && !matches!(p, Param::Mass(_) | Param::Com(_) | Param::Inertia(_))
            || p.is_tendon()
    };
    let dual_params: Vec<Param> = wrt.params.iter().copied().filter(|p| is_dual(*p)).collect();
    let analytic_params: Vec<Param>;
    let analytic_wrt = if dual_params.is_empty() {
        *wrt
    } else {
        analytic_params = wrt
            .params
            .iter()
            .copied()
            .filter(|p| !is_dual(*p))
            .collect();
        Wrt {
            params: &analytic_params,
            ..*wrt
        }
    };
    let analytic = if !wrt.state && !wrt.control && analytic_wrt.params.is_empty()
        || super::dual_step(model)
    {
        None
    } else if let Some(mode) = euler(&model.opt) {
        accel_derivatives(model, ws, mode, (q, v, tau), &analytic_wrt).then(|| {
            let h = mode.1;
            integrate_euler(tree, h, (q, v, &ws.qdd), (&mut q_next, &mut v_next));
            let mut jacobian = DMatrix::zeros(2 * n, ws.dqdd.ncols());
            let targets = [jacobian.as_mut_slice()];
            let turns = rotations(tree, h, &v_next);
            let state = analytic_wrt.state;
            euler_columns(ws.dqdd.as_slice(), (h, n), (state, &turns), targets);
            jacobian
        })
    } else {
        let tableau = tableau(model.opt.integrator).expect("not Euler");
        let next = (&mut q_next[..], &mut v_next[..]);
        step_applied(tree, &mut ws.data, (q, v, tau), next)?;
        runge_kutta(model, ws, tableau, (q, v, tau), &analytic_wrt)
    };
    let jacobian = match analytic {
        Some(analytic) if !dual_params.is_empty() => {
            let params = Wrt {
                params: &dual_params,
                ..Wrt::default()
            };
            let dual = dual_columns(model, &mut ws.duals, (q, v, tau), &params)?;
            interleave(wrt.params, (&analytic, &stacked(dual)), is_dual)
        }
        Some(analytic) => analytic,
        None => {
            // The value from the plain step: the dual steps' agrees to rounding only
            // (nalgebra's products sum f64 and dual numbers in different orders).
            let next = (&mut q_next[..], &mut v_next[..]);
            step_applied(tree, &mut ws.data, (q, v, tau), next)?;
            stacked(dual_columns(model, &mut ws.duals, (q, v, tau), wrt)?)
        }
    };
    if !q_next.iter().chain(&v_next).all(|x| x.is_finite()) {
        return Err(StepError::Diverged);
    }
    StepJacobians::assemble((q_next, v_next), jacobian, wrt)
}

impl StepJacobians {
    /// The next state with its Jacobian, columns the blocks of `wrt` in
    /// order; an error naming the first block that is not finite.
    pub(super) fn assemble(
        (q_next, v_next): (Vec<f64>, Vec<f64>),
        jacobian: DMatrix<f64>,
        wrt: &Wrt,
    ) -> Result<StepJacobians, StepError> {
        let columns = block_columns(v_next.len(), jacobian.ncols(), wrt);
        let out = StepJacobians {
            q_next,
            v_next,
            jacobian,
            columns,
        };
        match out.not_finite() {
            Some(block) => Err(StepError::JacobianNotFinite { block }),
            None => Ok(out),
        }
    }
}

/// The rows d q' above d v', from their n-row halves.
fn stacked((dq, dv): (DMatrix<f64>, DMatrix<f64>)) -> DMatrix<f64> {
    let mut out = DMatrix::zeros(2 * dq.nrows(), dq.ncols());
    out.rows_mut(0, dq.nrows()).copy_from(&dq);
    out.rows_mut(dq.nrows(), dv.nrows()).copy_from(&dv);
    out
}

/// The analytic Jacobian with its parameter columns, the last ones, and the
/// dual ones (`is_dual` tells which a parameter is) in the order of `params`.
fn interleave(
    params: &[Param],
    (analytic, dual): (&DMatrix<f64>, &DMatrix<f64>),
    is_dual: impl Fn(Param) -> bool,
) -> DMatrix<f64> {
    let n_analytic: usize = params
        .iter()
        .filter(|p| !is_dual(**p))
        .map(|p| p.size())
        .sum();
    let leading = analytic.ncols() - n_analytic;
    let mut out = DMatrix::zeros(analytic.nrows(), analytic.ncols() + dual.ncols());
    out.columns_mut(0, leading)
        .copy_from(&analytic.columns(0, leading));
    let (mut a, mut d, mut col) = (leading, 0, leading);
    for &p in params {
        let (from, next) = if is_dual(p) {
            (dual, &mut d)
        } else {
            (analytic, &mut a)
        };
        for _ in 0..p.size() {
            out.set_column(col, &from.column(*next));
            (col, *next) = (col + 1, *next + 1);
        }
    }
    out
}

/// Columns of each state block (q or v) and of the tau block.
fn state_and_tau_columns(n: usize, wrt: &Wrt) -> (usize, usize) {
    (
        if wrt.state { n } else { 0 },
        if wrt.control { n } else { 0 },
    )
}

/// Column ranges of the q, v, tau and parameter blocks.
fn block_columns(n: usize, total: usize, wrt: &Wrt) -> [(usize, usize); 4] {
    let (n_state, n_tau) = state_and_tau_columns(n, wrt);
    let params = 2 * n_state + n_tau;
    [
        (0, n_state),
        (n_state, n_state),
        (2 * n_state, n_tau),
        (params, total - params),
    ]
}

/// The Euler step's Jacobian columns from d qdd's (n rows each, in the
/// order [q, v, tau, p] of `dqdd`), each into the next column of 2n rows of
/// the column-major `targets` in turn (d q' above d v'): v' = v + h qdd and
/// q' = q + h v' give d v' = h d qdd (+ I on v) and d q' = h d v' (+ h I
/// on v, I on q), the identity blocks where `state` (the first 2n columns
/// are the state's); on the `rotations` of ball and free joints, d q' as
/// module `tangent` states.
pub(super) fn euler_columns<const N: usize>(
    dqdd: &[f64],
    (h, n): (f64, usize),
    (state, rotations): (bool, &[Rotation]),
    targets: [&mut [f64]; N],
) {
    if n == 0 {
        return;
    }
    let targets = targets.into_iter().flat_map(|t| t.chunks_exact_mut(2 * n));
    for (column, (target, source)) in targets.zip(dqdd.chunks_exact(n)).enumerate() {
        let (dq, dv) = target.split_at_mut(n);
        for i in 0..n {
            dv[i] = source[i] * h;
            dq[i] = dv[i] * h;
        }
        if state && column < n {
            dq[column] += 1.0;
        } else if state && column < 2 * n {
            dv[column - n] += 1.0;
            dq[column - n] += h;
        }
        if !rotations.is_empty() {
            let q_column = (state && column < n).then_some(column);
            rotate_rows(rotations, q_column, (dq, dv));
        }
    }
}

/// An explicit Runge-Kutta step ([`crate::dynamics::integrator`]) on
/// x = (q, v), differentiated stage by stage: with x_1 = x, k_i = f(x_i),
/// x_i = x + sum_j h a_ij k_j and x' = x + sum_i h b_i k_i,
/// d k_i = F_x(x_i) d x_i + F_u(x_i) for the inputs u = (tau, p). Rows
/// (q', v'); columns (q, v) if asked for, then the inputs. Hinges and
/// slides only (q indexed as v).
fn runge_kutta(
    model: &Model,
    ws: &mut Workspace,
    tableau: &Tableau,
    (q, v, tau): (&[f64], &[f64], &[f64]),
    wrt: &Wrt,
) -> Option<DMatrix<f64>> {
    let n = model.nv();
    let h = model.opt.timestep;
    let full = Wrt {
        state: true,
        ..*wrt
    };
    let n_state = if wrt.state { 2 * n } else { 0 };
    let mut n_cols = 0;
    // d x_i / d(columns): starts as the identity on the state columns.
    let mut dx_stage = DMatrix::zeros(2 * n, 0);
    let mut total = DMatrix::zeros(2 * n, 0);
    let (mut qs, mut vs) = (q.to_vec(), v.to_vec());
    // Per stage: d k, v (the rate of q) and qdd.
    let (mut dk, mut rates, mut qdds) = (vec![], vec![], vec![]);
    for k in 0..tableau.stages() {
        let mode = (PassiveMode::Explicit, h);
        if !accel_derivatives(model, ws, mode, (&qs, &vs, tau), &full) {
            return None;
        }
        let (d_state, d_inputs) = (
            ws.dqdd.columns(0, 2 * n),
            ws.dqdd.columns(2 * n, ws.dqdd.ncols() - 2 * n),
        );
        if k == 0 {
            n_cols = n_state + d_inputs.ncols();
            dx_stage = DMatrix::zeros(2 * n, n_cols);
            for i in 0..n_state {
                dx_stage[(i, i)] = 1.0;
            }
            total = dx_stage.clone();
        }
        // d k = [d v_stage; d qdd], with d qdd = Qx d x_stage + (direct input terms).
        let mut dk_stage = DMatrix::zeros(2 * n, n_cols);
        dk_stage.rows_mut(0, n).copy_from(&dx_stage.rows(n, n));
        let mut dqdd = d_state * &dx_stage;
        let mut inputs = dqdd.columns_mut(n_state, n_cols - n_state);
        inputs += d_inputs;
        dk_stage.rows_mut(n, n).copy_from(&dqdd);
        if let Some(w) = tableau.b[k].times(h) {
            total += &dk_stage * w;
        }
        dk.push(dk_stage);
        rates.push(vs.clone());
        qdds.push(ws.qdd.clone());
        if k + 1 < tableau.stages() {
            let terms = || tableau.stage_terms(k + 1, h);
            let mut next = DMatrix::zeros(2 * n, n_cols);
            for (m, (j, a)) in terms().enumerate() {
                if m == 0 {
                    next = &dk[j] * a;
                } else {
                    next += &dk[j] * a;
                }
            }
            for i in 0..n_state {
                next[(i, i)] += 1.0;
            }
            dx_stage = next;
            for i in 0..n {
                qs[i] = q[i] + weighted_sum(terms(), &rates, i);
                vs[i] = v[i] + weighted_sum(terms(), &qdds, i);
            }
        }
    }
    Some(total)
}

/// The acceleration at (q, v, tau) under (mode, h) into `ws.qdd`, and its
/// derivatives -M^-1 dR/d(columns) into `ws.dqdd`; under the constraint
/// model with rows at the point, by [`constrained_derivatives`]. False
/// (nothing written to `ws.dqdd`) where those do not apply.
pub(super) fn accel_derivatives(
    model: &Model,
    ws: &mut Workspace,
    (mode, h): (PassiveMode, f64),
    (q, v, tau): (&[f64], &[f64], &[f64]),
    wrt: &Wrt,
) -> bool {
    let n = model.nv();
    let tree = model.tree();
    acceleration(tree, &mut ws.data, (mode, h), (q, v, tau), &mut ws.qdd);
    implicit_terms(tree, (mode, h), (q, v), &mut ws.stretch, &mut ws.extra);
    let rotations = !model.one_dof_joints();
    if rotations && (ws.data.constrained.is_some() || !ws.data.contacts.is_empty()) {
        // The rows' and the soft contacts' partials index q as v.
        return false;
    }
    if let Some(c) = ws.data.constrained.take() {
        let done = differentiable(&c) && constrained_derivatives(model, ws, (mode, h), v, &c, wrt);
        ws.data.constrained = Some(c);
        return done;
    }
    // M + diag(extra), factored once along the tree for every column.
    crba(tree, &mut ws.data, q);
    for i in 0..n {
        ws.data.mass_matrix[(i, i)] += ws.extra[i];
    }
    ltdl_factor(tree, &mut ws.data.mass_matrix);
    // Velocities, accelerations and forces at the solution, for both
    // blocks; the world frames RNEA's derivatives read.
    rnea(tree, &mut ws.data, q, v, &ws.qdd, &mut ws.tau);
    world_frames(tree, &mut ws.data, v);

    let (n_state, n_tau) = state_and_tau_columns(n, wrt);
    let n_p: usize = wrt.params.iter().map(|p| p.size()).sum();
    let columns = 2 * n_state + n_tau + n_p;
    reset(&mut ws.r, n, columns);
    if wrt.state {
        let (r_q, r_v) = ws.r.as_mut_slice()[..2 * n * n].split_at_mut(n * n);
        let at = (v, &ws.qdd[..]);
        rnea_derivatives(tree, &ws.data, &mut ws.sweep, at, (r_q, r_v), None);
        add_passive_partials(model, (mode, h), &ws.stretch, (r_q, r_v));
    }
    for i in 0..n_tau {
        ws.r[(i, 2 * n_state + i)] = -1.0;
    }
    let mut col = 2 * n_state + n_tau;
    let mut contact_columns = vec![];
    for &param in wrt.params {
        if param.is_contact() {
            contact_columns.push((param, col));
        }
        for component in 0..param.size() {
            let point = (&ws.stretch[..], v, &ws.qdd[..]);
            residual_derivative(
                model,
                &ws.data,
                (mode, h),
                point,
                (param, component),
                &mut ws.tau,
            );
            ws.r.column_mut(col).copy_from_slice(&ws.tau);
            col += 1;
        }
    }
    let soft = Columns {
        state: wrt.state,
        v_start: n,
        params: &contact_columns,
    };
    subtract_soft_derivatives(model, &ws.data, (q, v), &soft, &mut ws.r);
    // dqdd = -M^-1 R: column by column when R is narrow, else through M^-1.
    reset(&mut ws.dqdd, n, columns);
    if columns <= n {
        ltdl_solve_columns(tree, &ws.data.mass_matrix, &mut ws.r);
        ws.dqdd.copy_from(&ws.r);
        ws.dqdd.neg_mut();
    } else {
        ws.inverse.fill_with_identity();
        ltdl_solve_columns(tree, &ws.data.mass_matrix, &mut ws.inverse);
        ws.dqdd.gemm(-1.0, &ws.inverse, &ws.r, 0.0);
    }
    true
}

/// dR/dq and dR/dv of the passive force -D v - K stretch,
/// stretch = q - springref (+ h v for DART), into `r_q` and `r_v` (n x n
/// column-major); a rotation's spring as module `tangent` states (`stretch`
/// its r: DART's springs on rotations go through dual numbers).
fn add_passive_partials(
    model: &Model,
    (mode, h): (PassiveMode, f64),
    stretch: &[f64],
    (r_q, r_v): (&mut [f64], &mut [f64]),
) {
    let tree = model.tree();
    let n = model.nv();
    let spring_v = ImplicitPassive::new(mode, h).spring_step();
    for i in 0..n {
        if !is_rotation(tree, i) {
            r_q[i * n + i] += tree.stiffness[i];
        }
        r_v[i * n + i] += tree.damping[i] + spring_v * tree.stiffness[i];
    }
    add_rotation_springs(tree, stretch, r_q);
}

/// The derivatives of the constraint model's acceleration in the state and
/// tau (`wrt` asks for no parameters), its rows and solution `c` at the
/// point (`ws.data` as the step left it: M, world frames). The solver's
/// acceleration a: da = -H^-1 dg ([`super::constraint`]); MuJoCo's implicit
/// passive solve (M + E) qdd = M a (E = `ws.extra`) then gives
/// (M + E) dqdd = M da + d(M y) with y = a - qdd, so
/// dqdd = -G dg + (M + E)^-1 d(M y), G = (M + E)^-1 M H^-1 = H^-1 - (M + E)^-1 E H^-1
/// (G = H^-1 without implicit passive forces); dg/dtau = -I.
/// False where H or M + E is not numerically positive definite (extreme
/// inputs): the dual numbers take over there.
fn constrained_derivatives(
    model: &Model,
    ws: &mut Workspace,
    (mode, h): (PassiveMode, f64),
    v: &[f64],
    c: &Constrained<f64>,
    wrt: &Wrt,
) -> bool {
    let n = model.nv();
    let tree = model.tree();
    let a = &c.solution.qacc;
    let implicit = ImplicitPassive::new(mode, h).acts();
    // G into ws.gain (H^-1 from the solver's factor of H, when it is on the
    // final zones); (M + E)^-1 into ws.inverse (from the step's factor).
    let factor = ws.matrix.as_mut_slice();
    if c.solution.factored {
        factor.copy_from_slice(&c.solution.hessian);
    } else {
        factor.copy_from_slice(ws.data.mass_matrix.as_slice());
        add_quadratic_rows(factor, &c.rows, &c.solution.zone);
        if !cholesky::factor(factor, n) {
            return false;
        }
    }
    cholesky::inverse(factor, n, ws.gain.as_mut_slice());
    if implicit {
        // (M + E)^-1 from the step's factor of M + E.
        let factored = ws.data.factored_mass();
        if !ltdl_inverse(factored, &mut ws.column, ws.inverse.as_mut_slice()) {
            return false;
        }
        let columns = ws.matrix.as_mut_slice().chunks_exact_mut(n);
        for (out, hi) in columns.zip(ws.gain.as_slice().chunks_exact(n)) {
            for ((x, e), h) in out.iter_mut().zip(&ws.extra).zip(hi) {
                *x = e * h;
            }
        }
        gemm(
            ws.gain.columns_mut(0, n),
            -1.0,
            &ws.inverse,
            ws.matrix.columns(0, n),
            1.0,
        );
    }
    ws.y.clear();
    ws.y.extend(a.iter().zip(&ws.qdd).map(|(a, b)| a - b));
    let y = std::mem::take(&mut ws.y);
    let (n_state, n_tau) = state_and_tau_columns(n, wrt);
    let n_p: usize = wrt.params.iter().map(|p| p.size()).sum();
    let columns = 2 * n_state + n_tau + n_p;
    reset(&mut ws.r, n, columns);
    reset(&mut ws.dqdd, n, columns);
    if wrt.state {
        // dg/d(q, v), and d(M y)/dq for the implicit passive forces.
        let (r_q, r_v) = ws.r.as_mut_slice()[..2 * n * n].split_at_mut(n * n);
        reset(&mut ws.dmy, n, n);
        let mass = implicit.then(|| (&y[..], ws.dmy.as_mut_slice()));
        rnea_derivatives(tree, &ws.data, &mut ws.sweep, (v, a), (r_q, r_v), mass);
        add_passive_partials(model, (mode, h), &ws.stretch, (r_q, r_v));
        add_row_partials(tree, &ws.data, (v, a), c, (r_q, r_v), &mut ws.rows);
        let state = ws.dqdd.columns_mut(0, 2 * n);
        gemm(state, -1.0, &ws.gain, ws.r.columns(0, 2 * n), 0.0);
        if implicit {
            let q_columns = ws.dqdd.columns_mut(0, n);
            gemm(q_columns, 1.0, &ws.inverse, ws.dmy.columns(0, n), 1.0);
        }
    }
    if wrt.control {
        ws.dqdd.columns_mut(2 * n_state, n).copy_from(&ws.gain);
    }
    if n_p > 0 {
        // The parameters' derivatives read RNEA at a (node frames).
        rnea_with_transforms(tree, &mut ws.data, v, a, &mut ws.tau);
        parameter_derivatives(model, ws, (mode, h), (v, &y), c, wrt);
        let start = columns - n_p;
        let p_columns = ws.dqdd.columns_mut(start, n_p);
        gemm(p_columns, -1.0, &ws.gain, ws.r.columns(start, n_p), 0.0);
        if implicit {
            let p_columns = ws.dqdd.columns_mut(start, n_p);
            gemm(p_columns, 1.0, &ws.inverse, ws.dmy.columns(0, n_p), 1.0);
        }
    }
    ws.y = y;
    true
}

/// The parameters' columns of dg into the last columns of `ws.r`: RNEA's
/// body force or the joint's entry at a (the solver's passive forces are
/// explicit), and the rows' R through invweight0; and, for the implicit
/// passive forces, dM/dp y - dE/dp qdd into `ws.dmy` (`ws.data` holds RNEA
/// at the solver's acceleration a).
fn parameter_derivatives(
    model: &Model,
    ws: &mut Workspace,
    (mode, h): (PassiveMode, f64),
    (v, y): (&[f64], &[f64]),
    c: &Constrained<f64>,
    wrt: &Wrt,
) {
    let tree = model.tree();
    let n = model.nv();
    let a = &c.solution.qacc;
    let param_columns: Vec<(Param, usize)> = wrt
        .params
        .iter()
        .flat_map(|p| (0..p.size()).map(move |k| (*p, k)))
        .collect();
    let start = ws.r.ncols() - param_columns.len();
    for (k, &(param, component)) in param_columns.iter().enumerate() {
        let point = (&ws.stretch[..], v, &a[..]);
        let explicit = (PassiveMode::Explicit, h);
        residual_derivative(
            model,
            &ws.data,
            explicit,
            point,
            (param, component),
            &mut ws.tau,
        );
        if matches!(
            param,
            Param::Mass(_) | Param::Com(_) | Param::Inertia(_) | Param::Armature(_)
        ) {
            let (d_body, d_dof) = ws.duals.invweight_slopes(model, (param, component));
            add_invweight_partials(tree, c, (d_body, d_dof), &mut ws.tau);
        }
        ws.r.column_mut(start + k).copy_from_slice(&ws.tau);
    }
    let implicit = ImplicitPassive::new(mode, h);
    if !implicit.acts() {
        return;
    }
    reset(&mut ws.dmy, n, param_columns.len());
    ws.sweep.mass_product(tree, &ws.data, y);
    for (k, &(param, component)) in param_columns.iter().enumerate() {
        ws.tau.fill(0.0);
        let accelerations = ws.sweep.mass_product_accelerations();
        let product = (accelerations, y);
        mass_product_derivative(
            model,
            &ws.data.x_up,
            product,
            (param, component),
            &mut ws.tau,
        );
        if let Some((i, de)) = implicit.partial(param) {
            ws.tau[i] -= de * ws.qdd[i];
        }
        ws.dmy.column_mut(k).copy_from_slice(&ws.tau);
    }
}

/// Zeros `m`, reshaped to rows x cols (allocating only when the shape changes).
fn reset(m: &mut DMatrix<f64>, rows: usize, cols: usize) {
    if m.shape() == (rows, cols) {
        m.as_mut_slice().fill(0.0);
    } else {
        *m = DMatrix::zeros(rows, cols);
    }
}
