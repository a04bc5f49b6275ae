//! Imitation of a model-predictive expert by DAgger (Ross, Gordon and Bagnell,
//! 2011): a policy network learns the actions that iLQR MPC with the true mu
//! ([`crate::control::ilqr::Mpc`], replanning at every control step) takes in
//! the states the network itself visits.
//!
//! Round 0 runs the expert, its actions perturbed by Gaussian noise of
//! standard deviation `noise` so that the data cover the neighbourhood of its
//! trajectories; every later round runs the current student. In every round the
//! expert labels each visited state with its own action (the plan's first
//! action from that state: a function of the state and the plan it was
//! warm-started from), the labelled pairs join one growing dataset, and the
//! student is refitted on all of it ([`crate::nn::fit_least_squares`], mean
//! squared error on the action, a tenth of each round's episodes held out).
//!
//! Episodes are the task's: mu uniform in its range, the reset distribution,
//! and with probability `change` a second mu drawn uniformly that takes
//! effect at a control step uniform in the episode (the expert then plans
//! anew with it), so the student also learns to move from one balance to
//! another (the paper's Table 4). A Universal Controller observes the true mu,
//! a domain-randomised student only the state: it learns the expert's action
//! averaged over the mus that pass through the states it sees.
//!
//! The input normalisation is frozen from round 0's states. The policy file is
//! the PPO one ([`Policy`]: tanh hidden layers, a linear mean action, clamped
//! to [-1, 1] when acting; its `log_std` is unused and set to
//! [`DaggerConfig::log_std`]). Everything runs on one thread from one seed:
//! the same seed gives bitwise the same weights.

use std::time::Instant;

use rand::rngs::StdRng;
use rand::{RngExt, SeedableRng};
use rand_distr::{Distribution, Normal};

use super::policy::{input_dim, observation, Policy, PolicyKind, TrainingInfo};
use super::stats::{normalize_into, RunningStats};
use crate::control::ilqr::{Mpc, MpcOptions};
use crate::control::ControlError;
use crate::nn::{fit_least_squares, Mlp, Schedule};
use crate::tasks::{sample_mu, Env, Task};

#[derive(Clone, Debug, PartialEq)]
pub struct DaggerConfig {
    pub seed: u64,
    pub rounds: usize,
    /// Episodes per round.
    pub episodes: usize,
    /// Hidden layer widths of the student.
    pub hidden: Vec<usize>,
    /// Epochs of the refit after each round, its minibatch and Adam's step size.
    pub epochs: usize,
    pub batch: usize,
    pub lr: f64,
    /// The expert (its replanning period is one control step).
    pub horizon: usize,
    pub iterations: usize,
    /// Standard deviation of the noise on round 0's expert actions.
    pub noise: f64,
    /// Probability that an episode's mu changes once.
    pub change: f64,
    /// The saved policy's (unused) log standard deviation.
    pub log_std: f32,
    pub obs_clip: f64,
}

impl Default for DaggerConfig {
    /// The cartpole's settings: the paper's 2 x 64 network; the expert plans
    /// 60 control steps (1.2 s) with at most 10 iLQR iterations. One round of
    /// 240 noisy expert episodes: on the cartpole, rounds driven by the
    /// student measured worse (its failing states get expert labels that
    /// depend on the plan the expert was warm-started from, and the fit
    /// averages them).
    fn default() -> Self {
        DaggerConfig {
            seed: 0,
            rounds: 1,
            episodes: 240,
            hidden: vec![64, 64],
            epochs: 40,
            batch: 256,
            lr: 1e-3,
            horizon: 60,
            iterations: 10,
            noise: 0.2,
            change: 0.5,
            log_std: -2.0,
            obs_clip: 10.0,
        }
    }
}

impl DaggerConfig {
    fn expert(&self) -> MpcOptions {
        MpcOptions::new(self.horizon, 1, self.iterations)
    }
}

/// One round of the learning curve.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct RoundRow {
    pub round: usize,
    /// Labelled states so far (one per control step run).
    pub env_steps: usize,
    /// Mean task metric of the round's episodes (the expert's in round 0,
    /// the student's after).
    pub mean_metric: f64,
    /// Held-out mean squared error of the student's action after the refit.
    pub held_out_mse: f64,
    pub seconds: f64,
}

impl RoundRow {
    pub const CSV_HEADER: &'static str = "round,env_steps,mean_metric,held_out_mse,seconds";

    pub fn csv(&self) -> String {
        format!(
            "{},{},{},{},{:.3}",
            self.round, self.env_steps, self.mean_metric, self.held_out_mse, self.seconds
        )
    }
}

/// Labelled states: raw policy inputs and the expert's actions, row-major.
#[derive(Default)]
struct Dataset {
    inputs: Vec<f64>,
    actions: Vec<f64>,
}

/// Trains a policy of `kind` on `task` by DAgger; `progress` sees each round.
pub fn train_dagger(
    task: &dyn Task,
    kind: PolicyKind,
    config: &DaggerConfig,
    mut progress: impl FnMut(&RoundRow),
) -> Result<(Policy, Vec<RoundRow>), ControlError> {
    let started = Instant::now();
    let mut seeds = StdRng::seed_from_u64(config.seed);
    let mut init_rng = StdRng::seed_from_u64(seeds.random());
    let mut episode_rng = StdRng::seed_from_u64(seeds.random());
    let mut noise_rng = StdRng::seed_from_u64(seeds.random());
    let mut fit_rng = StdRng::seed_from_u64(seeds.random());
    let (dim, act) = (input_dim(kind, task), task.act_dim());
    let sizes = [&[dim][..], &config.hidden, &[act]].concat();
    let mut student = Policy {
        task: task.name().to_string(),
        kind,
        obs_mean: vec![0.0; dim],
        obs_std: vec![1.0; dim],
        obs_clip: config.obs_clip,
        actor: Mlp::new(&sizes, 0.01, &mut init_rng),
        log_std: vec![config.log_std; act],
        training: None,
    };
    let noise = Normal::new(0.0, config.noise).expect("a finite noise level");
    let (mut train, mut held_out) = (Dataset::default(), Dataset::default());
    let mut rows = vec![];
    for round in 0..config.rounds {
        let mut scores = vec![];
        for e in 0..config.episodes {
            let data = if e % 10 == 9 {
                &mut held_out
            } else {
                &mut train
            };
            let driver = (round > 0).then_some(&student);
            let mut perturb = |a: f64| a + noise.sample(&mut noise_rng);
            let score = run(
                task,
                config,
                (kind, driver),
                &mut perturb,
                &mut episode_rng,
                data,
            )?;
            scores.push(score);
        }
        if round == 0 {
            let mut stats = RunningStats::new(dim);
            stats.update(&train.inputs);
            student.obs_mean = stats.mean.clone();
            student.obs_std = stats.std();
        }
        let held_out_mse = refit(&mut student, config, (&train, &held_out), &mut fit_rng);
        let row = RoundRow {
            round,
            env_steps: (train.actions.len() + held_out.actions.len()) / act,
            mean_metric: scores.iter().sum::<f64>() / scores.len() as f64,
            held_out_mse,
            seconds: started.elapsed().as_secs_f64(),
        };
        progress(&row);
        rows.push(row);
    }
    let last = rows.last().expect("at least one round");
    student.training = Some(TrainingInfo {
        seed: config.seed,
        env_steps: last.env_steps,
        iterations: config.rounds,
        wall_seconds: started.elapsed().as_secs_f64(),
        final_metric: Some(last.mean_metric),
    });
    Ok((student, rows))
}

/// One episode driven by `driver` (the expert with `perturb` on its actions
/// when None), every state labelled by the expert into `data` as the input of
/// a policy of `kind`; its score.
fn run(
    task: &dyn Task,
    config: &DaggerConfig,
    (kind, driver): (PolicyKind, Option<&Policy>),
    perturb: &mut impl FnMut(f64) -> f64,
    rng: &mut StdRng,
    data: &mut Dataset,
) -> Result<f64, ControlError> {
    let mu = sample_mu(task, rng);
    let mut env = Env::new(task);
    env.reset(&mu, rng)?;
    let change = (rng.random::<f64>() < config.change).then(|| {
        let at = rng.random_range(1..task.horizon());
        (at, sample_mu(task, rng))
    });
    let options = config.expert();
    let mut expert = Mpc::new(task, &mu, &options)?;
    let mut score = 0.0;
    loop {
        let input = observation(kind, task, env.state(), env.mu());
        let (label, _) = expert.act(env.state())?;
        data.inputs.extend_from_slice(&input);
        data.actions.extend_from_slice(&label);
        let action: Vec<f64> = match driver {
            Some(student) => student.act(&input),
            None => label.iter().map(|&a| perturb(a).clamp(-1.0, 1.0)).collect(),
        };
        let out = env.step(&action)?;
        score += out.metric;
        if out.terminated || out.truncated {
            return Ok(score);
        }
        if let Some((at, new_mu)) = &change {
            if env.t() == *at {
                env.set_mu(new_mu)?;
                expert = Mpc::new(task, new_mu, &options)?;
            }
        }
    }
}

/// Refits the student on `train` for the configured epochs; its held-out
/// mean squared error after.
fn refit(
    student: &mut Policy,
    config: &DaggerConfig,
    (train, held_out): (&Dataset, &Dataset),
    rng: &mut StdRng,
) -> f64 {
    let normalize = |raw: &[f64]| {
        let mut z = Vec::with_capacity(raw.len());
        normalize_into(
            &student.obs_mean,
            &student.obs_std,
            student.obs_clip,
            raw,
            &mut z,
        );
        z
    };
    let (z_train, z_held) = (normalize(&train.inputs), normalize(&held_out.inputs));
    let schedule = Schedule {
        epochs: config.epochs,
        batch: config.batch,
        lr: config.lr,
    };
    let losses = fit_least_squares(
        &mut student.actor,
        ((&z_train, &train.actions), (&z_held, &held_out.actions)),
        schedule,
        rng,
        |_, _| {},
    );
    *losses.last().expect("the initial loss at least")
}
