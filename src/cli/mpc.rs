//! `diffosi mpc`: the paper's runtime comparison. iLQR MPC (horizon H,
//! replanning every R control steps, the true mu) against the Universal
//! Controller with online DiffOSI on the same episodes.
//!
//! Timing conventions (wall time, one thread, seconds in the JSON):
//! - MPC: each planning call, linearisations, backward and forward passes
//!   included (the simulation of the executed steps excluded).
//! - UC: what UC-DiffOSI computes over the same R control steps, i.e. R policy
//!   forward passes plus the R online DiffOSI updates made in them. Each
//!   update is timed in the episode; the forward pass costs the same for any
//!   input, so it is timed once, as the mean of many calls, and counted R
//!   times. Periods are the episode's consecutive R-step blocks.

use std::path::{Path, PathBuf};
use std::time::Instant;

use indicatif::{ProgressBar, ProgressStyle};
use rand::rngs::StdRng;
use rand::SeedableRng;
use serde_json::json;

use diffosi::control::ilqr::{run_mpc_episode, MpcOptions};
use diffosi::control::{
    run_episode, ControlError, Episode, MuEstimator, OracleMu, Source, Sources,
};
use diffosi::derivatives::Transition;
use diffosi::rl::{mean_std, Policy, PolicyKind};
use diffosi::tasks::{self, Task};

pub struct Request<'a> {
    pub task: &'a str,
    /// The Universal Controller (default policies/<task>/uc-seed0.json); the
    /// report holds the MPC side only when the file is missing.
    pub policy: Option<PathBuf>,
    /// Overrides of the task's MPC settings ([`MpcOptions::for_task`]).
    pub horizon: Option<usize>,
    pub replan: Option<usize>,
    pub iterations: Option<usize>,
    pub episodes: usize,
    pub seed: u64,
    /// Transitions per DiffOSI window.
    pub window: usize,
    pub reports: &'a Path,
}

/// Mean, median and 95th percentile (nearest rank) of wall times, in ms.
fn timing(seconds: &[f64]) -> serde_json::Value {
    let mut ms: Vec<f64> = seconds.iter().map(|s| 1e3 * s).collect();
    ms.sort_by(f64::total_cmp);
    let rank = |p: f64| ms[((p * ms.len() as f64).ceil() as usize).clamp(1, ms.len()) - 1];
    json!({"mean_ms": mean_std(&ms).0, "p50_ms": rank(0.5), "p95_ms": rank(0.95), "count": ms.len()})
}

/// An estimator that records the wall time of each update it makes.
struct Timed {
    inner: Box<dyn MuEstimator>,
    seconds: Vec<f64>,
}

impl MuEstimator for Timed {
    fn reset(&mut self, truth: &[f64]) -> Result<(), ControlError> {
        self.inner.reset(truth)
    }
    fn observe(&mut self, transition: Transition, truth: &[f64]) -> Result<(), ControlError> {
        let start = Instant::now();
        let result = self.inner.observe(transition, truth);
        self.seconds.push(start.elapsed().as_secs_f64());
        result
    }
    fn mu(&self) -> &[f64] {
        self.inner.mu()
    }
}

fn bar(len: usize, what: &str) -> ProgressBar {
    let template = format!("{what:>6} {{bar:40}} {{pos}}/{{len}} episodes {{elapsed}}<{{eta}}");
    ProgressBar::new(len as u64)
        .with_style(ProgressStyle::with_template(&template).expect("valid template"))
}

/// Mean wall time of one policy forward pass (s), over reset states.
fn forward_seconds(task: &dyn Task, policy: &Policy, mu: &[f64]) -> f64 {
    const CALLS: usize = 2000;
    let mut rng = StdRng::seed_from_u64(0);
    let inputs: Vec<Vec<f64>> = (0..64)
        .map(|_| policy.observation(task, &task.reset(&mut rng), mu))
        .collect();
    let start = Instant::now();
    let mut sink = 0.0;
    for k in 0..CALLS {
        sink += policy.act(&inputs[k % inputs.len()])[0];
    }
    std::hint::black_box(sink);
    start.elapsed().as_secs_f64() / CALLS as f64
}

/// The UC side: UC-Oracle and UC-DiffOSI scores, UC-DiffOSI's compute per
/// `period` control steps and one policy forward pass (s).
struct UcSide {
    oracle: Vec<f64>,
    diffosi: Vec<f64>,
    periods: Vec<f64>,
    forward: f64,
}

fn uc_side(
    task: &dyn Task,
    policy: &Policy,
    episodes: &[Episode],
    period: usize,
    window: usize,
    seed: u64,
) -> Result<UcSide, String> {
    let forward = forward_seconds(task, policy, &episodes[0].mu);
    let sources = Sources {
        window,
        ..Sources::default()
    };
    let (mut oracle, mut diffosi, mut periods) = (vec![], vec![], vec![]);
    let progress = bar(episodes.len(), "UC");
    for episode in episodes {
        let mut truth = OracleMu::default();
        let trace = run_episode(task, policy, Some(&mut truth), episode);
        oracle.push(trace.map_err(|e| e.to_string())?.score());
        let mut timed = Timed {
            inner: sources.estimator(Source::Diffosi, task, seed)?,
            seconds: vec![],
        };
        let trace = run_episode(task, policy, Some(&mut timed), episode);
        diffosi.push(trace.map_err(|e| e.to_string())?.score());
        for block in timed.seconds.chunks_exact(period) {
            periods.push(block.iter().sum::<f64>() + period as f64 * forward);
        }
        progress.inc(1);
    }
    progress.finish();
    Ok(UcSide {
        oracle,
        diffosi,
        periods,
        forward,
    })
}

pub fn mpc(request: Request) -> Result<(), String> {
    let task = tasks::by_name(request.task)?;
    let task = task.as_ref();
    if task.model().nq() != task.model().nv() {
        return Err(format!(
            "--task {}: the iLQR planner needs nq = nv, and this task's model has a free joint",
            request.task
        ));
    }
    let mut options = MpcOptions::for_task(request.task);
    options.horizon = request.horizon.unwrap_or(options.horizon);
    options.replan = request.replan.unwrap_or(options.replan);
    options.ilqr.iterations = request.iterations.unwrap_or(options.ilqr.iterations);
    if request.episodes == 0 || options.replan == 0 || options.horizon < options.replan {
        return Err("need --episodes >= 1 and 1 <= --replan <= --horizon".into());
    }
    let mut rng = StdRng::seed_from_u64(request.seed);
    let episodes: Vec<Episode> = (0..request.episodes)
        .map(|_| Episode::draw(task, &mut rng))
        .collect();
    let started = Instant::now();
    let (mut scores, mut returns, mut plans) = (vec![], vec![], vec![]);
    let (mut iterations, mut accepted) = (vec![], vec![]);
    let progress = bar(episodes.len(), "MPC");
    for episode in &episodes {
        let run = run_mpc_episode(task, &episode.mu, &episode.initial, &options);
        let run = run.map_err(|e| e.to_string())?;
        scores.push(run.score());
        returns.push(run.rewards.iter().sum::<f64>());
        for replan in &run.replans {
            plans.push(replan.seconds);
            iterations.push(replan.log.iterations as f64);
            accepted.push((replan.log.costs.len() - 1) as f64);
        }
        progress.inc(1);
    }
    progress.finish();
    let mpc_seconds = started.elapsed().as_secs_f64();
    let policy_path = request
        .policy
        .unwrap_or_else(|| PathBuf::from(format!("policies/{}/uc-seed0.json", task.name())));
    let uc = if policy_path.exists() {
        let policy = Policy::load(&policy_path)?;
        if policy.task != task.name() || policy.kind != PolicyKind::Uc {
            return Err(format!(
                "{} is not a {} UC",
                policy_path.display(),
                task.name()
            ));
        }
        let UcSide {
            oracle,
            diffosi,
            periods,
            forward,
        } = uc_side(
            task,
            &policy,
            &episodes,
            options.replan,
            request.window,
            request.seed,
        )?;
        Some(json!({
            "policy": policy_path,
            "window": request.window,
            "oracle_score": mean_std(&oracle),
            "diffosi_score": mean_std(&diffosi),
            "oracle_scores": oracle,
            "diffosi_scores": diffosi,
            "forward_ms": 1e3 * forward,
            "period": timing(&periods),
        }))
    } else {
        None
    };
    let report = json!({
        "task": task.name(),
        "seed": request.seed,
        "episodes": request.episodes,
        "options": options,
        "mpc": {
            "score": mean_std(&scores),
            "return": mean_std(&returns),
            "scores": scores,
            "returns": returns,
            "iterations": mean_std(&iterations),
            "accepted_iterations": mean_std(&accepted),
            "replan": timing(&plans),
            "total_seconds": mpc_seconds,
        },
        "uc": uc,
    });
    let markdown = markdown(&report);
    print!("{markdown}");
    std::fs::create_dir_all(request.reports).map_err(|e| e.to_string())?;
    let stem = request.reports.join(format!("mpc-{}", task.name()));
    let json_text = serde_json::to_string_pretty(&report).expect("serialisable");
    for (path, text) in [
        (stem.with_extension("md"), markdown),
        (stem.with_extension("json"), json_text),
    ] {
        std::fs::write(&path, text).map_err(|e| format!("{}: {e}", path.display()))?;
        println!("wrote {}", path.display());
    }
    Ok(())
}

/// The cold start's horizons R, 2R, 4R, ..., H, as text.
fn stages(replan: usize, horizon: usize) -> String {
    let mut out = vec![replan.min(horizon)];
    while out[out.len() - 1] < horizon {
        out.push((2 * out[out.len() - 1]).min(horizon));
    }
    out.iter()
        .map(|h| h.to_string())
        .collect::<Vec<_>>()
        .join(", ")
}

/// The report as Markdown: the timing table, then task performance.
fn markdown(r: &serde_json::Value) -> String {
    let (mpc, uc, opt) = (&r["mpc"], &r["uc"], &r["options"]);
    let (h, period) = (&opt["horizon"], &opt["replan"]);
    let f = |v: &serde_json::Value| v.as_f64().unwrap_or(f64::NAN);
    let row = |label: &str, t: &serde_json::Value| {
        format!(
            "| {label} | {:.2} | {:.2} | {:.2} | {} |\n",
            f(&t["mean_ms"]),
            f(&t["p50_ms"]),
            f(&t["p95_ms"]),
            t["count"]
        )
    };
    let pm = |v: &serde_json::Value| format!("{:.1} ± {:.1}", f(&v[0]), f(&v[1]));
    let mut out = format!(
        "# MPC vs UC runtime: {}\n\n{} episodes (seed {}). iLQR MPC with the true mu: horizon {h}, \
         replanning every {period} control steps, at most {} iterations per plan (the first plan of \
         an episode, from zero actions, grows its horizon over {} with that many per stage). \
         Wall time, one thread, ms per {period} control steps.\n\n\
         | computation per {period} control steps | mean | p50 | p95 | count |\n|---|---|---|---|---|\n",
        r["task"].as_str().unwrap_or_default(),
        r["episodes"],
        r["seed"],
        opt["ilqr"]["iterations"],
        stages(f(period) as usize, f(h) as usize),
    );
    out += &row("MPC: one iLQR replan", &mpc["replan"]);
    if uc.is_null() {
        out += "\nNo Universal Controller weights: the UC side is not measured.\n";
    } else {
        out += &row(
            "UC-DiffOSI: policy forward + DiffOSI updates",
            &uc["period"],
        );
        out += &format!(
            "\nRatio MPC / UC: {:.1}x (means), {:.1}x (medians). One policy forward pass: {:.3} ms; \
             DiffOSI window {} transitions.\n",
            f(&mpc["replan"]["mean_ms"]) / f(&uc["period"]["mean_ms"]),
            f(&mpc["replan"]["p50_ms"]) / f(&uc["period"]["p50_ms"]),
            f(&uc["forward_ms"]),
            uc["window"],
        );
    }
    out += "\n| controller | task performance | training return |\n|---|---|---|\n";
    out += &format!(
        "| iLQR MPC (true mu) | {} | {} |\n",
        pm(&mpc["score"]),
        pm(&mpc["return"])
    );
    if !uc.is_null() {
        out += &format!("| UC-Oracle | {} | — |\n", pm(&uc["oracle_score"]));
        out += &format!("| UC-DiffOSI | {} | — |\n", pm(&uc["diffosi_score"]));
    }
    out += &format!(
        "\nMPC iterations per plan: {}, of which accepted (lower cost): {}. Paper (half cheetah, NimblePhysics): one MPC trajectory \
         optimisation 100-300 ms, the UC over 40 steps about 40 ms.\n",
        pm(&mpc["iterations"]),
        pm(&mpc["accepted_iterations"]),
    );
    out
}
