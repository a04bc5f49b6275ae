//! Step Jacobians: d(q', v') / d(q, v), d(q', v') / d tau and d(q', v') / d p.

use nalgebra::DMatrix;

use super::params::residual_derivative;
use super::rnea::{rnea_derivatives, Sweep};
use crate::dynamics::{
    acceleration, check_inputs, crba, implicit_terms, integrate_euler, ltdl_factor,
    ltdl_solve_columns, rnea, step,
};
use crate::dynamics::{Data, StepError, Tree};
use crate::model::{Integrator, Model, Param, PassiveMode};

/// Which Jacobian blocks to compute; only these directions are seeded.
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

/// Buffers reused across calls for one model's size.
#[derive(Clone, Debug)]
pub struct Workspace {
    data: Data<f64>,
    sweep: Sweep,
    /// Scratch of length nv: inverse dynamics, spring position, implicit diagonal.
    tau: Vec<f64>,
    q_spring: Vec<f64>,
    extra: Vec<f64>,
}

impl Workspace {
    pub fn new(model: &Model) -> Self {
        let n = model.nv();
        Workspace {
            data: model.data(),
            sweep: Sweep::new(n),
            tau: vec![0.0; n],
            q_spring: vec![0.0; n],
            extra: vec![0.0; n],
        }
    }
}

/// Derivatives of the acceleration at one point: columns for (q, v) if the
/// state was asked for, then tau, then the parameter scalars.
struct AccelDerivatives {
    qdd: Vec<f64>,
    /// d qdd / d(q, v): n x 2n (or n x 0).
    state: DMatrix<f64>,
    /// d qdd / d(tau, p): n x (n + np) (tau columns only if asked for).
    inputs: DMatrix<f64>,
}

/// One step of `model` from (q, v) under tau, with the Jacobians in `wrt`.
pub fn step_jacobians(
    model: &Model,
    ws: &mut Workspace,
    (q, v, tau): (&[f64], &[f64], &[f64]),
    wrt: &Wrt,
) -> Result<StepJacobians, StepError> {
    let n = model.nv();
    let (mut q_next, mut v_next) = (vec![0.0; n], vec![0.0; n]);
    let (dq, dv) = match model.opt.integrator {
        Integrator::Euler => {
            check_inputs(n, (q, v, tau))?;
            let (qdd, dq, dv) = euler(model, ws, (q, v, tau), wrt);
            integrate_euler(model.opt.timestep, (q, v, &qdd), (&mut q_next, &mut v_next));
            (dq, dv)
        }
        Integrator::Rk4 => {
            let next = (&mut q_next[..], &mut v_next[..]);
            step(model.tree(), &model.opt, &mut ws.data, (q, v, tau), next)?;
            rk4(model, ws, (q, v, tau), wrt)
        }
    };
    if !q_next.iter().chain(&v_next).all(|x| x.is_finite()) {
        return Err(StepError::Diverged);
    }
    let n_state = if wrt.state { n } else { 0 };
    let n_tau = if wrt.control { n } else { 0 };
    let split = |m: &DMatrix<f64>| {
        (
            m.columns(0, n_state).into_owned(),
            m.columns(n_state, n_state).into_owned(),
            m.columns(2 * n_state, n_tau).into_owned(),
            m.columns(2 * n_state + n_tau, m.ncols() - 2 * n_state - n_tau)
                .into_owned(),
        )
    };
    let (dq_dq, dq_dv, dq_dtau, dq_dp) = split(&dq);
    let (dv_dq, dv_dv, dv_dtau, dv_dp) = split(&dv);
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

/// Semi-implicit Euler: v' = v + h qdd, q' = q + h v'. Returns qdd, d q' and
/// d v' with columns [q, v (if state), tau (if control), p].
fn euler(
    model: &Model,
    ws: &mut Workspace,
    x: (&[f64], &[f64], &[f64]),
    wrt: &Wrt,
) -> (Vec<f64>, DMatrix<f64>, DMatrix<f64>) {
    let h = model.opt.timestep;
    let d = accel_derivatives(model, ws, (model.opt.passive, h), x, wrt);
    let n = model.nv();
    let mut dv = DMatrix::zeros(n, d.state.ncols() + d.inputs.ncols());
    dv.columns_mut(0, d.state.ncols())
        .copy_from(&(&d.state * h));
    dv.columns_mut(d.state.ncols(), d.inputs.ncols())
        .copy_from(&(&d.inputs * h));
    if wrt.state {
        // v' depends on v directly too.
        for i in 0..n {
            dv[(i, n + i)] += 1.0;
        }
    }
    let mut dq = &dv * h;
    if wrt.state {
        for i in 0..n {
            dq[(i, i)] += 1.0;
        }
    }
    (d.qdd, dq, dv)
}

/// Classic RK4 on x = (q, v), differentiated stage by stage: with x_1 = x,
/// k_i = f(x_i), x_{i+1} = x + c_i k_i and x' = x + sum w_i k_i,
/// d k_i = F_x(x_i) d x_i + F_u(x_i) for the inputs u = (tau, p).
fn rk4(
    model: &Model,
    ws: &mut Workspace,
    (q, v, tau): (&[f64], &[f64], &[f64]),
    wrt: &Wrt,
) -> (DMatrix<f64>, DMatrix<f64>) {
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
        let d = accel_derivatives(
            model,
            ws,
            (PassiveMode::Explicit, h),
            (&qs, &vs, tau),
            &full,
        );
        if k == 0 {
            n_cols = n_state + d.inputs.ncols();
            dx_stage = DMatrix::zeros(2 * n, n_cols);
            for i in 0..n_state {
                dx_stage[(i, i)] = 1.0;
            }
            total = dx_stage.clone();
        }
        // d k = [d v_stage; d qdd], with d qdd = Qx d x_stage + (direct input terms).
        let mut dk = DMatrix::zeros(2 * n, n_cols);
        dk.rows_mut(0, n).copy_from(&dx_stage.rows(n, n));
        let mut dqdd = &d.state * &dx_stage;
        let mut inputs = dqdd.columns_mut(n_state, n_cols - n_state);
        inputs += &d.inputs;
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
                vs[i] = v[i] + c[k] * d.qdd[i];
            }
        }
    }
    (total.rows(0, n).into_owned(), total.rows(n, n).into_owned())
}

/// -M^-1 R for M factored by `ltdl_factor`: column by column when R is
/// narrow, through M^-1 and one matrix product when it has more than n columns.
fn solve_negated(tree: &Tree<f64>, factored: &DMatrix<f64>, mut r: DMatrix<f64>) -> DMatrix<f64> {
    let n = tree.nv();
    if r.ncols() <= n {
        ltdl_solve_columns(tree, factored, &mut r);
        -r
    } else {
        let mut inverse = DMatrix::identity(n, n);
        ltdl_solve_columns(tree, factored, &mut inverse);
        -(inverse * r)
    }
}

/// The acceleration at (q, v, tau) under (mode, h) and its derivatives.
fn accel_derivatives(
    model: &Model,
    ws: &mut Workspace,
    (mode, h): (PassiveMode, f64),
    (q, v, tau): (&[f64], &[f64], &[f64]),
    wrt: &Wrt,
) -> AccelDerivatives {
    let n = model.nv();
    let tree = model.tree();
    let mut qdd = vec![0.0; n];
    acceleration(tree, &mut ws.data, (mode, h), (q, v, tau), &mut qdd);
    implicit_terms(tree, (mode, h), (q, v), &mut ws.q_spring, &mut ws.extra);
    // M + diag(extra), factored once along the tree for every column.
    crba(tree, &mut ws.data, q);
    for i in 0..n {
        ws.data.mass_matrix[(i, i)] += ws.extra[i];
    }
    ltdl_factor(tree, &mut ws.data.mass_matrix);
    // Velocities, accelerations and forces at the solution, for both blocks.
    rnea(tree, &mut ws.data, q, v, &qdd, &mut ws.tau);

    // dR/d(columns): [q, v] if asked for, then tau, then the parameter scalars.
    let n_state = if wrt.state { 2 * n } else { 0 };
    let n_tau = if wrt.control { n } else { 0 };
    let n_p: usize = wrt.params.iter().map(|p| p.size()).sum();
    let mut r = DMatrix::zeros(n, n_state + n_tau + n_p);
    if wrt.state {
        let (r_q, r_v) = r.columns_range_pair_mut(0..n, n..2 * n);
        rnea_derivatives(tree, &ws.data, &mut ws.sweep, v, r_q, r_v);
        // The passive force -D v - K (q_spring - springref), q_spring = q (+ h v for DART).
        let spring_v = if mode == PassiveMode::ImplicitDampingStiffness {
            h
        } else {
            0.0
        };
        for i in 0..n {
            r[(i, i)] += tree.stiffness[i];
            r[(i, n + i)] += tree.damping[i] + spring_v * tree.stiffness[i];
        }
    }
    for i in 0..n_tau {
        r[(i, n_state + i)] = -1.0;
    }
    let mut col = n_state + n_tau;
    for &param in wrt.params {
        for component in 0..param.size() {
            residual_derivative(
                model,
                &ws.data,
                (mode, h),
                (&ws.q_spring, v, &qdd),
                (param, component),
                &mut ws.tau,
            );
            r.column_mut(col).copy_from_slice(&ws.tau);
            col += 1;
        }
    }
    let dqdd = solve_negated(tree, &ws.data.mass_matrix, r);
    let state = dqdd.columns(0, n_state).into_owned();
    let inputs = dqdd.columns(n_state, dqdd.ncols() - n_state).into_owned();
    AccelDerivatives { qdd, state, inputs }
}
