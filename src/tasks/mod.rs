//! Control tasks: what a controller observes, how its actions drive the model,
//! what training rewards, when an episode ends and how it is scored.
//!
//! Conventions shared by every task:
//! - The state is the model's (q, v), SI units ([`State`]).
//! - An action has [`Task::act_dim`] components, each meaningful in [-1, 1]
//!   (the task clamps); [`Task::forces`] maps it to generalized forces on the
//!   model's dofs (N on slides, N m on hinges), or [`Task::inputs`] to the
//!   actuators' controls (servo targets) where the task says so.
//! - mu, the task's environment parameters, sets physical parameters of the
//!   model through the task's affine [`ParamMap`]; experiments draw mu
//!   uniformly in the box [`Task::mu_range`].
//! - One control step holds its forces for [`Task::substeps`] physics steps of
//!   the model's timestep.
//! - An episode lasts [`Task::horizon`] control steps, or fewer when
//!   [`Task::terminated`] says so; its score, the task metric, is the sum of the
//!   per-step [`Task::metric`] values.

mod cartpole;
mod half_cheetah;
pub mod quadruped;
pub mod wiping;

pub use cartpole::Cartpole;
pub use half_cheetah::{Contact, HalfCheetah};
pub use quadruped::Quadruped;
pub use wiping::{tool_down_at, Wiping};

use rand::rngs::StdRng;
use rand::RngExt;

use crate::derivatives::Transition;
use crate::dynamics::{Data, StepError};
use crate::model::{Inputs, ParamError, ParamMap, State};
use crate::Model;

/// A control task on a simulated model (see the module docs for conventions).
pub trait Task: Send + Sync {
    /// The name the command line and the weights files use.
    fn name(&self) -> &'static str;
    /// The nominal model; an episode runs on a copy with mu applied.
    fn model(&self) -> &Model;
    fn mu_map(&self) -> &ParamMap;
    /// Lower and upper bound of each component of mu.
    fn mu_range(&self) -> (&[f64], &[f64]);
    /// Control steps of a full episode.
    fn horizon(&self) -> usize;
    /// Physics steps per control step.
    fn substeps(&self) -> usize;
    /// Length of [`Task::observe`]'s output (without mu).
    fn obs_dim(&self) -> usize;
    fn act_dim(&self) -> usize;
    /// An initial state drawn from the task's reset distribution.
    fn reset(&self, rng: &mut StdRng) -> State;
    /// Appends the controller's observation of `state` to `out`.
    fn observe(&self, state: &State, out: &mut Vec<f64>);
    /// Generalized forces (length nv) for an action.
    fn forces(&self, action: &[f64]) -> Vec<f64>;
    /// The step's inputs for an action, held over the control step: by
    /// default [`Task::forces`] as tau and no controls; a task whose actions
    /// drive the model's actuators (servo targets) sets ctrl here.
    fn inputs(&self, action: &[f64]) -> Inputs {
        Inputs::tau(&self.forces(action))
    }
    /// The training reward of one control step, in an episode with parameters mu.
    fn reward(&self, mu: &[f64], state: &State, action: &[f64], next: &State) -> f64;
    /// The cost of one control step that a trajectory optimiser minimises
    /// ([`crate::control::ilqr`]): the negated reward, unless the task gives a
    /// cost smooth where its reward is not (a reward that vanishes once the
    /// task fails gives a planner no gradient there).
    fn cost(&self, mu: &[f64], state: &State, action: &[f64], next: &State) -> f64 {
        -self.reward(mu, state, action, next)
    }
    /// Whether the episode ends at `state`.
    fn terminated(&self, state: &State) -> bool;
    /// One control step's contribution to the task metric.
    fn metric(&self, state: &State, action: &[f64], next: &State) -> f64;
    /// What an episode's score means, for reports.
    fn metric_description(&self) -> String {
        "the task metric summed over the episode".into()
    }
}

/// The tasks the command line knows, by name.
pub fn by_name(name: &str) -> Result<Box<dyn Task>, String> {
    match name {
        "cartpole" => Ok(Box::new(Cartpole::new())),
        "half_cheetah" => Ok(Box::new(HalfCheetah::new())),
        "half_cheetah_contact" => Ok(Box::new(HalfCheetah::contact())),
        "quadruped" => Ok(Box::new(Quadruped::new())),
        _ => Err(format!(
            "unknown task '{name}' (known: cartpole, half_cheetah, half_cheetah_contact, quadruped)"
        )),
    }
}

/// A point drawn uniformly in the box [lower, upper] (one draw per
/// component, in order).
pub fn uniform_in(lower: &[f64], upper: &[f64], rng: &mut StdRng) -> Vec<f64> {
    lower
        .iter()
        .zip(upper)
        .map(|(&l, &h)| l + (h - l) * rng.random::<f64>())
        .collect()
}

/// The middle of the box [lower, upper].
pub fn middle_of(lower: &[f64], upper: &[f64]) -> Vec<f64> {
    lower
        .iter()
        .zip(upper)
        .map(|(l, h)| 0.5 * (l + h))
        .collect()
}

/// mu drawn uniformly in the task's box.
pub fn sample_mu(task: &dyn Task, rng: &mut StdRng) -> Vec<f64> {
    let (lo, hi) = task.mu_range();
    uniform_in(lo, hi, rng)
}

/// The middle of the task's mu box.
pub fn average_mu(task: &dyn Task) -> Vec<f64> {
    let (lo, hi) = task.mu_range();
    middle_of(lo, hi)
}

#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum EnvError {
    #[error("setting mu: {0}")]
    Mu(#[from] ParamError),
    #[error("simulating: {0}")]
    Step(#[from] StepError),
}

/// What one control step produced.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Outcome {
    pub reward: f64,
    pub metric: f64,
    /// The task ended the episode.
    pub terminated: bool,
    /// The horizon ended the episode (and the task did not).
    pub truncated: bool,
}

/// One running episode of a task: the model with the episode's mu applied,
/// its state and its step count.
pub struct Env<'a> {
    task: &'a dyn Task,
    model: Model,
    data: Data<f64>,
    mu: Vec<f64>,
    state: State,
    t: usize,
    /// The last physics step: its start state and the generalized forces
    /// it applied ([`Model::held_forces`]).
    last: Option<(State, Vec<f64>)>,
}

impl<'a> Env<'a> {
    /// An environment at the nominal model, at rest; call [`Env::reset`] first.
    pub fn new(task: &'a dyn Task) -> Env<'a> {
        let model = task.model().clone();
        let data = model.data();
        Env {
            task,
            data,
            mu: vec![],
            state: State::new(vec![0.0; model.nq()], vec![0.0; model.nv()]),
            model,
            t: 0,
            last: None,
        }
    }

    /// Starts an episode with environment parameters `mu`.
    pub fn reset(&mut self, mu: &[f64], rng: &mut StdRng) -> Result<(), EnvError> {
        let state = self.task.reset(rng);
        self.reset_to(mu, state)
    }

    /// Starts an episode with environment parameters `mu` from `state`.
    pub fn reset_to(&mut self, mu: &[f64], state: State) -> Result<(), EnvError> {
        self.set_mu(mu)?;
        self.state = state;
        self.t = 0;
        self.last = None;
        Ok(())
    }

    /// Changes the true mu in the middle of an episode (the state and the
    /// step count carry on).
    pub fn set_mu(&mut self, mu: &[f64]) -> Result<(), EnvError> {
        self.task.mu_map().apply(&mut self.model, mu)?;
        self.mu = mu.to_vec();
        Ok(())
    }

    pub fn task(&self) -> &'a dyn Task {
        self.task
    }

    pub fn state(&self) -> &State {
        &self.state
    }

    /// The true mu of this episode.
    pub fn mu(&self) -> &[f64] {
        &self.mu
    }

    /// Control steps taken in this episode.
    pub fn t(&self) -> usize {
        self.t
    }

    /// The last physics step of the last control step, as the identifiers see
    /// it: (q, v) before it, the forces held, (q, v) after it (the current
    /// state). With one substep it is the whole control step. None before the
    /// first step of an episode. Under controls (a servo task) the forces
    /// are the actuators' at its start state plus tau: the step under them
    /// as tau alone is the same step where actuator forces are explicit
    /// (Euler).
    pub fn last_transition(&self) -> Option<Transition> {
        let (start, tau) = self.last.clone()?;
        Some(Transition {
            start,
            tau,
            next: self.state.clone(),
        })
    }

    /// Applies an action for one control step.
    pub fn step(&mut self, action: &[f64]) -> Result<Outcome, EnvError> {
        let u = self.task.inputs(action);
        let model = &self.model;
        let step = |data: &mut Data<f64>, x: &State| {
            let State { q, v, .. } = model.step(data, x, &u)?;
            Ok::<_, StepError>(State::new(q, v))
        };
        let mut start = self.state.clone();
        let mut next = step(&mut self.data, &start)?;
        for _ in 1..self.task.substeps() {
            start = next;
            next = step(&mut self.data, &start)?;
        }
        let tau = if u.ctrl.is_empty() {
            u.tau
        } else {
            model.held_forces(&start, &u)
        };
        self.last = Some((start, tau));
        let reward = self.task.reward(&self.mu, &self.state, action, &next);
        let metric = self.task.metric(&self.state, action, &next);
        let terminated = self.task.terminated(&next);
        self.state = next;
        self.t += 1;
        Ok(Outcome {
            reward,
            metric,
            terminated,
            truncated: !terminated && self.t >= self.task.horizon(),
        })
    }
}
