//! Simulation on f64 states: the convenience layer over [`crate::dynamics`].

use super::Model;
use crate::dynamics::{self, Contact, Data, StepError};
use crate::model::{ContactModel, State};

/// A rollout stopped at `step` (0-based) because that step failed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("step {step}: {source}")]
pub struct RolloutError {
    pub step: usize,
    pub source: StepError,
}

impl Model {
    /// Generalized forces from actuator controls: tau = sum gear * u on each
    /// actuated joint's dof.
    pub fn actuator_forces(&self, u: &[f64]) -> Vec<f64> {
        let mut tau = vec![0.0; self.nv()];
        for (a, &ui) in self.actuators.iter().zip(u) {
            tau[self.joint_address(a.joint).1] += a.gear * ui;
        }
        tau
    }

    /// A workspace for this model's dynamics.
    pub fn data(&self) -> Data<f64> {
        Data::new(&self.tree)
    }

    /// One step from (q, v) under generalized forces tau (length nv).
    pub fn step(
        &self,
        data: &mut Data<f64>,
        q: &[f64],
        v: &[f64],
        tau: &[f64],
    ) -> Result<(Vec<f64>, Vec<f64>), StepError> {
        let (mut q1, mut v1) = (vec![0.0; self.nq()], vec![0.0; self.nv()]);
        dynamics::step(&self.tree, data, (q, v, tau), (&mut q1, &mut v1))?;
        Ok((q1, v1))
    }

    /// The contacts at (q, v) with their forces: those a semi-implicit Euler
    /// step from (q, v) under generalized forces tau applies (net force per
    /// body: [`dynamics::body_contact_forces`]). Under the smooth model the
    /// forces depend on (q, v) only ([`dynamics::contact`]); under the
    /// constraint model they are the solver's and depend on tau too
    /// ([`dynamics::constraint::contact_forces`]).
    pub fn contacts(
        &self,
        data: &mut Data<f64>,
        q: &[f64],
        v: &[f64],
        tau: &[f64],
    ) -> Result<Vec<Contact<f64>>, StepError> {
        dynamics::check_inputs(&self.tree, (q, v, tau))?;
        if self.opt.contact_model == ContactModel::Smooth {
            let mut out = vec![0.0; self.nv()];
            dynamics::add_soft_forces(&self.tree, data, (q, v), &mut out);
            return Ok(data.contacts.clone());
        }
        let mut qdd = vec![0.0; self.nv()];
        let mode = (self.opt.passive, self.opt.timestep);
        dynamics::acceleration(&self.tree, data, mode, (q, v, tau), &mut qdd);
        Ok(data.constrained.as_ref().map_or(vec![], |c| {
            dynamics::constraint::contact_forces(&c.contacts, &c.rows, &c.solution.force)
        }))
    }

    /// Steps from (q0, v0) under each row of `taus`; returns the T+1 states
    /// visited, the initial state first.
    pub fn rollout<'a>(
        &self,
        q0: &[f64],
        v0: &[f64],
        taus: impl IntoIterator<Item = &'a [f64]>,
    ) -> Result<Vec<State>, RolloutError> {
        let mut data = self.data();
        let mut states = vec![State::new(q0.to_vec(), v0.to_vec())];
        for (step, tau) in taus.into_iter().enumerate() {
            let State { q, v, .. } = states.last().expect("starts non-empty");
            let (q, v) = self
                .step(&mut data, q, v, tau)
                .map_err(|source| RolloutError { step, source })?;
            states.push(State::new(q, v));
        }
        Ok(states)
    }
}
