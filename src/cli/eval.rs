//! `diffosi eval`: the task metric of trained policies, mean +- std, with the
//! Universal Controller's mu from a chosen source (fixed or identified online).

use std::path::{Path, PathBuf};

use diffosi::control::{Source, Sources};
use diffosi::experiments::{self, Method, Models, MuBin, Study};
use diffosi::osi::mlp::MuMlp;
use diffosi::rl::{mean_std, Policy, PolicyKind};
use diffosi::tasks::{self, Task};

pub struct Request<'a> {
    pub task: &'a str,
    pub policies: &'a [PathBuf],
    pub source: Source,
    /// UC-MLP weights (used by the mlp and mlp-narrow sources).
    pub mlp: &'a Path,
    pub mlp_narrow: &'a Path,
    /// Transitions per DiffOSI / CMA-ES window.
    pub window: usize,
    pub episodes: usize,
    pub seed: u64,
    pub json: bool,
}

/// The estimator settings a source needs, loading UC-MLP weights only for
/// the sources that use them.
pub fn sources_for(
    wanted: &[Source],
    mlp: &Path,
    mlp_narrow: &Path,
    window: usize,
) -> Result<Sources, String> {
    let load = |source, path: &Path| -> Result<Option<MuMlp>, String> {
        wanted
            .contains(&source)
            .then(|| MuMlp::load(path))
            .transpose()
    };
    if window == 0 {
        return Err("--window must be at least 1 transition".into());
    }
    Ok(Sources {
        window,
        mlp: load(Source::Mlp, mlp)?,
        mlp_narrow: load(Source::MlpNarrow, mlp_narrow)?,
    })
}

fn load_policy(task: &dyn Task, path: &Path) -> Result<Policy, String> {
    let policy = Policy::load(path)?;
    if policy.task != task.name() {
        return Err(format!(
            "{} is a '{}' policy, not '{}'",
            path.display(),
            policy.task,
            task.name()
        ));
    }
    Ok(policy)
}

/// "by true mu: [lo, hi) mean (episodes) | ...", the last bin closed.
fn bins_line(bins: &[MuBin]) -> String {
    let cells: Vec<String> = bins
        .iter()
        .map(|b| {
            let mean = b.mean.map_or("-".into(), |m| format!("{m:.1}"));
            format!("[{:.2}, {:.2}) {mean} ({})", b.lo, b.hi, b.episodes)
        })
        .collect();
    format!("by true mu: {}", cells.join(" | "))
}

/// Evaluates every policy on the same episodes; the summary pools all
/// policies' episodes (the paper's "3 models x 10 episodes").
pub fn eval(request: Request) -> Result<(), String> {
    let task = tasks::by_name(request.task)?;
    if request.episodes == 0 {
        return Err("--episodes must be at least 1".into());
    }
    let sources = sources_for(
        &[request.source],
        request.mlp,
        request.mlp_narrow,
        request.window,
    )?;
    let mut rows = vec![];
    let (mut pooled, mut errors, mut all) = (vec![], vec![], vec![]);
    for path in request.policies {
        let policy = load_policy(task.as_ref(), path)?;
        let method = Method {
            label: format!("{:?}", request.source),
            policy: policy.kind,
            source: (policy.kind == PolicyKind::Uc).then_some(request.source),
            paper: None,
        };
        let study = Study {
            name: "eval".into(),
            methods: vec![method],
            episodes: request.episodes,
            seed: request.seed,
            change_at: None,
        };
        let one = std::slice::from_ref(&policy);
        let models = Models {
            names: vec![path.display().to_string()],
            uc: one,
            dr: one,
        };
        let results = experiments::run(task.as_ref(), &models, &sources, &study, 1, &|| {})?;
        let result = results.methods.into_iter().next().expect("one method");
        pooled.extend(result.episodes.iter().map(|e| e.score));
        errors.extend(result.episodes.iter().filter_map(|e| e.mu_mae));
        all.extend(result.episodes.iter().cloned());
        rows.push((path, policy.kind, result));
    }
    let (mean, std) = mean_std(&pooled);
    if request.json {
        let policies: Vec<_> = rows
            .iter()
            .map(|(path, kind, result)| {
                let episodes = &result.episodes;
                serde_json::json!({
                    "file": path.display().to_string(),
                    "kind": kind,
                    "mean": result.summary.task.0,
                    "std": result.summary.task.1,
                    "mu_mae": result.summary.mu_mae.map(|s| s.0),
                    "mu_mae_by_component": result.summary.mu_mae_by_component,
                    "fall_fraction": result.summary.fall_fraction,
                    "fell": episodes.iter().map(|e| e.trace.fell).collect::<Vec<_>>(),
                    "by_mu": result.summary.by_mu,
                    "metrics": episodes.iter().map(|e| e.score).collect::<Vec<_>>(),
                    "mu_true": episodes.iter().map(|e| &e.episode.mu).collect::<Vec<_>>(),
                    "mu_fed": episodes.iter().map(|e| e.trace.mu_hat.first()).collect::<Vec<_>>(),
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
            "fall_fraction": experiments::fall_fraction(&all),
            "by_mu": experiments::by_mu(task.as_ref(), &all),
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
        let (m, s) = result.summary.task;
        let error = result
            .summary
            .mu_mae
            .map_or(String::new(), |(e, _)| format!("  mean |mu error| {e:.3e}"));
        let by_component = result
            .summary
            .mu_mae_by_component
            .as_ref()
            .map_or(String::new(), |e| {
                let each: Vec<String> = e.iter().map(|x| format!("{x:.3e}")).collect();
                format!(" (per component {})", each.join(", "))
            });
        println!(
            "  {:<40} {kind:?}  {m:.2} +- {s:.2}  fall fraction {:.3}{error}{by_component}",
            path.display(),
            result.summary.fall_fraction
        );
        println!("    {}", bins_line(&result.summary.by_mu));
    }
    println!(
        "all {} episodes: {mean:.2} +- {std:.2}, fall fraction {:.3}",
        pooled.len(),
        experiments::fall_fraction(&all)
    );
    println!("  {}", bins_line(&experiments::by_mu(task.as_ref(), &all)));
    if !errors.is_empty() {
        println!("mean |mu error| {:.3e}", mean_std(&errors).0);
    }
    Ok(())
}
