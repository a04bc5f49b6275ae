//! The Universal Controller in its online loop (the paper's Figure 1): at each
//! control step the UC acts on the current estimate of mu; the transition it
//! causes is observed by a mu estimator, which updates the estimate for the
//! next step.
//!
//! Conventions:
//! - A [`MuEstimator`] sees transitions (q_t, v_t, tau_t, q_t+1, v_t+1) of
//!   the task's model (SI units, tau the generalized forces on every dof),
//!   one per control step: its last physics step ([`Env::last_transition`];
//!   the whole control step when a task takes one physics step per control
//!   step), and answers mu inside the task's range. Before its first transition it
//!   answers the prior, the middle of the range (the oracle excepted).
//! - The true mu is passed alongside, for the oracle only: at the start of an
//!   episode, and with each transition the true mu of the step to come (so a
//!   change of mu reaches the oracle the step it takes effect).
//! - [`run_episode`] records, per control step t = 0, 1, ..., the true mu of
//!   that step, the mu fed to the controller at it and the task metric of
//!   the step.

pub mod admittance;
pub mod ilqr;

use std::collections::VecDeque;

use rand::rngs::StdRng;
use rand::SeedableRng;

use crate::derivatives::Transition;
use crate::model::State;
use crate::osi::mlp::MuMlp;
use crate::osi::{ChangeDetection, CmaEs, Identifier, Lm, Online, OsiError, Problem, Sampling};
use crate::rl::{Policy, PolicyKind};
use crate::tasks::{average_mu, middle_of, sample_mu, uniform_in, Env, EnvError, Task};

#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ControlError {
    #[error(transparent)]
    Env(#[from] EnvError),
    #[error("identification: {0}")]
    Osi(#[from] OsiError),
}

/// Observes transitions, gives the current mu (see the module conventions).
pub trait MuEstimator: Send {
    /// A new episode starts (its true mu is `truth`): forget the old one.
    /// A fixed source keeps what it has.
    fn reset(&mut self, _truth: &[f64]) -> Result<(), ControlError> {
        Ok(())
    }
    /// The transition just made; `truth` is the true mu of the next step.
    /// A source that does not learn ignores it.
    fn observe(&mut self, _transition: Transition, _truth: &[f64]) -> Result<(), ControlError> {
        Ok(())
    }
    /// The mu to feed the controller now.
    fn mu(&self) -> &[f64];
}

/// UC-Oracle: the true mu.
#[derive(Clone, Debug, Default)]
pub struct OracleMu {
    mu: Vec<f64>,
}

impl MuEstimator for OracleMu {
    fn reset(&mut self, truth: &[f64]) -> Result<(), ControlError> {
        self.mu = truth.to_vec();
        Ok(())
    }
    fn observe(&mut self, _: Transition, truth: &[f64]) -> Result<(), ControlError> {
        self.mu = truth.to_vec();
        Ok(())
    }
    fn mu(&self) -> &[f64] {
        &self.mu
    }
}

/// UC-Average: always the middle of the range.
#[derive(Clone, Debug)]
pub struct AverageMu {
    mu: Vec<f64>,
}

impl AverageMu {
    pub fn new(task: &dyn Task) -> AverageMu {
        AverageMu {
            mu: average_mu(task),
        }
    }
}

impl MuEstimator for AverageMu {
    fn mu(&self) -> &[f64] {
        &self.mu
    }
}

/// UC-Random: a guess drawn uniformly in the range at the start of each
/// episode, independent of the true mu, kept for the episode.
#[derive(Debug)]
pub struct RandomMu {
    rng: StdRng,
    lower: Vec<f64>,
    upper: Vec<f64>,
    mu: Vec<f64>,
}

impl RandomMu {
    pub fn new(task: &dyn Task, seed: u64) -> RandomMu {
        let (lower, upper) = task.mu_range();
        RandomMu {
            rng: StdRng::seed_from_u64(seed),
            lower: lower.to_vec(),
            upper: upper.to_vec(),
            mu: average_mu(task),
        }
    }
}

impl MuEstimator for RandomMu {
    fn reset(&mut self, _: &[f64]) -> Result<(), ControlError> {
        self.mu = uniform_in(&self.lower, &self.upper, &mut self.rng);
        Ok(())
    }
    fn mu(&self) -> &[f64] {
        &self.mu
    }
}

/// UC-DiffOSI and UC-CMA-ES: [`Online`] identification on the most recent
/// `window` transitions, warm-started from the last estimate, optionally with
/// change detection; a fresh buffer every episode.
#[derive(Debug)]
pub struct OnlineMu<I> {
    problem: Problem,
    identifier: I,
    window: usize,
    change: Option<ChangeDetection>,
    online: Online<I>,
    mu: Vec<f64>,
}

impl<I: Identifier + Clone + Send> OnlineMu<I> {
    pub fn new(
        problem: Problem,
        identifier: I,
        window: usize,
        change: Option<ChangeDetection>,
    ) -> Result<OnlineMu<I>, ControlError> {
        let online = Self::fresh(&problem, &identifier, window, change)?;
        Ok(OnlineMu {
            mu: problem.prior().to_vec(),
            problem,
            identifier,
            window,
            change,
            online,
        })
    }

    fn fresh(
        problem: &Problem,
        identifier: &I,
        window: usize,
        change: Option<ChangeDetection>,
    ) -> Result<Online<I>, ControlError> {
        let online = Online::new(
            problem.clone(),
            identifier.clone(),
            window,
            Sampling::Recent,
            0,
        )?;
        Ok(match change {
            Some(options) => online.with_change_detection(options)?,
            None => online,
        })
    }
}

impl<I: Identifier + Clone + Send> MuEstimator for OnlineMu<I> {
    fn reset(&mut self, _: &[f64]) -> Result<(), ControlError> {
        self.online = Self::fresh(&self.problem, &self.identifier, self.window, self.change)?;
        self.mu = self.problem.prior().to_vec();
        Ok(())
    }
    fn observe(&mut self, transition: Transition, _: &[f64]) -> Result<(), ControlError> {
        self.mu = self.online.push(transition)?.mu.clone();
        Ok(())
    }
    fn mu(&self) -> &[f64] {
        &self.mu
    }
}

/// UC-MLP: the network's prediction from the last transitions, clamped to the
/// task's range; the prior until enough transitions arrived.
#[derive(Clone, Debug)]
pub struct MlpMu {
    net: MuMlp,
    lower: Vec<f64>,
    upper: Vec<f64>,
    history: VecDeque<Transition>,
    mu: Vec<f64>,
}

impl MlpMu {
    pub fn new(task: &dyn Task, net: MuMlp) -> MlpMu {
        let (lower, upper) = task.mu_range();
        MlpMu {
            history: VecDeque::with_capacity(net.transitions),
            net,
            lower: lower.to_vec(),
            upper: upper.to_vec(),
            mu: average_mu(task),
        }
    }
}

impl MuEstimator for MlpMu {
    fn reset(&mut self, _: &[f64]) -> Result<(), ControlError> {
        self.history.clear();
        self.mu = middle_of(&self.lower, &self.upper);
        Ok(())
    }
    fn observe(&mut self, transition: Transition, _: &[f64]) -> Result<(), ControlError> {
        if self.history.len() == self.net.transitions {
            self.history.pop_front();
        }
        self.history.push_back(transition);
        if let Some(mu) = self.net.predict(self.history.make_contiguous()) {
            let bounds = self.lower.iter().zip(&self.upper);
            self.mu = mu
                .iter()
                .zip(bounds)
                .map(|(m, (l, h))| m.clamp(*l, *h))
                .collect();
        }
        Ok(())
    }
    fn mu(&self) -> &[f64] {
        &self.mu
    }
}

/// Where a Universal Controller's mu comes from.
#[derive(
    Clone, Copy, Debug, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize, clap::ValueEnum,
)]
#[serde(rename_all = "kebab-case")]
pub enum Source {
    /// The true mu (UC-Oracle).
    Oracle,
    /// A uniform guess per episode (UC-Random).
    Random,
    /// The middle of the range (UC-Average).
    Average,
    /// The UC-MLP trained on the whole range.
    Mlp,
    /// The UC-MLP trained on the narrow range.
    MlpNarrow,
    /// Online CMA-ES on the recent window.
    Cmaes,
    /// Online DiffOSI (Levenberg-Marquardt) on the recent window, with change detection.
    Diffosi,
    /// Online DiffOSI without change detection.
    DiffosiNoCd,
}

/// What the estimators need besides the task: the window of the online
/// identifiers and the UC-MLP weights.
#[derive(Clone, Debug)]
pub struct Sources {
    /// Transitions per window of DiffOSI and CMA-ES (the context window N is
    /// one more).
    pub window: usize,
    pub mlp: Option<MuMlp>,
    pub mlp_narrow: Option<MuMlp>,
}

impl Default for Sources {
    /// Windows of 4 transitions (N = 5); no UC-MLP weights.
    fn default() -> Self {
        Sources {
            window: 4,
            mlp: None,
            mlp_narrow: None,
        }
    }
}

/// The identification problem of a task's mu on noise-free transitions: the
/// task's range, the prior at its middle, residuals scaled by 1e-6 dt (q) and
/// 1e-6 (v) so that a loss per residual of order one means a 1e-6 misfit.
pub fn task_problem(task: &dyn Task) -> Result<Problem, OsiError> {
    let model = task.model();
    let (nv, dt) = (model.nv(), model.opt.timestep);
    let scale: Vec<f64> = (0..2 * nv)
        .map(|k| if k < nv { 1e-6 * dt } else { 1e-6 })
        .collect();
    let (lower, upper) = task.mu_range();
    Problem::new(
        model,
        task.mu_map().clone(),
        lower,
        upper,
        &average_mu(task),
        &scale,
    )
}

impl Sources {
    /// An estimator of `source` for `task`; `seed` drives its random choices.
    pub fn estimator(
        &self,
        source: Source,
        task: &dyn Task,
        seed: u64,
    ) -> Result<Box<dyn MuEstimator>, String> {
        let mlp = |net: &Option<MuMlp>, flag: &str| match net {
            Some(net) if net.task == task.name() => Ok(MlpMu::new(task, net.clone())),
            Some(net) => Err(format!("the {flag} weights are for '{}'", net.task)),
            None => Err(format!("{source:?} needs {flag} weights")),
        };
        let window = self.window;
        Ok(match source {
            Source::Oracle => Box::new(OracleMu::default()),
            Source::Random => Box::new(RandomMu::new(task, seed)),
            Source::Average => Box::new(AverageMu::new(task)),
            Source::Mlp => Box::new(mlp(&self.mlp, "--mlp")?),
            Source::MlpNarrow => Box::new(mlp(&self.mlp_narrow, "--mlp-narrow")?),
            Source::Cmaes => online(task, CmaEs::default(), window, None)?,
            Source::Diffosi => online(
                task,
                Lm::default(),
                window,
                Some(ChangeDetection::default()),
            )?,
            Source::DiffosiNoCd => online(task, Lm::default(), window, None)?,
        })
    }
}

/// An [`OnlineMu`] on the task's problem ([`task_problem`]).
fn online<I: Identifier + Clone + Send + 'static>(
    task: &dyn Task,
    identifier: I,
    window: usize,
    change: Option<ChangeDetection>,
) -> Result<Box<dyn MuEstimator>, String> {
    let problem = task_problem(task).map_err(|e| e.to_string())?;
    let estimator = OnlineMu::new(problem, identifier, window, change);
    Ok(Box::new(estimator.map_err(|e| e.to_string())?))
}

/// One evaluation episode: the true mu, the initial state, and optionally a
/// change of the true mu to another value from a control step on.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Episode {
    pub mu: Vec<f64>,
    pub initial: State,
    pub change: Option<(usize, Vec<f64>)>,
}

impl Episode {
    /// mu uniform in the task's range, then the initial state, from `rng`.
    pub fn draw(task: &dyn Task, rng: &mut StdRng) -> Episode {
        let mu = sample_mu(task, rng);
        let initial = task.reset(rng);
        Episode {
            mu,
            initial,
            change: None,
        }
    }
}

/// What happened at each control step of an episode.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize)]
pub struct Trace {
    pub mu_true: Vec<Vec<f64>>,
    /// The mu fed to the controller (empty for a domain-randomised policy).
    pub mu_hat: Vec<Vec<f64>>,
    pub metric: Vec<f64>,
    /// Whether the task's termination ended the episode (a fall), rather
    /// than its horizon.
    pub fell: bool,
}

impl Trace {
    /// The episode's score: the sum of the per-step task metric.
    pub fn score(&self) -> f64 {
        self.metric.iter().sum()
    }
}

/// Runs `policy` for one episode; a Universal Controller takes its mu from
/// `estimator` (required for one, ignored for a domain-randomised policy).
pub fn run_episode(
    task: &dyn Task,
    policy: &Policy,
    mut estimator: Option<&mut dyn MuEstimator>,
    episode: &Episode,
) -> Result<Trace, ControlError> {
    if policy.kind == PolicyKind::Dr {
        estimator = None;
    } else {
        assert!(
            estimator.is_some(),
            "a Universal Controller needs a mu estimator"
        );
    }
    let mut env = Env::new(task);
    env.reset_to(&episode.mu, episode.initial.clone())?;
    if let Some(e) = estimator.as_deref_mut() {
        e.reset(&episode.mu)?;
    }
    let mut trace = Trace::default();
    loop {
        let fed = estimator.as_deref().map_or(&[][..], |e| e.mu()).to_vec();
        let action = policy.act(&policy.observation(task, env.state(), &fed));
        trace.mu_true.push(env.mu().to_vec());
        let out = env.step(&action)?;
        trace.metric.push(out.metric);
        if estimator.is_some() {
            trace.mu_hat.push(fed);
        }
        if out.terminated || out.truncated {
            trace.fell = out.terminated;
            return Ok(trace);
        }
        if let Some((at, mu)) = &episode.change {
            if env.t() == *at {
                env.set_mu(mu)?;
            }
        }
        if let Some(e) = estimator.as_deref_mut() {
            let transition = env.last_transition().expect("a step was taken");
            e.observe(transition, env.mu())?;
        }
    }
}
