//! Step Jacobians: d(q', v') / d(q, v), d(q', v') / d tau and d(q', v') / d p:
//! analytic through the articulated dynamics, the smooth model and the
//! constraint model's solver ([`super::implicit`]); by dual numbers for the
//! constraint model's contact parameters ([`super::constrained`]).

use nalgebra::{DMatrix, DMatrixView, DMatrixViewMut};

use super::constrained::{dual_columns, DualTrees};
use super::implicit::{add_invweight_partials, add_row_partials, differentiable, Scratch};
use super::params::{implicit_diagonal_derivative, mass_product_derivative, residual_derivative};
use super::rnea::{rnea_derivatives, Sweep};
use super::soft::{subtract_soft_derivatives, Columns};
use super::window::WindowScratch;
use crate::dynamics::cholesky;
use crate::dynamics::constraint::world_frames;
use crate::dynamics::solver::add_quadratic_rows;
use crate::dynamics::{
    acceleration, check_inputs, crba, implicit_terms, integrate_euler, ltdl_factor, ltdl_inverse,
    ltdl_solve_columns, rnea, rnea_with_transforms, step,
};
use crate::dynamics::{Constrained, Data, StepError};
use crate::model::{Integrator, Param, PassiveMode};
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

/// The next state and the requested Jacobian blocks (n x n, n x n and
/// n x (total length of the parameters)); blocks not requested have no columns.
#[derive(Clone, Debug, PartialEq)]
pub struct StepJacobians {
    pub q_next: Vec<f64>,
    pub v_next: Vec<f64>,
    pub dq_dq: DMatrix<f64>,
    pub dq_dv: DMatrix<f64>,
    pub dv_dq: DMatrix<f64>,
    pub dv_dv: DMatrix<f64>,
    pub dq_dtau: DMatrix<f64>,
    pub dv_dtau: DMatrix<f64>,
    pub dq_dp: DMatrix<f64>,
    pub dv_dp: DMatrix<f64>,
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
    duals: DualTrees,
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

    /// Rebuilt for `model` if it was sized for another nv.
    pub(super) fn size_for(&mut self, model: &Model) {
        if self.qdd.len() != model.nv() {
            *self = Workspace::new(model);
        }
    }
}

/// One step of `model` from (q, v) under tau, with the Jacobians in `wrt`.
pub fn step_jacobians(
    model: &Model,
    ws: &mut Workspace,
    (q, v, tau): (&[f64], &[f64], &[f64]),
    wrt: &Wrt,
) -> Result<StepJacobians, StepError> {
    let n = model.nv();
    let tree = model.tree();
    check_inputs(tree, (q, v, tau))?;
    ws.size_for(model);
    let (mut q_next, mut v_next) = (vec![0.0; model.nq()], vec![0.0; n]);
    // Under the constraint model the columns are analytic but the contact
    // parameters' (friction, solref, solimp, dry friction), which are dual
    // and interleaved back in order; where the zones defeat the analytic
    // derivative (an elliptic cone in its middle zone), every column is dual.
    let is_dual = |p: Param| tree.has_constraints() && p.is_constraint();
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
    let analytic = match model.opt.integrator {
        _ if !wrt.state && !wrt.control && analytic_wrt.params.is_empty() => None,
        _ if super::dual_only(model) => None,
        Integrator::Euler => {
            let h = model.opt.timestep;
            let mode = (model.opt.passive, h);
            accel_derivatives(model, ws, mode, (q, v, tau), &analytic_wrt).then(|| {
                integrate_euler(tree, h, (q, v, &ws.qdd), (&mut q_next, &mut v_next));
                euler_blocks(&ws.dqdd, h, n, &analytic_wrt)
            })
        }
        Integrator::Rk4 => {
            let next = (&mut q_next[..], &mut v_next[..]);
            step(tree, &model.opt, &mut ws.data, (q, v, tau), next)?;
            rk4(model, ws, (q, v, tau), &analytic_wrt).map(|(dq, dv)| {
                let (dq_dq, dq_dv, dq_dtau, dq_dp) = split(&dq, n, &analytic_wrt);
                let (dv_dq, dv_dv, dv_dtau, dv_dp) = split(&dv, n, &analytic_wrt);
                [dq_dq, dq_dv, dq_dtau, dq_dp, dv_dq, dv_dv, dv_dtau, dv_dp]
            })
        }
    };
    let blocks = match analytic {
        Some(mut blocks) if !dual_params.is_empty() => {
            let params = Wrt {
                params: &dual_params,
                ..Wrt::default()
            };
            let (dq, dv) = dual_columns(model, &mut ws.duals, (q, v, tau), &params)?;
            blocks[3] = interleave(wrt.params, (&blocks[3], &dq), is_dual);
            blocks[7] = interleave(wrt.params, (&blocks[7], &dv), is_dual);
            blocks
        }
        Some(blocks) => blocks,
        None => {
            // The value from the plain step: the dual steps' agrees to rounding only
            // (nalgebra's products sum f64 and dual numbers in different orders).
            let next = (&mut q_next[..], &mut v_next[..]);
            step(tree, &model.opt, &mut ws.data, (q, v, tau), next)?;
            let (dq, dv) = dual_columns(model, &mut ws.duals, (q, v, tau), wrt)?;
            let (dq_dq, dq_dv, dq_dtau, dq_dp) = split(&dq, n, wrt);
            let (dv_dq, dv_dv, dv_dtau, dv_dp) = split(&dv, n, wrt);
            [dq_dq, dq_dv, dq_dtau, dq_dp, dv_dq, dv_dv, dv_dtau, dv_dp]
        }
    };
    if !q_next.iter().chain(&v_next).all(|x| x.is_finite()) {
        return Err(StepError::Diverged);
    }
    const NAMES: [&str; 8] = [
        "dq_dq", "dq_dv", "dq_dtau", "dq_dp", "dv_dq", "dv_dv", "dv_dtau", "dv_dp",
    ];
    let finite = |m: &DMatrix<f64>| m.as_slice().iter().all(|x| x.is_finite());
    if let Some(k) = blocks.iter().position(|m| !finite(m)) {
        return Err(StepError::JacobianNotFinite { block: NAMES[k] });
    }
    let [dq_dq, dq_dv, dq_dtau, dq_dp, dv_dq, dv_dv, dv_dtau, dv_dp] = blocks;
    Ok(StepJacobians {
        q_next,
        v_next,
        dq_dq,
        dq_dv,
        dv_dq,
        dv_dv,
        dq_dtau,
        dv_dtau,
        dq_dp,
        dv_dp,
    })
}

/// The parameter columns in the order of `params` from the columns of the
/// analytic ones and of the dual ones (`is_dual` tells which a parameter is).
fn interleave(
    params: &[Param],
    (analytic, dual): (&DMatrix<f64>, &DMatrix<f64>),
    is_dual: impl Fn(Param) -> bool,
) -> DMatrix<f64> {
    let mut out = DMatrix::zeros(analytic.nrows(), analytic.ncols() + dual.ncols());
    let (mut a, mut d, mut col) = (0, 0, 0);
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

/// Splits [q, v, tau, p] columns into their blocks.
fn split(
    m: &DMatrix<f64>,
    n: usize,
    wrt: &Wrt,
) -> (DMatrix<f64>, DMatrix<f64>, DMatrix<f64>, DMatrix<f64>) {
    let [a, b, c, d] =
        block_columns(n, m.ncols(), wrt).map(|(start, len)| m.columns(start, len).into_owned());
    (a, b, c, d)
}

/// Semi-implicit Euler: v' = v + h qdd, q' = q + h v', so d v' = h d qdd
/// (+ I on v) and d q' = h d v' (+ I on q). Returns the eight blocks
/// [dq_dq, dq_dv, dq_dtau, dq_dp, dv_dq, dv_dv, dv_dtau, dv_dp].
fn euler_blocks(dqdd: &DMatrix<f64>, h: f64, n: usize, wrt: &Wrt) -> [DMatrix<f64>; 8] {
    // Scaled over contiguous slices: nalgebra's scalar products of views
    // walk them entry by entry.
    let scaled =
        |m: &[f64], len: usize, by: f64| DMatrix::from_iterator(n, len, m.iter().map(|x| x * by));
    let columns = block_columns(n, dqdd.ncols(), wrt);
    let dv =
        columns.map(|(start, len)| scaled(&dqdd.as_slice()[start * n..(start + len) * n], len, h));
    let [mut dq_dq, mut dq_dv, dq_dtau, dq_dp] =
        dv.each_ref().map(|m| scaled(m.as_slice(), m.ncols(), h));
    let [dv_dq, mut dv_dv, dv_dtau, dv_dp] = dv;
    if wrt.state {
        for i in 0..n {
            dv_dv[(i, i)] += 1.0;
            dq_dv[(i, i)] += h;
            dq_dq[(i, i)] += 1.0;
        }
    }
    [dq_dq, dq_dv, dq_dtau, dq_dp, dv_dq, dv_dv, dv_dtau, dv_dp]
}

/// Classic RK4 on x = (q, v), differentiated stage by stage: with x_1 = x,
/// k_i = f(x_i), x_{i+1} = x + c_i k_i and x' = x + sum w_i k_i,
/// d k_i = F_x(x_i) d x_i + F_u(x_i) for the inputs u = (tau, p).
fn rk4(
    model: &Model,
    ws: &mut Workspace,
    (q, v, tau): (&[f64], &[f64], &[f64]),
    wrt: &Wrt,
) -> Option<(DMatrix<f64>, DMatrix<f64>)> {
    let n = model.nv();
    let h = model.opt.timestep;
    let full = Wrt {
        state: true,
        ..*wrt
    };
    // Columns of the result: (q, v) if asked for, then the inputs.
    let n_state = if wrt.state { 2 * n } else { 0 };
    let mut n_cols = 0;
    let c = [h / 2.0, h / 2.0, h];
    let w = [h / 6.0, h / 3.0, h / 3.0, h / 6.0];
    // d x_i / d(columns): starts as the identity on the state columns.
    let mut dx_stage = DMatrix::zeros(2 * n, 0);
    let mut total = DMatrix::zeros(2 * n, 0);
    let (mut qs, mut vs) = (q.to_vec(), v.to_vec());
    for k in 0..4 {
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
        let mut dk = DMatrix::zeros(2 * n, n_cols);
        dk.rows_mut(0, n).copy_from(&dx_stage.rows(n, n));
        let mut dqdd = d_state * &dx_stage;
        let mut inputs = dqdd.columns_mut(n_state, n_cols - n_state);
        inputs += d_inputs;
        dk.rows_mut(n, n).copy_from(&dqdd);
        total += &dk * w[k];
        if k < 3 {
            let mut next = &dk * c[k];
            for i in 0..n_state {
                next[(i, i)] += 1.0;
            }
            dx_stage = next;
            for i in 0..n {
                qs[i] = q[i] + c[k] * vs[i];
                vs[i] = v[i] + c[k] * ws.qdd[i];
            }
        }
    }
    Some((total.rows(0, n).into_owned(), total.rows(n, n).into_owned()))
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
        add_passive_partials(model, (mode, h), (r_q, r_v));
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
/// stretch = q - springref (+ h v for DART), into `r_q` and `r_v` (n x n column-major).
fn add_passive_partials(
    model: &Model,
    (mode, h): (PassiveMode, f64),
    (r_q, r_v): (&mut [f64], &mut [f64]),
) {
    let tree = model.tree();
    let n = model.nv();
    let spring_v = if mode == PassiveMode::ImplicitDampingStiffness {
        h
    } else {
        0.0
    };
    for i in 0..n {
        r_q[i * n + i] += tree.stiffness[i];
        r_v[i * n + i] += tree.damping[i] + spring_v * tree.stiffness[i];
    }
}

/// The derivatives of the constraint model's acceleration in the state and
/// tau (`wrt` asks for no parameters), its rows and solution `c` at the
/// point (`ws.data` as the step left it: M, world frames). The solver's
/// acceleration a: da = -H^-1 dg ([`super::implicit`]); MuJoCo's implicit
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
    let implicit = mode != PassiveMode::Explicit;
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
        product(
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
        add_passive_partials(model, (mode, h), (r_q, r_v));
        add_row_partials(tree, &ws.data, (v, a), c, (r_q, r_v), &mut ws.rows);
        let state = ws.dqdd.columns_mut(0, 2 * n);
        product(state, -1.0, &ws.gain, ws.r.columns(0, 2 * n), 0.0);
        if implicit {
            let q_columns = ws.dqdd.columns_mut(0, n);
            product(q_columns, 1.0, &ws.inverse, ws.dmy.columns(0, n), 1.0);
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
        product(p_columns, -1.0, &ws.gain, ws.r.columns(start, n_p), 0.0);
        if implicit {
            let p_columns = ws.dqdd.columns_mut(start, n_p);
            product(p_columns, 1.0, &ws.inverse, ws.dmy.columns(0, n_p), 1.0);
        }
    }
    ws.y = y;
    true
}

/// out = alpha a b + beta out, column by column over a's contiguous
/// columns, skipping b's zeros (nalgebra's gemm goes through
/// matrixmultiply, whose packing allocates: slower on matrices this small).
/// Each output entry is summed from beta out over a's columns in order, in
/// blocks of `BLOCK` rows held in registers, two blocks per pass over b;
/// the last block overlaps the one before it when `BLOCK` does not divide
/// the rows (an entry's sum is the same in either), and both are formed
/// in one pass, from the entries before either is written.
fn product(
    mut out: DMatrixViewMut<f64>,
    alpha: f64,
    a: &DMatrix<f64>,
    b: DMatrixView<f64>,
    beta: f64,
) {
    let n = a.nrows();
    let a = a.as_slice();
    let terms = (alpha, a, beta);
    for (mut column, b) in out.column_iter_mut().zip(b.column_iter()) {
        let (column, b) = (column.as_mut_slice(), b.as_slice());
        if n < BLOCK {
            for (i, x) in column.iter_mut().enumerate() {
                let mut sum = scaled(*x, beta);
                for (k, &bk) in b.iter().enumerate().filter(|(_, bk)| **bk != 0.0) {
                    sum += alpha * bk * a[k * n + i];
                }
                *x = sum;
            }
            continue;
        }
        let start = |block: usize| (block * BLOCK).min(n - BLOCK);
        let mut blocks = n.div_ceil(BLOCK);
        while blocks >= 2 {
            let pair = [start(blocks - 2), start(blocks - 1)];
            let sums = block_product(column, terms, b, pair);
            for (s, sum) in pair.into_iter().zip(sums) {
                column[s..s + BLOCK].copy_from_slice(&sum);
            }
            blocks -= 2;
        }
        if blocks == 1 {
            let [sum] = block_product(column, terms, b, [0]);
            column[..BLOCK].copy_from_slice(&sum);
        }
    }
}

/// Rows per block of [`product`].
const BLOCK: usize = 8;

/// beta x, with beta = 0 giving 0 and beta = 1 giving x exactly.
fn scaled(x: f64, beta: f64) -> f64 {
    if beta == 0.0 {
        0.0
    } else if beta == 1.0 {
        x
    } else {
        x * beta
    }
}

/// The blocks of rows start..start + BLOCK (for each start) of
/// alpha a b + beta out, for one column b of length n and its output
/// column `out`.
#[inline(always)]
fn block_product<const BLOCKS: usize>(
    out: &[f64],
    (alpha, a, beta): (f64, &[f64], f64),
    b: &[f64],
    starts: [usize; BLOCKS],
) -> [[f64; BLOCK]; BLOCKS] {
    let n = b.len();
    let mut sums = starts.map(|s| std::array::from_fn(|r| scaled(out[s + r], beta)));
    for (k, &bk) in b.iter().enumerate() {
        if bk != 0.0 {
            let s = alpha * bk;
            for (sum, start) in sums.iter_mut().zip(starts) {
                let a = &a[k * n + start..k * n + start + BLOCK];
                for r in 0..BLOCK {
                    sum[r] += s * a[r];
                }
            }
        }
    }
    sums
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
    if mode == PassiveMode::Explicit {
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
        if let Some((i, de)) = implicit_diagonal_derivative((mode, h), param) {
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

#[cfg(test)]
mod tests {
    use super::*;

    /// The blocked product equals the plain sum in the same order, bit for
    /// bit, for sizes below, at and between multiples of the block, with
    /// zeros in b and every kind of beta.
    #[test]
    fn product_sums_in_order() {
        for n in [1, 3, 7, 8, 9, 16, 17, 20] {
            let a = DMatrix::from_fn(n, n, |i, j| ((3 * i + 5 * j) % 7) as f64 / 7.0 - 0.3);
            let b = DMatrix::from_fn(n, 3, |i, j| {
                if (i + j) % 3 == 0 {
                    0.0
                } else {
                    0.1 * (i as f64 - j as f64).sin()
                }
            });
            let start = DMatrix::from_fn(n, 3, |i, j| (i + 2 * j) as f64 / 5.0);
            for beta in [0.0, 1.0, -0.5] {
                let mut out = start.clone();
                product(out.columns_mut(0, 3), -1.5, &a, b.columns(0, 3), beta);
                let expected = DMatrix::from_fn(n, 3, |i, j| {
                    let mut sum = scaled(start[(i, j)], beta);
                    for k in (0..n).filter(|&k| b[(k, j)] != 0.0) {
                        sum += -1.5 * b[(k, j)] * a[(i, k)];
                    }
                    sum
                });
                assert_eq!(out, expected, "n = {n}, beta = {beta}");
            }
        }
    }
}
