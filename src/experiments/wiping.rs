//! The paper's wiping experiments (Section 4.4, Table 3): the Universal
//! Controller mapping mu to the admittance gains theta*, the domain-
//! randomised gains, the learned identifier UC-MLP, and the comparison of
//! identifiers.
//!
//! - theta*(mu) minimises the episode metric at mu over (ln k_tau, ln k_xi)
//!   in the box [`GAINS_LOWER`], [`GAINS_UPPER`]: a coarse grid, then
//!   CMA-ES ([`optimise_gains`]); episodes are deterministic, so one episode is one
//!   evaluation. An episode that loses contact or diverges is rejected.
//! - The dataset: [`PAIRS`] mu drawn uniformly in the box (the paper's 85),
//!   each with its theta*. The UC is an MLP (2 x 512 ReLU, linear output,
//!   the paper's) from mu scaled to [-1, 1] to ln theta scaled to [-1, 1] on
//!   the box, fitted by least squares.
//! - DR: theta minimising the mean metric over [`DR_ENVIRONMENTS`] mu drawn
//!   uniformly (the randomised environment).
//! - UC-MLP: `osi::mlp::MuMlp` (2 x 512 ReLU, as the paper's UC) from one
//!   transition (q, v, tau, q', v') to mu, trained on transitions of
//!   episodes run with the canonical gains at uniform mu: the distribution
//!   the identification segments come from (the paper trained it on
//!   trajectories of the UC itself, which the test data do not come from).
//!   Its estimate from 50 segments is the mean of its predictions from each
//!   segment's first transition.
//! - A run of Table 3: the true mu uniform in the box; one canonical-gain
//!   episode there; 50 segments of [`SEGMENT_STEPS`] steps sampled
//!   uniformly; each identifier's mu_hat; then the UC's gains at mu_hat run
//!   at the true mu give the task metric. MAE is the mean over mu's
//!   components of |mu_hat - mu|, MARE of |mu_hat - mu| / mu.
//!
//! Everything is seeded; parallel work is split by item, so the numbers do
//! not depend on the number of threads.

use std::time::Instant;

use rand::rngs::StdRng;
use rand::SeedableRng;
use serde::{Deserialize, Serialize};

use crate::control::admittance::Gains;
use crate::derivatives::Transition;
use crate::nn::{fit_least_squares, Activation, LayerFile, Mlp, Schedule, Tape};
use crate::osi::mlp::{fit_mlp, Dataset, MlpConfig, MuMlp};
use crate::osi::{CmaEs, CmaEsOptions, Lm};
use crate::tasks::wiping::{Episode, Segments, Wiping, CANONICAL, GAINS_LOWER, GAINS_UPPER, STEPS};

/// (mu, theta*) pairs of the UC's dataset (the paper's count).
pub const PAIRS: usize = 85;
/// Environments of the DR objective.
pub const DR_ENVIRONMENTS: usize = 16;
/// Segments per identification, and their length in steps.
pub const SEGMENTS: usize = 50;
pub const SEGMENT_STEPS: usize = 5;
const UC_FORMAT: &str = "diffosi-wiping-uc/1";

fn log_box() -> (Vec<f64>, Vec<f64>) {
    let ln = |g: Gains| vec![g.k_tau.ln(), g.k_xi.ln()];
    (ln(GAINS_LOWER), ln(GAINS_UPPER))
}

/// Points per axis of the coarse grid that starts a gains search.
const GRID: usize = 8;

/// The gains minimising the mean metric over `mus`, with that mean and the
/// evaluations (episodes x mus) spent: a coarse log grid (`GRID`^2
/// points) picks the start, then CMA-ES (step 0.1 of the box) refines it
/// with the rest of `budget`. The grid keeps the search out of the poor
/// basins a single local search from the canonical gains can end in (the
/// metric has a cliff where the admittance loop turns unstable).
pub fn optimise_gains(
    task: &Wiping,
    mus: &[Vec<f64>],
    budget: usize,
    seed: u64,
) -> (Gains, f64, usize) {
    let (lo, hi) = log_box();
    let gains = |y: &[f64]| Gains {
        k_tau: y[0].exp(),
        k_xi: y[1].exp(),
    };
    let mean_metric = |y: &[f64]| -> Option<f64> {
        let g = gains(y);
        let mut total = 0.0;
        for mu in mus {
            total += task.episode(mu, g, STEPS).ok()?.metric;
        }
        Some(total / mus.len() as f64)
    };
    let axis = |i: usize, k: usize| lo[i] + (hi[i] - lo[i]) * k as f64 / (GRID - 1) as f64;
    let mut best = (
        vec![CANONICAL.k_tau.ln(), CANONICAL.k_xi.ln()],
        f64::INFINITY,
    );
    for a in 0..GRID {
        for b in 0..GRID {
            let y = vec![axis(0, a), axis(1, b)];
            if let Some(m) = mean_metric(&y).filter(|m| *m < best.1) {
                best = (y, m);
            }
        }
    }
    let cma = CmaEs {
        options: CmaEsOptions {
            max_evaluations: budget.saturating_sub(GRID * GRID),
            sigma0: 0.1,
            seed,
            x_tol: 1e-4,
            f_tol: 1e-6,
            ..CmaEsOptions::default()
        },
    };
    let search = cma
        .minimize((&lo, &hi), &best.0, |y| Ok::<_, ()>(mean_metric(y)))
        .expect("the objective never fails");
    if let Some((y, m)) = search.best.filter(|(_, m)| *m < best.1) {
        best = (y.as_slice().to_vec(), m);
    }
    let evaluations = (GRID * GRID + search.evaluations) * mus.len();
    (gains(&best.0), best.1, evaluations)
}

/// One pair of the UC's dataset.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Pair {
    pub mu: Vec<f64>,
    pub k_tau: f64,
    pub k_xi: f64,
    /// The metric at mu with these gains (N^2).
    pub metric: f64,
    pub evaluations: usize,
}

/// `f(i)` for i in 0..n on `threads` workers, in index order.
pub fn parallel<T: Send>(n: usize, threads: usize, f: impl Fn(usize) -> T + Sync) -> Vec<T> {
    let threads = threads.clamp(1, n.max(1));
    let mut out: Vec<Option<T>> = (0..n).map(|_| None).collect();
    std::thread::scope(|s| {
        let f = &f;
        let chunks: Vec<_> = out
            .chunks_mut(n.div_ceil(threads).max(1))
            .enumerate()
            .map(|(c, chunk)| {
                let base = c * n.div_ceil(threads).max(1);
                s.spawn(move || {
                    for (k, slot) in chunk.iter_mut().enumerate() {
                        *slot = Some(f(base + k));
                    }
                })
            })
            .collect();
        chunks
            .into_iter()
            .for_each(|h| h.join().expect("a worker panicked"));
    });
    out.into_iter()
        .map(|x| x.expect("every item ran"))
        .collect()
}

/// The UC's dataset: `count` mu with their theta*; `done` sees each finished
/// pair's index.
pub fn dataset(
    task: &Wiping,
    (count, budget, seed): (usize, usize, u64),
    threads: usize,
    done: &(dyn Fn(usize) + Sync),
) -> Vec<Pair> {
    let mut rng = StdRng::seed_from_u64(seed);
    let mus: Vec<Vec<f64>> = (0..count).map(|_| task.sample_mu(&mut rng)).collect();
    parallel(count, threads, |i| {
        let (g, metric, evaluations) =
            optimise_gains(task, std::slice::from_ref(&mus[i]), budget, seed + i as u64);
        done(i);
        Pair {
            mu: mus[i].clone(),
            k_tau: g.k_tau,
            k_xi: g.k_xi,
            metric,
            evaluations,
        }
    })
}

/// The Universal Controller: mu -> theta (see the module docs).
#[derive(Clone, Debug, PartialEq)]
pub struct Uc {
    pub net: Mlp<f32>,
    pub mu_lower: Vec<f64>,
    pub mu_upper: Vec<f64>,
}

#[derive(Serialize, Deserialize)]
struct UcFile {
    format: String,
    mu_lower: Vec<f64>,
    mu_upper: Vec<f64>,
    /// ln of the gains' box, (k_tau, k_xi).
    log_gains_lower: Vec<f64>,
    log_gains_upper: Vec<f64>,
    activation: Activation,
    layers: Vec<LayerFile>,
}

fn to_unit(x: f64, (lo, hi): (f64, f64)) -> f64 {
    (2.0 * x - lo - hi) / (hi - lo)
}

fn from_unit(y: f64, (lo, hi): (f64, f64)) -> f64 {
    0.5 * (lo + hi) + 0.5 * (hi - lo) * y.clamp(-1.0, 1.0)
}

impl Uc {
    /// Fits the UC to the dataset (2 x 512 ReLU, full batches).
    pub fn train(task: &Wiping, pairs: &[Pair], epochs: usize, seed: u64) -> Uc {
        let (lo, hi) = task.mu_range();
        let (glo, ghi) = log_box();
        let mut rng = StdRng::seed_from_u64(seed);
        let nmu = lo.len();
        let mut net =
            Mlp::<f32>::new(&[nmu, 512, 512, 2], 1.0, &mut rng).with_activation(Activation::Relu);
        let inputs: Vec<f32> = pairs
            .iter()
            .flat_map(|p| (0..nmu).map(|i| to_unit(p.mu[i], (lo[i], hi[i])) as f32))
            .collect();
        let targets: Vec<f64> = pairs
            .iter()
            .flat_map(|p| {
                [
                    to_unit(p.k_tau.ln(), (glo[0], ghi[0])),
                    to_unit(p.k_xi.ln(), (glo[1], ghi[1])),
                ]
            })
            .collect();
        let schedule = Schedule {
            epochs,
            batch: pairs.len(),
            lr: 1e-3,
        };
        let data = (inputs.as_slice(), targets.as_slice());
        fit_least_squares(&mut net, (data, data), schedule, &mut rng, |_, _| {});
        Uc {
            net,
            mu_lower: lo,
            mu_upper: hi,
        }
    }

    /// theta for mu (mu clamped into the training box).
    pub fn gains(&self, mu: &[f64]) -> Gains {
        let (glo, ghi) = log_box();
        let z: Vec<f32> = mu
            .iter()
            .enumerate()
            .map(|(i, m)| to_unit(*m, (self.mu_lower[i], self.mu_upper[i])).clamp(-1.0, 1.0) as f32)
            .collect();
        let y = self.net.forward(&z, &mut Tape::default()).to_vec();
        Gains {
            k_tau: from_unit(y[0] as f64, (glo[0], ghi[0])).exp(),
            k_xi: from_unit(y[1] as f64, (glo[1], ghi[1])).exp(),
        }
    }

    pub fn save(&self, path: &std::path::Path) -> Result<(), String> {
        let (glo, ghi) = log_box();
        let file = UcFile {
            format: UC_FORMAT.into(),
            mu_lower: self.mu_lower.clone(),
            mu_upper: self.mu_upper.clone(),
            log_gains_lower: glo,
            log_gains_upper: ghi,
            activation: self.net.activation(),
            layers: self.net.to_files(),
        };
        let text = serde_json::to_string(&file).expect("a UC serialises");
        std::fs::write(path, text).map_err(|e| format!("cannot write {}: {e}", path.display()))
    }

    pub fn load(path: &std::path::Path) -> Result<Uc, String> {
        let shown = path.display();
        let text =
            std::fs::read_to_string(path).map_err(|e| format!("cannot read {shown}: {e}"))?;
        let file: UcFile = serde_json::from_str(&text)
            .map_err(|e| format!("{shown}: not a wiping UC file: {e}"))?;
        if file.format != UC_FORMAT {
            return Err(format!(
                "{shown}: format '{}', expected '{UC_FORMAT}'",
                file.format
            ));
        }
        if (file.log_gains_lower.clone(), file.log_gains_upper.clone()) != log_box() {
            return Err(format!("{shown}: made for another gains box"));
        }
        let net = Mlp::from_files(&file.layers)
            .map_err(|e| format!("{shown}: {e}"))?
            .with_activation(file.activation);
        if net.inputs() != file.mu_lower.len() || net.outputs() != 2 {
            return Err(format!("{shown}: the network must map mu to two gains"));
        }
        Ok(Uc {
            net,
            mu_lower: file.mu_lower,
            mu_upper: file.mu_upper,
        })
    }
}

/// The first transition of each segment, as the UC-MLP reads it.
fn first_transitions(episode: &Episode, segments: &Segments) -> Vec<Transition> {
    segments
        .segments
        .iter()
        .map(|s| transition(episode, s.start))
        .collect()
}

fn transition(episode: &Episode, k: usize) -> Transition {
    Transition {
        start: episode.states[k].clone(),
        tau: episode.taus[k].clone(),
        next: episode.states[k + 1].clone(),
    }
}

/// UC-MLP trained on `episodes` canonical-gain episodes at uniform mu, every
/// `stride`-th transition of each (one episode in ten held out).
pub fn train_uc_mlp(
    task: &Wiping,
    (episodes, stride, epochs): (usize, usize, usize),
    seed: u64,
    threads: usize,
) -> Result<MuMlp, String> {
    let started = Instant::now();
    let (lo, hi) = task.mu_range();
    let mut rng = StdRng::seed_from_u64(seed);
    let mus: Vec<Vec<f64>> = (0..episodes).map(|_| task.sample_mu(&mut rng)).collect();
    let runs = parallel(episodes, threads, |i| {
        task.episode(&mus[i], CANONICAL, STEPS)
    });
    let (mut train, mut held_out) = (Dataset::default(), Dataset::default());
    for (i, run) in runs.into_iter().enumerate() {
        let episode = run.map_err(|e| e.to_string())?;
        let set = if i % 10 == 9 {
            &mut held_out
        } else {
            &mut train
        };
        for k in (0..STEPS).step_by(stride.max(1)) {
            set.push(&[transition(&episode, k)], &mus[i], (&lo, &hi));
        }
    }
    let config = MlpConfig {
        seed,
        transitions: 1,
        hidden: vec![512, 512],
        activation: Activation::Relu,
        episodes,
        epochs,
        batch: 256,
        ..MlpConfig::new(&lo, &hi)
    };
    Ok(fit_mlp(
        "wiping",
        (train, held_out),
        &config,
        started,
        |_, _| {},
    ))
}

/// The identifiers of Table 3, in its order.
pub const METHODS: [&str; 7] = [
    "DR",
    "UC-Random",
    "UC-Average",
    "UC-MLP",
    "UC-CMA-ES",
    "UC-DiffOSI",
    "UC-Oracle",
];

/// A row of the paper's Table 3: MAE, MARE and task metric, each (mean,
/// std); None where it prints N/A.
pub type PaperRow = (Option<(f64, f64)>, Option<(f64, f64)>, (f64, f64));

/// The paper's Table 3 rows.
pub const PAPER: [PaperRow; 7] = [
    (None, None, (1.69, 1.58)),
    (Some((39.038, 22.157)), Some((3.607, 7.874)), (1.07, 0.78)),
    (Some((22.296, 12.333)), Some((2.120, 4.129)), (0.92, 0.73)),
    (Some((36.875, 20.324)), Some((3.508, 6.569)), (0.93, 0.75)),
    (Some((0.418, 0.502)), Some((0.029, 0.037)), (0.50, 0.32)),
    (Some((0.001, 0.001)), Some((4.3e-5, 4.0e-5)), (0.51, 0.32)),
    (Some((0.0, 0.0)), Some((0.0, 0.0)), (0.51, 0.32)),
];

/// What Table 3 runs with.
pub struct Controllers<'a> {
    pub uc: &'a Uc,
    pub dr: Gains,
    pub mlp: &'a MuMlp,
    /// CMA-ES's evaluation budget per identification.
    pub cmaes_budget: usize,
}

/// One identifier's result in one run.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Outcome {
    /// None for DR.
    pub mu_hat: Option<Vec<f64>>,
    pub metric: f64,
    /// Evaluations of the segment loss (DiffOSI's include the Jacobian).
    pub evaluations: usize,
    /// Wall time of the identification (s): not serialised with the
    /// deterministic numbers.
    #[serde(skip)]
    pub seconds: f64,
}

/// One run of Table 3: per method in [`METHODS`] order.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Run {
    pub mu: Vec<f64>,
    pub outcomes: Vec<Outcome>,
}

/// Runs Table 3's `runs` runs from `seed`.
pub fn table3(
    task: &Wiping,
    c: &Controllers,
    (runs, seed): (usize, u64),
    threads: usize,
    done: &(dyn Fn(usize) + Sync),
) -> Result<Vec<Run>, String> {
    let mut rng = StdRng::seed_from_u64(seed);
    let mus: Vec<Vec<f64>> = (0..runs).map(|_| task.sample_mu(&mut rng)).collect();
    let out = parallel(runs, threads, |r| {
        let run = one_run(task, c, &mus[r], seed.wrapping_add(r as u64 + 1));
        done(r);
        run
    });
    out.into_iter().collect()
}

fn one_run(task: &Wiping, c: &Controllers, truth: &[f64], seed: u64) -> Result<Run, String> {
    let err = |e: &dyn std::fmt::Display| e.to_string();
    let episode = task.episode(truth, CANONICAL, STEPS).map_err(|e| err(&e))?;
    let mut rng = StdRng::seed_from_u64(seed);
    let segments = Segments::sample(
        task,
        (&episode.states, &episode.xi, &episode.forces, CANONICAL),
        (SEGMENTS, SEGMENT_STEPS),
        &mut rng,
    )?;
    let (lo, hi) = task.mu_range();
    let prior = task.prior();
    let mut problem = task.problem();
    let mut outcomes = vec![];
    // The UC's gains at mu_hat (DR's without one) run at the true mu; the
    // wall time since `started` is the identification's.
    let mut score = |mu_hat: Option<Vec<f64>>, evaluations, started: Option<Instant>| {
        let gains = mu_hat.as_deref().map_or(c.dr, |m| c.uc.gains(m));
        let seconds = started.map_or(0.0, |t| t.elapsed().as_secs_f64());
        let metric = task
            .episode(truth, gains, STEPS)
            .map_or(f64::INFINITY, |e| e.metric);
        outcomes.push(Outcome {
            mu_hat,
            metric,
            evaluations,
            seconds,
        });
    };
    score(None, 0, None);
    score(Some(task.sample_mu(&mut rng)), 0, None);
    score(Some(prior.clone()), 0, None);
    let t = Instant::now();
    let inputs = first_transitions(&episode, &segments);
    let predictions: Vec<Vec<f64>> = inputs
        .iter()
        .filter_map(|tr| c.mlp.predict(std::slice::from_ref(tr)))
        .collect();
    let mlp: Vec<f64> = (0..lo.len())
        .map(|i| {
            let mean = predictions.iter().map(|p| p[i]).sum::<f64>() / predictions.len() as f64;
            mean.clamp(lo[i], hi[i])
        })
        .collect();
    score(Some(mlp), 0, Some(t));
    let t = Instant::now();
    let mut cma = CmaEs {
        options: CmaEsOptions {
            max_evaluations: c.cmaes_budget,
            seed,
            ..CmaEsOptions::default()
        },
    };
    let e = cma
        .identify_on(&mut problem, &segments, &prior)
        .map_err(|e| err(&e))?;
    score(Some(e.mu), e.evaluations, Some(t));
    let t = Instant::now();
    let e = Lm::default()
        .identify_on(&mut problem, &segments, &prior)
        .map_err(|e| err(&e))?;
    score(Some(e.mu), e.evaluations, Some(t));
    score(Some(truth.to_vec()), 0, None);
    Ok(Run {
        mu: truth.to_vec(),
        outcomes,
    })
}

/// Mean and population standard deviation.
fn mean_std(x: &[f64]) -> (f64, f64) {
    let n = x.len().max(1) as f64;
    let mean = x.iter().sum::<f64>() / n;
    let var = x.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / n;
    (mean, var.sqrt())
}

/// Per method: (MAE, MARE) as (mean, std) over runs (None for DR), the
/// metric's (mean, std), mean evaluations and mean seconds.
pub struct Row {
    pub label: &'static str,
    pub mae: Option<(f64, f64)>,
    pub mare: Option<(f64, f64)>,
    pub metric: (f64, f64),
    pub evaluations: f64,
    pub seconds: f64,
}

pub fn summarise(runs: &[Run]) -> Vec<Row> {
    METHODS
        .iter()
        .enumerate()
        .map(|(m, label)| {
            let outcomes: Vec<(&Run, &Outcome)> =
                runs.iter().map(|r| (r, &r.outcomes[m])).collect();
            let errors = |relative: bool| -> Option<(f64, f64)> {
                let per_run: Option<Vec<f64>> = outcomes
                    .iter()
                    .map(|(r, o)| {
                        let hat = o.mu_hat.as_ref()?;
                        let e = hat
                            .iter()
                            .zip(&r.mu)
                            .map(|(h, m)| (h - m).abs() / if relative { m.abs() } else { 1.0 });
                        Some(e.sum::<f64>() / r.mu.len() as f64)
                    })
                    .collect();
                per_run.map(|x| mean_std(&x))
            };
            let metric: Vec<f64> = outcomes.iter().map(|(_, o)| o.metric).collect();
            let count = outcomes.len().max(1) as f64;
            Row {
                label,
                mae: errors(false),
                mare: errors(true),
                metric: mean_std(&metric),
                evaluations: outcomes
                    .iter()
                    .map(|(_, o)| o.evaluations as f64)
                    .sum::<f64>()
                    / count,
                seconds: outcomes.iter().map(|(_, o)| o.seconds).sum::<f64>() / count,
            }
        })
        .collect()
}

fn cell(x: Option<(f64, f64)>) -> String {
    match x {
        None => "N/A".into(),
        Some((m, s)) if m != 0.0 && (m.abs() < 1e-2 || m.abs() >= 1e4) => {
            format!("{m:.1e} ± {s:.1e}")
        }
        Some((m, s)) => format!("{m:.3} ± {s:.3}"),
    }
}

/// Table 3 as markdown: ours, then the paper's.
pub fn markdown(runs: &[Run], settings: &str) -> String {
    let mut out = format!(
        "# Table 3: table wiping\n\n{settings}\n\n| Approach | MAE (mu) | MARE (mu) | Task metric (N^2) | Evaluations | Identification time |\n|---|---|---|---|---|---|\n"
    );
    for row in summarise(runs) {
        let time = if row.seconds > 0.0 {
            format!("{:.1} ms", 1e3 * row.seconds)
        } else {
            "-".into()
        };
        out += &format!(
            "| {} | {} | {} | {} | {:.0} | {time} |\n",
            row.label,
            cell(row.mae),
            cell(row.mare),
            cell(Some(row.metric)),
            row.evaluations
        );
    }
    out += "\nThe paper's Table 3 (NimblePhysics, its own arm, tool and controller):\n\n| Approach | MAE (mu) | MARE (mu) | Task performance |\n|---|---|---|---|\n";
    for (label, (mae, mare, metric)) in METHODS.iter().zip(PAPER) {
        out += &format!(
            "| {label} | {} | {} | {} |\n",
            cell(mae),
            cell(mare),
            cell(Some(metric))
        );
    }
    out
}

/// Table 3 as JSON: settings, per method the summary, the paper's row and the
/// runs; identification times apart under `timing_seconds` (not deterministic).
pub fn json(runs: &[Run], settings: serde_json::Value) -> serde_json::Value {
    let rows = summarise(runs);
    let methods: Vec<serde_json::Value> = rows
        .iter()
        .enumerate()
        .map(|(m, row)| {
            let (mae, mare, metric) = PAPER[m];
            serde_json::json!({
                "label": row.label,
                "summary": {"mu_mae": row.mae, "mu_mare": row.mare, "task": row.metric, "evaluations": row.evaluations},
                "paper": {"mu_mae": mae, "mu_mare": mare, "task": metric},
                "runs": runs.iter().map(|r| &r.outcomes[m]).collect::<Vec<_>>(),
            })
        })
        .collect();
    let timing: serde_json::Map<String, serde_json::Value> = rows
        .iter()
        .map(|r| (r.label.to_string(), r.seconds.into()))
        .collect();
    serde_json::json!({
        "experiment": "table3",
        "task": "wiping",
        "settings": settings,
        "true_mu": runs.iter().map(|r| &r.mu).collect::<Vec<_>>(),
        "methods": methods,
        "timing_seconds": timing,
    })
}
