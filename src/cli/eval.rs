//! `diffosi eval`: the task metric of trained policies, mean +- std.

use std::path::PathBuf;

use diffosi::rl::{self, mean_std, MuSource, Policy};
use diffosi::tasks;

pub struct Request<'a> {
    pub task: &'a str,
    pub policies: &'a [PathBuf],
    pub source: MuSource,
    pub episodes: usize,
    pub seed: u64,
    pub json: bool,
}

/// Evaluates every policy on the same episodes; the summary pools all
/// policies' episodes (the paper's "3 models x 10 episodes").
pub fn eval(request: Request) -> Result<(), String> {
    let task = tasks::by_name(request.task)?;
    if request.episodes == 0 {
        return Err("--episodes must be at least 1".into());
    }
    let mut rows = vec![];
    let mut pooled = vec![];
    for path in request.policies {
        let policy = Policy::load(path)?;
        if policy.task != task.name() {
            return Err(format!(
                "{} is a '{}' policy, not '{}'",
                path.display(),
                policy.task,
                task.name()
            ));
        }
        let result = rl::evaluate(
            task.as_ref(),
            &policy,
            request.source,
            request.episodes,
            request.seed,
        )
        .map_err(|e| e.to_string())?;
        pooled.extend_from_slice(&result.metrics);
        rows.push((path, policy.kind, result));
    }
    let (mean, std) = mean_std(&pooled);
    if request.json {
        let policies: Vec<_> = rows
            .iter()
            .map(|(path, kind, result)| {
                serde_json::json!({
                    "file": path.display().to_string(),
                    "kind": kind,
                    "mean": result.mean(),
                    "std": result.std(),
                    "metrics": result.metrics,
                    "mu_true": result.mu_true,
                    "mu_fed": result.mu_fed,
                })
            })
            .collect();
        let out = serde_json::json!({
            "task": task.name(),
            "mu_source": request.source,
            "episodes": request.episodes,
            "seed": request.seed,
            "mean": mean,
            "std": std,
            "policies": policies,
        });
        println!(
            "{}",
            serde_json::to_string_pretty(&out).expect("serialises")
        );
        return Ok(());
    }
    println!(
        "{}: task metric, mu source {:?}, {} episodes per policy (seed {})",
        task.name(),
        request.source,
        request.episodes,
        request.seed
    );
    for (path, kind, result) in &rows {
        println!(
            "  {:<40} {:?}  {:.2} +- {:.2}",
            path.display(),
            kind,
            result.mean(),
            result.std()
        );
    }
    println!("all {} episodes: {mean:.2} +- {std:.2}", pooled.len());
    Ok(())
}
