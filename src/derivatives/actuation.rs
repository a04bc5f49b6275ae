//! Step Jacobians with actuators: the blocks in ctrl and act and the rows
//! of act', laid out as mjd_transitionFD's A = d(q', v', act')/d(q, v, act)
//! and B = d(q', v', act')/d ctrl (besides tau's and the parameters').
//!
//! The actuators' generalized force F(q, v, ctrl, act) joins tau
//! ([`crate::dynamics::actuation`]), so with Phi(q, v, tau) the step under
//! applied forces alone ([`crate::dynamics::step_applied`], its Jacobians
//! exact as [`super::step_jacobians`] computes them) and Euler's
//! x' = Phi(q, v, tau + F), the chain rule is exact:
//! dx'/d(q, v) = Phi_(q, v) + Phi_tau F_(q, v), dx'/d(ctrl, act) =
//! Phi_tau F_(ctrl, act). F = r f(l, l', ctrl, act) with r the actuator's
//! moment, constant in q for joint and fixed-tendon transmissions, and
//! (l, l') = (r q, r v) (in the tangent space), so F_q = r f_l r^T and F_v
//! = r f_l' r^T. A site or spatial-tendon moment moves with q: such
//! actuators take the dual path below. f's partials and act' = next(ctrl, act)'s come from dual
//! numbers through the generic actuation code (one actuator at a time: it
//! reads its length and velocity, its ctrl and its act). The same holds
//! under RK4 when F is the same at every stage (no activation, no length
//! or velocity terms), and under the implicit integrators then (F's velocity
//! slope, which they take implicitly, is zero); with other actuators under
//! RK4 or the implicit integrators every block comes
//! from dual numbers through the whole actuated step (one step per column,
//! positions in the tangent space as module `constrained` seeds them).
//! Where a clamp (ctrl, force or act range) is active the derivative is the
//! clamped side's, zero.

use nalgebra::{DMatrix, DVector};
use num_dual::Dual64;

use super::constrained::{tangent_point, tangent_slope, DualTrees};
use super::step::{applied_jacobians, StepJacobians, Workspace, Wrt};
use crate::dynamics::actuation::transmissions;
use crate::dynamics::integrator::tableau;
use crate::dynamics::{check_actuation, check_inputs, step_actuated, StepError};
use crate::model::Param;
use crate::Model;

/// A step's Jacobians with the actuators' blocks: `step` holds d(q', v') in
/// q, v, tau and the parameters ([`StepJacobians`]); act' does not depend
/// on those (the activation dynamics read ctrl and act only).
#[derive(Clone, Debug, PartialEq)]
pub struct InputJacobians {
    pub step: StepJacobians,
    pub act_next: Vec<f64>,
    /// d(q', v') / d act (2 nv x na) and / d ctrl (2 nv x nu), q' above v'.
    pub dx_dact: DMatrix<f64>,
    pub dx_dctrl: DMatrix<f64>,
    /// d act' / d act (na x na) and / d ctrl (na x nu).
    pub dact_dact: DMatrix<f64>,
    pub dact_dctrl: DMatrix<f64>,
}

/// Per actuator: the partials of its scalar force and of its next
/// activation in (length, velocity, ctrl, act), and Phi_tau r (2 nv) with
/// r its moment.
type Partials = ([f64; 4], [f64; 4], DVector<f64>);

/// One step from the state (q, v, act) under the inputs (ctrl, tau), as
/// [`crate::dynamics::step_actuated`] takes them (ctrl or act empty: zero),
/// with the Jacobians in `wrt` and the actuators' blocks.
pub fn input_jacobians(
    model: &Model,
    ws: &mut Workspace,
    (q, v, act): (&[f64], &[f64], &[f64]),
    (ctrl, tau): (&[f64], &[f64]),
    wrt: &Wrt,
) -> Result<InputJacobians, StepError> {
    let tree = model.tree();
    check_inputs(tree, (q, v, tau))?;
    check_actuation(tree, (ctrl, act))?;
    // Under RK4 F changes between stages; under the implicit integrators
    // its velocity slope joins the matrix solved: no chain rule through tau.
    // A moment that moves with q (a site, a spatial tendon) has F_q beyond
    // r f_l r^T: the dual path too.
    let staged = tableau(model.opt.integrator).is_some() || model.opt.integrator.is_implicit();
    let moving = tree.actuators.iter().any(|a| a.reads_frames(tree));
    if moving || staged && !tree.actuators.iter().all(|a| a.state_independent()) {
        if wrt.params.iter().any(|p| p.is_actuator()) {
            return Err(StepError::NoActuatorParamDerivatives(model.opt.integrator));
        }
        let zeros_if_empty = |x: &[f64], len: usize| {
            if x.is_empty() {
                vec![0.0; len]
            } else {
                x.to_vec()
            }
        };
        let (act, ctrl) = (
            zeros_if_empty(act, tree.na),
            zeros_if_empty(ctrl, tree.nu()),
        );
        let point = Point {
            q,
            v,
            act: &act,
            tau,
            ctrl: &ctrl,
        };
        return dual_jacobians(model, ws, &point, wrt);
    }
    let (n, nu, na) = (model.nv(), model.nu(), model.na());
    let h = model.opt.timestep;
    let mut total = tau.to_vec();
    let mut act_next = vec![0.0; na];
    let mut partials = Vec::with_capacity(nu);
    let mut law_slopes = Vec::with_capacity(nu);
    let mut moments = Vec::with_capacity(nu);
    transmissions(tree, &mut ws.data, (q, v));
    for (i, (a, s)) in tree.actuators.iter().zip(&ws.data.actuator).enumerate() {
        let c = ctrl.get(i).copied().unwrap_or(0.0);
        let current = a.act.and_then(|k| act.get(k).copied()).unwrap_or(0.0);
        let (l, ld) = (s.length, s.velocity);
        let point = [l, ld, c, current];
        let seeded = |s: usize| {
            let x: [Dual64; 4] = std::array::from_fn(|j| Dual64::new(point[j], f64::from(j == s)));
            a.output(h, (x[0], x[1]), (x[2], x[3]))
        };
        let outputs: [(Dual64, Dual64); 4] = std::array::from_fn(seeded);
        let (force, next) = outputs[0];
        s.add_dense(force.re, &mut total);
        if let Some(k) = a.act {
            act_next[k] = next.re;
        }
        partials.push((outputs.map(|(f, _)| f.eps), outputs.map(|(_, x)| x.eps)));
        law_slopes.push(a.law_slopes(h, (l, ld), (c, current)));
        moments.push(s.moment.clone());
    }
    let inner = Wrt {
        control: true,
        ..*wrt
    };
    let mut step = applied_jacobians(model, ws, (q, v, &total), &inner)?;
    let b_tau = step.tau().clone_owned();
    let partials: Vec<Partials> = partials
        .into_iter()
        .zip(&moments)
        .map(|((df, dnext), r)| (df, dnext, &b_tau * DVector::from_column_slice(r)))
        .collect();
    let mut dx_dact = DMatrix::zeros(2 * n, na);
    let mut dx_dctrl = DMatrix::zeros(2 * n, nu);
    let mut dact_dact = DMatrix::zeros(na, na);
    let mut dact_dctrl = DMatrix::zeros(na, nu);
    for (i, (a, (df, dnext, b))) in tree.actuators.iter().zip(&partials).enumerate() {
        for (dof, &r) in moments[i].iter().enumerate().filter(|(_, r)| **r != 0.0) {
            for (k, slope) in [(dof, df[0] * r), (n + dof, df[1] * r)] {
                if let Some(col) = step.state_column(k) {
                    step.jacobian.column_mut(col).axpy(slope, b, 1.0);
                }
            }
        }
        dx_dctrl.column_mut(i).axpy(df[2], b, 1.0);
        if let Some(k) = a.act {
            dx_dact.column_mut(k).axpy(df[3], b, 1.0);
            dact_dact[(k, k)] = dnext[3];
            dact_dctrl[(k, i)] = dnext[2];
        }
    }
    // An actuator's gain and bias move its force: Phi_tau dF/dp.
    let mut k = 0;
    for p in wrt.params {
        if let Param::ActuatorGain(i) | Param::ActuatorBias(i) = *p {
            let slopes = law_slopes[i][usize::from(matches!(p, Param::ActuatorBias(_)))];
            let b = &partials[i].2;
            for (c, slope) in slopes.into_iter().enumerate() {
                let col = step.param_column(k + c);
                step.jacobian.column_mut(col).axpy(slope, b, 1.0);
            }
        }
        k += p.size();
    }
    let step = if wrt.control {
        step
    } else {
        step.without_tau()
    };
    Ok(InputJacobians {
        step,
        act_next,
        dx_dact,
        dx_dctrl,
        dact_dact,
        dact_dctrl,
    })
}

/// Every block by dual numbers through [`step_actuated`] at `point` (act
/// and ctrl full length): columns (q, v, act) if the state is asked for,
/// tau if control is, ctrl, then the parameters; the value from the plain
/// step.
fn dual_jacobians(
    model: &Model,
    ws: &mut Workspace,
    point: &Point,
    wrt: &Wrt,
) -> Result<InputJacobians, StepError> {
    let (n, nu, na) = (model.nv(), model.nu(), model.na());
    let mut next = (vec![0.0; model.nq()], vec![0.0; n], vec![0.0; na]);
    let out = (&mut next.0[..], &mut next.1[..], &mut next.2[..]);
    let Point {
        q,
        v,
        act,
        tau,
        ctrl,
    } = *point;
    step_actuated(model.tree(), &mut ws.data, (q, v, act), (ctrl, tau), out)?;
    // An input column is an index into (q's tangent, v, act, tau, ctrl).
    let ranges = [
        (wrt.state, 0..2 * n + na),
        (wrt.control, 2 * n + na..3 * n + na),
    ];
    let mut inputs: Vec<usize> = ranges
        .into_iter()
        .filter(|(on, _)| *on)
        .flat_map(|(_, r)| r)
        .collect();
    inputs.extend(3 * n + na..3 * n + na + nu);
    let params = wrt
        .params
        .iter()
        .flat_map(|p| (0..p.size()).map(move |k| (*p, k)));
    let seeds: Vec<Seed> = inputs
        .into_iter()
        .map(|i| (Some(i), None))
        .chain(params.map(|p| (None, Some(p))))
        .collect();
    let mut columns = DMatrix::zeros(2 * n + na, seeds.len());
    for (col, &seed) in seeds.iter().enumerate() {
        let slope = dual_column(model, &mut ws.duals, point, seed)?;
        columns.set_column(col, &slope);
    }
    // Columns: state (q, v | act), tau, ctrl, params; rows q', v' | act'.
    let n_state = if wrt.state { 2 * n } else { 0 };
    let n_act = if wrt.state { na } else { 0 };
    let n_tau = if wrt.control { n } else { 0 };
    let ctrl_at = n_state + n_act + n_tau;
    let n_p = seeds.len() - ctrl_at - nu;
    let x_rows = columns.rows(0, 2 * n);
    let mut jacobian = DMatrix::zeros(2 * n, n_state + n_tau + n_p);
    jacobian
        .columns_mut(0, n_state)
        .copy_from(&x_rows.columns(0, n_state));
    let (tau_at, p_at) = (n_state + n_act, ctrl_at + nu);
    jacobian
        .columns_mut(n_state, n_tau)
        .copy_from(&x_rows.columns(tau_at, n_tau));
    jacobian
        .columns_mut(n_state + n_tau, n_p)
        .copy_from(&x_rows.columns(p_at, n_p));
    let act_rows = columns.rows(2 * n, na);
    let dact_dact = if wrt.state {
        act_rows.columns(n_state, na).clone_owned()
    } else {
        DMatrix::zeros(na, na)
    };
    let dx_dact = if wrt.state {
        x_rows.columns(n_state, na).clone_owned()
    } else {
        DMatrix::zeros(2 * n, na)
    };
    Ok(InputJacobians {
        step: StepJacobians::assemble((next.0, next.1), jacobian, wrt)?,
        act_next: next.2,
        dx_dact,
        dx_dctrl: x_rows.columns(ctrl_at, nu).clone_owned(),
        dact_dact,
        dact_dctrl: act_rows.columns(ctrl_at, nu).clone_owned(),
    })
}

/// An input seeded with 1 (an index into the inputs of [`dual_jacobians`])
/// or a parameter's scalar.
type Seed = (Option<usize>, Option<(Param, usize)>);

/// The point a dual column is taken at.
#[derive(Clone, Copy)]
struct Point<'a> {
    q: &'a [f64],
    v: &'a [f64],
    act: &'a [f64],
    tau: &'a [f64],
    ctrl: &'a [f64],
}

/// The slopes (q' in the tangent space, v', act') of one dual step along `seed`.
fn dual_column(
    model: &Model,
    duals: &mut DualTrees,
    x: &Point,
    seed: Seed,
) -> Result<DVector<f64>, StepError> {
    let (n, na) = (model.nv(), model.na());
    let (tree, data) = duals.get(model, seed.1);
    let lift = |values: &[f64], offset: usize| -> Vec<Dual64> {
        let slope = |i: usize| f64::from(seed.0 == Some(offset + i));
        values
            .iter()
            .enumerate()
            .map(|(i, &xi)| Dual64::new(xi, slope(i)))
            .collect()
    };
    let qd = tangent_point(tree, x.q, seed.0);
    let (vd, actd) = (lift(x.v, n), lift(x.act, 2 * n));
    let (taud, ctrld) = (lift(x.tau, 2 * n + na), lift(x.ctrl, 3 * n + na));
    let zero = Dual64::from(0.0);
    let (mut q1, mut v1, mut a1) = (vec![zero; x.q.len()], vec![zero; n], vec![zero; na]);
    let next = (&mut q1[..], &mut v1[..], &mut a1[..]);
    step_actuated(tree, data, (&qd, &vd, &actd), (&ctrld, &taud), next)?;
    let q_slope = tangent_slope(tree, &q1);
    let rest = v1.iter().chain(&a1).map(|d| d.eps);
    Ok(DVector::from_iterator(
        2 * n + na,
        q_slope.iter().copied().chain(rest),
    ))
}
