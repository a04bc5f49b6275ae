//! UC-MLP, the learned identifier of Yu et al. (2017) that the paper compares
//! against: an MLP (tanh hidden layers, the paper's 256, 128, 64 on the
//! cartpole and 512, 128 on the half cheetah; linear output) that predicts mu
//! from the observations DiffOSI sees.
//!
//! Conventions:
//! - Input: the last [`MlpConfig::transitions`] transitions (default 4, a
//!   context window of N = 5 states), oldest first, each as q_t, v_t, tau_t,
//!   q_t+1, v_t+1 (SI units, tau the generalized forces on every dof). Each
//!   input component is standardised, z = (x - input_mean) / input_std, with
//!   the statistics of the training set (a constant component gets std 1).
//! - Output: y, with mu = mid + half y, where mid and half are the centre and
//!   half-width of the training range of mu (so y lies in [-1, 1] on it).
//!   The prediction is not clamped here; a caller feeding a controller clamps
//!   it to the controller's range.
//! - Training data: episodes of the task in our engine with mu uniform in the
//!   training range, driven by the given Universal Controllers fed the true mu
//!   and sampling their Gaussian actions (the exploration they were trained
//!   with, so the states cover more than the deterministic controller visits);
//!   every run of consecutive transitions of an episode is one example. The
//!   loss is the mean squared error of y; Adam on minibatches; a tenth of the
//!   episodes is held out and its loss reported after every epoch.
//!
//! The weights file is JSON (`format: "diffosi-mu-mlp/1"`): `task`,
//! `transitions`, `input_mean`, `input_std`, `mu_lower`, `mu_upper` (the
//! training range), `layers` (as in the policy files: `w` as `out` rows of
//! `in` values, `b`), `training` (informational). In Python:
//! ```text
//! f = json.load(open(path)); z = (x - f["input_mean"]) / f["input_std"]
//! for i, l in enumerate(f["layers"]):
//!     z = np.asarray(l["w"]) @ z + l["b"]; z = np.tanh(z) if i + 1 < len(f["layers"]) else z
//! lo, hi = np.array(f["mu_lower"]), np.array(f["mu_upper"]); mu = (lo + hi) / 2 + (hi - lo) / 2 * z
//! ```

use std::path::Path;
use std::time::Instant;

use rand::rngs::StdRng;
use rand::SeedableRng;
use rand_distr::{Distribution, StandardNormal};
use serde::{Deserialize, Serialize};

use crate::derivatives::Transition;
use crate::nn::{fit_least_squares, Activation, LayerFile, Mlp, Schedule, Tape};
use crate::rl::Policy;
use crate::tasks::{uniform_in, Env, EnvError, Task};

const FORMAT: &str = "diffosi-mu-mlp/1";

/// How a UC-MLP is made.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct MlpConfig {
    pub seed: u64,
    /// Training range of mu, per component.
    pub mu_lower: Vec<f64>,
    pub mu_upper: Vec<f64>,
    /// Transitions per input.
    pub transitions: usize,
    pub hidden: Vec<usize>,
    /// The hidden layers' nonlinearity (tanh unless a file says otherwise).
    #[serde(default)]
    pub activation: Activation,
    /// Episodes collected per controller.
    pub episodes: usize,
    pub epochs: usize,
    pub batch: usize,
    /// Adam's step size, annealed linearly to zero.
    pub lr: f64,
}

impl MlpConfig {
    /// The paper's network (256, 128, 64) on a mu range, with the settings
    /// used for the shipped cartpole weights.
    pub fn new(mu_lower: &[f64], mu_upper: &[f64]) -> MlpConfig {
        MlpConfig {
            seed: 0,
            mu_lower: mu_lower.to_vec(),
            mu_upper: mu_upper.to_vec(),
            transitions: 4,
            hidden: vec![256, 128, 64],
            activation: Activation::Tanh,
            episodes: 150,
            epochs: 30,
            batch: 256,
            lr: 1e-3,
        }
    }
}

impl MlpConfig {
    /// The settings for a task by name on a mu range: [`MlpConfig::new`] for
    /// the cartpole; for the half cheetah the paper's hidden layers (512,
    /// 128), 20 episodes (20 000 examples) per controller and 20 epochs (the
    /// paper's 600 000 examples would take an hour here).
    pub fn for_task(task: &str, mu_lower: &[f64], mu_upper: &[f64]) -> MlpConfig {
        let config = MlpConfig::new(mu_lower, mu_upper);
        match task {
            "half_cheetah" | "half_cheetah_contact" => MlpConfig {
                hidden: vec![512, 128],
                episodes: 20,
                epochs: 20,
                ..config
            },
            _ => config,
        }
    }
}

/// How the weights were made, kept in their file.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct MlpTraining {
    pub config: MlpConfig,
    pub examples: usize,
    /// Mean squared error of y on the held-out episodes before training, then
    /// after each epoch.
    pub validation_loss: Vec<f64>,
    pub wall_seconds: f64,
}

/// A trained UC-MLP (see the module docs).
#[derive(Clone, Debug, PartialEq)]
pub struct MuMlp {
    pub task: String,
    pub transitions: usize,
    pub input_mean: Vec<f64>,
    pub input_std: Vec<f64>,
    pub mu_lower: Vec<f64>,
    pub mu_upper: Vec<f64>,
    pub net: Mlp<f32>,
    pub training: Option<MlpTraining>,
}

#[derive(Serialize, Deserialize)]
struct File {
    format: String,
    task: String,
    transitions: usize,
    input_mean: Vec<f64>,
    input_std: Vec<f64>,
    mu_lower: Vec<f64>,
    mu_upper: Vec<f64>,
    layers: Vec<LayerFile>,
    #[serde(default)]
    activation: Activation,
    training: Option<MlpTraining>,
}

/// Appends the raw input of a run of transitions (oldest first).
fn features(window: &[Transition], out: &mut Vec<f64>) {
    for t in window {
        for x in [&t.start.q, &t.start.v, &t.tau, &t.next.q, &t.next.v] {
            out.extend_from_slice(x);
        }
    }
}

impl MuMlp {
    /// mu predicted from the last `transitions` transitions of `window`
    /// (oldest first); None if it holds fewer.
    pub fn predict(&self, window: &[Transition]) -> Option<Vec<f64>> {
        let k = self.transitions;
        if window.len() < k {
            return None;
        }
        let mut raw = vec![];
        features(&window[window.len() - k..], &mut raw);
        let z: Vec<f32> = raw
            .iter()
            .zip(self.input_mean.iter().zip(&self.input_std))
            .map(|(x, (m, s))| ((x - m) / s) as f32)
            .collect();
        let y = self.net.forward(&z, &mut Tape::default()).to_vec();
        Some(self.denormalize(&y))
    }

    fn denormalize(&self, y: &[f32]) -> Vec<f64> {
        let lo_hi = self.mu_lower.iter().zip(&self.mu_upper);
        lo_hi
            .zip(y)
            .map(|((l, h), &y)| 0.5 * (l + h) + 0.5 * (h - l) * y as f64)
            .collect()
    }

    pub fn save(&self, path: &Path) -> Result<(), String> {
        let file = File {
            format: FORMAT.into(),
            task: self.task.clone(),
            transitions: self.transitions,
            input_mean: self.input_mean.clone(),
            input_std: self.input_std.clone(),
            mu_lower: self.mu_lower.clone(),
            mu_upper: self.mu_upper.clone(),
            layers: self.net.to_files(),
            activation: self.net.activation(),
            training: self.training.clone(),
        };
        let text = serde_json::to_string(&file).expect("a UC-MLP serialises");
        std::fs::write(path, text).map_err(|e| format!("cannot write {}: {e}", path.display()))
    }

    pub fn load(path: &Path) -> Result<MuMlp, String> {
        let shown = path.display();
        let text =
            std::fs::read_to_string(path).map_err(|e| format!("cannot read {shown}: {e}"))?;
        let file: File =
            serde_json::from_str(&text).map_err(|e| format!("{shown}: not a UC-MLP file: {e}"))?;
        if file.format != FORMAT {
            return Err(format!(
                "{shown}: format '{}', expected '{FORMAT}'",
                file.format
            ));
        }
        let bad = |why: String| format!("{shown}: {why}");
        let net = Mlp::from_files(&file.layers)
            .map_err(bad)?
            .with_activation(file.activation);
        let nmu = net.outputs();
        if file.input_mean.len() != net.inputs() || file.input_std.len() != net.inputs() {
            return Err(bad(format!(
                "input_mean and input_std need {} values",
                net.inputs()
            )));
        }
        if file.mu_lower.len() != nmu || file.mu_upper.len() != nmu || file.transitions == 0 {
            return Err(bad(format!(
                "mu_lower and mu_upper need {nmu} values, transitions >= 1"
            )));
        }
        Ok(MuMlp {
            task: file.task,
            transitions: file.transitions,
            input_mean: file.input_mean,
            input_std: file.input_std,
            mu_lower: file.mu_lower,
            mu_upper: file.mu_upper,
            net,
            training: file.training,
        })
    }
}

/// Training examples: raw inputs (rows) and normalised targets y.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Dataset {
    inputs: Vec<f64>,
    targets: Vec<f64>,
}

impl Dataset {
    fn len(&self, nmu: usize) -> usize {
        self.targets.len() / nmu
    }

    /// One example: a run of transitions (oldest first) made at mu, with
    /// mu's training range.
    pub fn push(&mut self, run: &[Transition], mu: &[f64], (lower, upper): (&[f64], &[f64])) {
        features(run, &mut self.inputs);
        let y = mu
            .iter()
            .zip(lower.iter().zip(upper))
            .map(|(m, (l, h))| (m - 0.5 * (l + h)) / (0.5 * (h - l)));
        self.targets.extend(y);
    }
}

/// Runs each controller for `config.episodes` episodes (see the module docs)
/// and returns the training and the held-out examples.
fn collect(
    task: &dyn Task,
    controllers: &[Policy],
    config: &MlpConfig,
) -> Result<(Dataset, Dataset), EnvError> {
    let mut rng = StdRng::seed_from_u64(config.seed);
    let (mut train, mut held_out) = (Dataset::default(), Dataset::default());
    let mut env = Env::new(task);
    let k = config.transitions;
    for policy in controllers {
        let std: Vec<f64> = policy.log_std.iter().map(|s| (*s as f64).exp()).collect();
        for episode in 0..config.episodes {
            let mu = uniform_in(&config.mu_lower, &config.mu_upper, &mut rng);
            env.reset(&mu, &mut rng)?;
            let mut history: Vec<Transition> = vec![];
            loop {
                let mean = policy.act(&policy.observation(task, env.state(), &mu));
                let action: Vec<f64> = mean
                    .iter()
                    .zip(&std)
                    .map(|(m, s)| {
                        let z: f64 = StandardNormal.sample(&mut rng);
                        m + s * z
                    })
                    .collect();
                let out = env.step(&action)?;
                history.push(env.last_transition().expect("a step was taken"));
                if out.terminated || out.truncated {
                    break;
                }
            }
            let set = if episode % 10 == 9 {
                &mut held_out
            } else {
                &mut train
            };
            for run in history.windows(k) {
                set.push(run, &mu, (&config.mu_lower, &config.mu_upper));
            }
        }
    }
    Ok((train, held_out))
}

/// Mean and standard deviation of each input component (std 1 where constant).
fn input_stats(rows: &[f64], dim: usize) -> (Vec<f64>, Vec<f64>) {
    let n = (rows.len() / dim) as f64;
    let mut mean = vec![0.0; dim];
    let mut var = vec![0.0; dim];
    for row in rows.chunks_exact(dim) {
        mean.iter_mut().zip(row).for_each(|(m, x)| *m += x / n);
    }
    for row in rows.chunks_exact(dim) {
        for i in 0..dim {
            var[i] += (row[i] - mean[i]).powi(2) / n;
        }
    }
    let std = var
        .iter()
        .map(|v| if *v > 1e-24 { v.sqrt() } else { 1.0 })
        .collect();
    (mean, std)
}

/// Standardised f32 rows.
fn standardise(rows: &[f64], mean: &[f64], std: &[f64]) -> Vec<f32> {
    let dim = mean.len();
    rows.iter()
        .enumerate()
        .map(|(k, x)| ((x - mean[k % dim]) / std[k % dim]) as f32)
        .collect()
}

/// Collects data with the Universal Controllers `controllers` and trains a
/// UC-MLP; `progress` sees (epoch, held-out loss) after every epoch.
pub fn train_mlp(
    task: &dyn Task,
    controllers: &[Policy],
    config: &MlpConfig,
    progress: impl FnMut(usize, f64),
) -> Result<MuMlp, EnvError> {
    let started = Instant::now();
    let nmu = task.mu_map().nmu;
    assert_eq!(config.mu_lower.len(), nmu, "mu_lower has nmu values");
    assert_eq!(config.mu_upper.len(), nmu, "mu_upper has nmu values");
    let data = collect(task, controllers, config)?;
    Ok(fit_mlp(task.name(), data, config, started, progress))
}

/// Trains a UC-MLP on collected examples (training, held out) of mu's
/// range in `config`; `progress` as for [`train_mlp`], `started` when the
/// collection began (for the wall time kept in the file).
pub fn fit_mlp(
    task: &str,
    (train, held_out): (Dataset, Dataset),
    config: &MlpConfig,
    started: Instant,
    progress: impl FnMut(usize, f64),
) -> MuMlp {
    let nmu = config.mu_lower.len();
    let dim = train.inputs.len() / train.len(nmu).max(1);
    let (input_mean, input_std) = input_stats(&train.inputs, dim);
    let z_train = standardise(&train.inputs, &input_mean, &input_std);
    let z_held = standardise(&held_out.inputs, &input_mean, &input_std);
    let mut rng = StdRng::seed_from_u64(config.seed ^ 0x5bd1_e995);
    let sizes = [&[dim][..], &config.hidden, &[nmu]].concat();
    let mut net = Mlp::<f32>::new(&sizes, 1.0, &mut rng).with_activation(config.activation);
    let schedule = Schedule {
        epochs: config.epochs,
        batch: config.batch,
        lr: config.lr,
    };
    let train = (z_train.as_slice(), train.targets.as_slice());
    let held_out = (z_held.as_slice(), held_out.targets.as_slice());
    let validation_loss =
        fit_least_squares(&mut net, (train, held_out), schedule, &mut rng, progress);
    let examples = train.1.len() / nmu;
    MuMlp {
        task: task.into(),
        transitions: config.transitions,
        input_mean,
        input_std,
        mu_lower: config.mu_lower.clone(),
        mu_upper: config.mu_upper.clone(),
        net,
        training: Some(MlpTraining {
            config: config.clone(),
            examples,
            validation_loss,
            wall_seconds: started.elapsed().as_secs_f64(),
        }),
    }
}
