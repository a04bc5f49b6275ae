//! A trained policy and its weights file.
//!
//! The file is JSON (`format: "diffosi-policy/1"`):
//! - `task`: the task name; `kind`: `"uc"` (input = task observation, then
//!   mu) or `"dr"` (task observation only);
//! - `obs_mean`, `obs_std`, `obs_clip`: the input is
//!   z = clip((input - obs_mean) / obs_std, -obs_clip, obs_clip);
//! - `layers`: one `{"w": [[...], ...], "b": [...]}` per layer, `w` as
//!   `out` rows of `in` values; hidden layers are tanh(w z + b), the last is
//!   linear and gives the mean action;
//! - `log_std`: the Gaussian head's state-independent log standard deviation
//!   (used in training; evaluation acts with the mean);
//! - `training`: how the policy was made (informational).
//!
//! The action is the mean clamped to [-1, 1]; the task maps it to forces. In
//! Python:
//! ```text
//! p = json.load(open(path))
//! z = np.clip((x - p["obs_mean"]) / p["obs_std"], -p["obs_clip"], p["obs_clip"])
//! for i, layer in enumerate(p["layers"]):
//!     z = np.asarray(layer["w"]) @ z + layer["b"]
//!     z = np.tanh(z) if i + 1 < len(p["layers"]) else z
//! action = np.clip(z, -1, 1)
//! ```

use std::path::Path;

use serde::{Deserialize, Serialize};

use super::stats::normalize_into;
use crate::model::State;
use crate::nn::{LayerFile, Mlp, Tape};
use crate::tasks::Task;

const FORMAT: &str = "diffosi-policy/1";

/// What a policy observes besides the task state.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "lowercase")]
pub enum PolicyKind {
    /// Universal Controller: the task observation and mu.
    Uc,
    /// Domain-randomised baseline: the task observation only.
    Dr,
}

/// How a policy was trained, kept in its file.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct TrainingInfo {
    pub seed: u64,
    pub env_steps: usize,
    pub iterations: usize,
    pub wall_seconds: f64,
    /// Mean task metric of the last episodes of training (None if no
    /// episode finished).
    pub final_metric: Option<f64>,
}

#[derive(Clone, Debug, PartialEq)]
pub struct Policy {
    pub task: String,
    pub kind: PolicyKind,
    pub obs_mean: Vec<f64>,
    pub obs_std: Vec<f64>,
    pub obs_clip: f64,
    pub actor: Mlp<f32>,
    pub log_std: Vec<f32>,
    pub training: Option<TrainingInfo>,
}

#[derive(Serialize, Deserialize)]
struct File {
    format: String,
    task: String,
    kind: PolicyKind,
    obs_mean: Vec<f64>,
    obs_std: Vec<f64>,
    obs_clip: f64,
    layers: Vec<LayerFile>,
    log_std: Vec<f32>,
    training: Option<TrainingInfo>,
}

impl Policy {
    /// The policy's input for a task state, given the mu it is fed (ignored
    /// by a domain-randomised policy).
    pub fn observation(&self, task: &dyn Task, state: &State, mu: &[f64]) -> Vec<f64> {
        observation(self.kind, task, state, mu)
    }

    /// The deterministic action (the Gaussian's mean, clamped to [-1, 1]).
    pub fn act(&self, input: &[f64]) -> Vec<f64> {
        let mut z = Vec::with_capacity(input.len());
        normalize_into(&self.obs_mean, &self.obs_std, self.obs_clip, input, &mut z);
        let mut tape = Tape::default();
        let mean = self.actor.forward(&z, &mut tape);
        mean.iter().map(|&a| (a as f64).clamp(-1.0, 1.0)).collect()
    }

    pub fn save(&self, path: &Path) -> Result<(), String> {
        let file = File {
            format: FORMAT.into(),
            task: self.task.clone(),
            kind: self.kind,
            obs_mean: self.obs_mean.clone(),
            obs_std: self.obs_std.clone(),
            obs_clip: self.obs_clip,
            layers: self.actor.to_files(),
            log_std: self.log_std.clone(),
            training: self.training.clone(),
        };
        let text = serde_json::to_string(&file).expect("a policy serialises");
        std::fs::write(path, text).map_err(|e| format!("cannot write {}: {e}", path.display()))
    }

    pub fn load(path: &Path) -> Result<Policy, String> {
        let shown = path.display();
        let text =
            std::fs::read_to_string(path).map_err(|e| format!("cannot read {shown}: {e}"))?;
        let file: File =
            serde_json::from_str(&text).map_err(|e| format!("{shown}: not a policy file: {e}"))?;
        if file.format != FORMAT {
            return Err(format!(
                "{shown}: format '{}', expected '{FORMAT}'",
                file.format
            ));
        }
        let bad = |why: String| format!("{shown}: {why}");
        let actor = Mlp::from_files(&file.layers).map_err(bad)?;
        let inputs = actor.inputs();
        if file.obs_mean.len() != inputs || file.obs_std.len() != inputs {
            return Err(bad(format!("obs_mean and obs_std need {inputs} values")));
        }
        if file.log_std.len() != actor.outputs() {
            return Err(bad(format!("log_std needs {} values", actor.outputs())));
        }
        Ok(Policy {
            task: file.task,
            kind: file.kind,
            obs_mean: file.obs_mean,
            obs_std: file.obs_std,
            obs_clip: file.obs_clip,
            actor,
            log_std: file.log_std,
            training: file.training,
        })
    }
}

/// A policy input: the task's observation, then mu for a Universal Controller.
pub(super) fn observation(
    kind: PolicyKind,
    task: &dyn Task,
    state: &State,
    mu: &[f64],
) -> Vec<f64> {
    let mut out = Vec::with_capacity(task.obs_dim() + mu.len());
    task.observe(state, &mut out);
    if kind == PolicyKind::Uc {
        out.extend_from_slice(mu);
    }
    out
}

/// Input size of a policy of this kind on a task.
pub(super) fn input_dim(kind: PolicyKind, task: &dyn Task) -> usize {
    match kind {
        PolicyKind::Uc => task.obs_dim() + task.mu_map().nmu,
        PolicyKind::Dr => task.obs_dim(),
    }
}
