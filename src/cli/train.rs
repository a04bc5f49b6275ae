//! `diffosi train`: PPO on a task, writing the policy and its learning curve.

use std::io::Write;
use std::path::{Path, PathBuf};

use diffosi::rl::{self, CurveRow, PolicyKind, PpoConfig};
use diffosi::tasks;
use indicatif::{ProgressBar, ProgressStyle};

pub struct Request<'a> {
    pub task: &'a str,
    pub kind: PolicyKind,
    pub seed: u64,
    pub steps: Option<usize>,
    pub output: &'a Path,
    pub curve: Option<PathBuf>,
}

pub fn train(request: Request) -> Result<(), String> {
    let task = tasks::by_name(request.task)?;
    let mut config = PpoConfig {
        seed: request.seed,
        ..PpoConfig::default()
    };
    if let Some(steps) = request.steps {
        config.total_steps = steps;
    }
    let curve_path = request
        .curve
        .unwrap_or_else(|| request.output.with_extension("curve.csv"));
    let batch = config.num_envs * config.rollout_len;
    let bar = ProgressBar::new(config.total_steps.div_ceil(batch) as u64).with_style(
        ProgressStyle::with_template("{bar:40} {pos}/{len} iterations {elapsed}<{eta} {msg}")
            .expect("valid template"),
    );
    let trained = rl::train(task.as_ref(), request.kind, &config, |row| {
        bar.set_message(format!("metric {:.1}", row.mean_metric));
        bar.inc(1);
    })
    .map_err(|e| e.to_string())?;
    bar.finish_and_clear();
    trained.policy.save(request.output)?;
    write_curve(&curve_path, &trained.curve)?;
    let info = trained.policy.training.as_ref().expect("set by training");
    println!(
        "{} {:?} seed {}: {} env steps in {:.1} s, mean task metric of the last {} training episodes {:.1}",
        request.task,
        request.kind,
        request.seed,
        info.env_steps,
        info.wall_seconds,
        config.curve_window,
        info.final_metric
    );
    println!(
        "wrote {} and {}",
        request.output.display(),
        curve_path.display()
    );
    Ok(())
}

fn write_curve(path: &Path, curve: &[CurveRow]) -> Result<(), String> {
    let io = |e: std::io::Error| format!("cannot write {}: {e}", path.display());
    let mut out = std::io::BufWriter::new(std::fs::File::create(path).map_err(io)?);
    writeln!(out, "{}", CurveRow::CSV_HEADER).map_err(io)?;
    for row in curve {
        writeln!(out, "{}", row.csv()).map_err(io)?;
    }
    out.flush().map_err(io)
}
