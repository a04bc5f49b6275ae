//! The paper's cartpole and half cheetah experiments as runnable studies: "methods x trained
//! models x episodes" ([`run`]), summarised like the paper's tables
//! ([`markdown`]), and the context-window study ([`window_study`]).
//!
//! Episodes. From `seed`, one stream draws `models x episodes` episodes (true
//! mu uniform in the task's range, then the initial state); model m meets
//! episodes m E .. (m + 1) E - 1, and every method meets the same ones. With
//! `change_at = Some(t)`, a second stream of the seed draws each episode's new
//! mu', which takes effect from control step t (Table 4). Random guesses are
//! seeded from `seed` and the model index. Jobs (method, model) run on all
//! cores but each is sequential and seeded, so the same seed gives the same
//! numbers, bit for bit.
//!
//! Metrics of an episode (control steps t = 0 .. T - 1, T its length):
//! - `mu_mae`: mean over t (and over mu's components) of |mu_hat_t - mu_t|,
//!   where mu_hat_t is the mu fed to the controller at step t;
//! - `mu_mare`: mean over t of |mu_hat_t - mu_t| / max(|mu_t|, floor), floor
//!   a tenth of the half-width of the range (0.06 m on the cartpole, 2.45 kg
//!   on the half cheetah), so a true mu near zero does not divide by zero;
//! - `score`: the task metric summed over the episode;
//! - `fell`: whether the task's termination ended it (a fall), its horizon
//!   not reached.
//!
//! The table reports mean +- population standard deviation of each over all
//! models' episodes pooled, and each method's task performance as a fraction
//! of UC-Oracle's; the results JSON also the fraction of episodes that fell.
//!
//! Results JSON (`results_json`): `experiment`, `task`, `seed`, `models`
//! (file names), `episodes_per_model`, `change_at`, and `methods`, each with
//! `label`, `policy` ("uc"/"dr"), `source` (null for DR), `summary`
//! (`mu_mae`, `mu_mare`, `task`: [mean, std], null for DR's mu errors;
//! `mu_mae_by_component`, the mean of the episodes'; `fall_fraction`;
//! `by_mu`: [`MuBin`]s with `lo`, `hi`, `episodes`, `mean`;
//! `fraction_of_oracle`), `paper` (the paper's row as printed, or null) and
//! `episodes`: per episode `model`, `mu`, `change` ([t, mu'] or null),
//! `score`, `mu_mae`, `mu_mae_by_component` (per component of mu, the mean
//! over t of |mu_hat_t - mu_t|), `mu_mare`, `fell`, and per step `metric` and `mu_error`
//! (mu_hat_t - mu_t, 4 significant digits; empty for DR).
//!
//! Window study JSON (`window_json`): `task`, `seed`, `models`,
//! `episodes_per_model`, `steps` (the horizon), and `curves`, one per context
//! window N with `context_window` (N), `transitions` (N - 1), `mean_abs_error`
//! (length `steps`: at step t the mean over the episodes still running of
//! |mu_hat_t - mu_t|, null where none runs) and `running` (how many
//! episodes reached step t).

mod report;
pub mod wiping;
pub mod wiping_dims;

pub use report::{markdown, results_json, window_json, window_svg};

use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;

use rand::rngs::StdRng;
use rand::SeedableRng;

use crate::control::{run_episode, ControlError, Episode, MuEstimator, Source, Sources, Trace};
use crate::rl::{mean_std, Policy, PolicyKind};
use crate::tasks::{sample_mu, Task};

/// One row of a table: a policy kind and, for a Universal Controller, where
/// its mu comes from.
#[derive(Clone, Debug, PartialEq)]
pub struct Method {
    pub label: String,
    pub policy: PolicyKind,
    pub source: Option<Source>,
    /// The paper's row (mean abs. error, mean abs. rel. error, task
    /// performance), as printed there.
    pub paper: Option<[&'static str; 3]>,
}

impl Method {
    pub fn uc(label: &str, source: Source, paper: Option<[&'static str; 3]>) -> Method {
        Method {
            label: label.into(),
            policy: PolicyKind::Uc,
            source: Some(source),
            paper,
        }
    }
}

/// A study: which methods, how many episodes per model, the seed, and an
/// optional change of mu.
#[derive(Clone, Debug, PartialEq)]
pub struct Study {
    pub name: String,
    pub methods: Vec<Method>,
    pub episodes: usize,
    pub seed: u64,
    pub change_at: Option<usize>,
}

impl Study {
    /// The paper's Table 1: 8 methods, 10 episodes per model.
    pub fn table1(seed: u64) -> Study {
        let dr = Method {
            label: "DR".into(),
            policy: PolicyKind::Dr,
            source: None,
            paper: Some(["N/A", "N/A", "277.77 ± 169.63"]),
        };
        Study {
            name: "table1".into(),
            methods: vec![
                dr,
                Method::uc(
                    "UC-Random",
                    Source::Random,
                    Some(["0.45 ± 0.11", "1.42 ± 1.50", "169.63 ± 127.92"]),
                ),
                Method::uc(
                    "UC-Average",
                    Source::Average,
                    Some(["0.39 ± 0.15", "0.50 ± 0.00", "215.83 ± 126.89"]),
                ),
                Method::uc(
                    "UC-MLP-Narrow",
                    Source::MlpNarrow,
                    Some(["0.32 ± 0.12", "0.60 ± 0.13", "242.77 ± 157.96"]),
                ),
                Method::uc(
                    "UC-MLP",
                    Source::Mlp,
                    Some(["0.09 ± 0.03", "0.38 ± 0.43", "309.23 ± 72.55"]),
                ),
                Method::uc("UC-CMA-ES", Source::Cmaes, None),
                Method::uc(
                    "UC-DiffOSI",
                    Source::Diffosi,
                    Some(["0.09 ± 0.07", "0.13 ± 0.05", "390.77 ± 95.67"]),
                ),
                Method::uc(
                    "UC-Oracle",
                    Source::Oracle,
                    Some(["0.00 ± 0.00", "0.00 ± 0.00", "451.33 ± 48.59"]),
                ),
            ],
            episodes: 10,
            seed,
            change_at: None,
        }
    }

    /// The paper's Table 2 (half cheetah): 6 methods, 3 episodes per model
    /// (the paper's "each model evaluated on 3 random seeds").
    pub fn table2(seed: u64) -> Study {
        let dr = Method {
            label: "DR".into(),
            policy: PolicyKind::Dr,
            source: None,
            paper: Some(["N/A", "N/A", "2546.51 ± 1593.81"]),
        };
        Study {
            name: "table2".into(),
            methods: vec![
                dr,
                Method::uc(
                    "UC-Random",
                    Source::Random,
                    Some(["19.11 ± 12.97", "2.27 ± 3.42", "3567.45 ± 588.88"]),
                ),
                Method::uc(
                    "UC-Average",
                    Source::Average,
                    Some(["17.97 ± 2.85", "2.24 ± 2.63", "3596.58 ± 802.73"]),
                ),
                Method::uc(
                    "UC-MLP",
                    Source::Mlp,
                    Some(["9.25 ± 10.20", "1.27 ± 2.25", "3102.02 ± 2202.76"]),
                ),
                Method::uc(
                    "UC-DiffOSI",
                    Source::Diffosi,
                    Some(["0.06 ± 0.14", "0.01 ± 0.02", "3930.97 ± 801.29"]),
                ),
                Method::uc(
                    "UC-Oracle",
                    Source::Oracle,
                    Some(["0.0 ± 0.0", "0.0 ± 0.0", "3936.30 ± 609.14"]),
                ),
            ],
            episodes: 3,
            seed,
            change_at: None,
        }
    }

    /// The paper's Table 4: mu changes at t = 250 to a new uniform mu'.
    pub fn table4(seed: u64) -> Study {
        Study {
            name: "table4".into(),
            methods: vec![
                Method::uc(
                    "UC-MLP",
                    Source::Mlp,
                    Some(["0.13 ± 0.06", "0.92 ± 0.84", "192.33 ± 160.02"]),
                ),
                Method::uc(
                    "UC-DiffOSI (change detection)",
                    Source::Diffosi,
                    Some(["0.02 ± 0.01", "0.27 ± 0.18", "222.33 ± 89.09"]),
                ),
                Method::uc(
                    "UC-DiffOSI (no change detection)",
                    Source::DiffosiNoCd,
                    None,
                ),
                Method::uc(
                    "UC-Oracle",
                    Source::Oracle,
                    Some(["0.00 ± 0.00", "0.00 ± 0.00", "435.00 ± 91.92"]),
                ),
            ],
            episodes: 10,
            seed,
            change_at: Some(250),
        }
    }
}

/// One episode's record.
#[derive(Clone, Debug, PartialEq)]
pub struct EpisodeResult {
    pub model: usize,
    pub episode: Episode,
    pub trace: Trace,
    pub score: f64,
    /// None for a domain-randomised policy.
    pub mu_mae: Option<f64>,
    /// Per component of mu, the mean over t of |mu_hat_t - mu_t| (`mu_mae`
    /// is their mean); None for a domain-randomised policy.
    pub mu_mae_by_component: Option<Vec<f64>>,
    pub mu_mare: Option<f64>,
}

/// Mean and population standard deviation over the pooled episodes.
#[derive(Clone, Debug, PartialEq)]
pub struct Summary {
    pub mu_mae: Option<(f64, f64)>,
    /// The episodes' mean of [`EpisodeResult::mu_mae_by_component`].
    pub mu_mae_by_component: Option<Vec<f64>>,
    pub mu_mare: Option<(f64, f64)>,
    pub task: (f64, f64),
    /// The fraction of episodes that fell ([`Trace::fell`]).
    pub fall_fraction: f64,
    /// Task performance against the true mu ([`by_mu`]).
    pub by_mu: Vec<MuBin>,
}

/// The episodes whose true mu (its first component, at the start) lies in
/// [lo, hi): how many, and their mean score (None when there are none).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct MuBin {
    pub lo: f64,
    pub hi: f64,
    pub episodes: usize,
    pub mean: Option<f64>,
}

/// Bins of the task performance against the true mu: [`MU_BINS`] equal bins
/// of the range of mu's first component (the last bin closed), over `episodes`.
pub fn by_mu<'a>(
    task: &dyn Task,
    episodes: impl IntoIterator<Item = &'a EpisodeResult>,
) -> Vec<MuBin> {
    let (lo, hi) = task.mu_range();
    let (lo, width) = (lo[0], (hi[0] - lo[0]) / MU_BINS as f64);
    let mut sums = [(0usize, 0.0); MU_BINS];
    for e in episodes {
        let k = (((e.episode.mu[0] - lo) / width).floor().max(0.0) as usize).min(MU_BINS - 1);
        sums[k].0 += 1;
        sums[k].1 += e.score;
    }
    sums.iter()
        .enumerate()
        .map(|(k, &(n, total))| MuBin {
            lo: lo + k as f64 * width,
            hi: lo + (k + 1) as f64 * width,
            episodes: n,
            mean: (n > 0).then(|| total / n as f64),
        })
        .collect()
}

/// Bins of [`by_mu`]: on the cartpole, the first holds the poles with
/// mu <= -0.45 that are the hardest to balance.
pub const MU_BINS: usize = 8;

#[derive(Clone, Debug, PartialEq)]
pub struct MethodResult {
    pub method: Method,
    pub episodes: Vec<EpisodeResult>,
    pub summary: Summary,
}

#[derive(Clone, Debug, PartialEq)]
pub struct Results {
    pub study: Study,
    pub task: String,
    pub models: Vec<String>,
    pub methods: Vec<MethodResult>,
}

impl Results {
    /// A method's mean task performance over UC-Oracle's (None without an
    /// oracle row).
    pub fn fraction_of_oracle(&self, m: &MethodResult) -> Option<f64> {
        let oracle = self
            .methods
            .iter()
            .find(|r| r.method.source == Some(Source::Oracle))?;
        Some(m.summary.task.0 / oracle.summary.task.0)
    }
}

/// The trained models of a study: Universal Controllers and domain-randomised
/// policies, the same number of each when both are used, with their names.
pub struct Models<'a> {
    pub names: Vec<String>,
    pub uc: &'a [Policy],
    pub dr: &'a [Policy],
}

/// The study's episodes for `models` models (see the module docs).
pub fn episodes(task: &dyn Task, study: &Study, models: usize) -> Vec<Episode> {
    let mut rng = StdRng::seed_from_u64(study.seed);
    let mut changes = StdRng::seed_from_u64(study.seed ^ 0x9e37_79b9_7f4a_7c15);
    (0..models * study.episodes)
        .map(|_| {
            let mut episode = Episode::draw(task, &mut rng);
            if let Some(at) = study.change_at {
                episode.change = Some((at, sample_mu(task, &mut changes)));
            }
            episode
        })
        .collect()
}

/// Runs every (method, model) job on `threads` threads; `progress` is called
/// after every episode.
pub fn run(
    task: &dyn Task,
    models: &Models,
    sources: &Sources,
    study: &Study,
    threads: usize,
    progress: &(dyn Fn() + Sync),
) -> Result<Results, String> {
    let n_models = models.names.len();
    let all = episodes(task, study, n_models);
    let jobs: Vec<(usize, usize)> = (0..study.methods.len())
        .flat_map(|m| (0..n_models).map(move |k| (m, k)))
        .collect();
    let outputs = parallel(jobs.len(), threads, |j| {
        let (m, k) = jobs[j];
        let method = &study.methods[m];
        let policies = match method.policy {
            PolicyKind::Uc => models.uc,
            PolicyKind::Dr => models.dr,
        };
        let policy = policies
            .get(k)
            .ok_or_else(|| format!("no {:?} model {k}", method.policy))?;
        let mut estimator = match method.source {
            Some(source) => Some(sources.estimator(source, task, study.seed ^ (k as u64 + 1))?),
            None => None,
        };
        let mine = &all[k * study.episodes..(k + 1) * study.episodes];
        let mut done = Vec::with_capacity(mine.len());
        for episode in mine {
            let estimator: Option<&mut dyn MuEstimator> = match &mut estimator {
                Some(e) => Some(e.as_mut()),
                None => None,
            };
            let trace = run_episode(task, policy, estimator, episode)
                .map_err(|e: ControlError| e.to_string())?;
            progress();
            done.push(score_episode(task, k, episode.clone(), trace));
        }
        Ok(done)
    })?;
    let mut outputs = outputs.into_iter();
    let methods = study
        .methods
        .iter()
        .map(|method| {
            let episodes: Vec<EpisodeResult> = outputs.by_ref().take(n_models).flatten().collect();
            MethodResult {
                summary: summarise(task, &episodes),
                method: method.clone(),
                episodes,
            }
        })
        .collect();
    Ok(Results {
        study: study.clone(),
        task: task.name().into(),
        models: models.names.clone(),
        methods,
    })
}

/// Runs `n` jobs on up to `threads` threads, results in job order; the first
/// error (in job order) wins.
fn parallel<T: Send>(
    n: usize,
    threads: usize,
    job: impl Fn(usize) -> Result<T, String> + Sync,
) -> Result<Vec<T>, String> {
    let next = AtomicUsize::new(0);
    let slots: Vec<Mutex<Option<Result<T, String>>>> = (0..n).map(|_| Mutex::new(None)).collect();
    std::thread::scope(|scope| {
        for _ in 0..threads.clamp(1, n.max(1)) {
            scope.spawn(|| loop {
                let j = next.fetch_add(1, Ordering::Relaxed);
                if j >= n {
                    break;
                }
                let out = job(j);
                *slots[j].lock().expect("no panics while holding") = Some(out);
            });
        }
    });
    slots
        .into_iter()
        .map(|s| {
            s.into_inner()
                .expect("not poisoned")
                .expect("every job ran")
        })
        .collect()
}

/// The floor of the relative error's denominator: a tenth of each
/// component's half-width.
fn relative_floor(task: &dyn Task) -> Vec<f64> {
    let (lo, hi) = task.mu_range();
    lo.iter().zip(hi).map(|(l, h)| 0.05 * (h - l)).collect()
}

fn score_episode(task: &dyn Task, model: usize, episode: Episode, trace: Trace) -> EpisodeResult {
    let score = trace.score();
    let (mu_mae, mu_mae_by_component, mu_mare) = if trace.mu_hat.is_empty() {
        (None, None, None)
    } else {
        let floor = relative_floor(task);
        let mut abs = vec![0.0; floor.len()];
        let (mut rel, mut n) = (0.0, 0.0);
        for (hat, truth) in trace.mu_hat.iter().zip(&trace.mu_true) {
            for i in 0..hat.len() {
                let e = (hat[i] - truth[i]).abs();
                abs[i] += e;
                rel += e / truth[i].abs().max(floor[i]);
                n += 1.0;
            }
        }
        let mae = abs.iter().sum::<f64>() / n;
        let steps = trace.mu_hat.len() as f64;
        let by_component = abs.into_iter().map(|a| a / steps).collect();
        (Some(mae), Some(by_component), Some(rel / n))
    };
    EpisodeResult {
        model,
        episode,
        trace,
        score,
        mu_mae,
        mu_mae_by_component,
        mu_mare,
    }
}

/// The mean over `episodes` of their per-component mu errors (None for
/// none or a domain-randomised policy).
fn mean_by_component(episodes: &[EpisodeResult]) -> Option<Vec<f64>> {
    let each: Option<Vec<&Vec<f64>>> = episodes
        .iter()
        .map(|e| e.mu_mae_by_component.as_ref())
        .collect();
    let each = each.filter(|v| !v.is_empty())?;
    let n = each.len() as f64;
    Some(
        (0..each[0].len())
            .map(|i| each.iter().map(|e| e[i]).sum::<f64>() / n)
            .collect(),
    )
}

/// The fraction of `episodes` that fell (0 for none).
pub fn fall_fraction(episodes: &[EpisodeResult]) -> f64 {
    let fell = episodes.iter().filter(|e| e.trace.fell).count();
    fell as f64 / episodes.len().max(1) as f64
}

fn summarise(task: &dyn Task, episodes: &[EpisodeResult]) -> Summary {
    let stat = |f: &dyn Fn(&EpisodeResult) -> Option<f64>| {
        let values: Option<Vec<f64>> = episodes.iter().map(f).collect();
        values.filter(|v| !v.is_empty()).map(|v| mean_std(&v))
    };
    let scores: Vec<f64> = episodes.iter().map(|e| e.score).collect();
    Summary {
        mu_mae: stat(&|e| e.mu_mae),
        mu_mae_by_component: mean_by_component(episodes),
        mu_mare: stat(&|e| e.mu_mare),
        task: mean_std(&scores),
        fall_fraction: fall_fraction(episodes),
        by_mu: by_mu(task, episodes),
    }
}

/// The context-window study: per-step mean |mu_hat - mu| of UC-DiffOSI for
/// each context window N (N - 1 transitions), on the episodes of a table
/// run with the same seed.
#[derive(Clone, Debug, PartialEq)]
pub struct WindowStudy {
    pub task: String,
    pub seed: u64,
    pub models: Vec<String>,
    pub episodes: usize,
    pub steps: usize,
    /// (N, per-step mean absolute error (None where no episode runs), running episodes).
    pub curves: Vec<(usize, Vec<Option<f64>>, Vec<usize>)>,
}

/// Runs UC-DiffOSI with each context window in `windows` (N >= 2).
pub fn window_study(
    task: &dyn Task,
    models: &Models,
    windows: &[usize],
    episodes: usize,
    seed: u64,
    threads: usize,
    progress: &(dyn Fn() + Sync),
) -> Result<WindowStudy, String> {
    let steps = task.horizon();
    let mut curves = vec![];
    for &n in windows {
        if n < 2 {
            return Err(format!("a context window holds at least 2 states, not {n}"));
        }
        let study = Study {
            name: format!("window-{n}"),
            methods: vec![Method::uc(&format!("N = {n}"), Source::Diffosi, None)],
            episodes,
            seed,
            change_at: None,
        };
        let sources = Sources {
            window: n - 1,
            ..Sources::default()
        };
        let results = run(task, models, &sources, &study, threads, progress)?;
        let (mut sum, mut running) = (vec![0.0; steps], vec![0usize; steps]);
        for e in &results.methods[0].episodes {
            for (t, (hat, truth)) in e.trace.mu_hat.iter().zip(&e.trace.mu_true).enumerate() {
                let err: f64 = hat.iter().zip(truth).map(|(h, m)| (h - m).abs()).sum();
                sum[t] += err / hat.len() as f64;
                running[t] += 1;
            }
        }
        let mean = sum
            .iter()
            .zip(&running)
            .map(|(s, &r)| (r > 0).then(|| s / r as f64))
            .collect();
        curves.push((n, mean, running));
    }
    Ok(WindowStudy {
        task: task.name().into(),
        seed,
        models: models.names.clone(),
        episodes,
        steps,
        curves,
    })
}
