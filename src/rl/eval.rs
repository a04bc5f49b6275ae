//! Evaluation of a trained policy: episodes of its task with the true mu
//! drawn uniformly, the policy fed mu from a chosen source, acting with its
//! mean action. The score of an episode is the task metric.

use rand::rngs::StdRng;
use rand::SeedableRng;

use super::Policy;
use crate::control::{
    run_episode, AverageMu, ControlError, Episode, MuEstimator, OracleMu, RandomMu,
};
use crate::tasks::{EnvError, Task};

/// Where a Universal Controller's mu comes from during evaluation (a
/// domain-randomised policy ignores it). Each source fixes the fed mu at the
/// start of an episode; the online identifiers are in
/// [`crate::control::Source`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, clap::ValueEnum)]
#[serde(rename_all = "lowercase")]
pub enum MuSource {
    /// The episode's true mu (UC-Oracle).
    Oracle,
    /// A guess drawn uniformly in the task's mu box, independent of the true mu
    /// (UC-Random).
    Random,
    /// The middle of the task's mu box (UC-Average).
    Average,
}

/// Per-episode results of an evaluation.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Evaluation {
    pub metrics: Vec<f64>,
    pub mu_true: Vec<Vec<f64>>,
    pub mu_fed: Vec<Vec<f64>>,
}

impl Evaluation {
    pub fn mean(&self) -> f64 {
        mean_std(&self.metrics).0
    }

    /// The population standard deviation of the episode metrics.
    pub fn std(&self) -> f64 {
        mean_std(&self.metrics).1
    }
}

/// Mean and population standard deviation.
pub fn mean_std(x: &[f64]) -> (f64, f64) {
    let n = x.len() as f64;
    let mean = x.iter().sum::<f64>() / n;
    let var = x.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / n;
    (mean, var.sqrt())
}

/// Runs `episodes` episodes. The true mu and initial states depend only on
/// `seed`, so every policy and every source meets the same episodes; random
/// guesses come from a second stream of the same seed.
pub fn evaluate(
    task: &dyn Task,
    policy: &Policy,
    source: MuSource,
    episodes: usize,
    seed: u64,
) -> Result<Evaluation, EnvError> {
    let mut episode_rng = StdRng::seed_from_u64(seed);
    let mut estimator: Box<dyn MuEstimator> = match source {
        MuSource::Oracle => Box::new(OracleMu::default()),
        MuSource::Random => Box::new(RandomMu::new(task, seed ^ 0x6a09_e667_f3bc_c908)),
        MuSource::Average => Box::new(AverageMu::new(task)),
    };
    let mut result = Evaluation {
        metrics: vec![],
        mu_true: vec![],
        mu_fed: vec![],
    };
    for _ in 0..episodes {
        let episode = Episode::draw(task, &mut episode_rng);
        let trace = match run_episode(task, policy, Some(estimator.as_mut()), &episode) {
            Ok(trace) => trace,
            Err(ControlError::Env(e)) => return Err(e),
            Err(e) => unreachable!("fixed mu sources do not identify: {e}"),
        };
        result.metrics.push(trace.score());
        result.mu_true.push(episode.mu);
        result
            .mu_fed
            .push(trace.mu_hat.first().cloned().unwrap_or_default());
    }
    Ok(result)
}
