//! Reinforcement learning of the task controllers: PPO (Schulman et al., 2017)
//! with a Gaussian policy, and the evaluation of trained policies.
//!
//! Two kinds of policy share the machinery ([`PolicyKind`]): the Universal
//! Controller, which observes the task state and mu, and the
//! domain-randomised baseline, which observes the state only. Both are
//! trained with mu drawn afresh for every episode.

mod apg;
mod dagger;
mod eval;
mod policy;
mod ppo;
mod stats;

pub use apg::{train_apg, ApgConfig, ApgRow};
pub use dagger::{train_dagger, DaggerConfig, RoundRow};
pub use eval::{evaluate, mean_std, Evaluation, MuSource};
pub use policy::{Policy, PolicyKind, TrainingInfo};
pub use ppo::{train, train_from, CurveRow, PpoConfig, Trained};
pub use stats::RunningStats;
