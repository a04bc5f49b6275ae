//! Simulation on f64 states: the convenience layer over [`crate::dynamics`].

use std::borrow::Borrow;

use super::Model;
use crate::dynamics::{self, Contact, Data, StepError};
use crate::model::{ContactModel, Gain, Inputs, State};

/// A rollout stopped at `step` (0-based) because that step failed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("step {step}: {source}")]
pub struct RolloutError {
    pub step: usize,
    pub source: StepError,
}

impl Model {
    /// Generalized forces from motor controls: tau = sum moment gain u
    /// (moment = gear on a joint's dof), for models whose actuators are all
    /// motor-like ([`crate::model::Actuator::force_per_control`]) on joints
    /// or fixed tendons, whose moments are the same at every state (others
    /// add nothing here: step them with ctrl, [`Model::step`]).
    pub fn actuator_forces(&self, u: &[f64]) -> Vec<f64> {
        let mut tau = vec![0.0; self.nv()];
        let tree = self.tree();
        let mut data = self.data();
        let q0 = self.reference_q();
        dynamics::actuation::transmissions(tree, &mut data, (&q0, &tau));
        let terms = self
            .actuators
            .iter()
            .zip(&tree.actuators)
            .zip(&data.actuator);
        for (((a, term), s), &ui) in terms.zip(u) {
            if let (Some(_), Gain::Fixed(g)) = (a.force_per_control(), a.gain) {
                if !term.reads_frames(tree) {
                    s.add_dense(g * ui, &mut tau);
                }
            }
        }
        tau
    }

    /// The generalized forces that, given as tau with zero controls, make
    /// the step from `x` under `u`: u.tau plus the actuators' forces at
    /// u.ctrl minus theirs at zero controls, both read at x (a step without
    /// ctrl still applies the latter, e.g. a servo's bias). Exact where the
    /// actuators' forces are explicit in the step (Euler).
    pub fn held_forces(&self, x: &State, u: &Inputs) -> Vec<f64> {
        let mut force = u.tau.clone();
        force.resize(self.nv(), 0.0);
        let at_ctrl = self.actuator_forces_at(x, &u.ctrl);
        let at_zero = self.actuator_forces_at(x, &[]);
        for (f, (c, z)) in force.iter_mut().zip(at_ctrl.iter().zip(&at_zero)) {
            *f += c - z;
        }
        force
    }

    /// The actuators' generalized forces (nv) at x under ctrl.
    fn actuator_forces_at(&self, x: &State, ctrl: &[f64]) -> Vec<f64> {
        use dynamics::actuation::{act_rates, add_actuator_forces};
        let actuators = &self.tree.actuators;
        let mut rates = vec![0.0; x.act.len()];
        act_rates(actuators, (ctrl, &x.act), &mut rates);
        let mut force = vec![0.0; self.nv()];
        let (h, state) = (self.opt.timestep, (&x.q[..], &x.v[..]));
        let mut data = self.data();
        let inputs = (ctrl, &x.act[..], &rates[..]);
        add_actuator_forces(&self.tree, h, &mut data, state, inputs, &mut force);
        force
    }

    /// A workspace for this model's dynamics.
    pub fn data(&self) -> Data<f64> {
        Data::new(&self.tree)
    }

    /// One step as MuJoCo's mj_step takes it: from the state x = (q, v,
    /// act) under the inputs u = (ctrl, tau, mocap poses)
    /// ([`dynamics::step_actuated`]; an empty ctrl or act is zero, empty
    /// mocap poses the compiled ones). The next state has na activations.
    /// A step that diverges names its likely cause ([`StepError::DivergedAt`]).
    pub fn step(&self, data: &mut Data<f64>, x: &State, u: &Inputs) -> Result<State, StepError> {
        let mut next = State {
            q: vec![0.0; self.nq()],
            v: vec![0.0; self.nv()],
            act: vec![0.0; self.na()],
        };
        let out = (&mut next.q[..], &mut next.v[..], &mut next.act[..]);
        let state = (&x.q[..], &x.v[..], &x.act[..]);
        dynamics::mocap::set_mocap(&self.tree, data, (&u.mocap_pos, &u.mocap_quat))?;
        match dynamics::step_actuated(&self.tree, data, state, (&u.ctrl, &u.tau), out) {
            Err(StepError::Diverged) => Err(StepError::DivergedAt {
                cause: self.divergence_cause(data, x, u),
            }),
            result => result.map(|()| next),
        }
    }

    /// What a diverging step from x under u most likely blew up on: the
    /// fastest dof (its joint, and whether it is beyond its range), and the
    /// deepest contact if any.
    fn divergence_cause(&self, data: &mut Data<f64>, x: &State, u: &Inputs) -> String {
        let State { q, v, .. } = x;
        let Some((dof, speed)) = v
            .iter()
            .map(|x| x.abs())
            .enumerate()
            .max_by(|a, b| a.1.total_cmp(&b.1))
        else {
            return "the model has no dofs".into();
        };
        if speed == 0.0 {
            return "at rest: the forces are not finite (parameters that overflow?)".into();
        }
        let joint = (0..self.joints.len())
            .rev()
            .find(|&j| self.joint_address(j).1 <= dof)
            .expect("dof 0 is joint 0's");
        let (qa, va) = self.joint_address(joint);
        let j = &self.joints[joint];
        let mut cause = format!(
            "fastest: dof {dof} of joint '{}' (|v| = {speed:.3e}; a joint too light or too \
             stiff for the timestep?)",
            j.name
        );
        if let Some((lo, hi)) = j.range.filter(|_| va == dof && j.kind.nq() == 1) {
            if !(lo..=hi).contains(&q[qa]) {
                cause += &format!(", at q = {:.4e} beyond its range [{lo}, {hi}]", q[qa]);
            }
        }
        let at = State::new(q.clone(), v.clone());
        let passive = Inputs {
            ctrl: vec![],
            ..u.clone()
        };
        let contacts = self.contacts(data, &at, &passive).unwrap_or_default();
        if let Some(c) = contacts.iter().min_by(|a, b| a.dist.total_cmp(&b.dist)) {
            let [a, b] = c.geoms.map(|g| self.geoms[g].name.clone());
            cause += &format!(
                "; {} contacts, the deepest between geoms {} '{a}' and {} '{b}' at distance \
                 {:.3e}",
                contacts.len(),
                c.geoms[0],
                c.geoms[1],
                c.dist
            );
        }
        cause
    }

    /// The contacts at x = (q, v) with their forces, the mocap bodies at u's
    /// poses (empty: the compiled ones): those a semi-implicit Euler step
    /// from (q, v) under generalized forces u.tau applies (net force per
    /// body: [`dynamics::body_contact_forces`]). Under the smooth model the
    /// forces depend on (q, v) only ([`dynamics::contact`]); under the
    /// constraint model they are the solver's and depend on tau too
    /// ([`dynamics::constraint::contact_forces`]). The actuators are left
    /// out: a non-empty ctrl or act is refused ([`StepError::NotRead`]).
    pub fn contacts(
        &self,
        data: &mut Data<f64>,
        x: &State,
        u: &Inputs,
    ) -> Result<Vec<Contact<f64>>, StepError> {
        self.unactuated(data, x, u)?;
        let (q, v, tau) = (&x.q[..], &x.v[..], &u.tau[..]);
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

    /// Checks x and u for an evaluation that leaves the actuators out
    /// (contacts) and places the mocap bodies at u's poses in `data`; a
    /// non-empty ctrl or act is refused rather than ignored.
    fn unactuated(&self, data: &mut Data<f64>, x: &State, u: &Inputs) -> Result<(), StepError> {
        for (name, given) in [("ctrl", &u.ctrl), ("act", &x.act)] {
            if !given.is_empty() {
                return Err(StepError::NotRead { name });
            }
        }
        self.place(data, x, u)
    }

    /// Checks (q, v, tau) of x and u and places the mocap bodies at u's
    /// poses in `data`.
    pub(super) fn place(
        &self,
        data: &mut Data<f64>,
        x: &State,
        u: &Inputs,
    ) -> Result<(), StepError> {
        dynamics::check_inputs(&self.tree, (&x.q, &x.v, &u.tau))?;
        dynamics::mocap::set_mocap(&self.tree, data, (&u.mocap_pos, &u.mocap_quat))
    }

    /// Steps from `x0` under each of `inputs` (each step's ctrl, tau and
    /// mocap poses; owned or borrowed); returns the T+1 states visited, the
    /// initial state first.
    pub fn rollout(
        &self,
        x0: &State,
        inputs: impl IntoIterator<Item = impl Borrow<Inputs>>,
    ) -> Result<Vec<State>, RolloutError> {
        let mut data = self.data();
        let mut states = vec![x0.clone()];
        for (step, u) in inputs.into_iter().enumerate() {
            let x = states.last().expect("starts non-empty");
            let next = self
                .step(&mut data, x, u.borrow())
                .map_err(|source| RolloutError { step, source })?;
            states.push(next);
        }
        Ok(states)
    }
}
