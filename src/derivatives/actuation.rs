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
//! Phi_tau F_(ctrl, act). F's partials and act' = next(ctrl, act)'s come
//! from dual numbers through the generic actuation code (one actuator at a
//! time: it reads its joint's q and v, its ctrl and its act). The same holds
//! under RK4 when F is the same at every stage (no activation, no length
//! or velocity terms); other actuators under RK4 are refused for now.
//! Where a clamp (ctrl, force or act range) is active the derivative is the
//! clamped side's, zero.

use nalgebra::DMatrix;
use num_dual::Dual64;

use super::step::{applied_jacobians, StepJacobians, Workspace, Wrt};
use crate::dynamics::integrator::tableau;
use crate::dynamics::{check_actuation, check_inputs, StepError};
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

/// Per actuator: the partials of its generalized force and of its next
/// activation in (joint coordinate, joint velocity, ctrl, act).
type Partials = ([f64; 4], [f64; 4]);

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
    let runge_kutta = tableau(model.opt.integrator).is_some();
    if runge_kutta && !tree.actuators.iter().all(|a| a.state_independent()) {
        return Err(StepError::NoActuatorDerivatives);
    }
    let (n, nu, na) = (model.nv(), model.nu(), model.na());
    let h = model.opt.timestep;
    let mut total = tau.to_vec();
    let mut act_next = vec![0.0; na];
    let mut partials: Vec<Partials> = Vec::with_capacity(nu);
    for (i, a) in tree.actuators.iter().enumerate() {
        let c = ctrl.get(i).copied().unwrap_or(0.0);
        let current = a.act.and_then(|k| act.get(k).copied()).unwrap_or(0.0);
        let point = [q[a.q_at], v[a.dof], c, current];
        let seeded = |s: usize| {
            let x: [Dual64; 4] = std::array::from_fn(|j| Dual64::new(point[j], f64::from(j == s)));
            a.output(h, (x[0], x[1]), (x[2], x[3]))
        };
        let outputs: [(Dual64, Dual64); 4] = std::array::from_fn(seeded);
        let (force, next) = outputs[0];
        total[a.dof] += force.re;
        if let Some(k) = a.act {
            act_next[k] = next.re;
        }
        partials.push((outputs.map(|(f, _)| f.eps), outputs.map(|(_, x)| x.eps)));
    }
    let inner = Wrt {
        control: true,
        ..*wrt
    };
    let mut step = applied_jacobians(model, ws, (q, v, &total), &inner)?;
    let b_tau = step.tau().clone_owned();
    let mut dx_dact = DMatrix::zeros(2 * n, na);
    let mut dx_dctrl = DMatrix::zeros(2 * n, nu);
    let mut dact_dact = DMatrix::zeros(na, na);
    let mut dact_dctrl = DMatrix::zeros(na, nu);
    for (i, (a, (df, dnext))) in tree.actuators.iter().zip(&partials).enumerate() {
        let b = b_tau.column(a.dof);
        for (k, slope) in [(a.dof, df[0]), (n + a.dof, df[1])] {
            if let Some(col) = step.state_column(k) {
                step.jacobian.column_mut(col).axpy(slope, &b, 1.0);
            }
        }
        dx_dctrl.column_mut(i).axpy(df[2], &b, 1.0);
        if let Some(k) = a.act {
            dx_dact.column_mut(k).axpy(df[3], &b, 1.0);
            dact_dact[(k, k)] = dnext[3];
            dact_dctrl[(k, i)] = dnext[2];
        }
    }
    let step = if wrt.control { step } else { step.without_tau() };
    Ok(InputJacobians {
        step,
        act_next,
        dx_dact,
        dx_dctrl,
        dact_dact,
        dact_dctrl,
    })
}
