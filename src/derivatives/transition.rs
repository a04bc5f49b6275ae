//! A step's Jacobians in MuJoCo's layout (mjd_transitionFD's A and B), exact:
//! with x = (q, v), A = dx'/dx (2n x 2n) and B = dx'/dtau (2n x n),
//! column-major, q' above v' in the rows and q before v in A's columns.
//!
//! Under semi-implicit Euler with the analytic derivatives they are written
//! straight from d qdd as [`step_jacobians`] writes them; otherwise they are
//! its state and tau columns. Either way the same numbers, bit for bit.

use nalgebra::DMatrix;

use super::step::{accel_derivatives, euler_columns, step_jacobians, Workspace, Wrt};
use super::tangent::rotations;
use crate::dynamics::actuation::idle_without_inputs;
use crate::dynamics::{check_inputs, integrate_euler, integrator, StepError};
use crate::Model;

/// The next state and A, B of the module documentation; reused across
/// calls (resized when the model's size changes).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct TransitionJacobians {
    pub q_next: Vec<f64>,
    pub v_next: Vec<f64>,
    pub a: DMatrix<f64>,
    pub b: DMatrix<f64>,
}

impl TransitionJacobians {
    /// Sized for n dofs.
    /// Buffers for a model with nq position coordinates and n = nv dofs.
    pub fn new(nq: usize, n: usize) -> Self {
        TransitionJacobians {
            q_next: vec![0.0; nq],
            v_next: vec![0.0; n],
            a: DMatrix::zeros(2 * n, 2 * n),
            b: DMatrix::zeros(2 * n, n),
        }
    }
}

/// One step of `model` from (q, v) under tau into `out`, with A and B.
pub fn transition_jacobians(
    model: &Model,
    ws: &mut Workspace,
    (q, v, tau): (&[f64], &[f64], &[f64]),
    out: &mut TransitionJacobians,
) -> Result<(), StepError> {
    let n = model.nv();
    check_inputs(model.tree(), (q, v, tau))?;
    ws.size_for(model);
    if (out.q_next.len(), out.v_next.len()) != (model.nq(), n) {
        *out = TransitionJacobians::new(model.nq(), n);
    }
    let wrt = Wrt {
        state: true,
        control: true,
        params: &[],
    };
    // Actuators that act at zero control go through step_jacobians.
    let idle = idle_without_inputs(&model.tree().actuators);
    let euler = integrator::euler(&model.opt).filter(|_| !super::dual_step(model) && idle);
    if let Some(mode) = euler.filter(|&mode| accel_derivatives(model, ws, mode, (q, v, tau), &wrt))
    {
        let h = mode.1;
        integrate_euler(
            model.tree(),
            h,
            (q, v, &ws.qdd),
            (&mut out.q_next, &mut out.v_next),
        );
        // Without short-circuit: a loop the compiler vectorises.
        let finite = |x: &[f64]| x.iter().fold(true, |all, x| all & x.is_finite());
        if !finite(&out.q_next) || !finite(&out.v_next) {
            return Err(StepError::Diverged);
        }
        // A's columns come from d qdd's first 2n, B's from the rest.
        let (to_a, to_b) = ws.dqdd.as_slice().split_at(2 * n * n);
        for (block, part) in [("A", to_a), ("B", to_b)] {
            if !finite(part) {
                return Err(StepError::JacobianNotFinite { block });
            }
        }
        let targets = [out.a.as_mut_slice(), out.b.as_mut_slice()];
        let turns = rotations(model.tree(), h, &out.v_next);
        euler_columns(ws.dqdd.as_slice(), (h, n), (true, &turns), targets);
    } else {
        // Checked as step_jacobians checks its blocks.
        let j = step_jacobians(model, ws, (q, v, tau), &wrt)?;
        out.a.copy_from(&j.state());
        out.b.copy_from(&j.tau());
        out.q_next.copy_from_slice(&j.q_next);
        out.v_next.copy_from_slice(&j.v_next);
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::Integrator;
    use crate::model::{Inputs, State};

    /// A and B hold step_jacobians' blocks bit for bit, on the fast path
    /// (Euler, in contact) and on the assembled one (RK4), without and with
    /// contact; bad input is an error, not garbage.
    #[test]
    fn equals_the_step_jacobians_blocks() {
        let dir = env!("CARGO_MANIFEST_DIR");
        for (file, integrator) in [
            ("half_cheetah.xml", Integrator::Euler),
            ("half_cheetah.xml", Integrator::Rk4),
            ("cartpole.xml", Integrator::Euler),
        ] {
            let model = Model::load(format!("{dir}/reference_models/{file}"))
                .and_then(|m| m.edited(|s| s.opt.integrator = integrator))
                .unwrap();
            let n = model.nv();
            let mut data = model.data();
            let (mut q, mut v) = (model.reference_q(), vec![0.0; n]);
            let tau: Vec<f64> = (0..n).map(|i| 0.1 * (i as f64).sin()).collect();
            for _ in 0..200 {
                State { q, v, .. } = model
                    .step(&mut data, &State::new(q, v), &Inputs::tau(&tau))
                    .unwrap();
            }
            let touching = !model
                .contacts(
                    &mut data,
                    &State::new(q.to_vec(), v.to_vec()),
                    &Inputs::tau(&tau),
                )
                .unwrap()
                .is_empty();
            assert_eq!(touching, file == "half_cheetah.xml");
            let wrt = Wrt {
                state: true,
                control: true,
                params: &[],
            };
            let mut ws = Workspace::new(&model);
            let j = step_jacobians(&model, &mut ws, (&q, &v, &tau), &wrt).unwrap();
            let mut t = TransitionJacobians::default();
            transition_jacobians(&model, &mut ws, (&q, &v, &tau), &mut t).unwrap();
            let blocks = [
                (t.a.view((0, 0), (n, n)), j.dq_dq()),
                (t.a.view((0, n), (n, n)), j.dq_dv()),
                (t.a.view((n, 0), (n, n)), j.dv_dq()),
                (t.a.view((n, n), (n, n)), j.dv_dv()),
                (t.b.view((0, 0), (n, n)), j.dq_dtau()),
                (t.b.view((n, 0), (n, n)), j.dv_dtau()),
            ];
            for (k, (ours, theirs)) in blocks.into_iter().enumerate() {
                assert_eq!(ours, theirs, "{file} {integrator:?} block {k}");
            }
            assert_eq!((&t.q_next, &t.v_next), (&j.q_next, &j.v_next));
            let mut bad = q.clone();
            bad[0] = f64::NAN;
            assert!(transition_jacobians(&model, &mut ws, (&bad, &v, &tau), &mut t).is_err());
        }
    }
}
