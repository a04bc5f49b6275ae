//! `diffosi train`: PPO on a task, writing the policy and its learning curve.

use std::io::Write;
use std::path::{Path, PathBuf};

use diffosi::osi::mlp::{self, MlpConfig};
use diffosi::rl::{
    self, ApgConfig, ApgRow, CurveRow, DaggerConfig, Policy, PolicyKind, PpoConfig, RoundRow,
};
use diffosi::tasks::{self, Task};
use indicatif::{ProgressBar, ProgressStyle};

/// What `diffosi train` trains.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum Target {
    /// Universal Controller (PPO; observes the state and mu).
    Uc,
    /// Domain-randomised baseline (PPO; the state only).
    Dr,
    /// UC-MLP on the task's whole mu range.
    Mlp,
    /// UC-MLP on the narrow range [-0.2, 0.2] (the paper's MLP-Narrow).
    MlpNarrow,
}

/// How `diffosi train` makes a uc or dr policy.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum Method {
    /// PPO from a random network, or from --init.
    Ppo,
    /// DAgger on the iLQR MPC expert ([`rl::train_dagger`]).
    Imitation,
    /// Analytic policy gradients through the engine, from --init ([`rl::train_apg`]).
    Apg,
}

pub struct Request<'a> {
    pub task: &'a str,
    pub target: Target,
    /// Universal Controllers that collect the UC-MLP's data.
    pub controllers: &'a [PathBuf],
    pub seed: u64,
    pub steps: Option<usize>,
    pub output: &'a Path,
    pub curve: Option<PathBuf>,
    pub method: Method,
    pub init: Option<PathBuf>,
}

pub fn train(request: Request) -> Result<(), String> {
    let kind = match request.target {
        Target::Uc => PolicyKind::Uc,
        Target::Dr => PolicyKind::Dr,
        Target::Mlp | Target::MlpNarrow => return train_mlp(request),
    };
    let task = tasks::by_name(request.task)?;
    let init = request
        .init
        .as_deref()
        .map(|path| load_init(path, kind, task.as_ref()))
        .transpose()?;
    match (request.method, init) {
        (Method::Imitation, _) => imitate(task.as_ref(), kind, &request),
        (Method::Apg, Some(init)) => refine(task.as_ref(), &init, &request),
        (Method::Apg, None) => Err("--method apg refines a policy: give it with --init".into()),
        (Method::Ppo, init) => ppo(task.as_ref(), kind, init, &request),
    }
}

/// The --init policy, checked to be of `kind` for `task`.
fn load_init(path: &Path, kind: PolicyKind, task: &dyn Task) -> Result<Policy, String> {
    let policy = Policy::load(path)?;
    if policy.kind != kind || policy.task != task.name() {
        return Err(format!(
            "--init: a {:?} policy for '{}', not {kind:?} for '{}'",
            policy.kind,
            policy.task,
            task.name()
        ));
    }
    Ok(policy)
}

/// `diffosi train --method ppo`.
fn ppo(
    task: &dyn Task,
    kind: PolicyKind,
    init: Option<Policy>,
    request: &Request,
) -> Result<(), String> {
    let mut config = PpoConfig {
        seed: request.seed,
        // A given network meets a value function trained first.
        value_warmup: if init.is_some() { INIT_VALUE_WARMUP } else { 0 },
        ..PpoConfig::for_task(request.task)
    };
    if let Some(steps) = request.steps {
        config.total_steps = steps;
    }
    let curve_path = curve_path(request);
    let batch = config.num_envs * config.rollout_len;
    let bar = ProgressBar::new(config.total_steps.div_ceil(batch) as u64).with_style(
        ProgressStyle::with_template("{bar:40} {pos}/{len} iterations {elapsed}<{eta} {msg}")
            .expect("valid template"),
    );
    let trained = rl::train_from(task, kind, &config, init.as_ref(), |row| {
        bar.set_message(format!("metric {:.1}", row.mean_metric));
        bar.inc(1);
    })
    .map_err(|e| e.to_string())?;
    bar.finish_and_clear();
    trained.policy.save(request.output)?;
    let rows: Vec<String> = trained.curve.iter().map(CurveRow::csv).collect();
    let points: Vec<(f64, f64)> = trained
        .curve
        .iter()
        .map(|r| (r.env_steps as f64, r.mean_metric))
        .collect();
    let plot_path = write_curve(&curve_path, CurveRow::CSV_HEADER, &rows, &points)?;
    let info = trained.policy.training.as_ref().expect("set by training");
    println!(
        "{} {:?} seed {}: {} env steps in {:.1} s, mean task metric of the last {} training episodes {}",
        request.task,
        kind,
        request.seed,
        info.env_steps,
        info.wall_seconds,
        config.curve_window,
        info.final_metric.map_or("-".into(), |m| format!("{m:.1}"))
    );
    println!(
        "wrote {}, {} and {}",
        request.output.display(),
        curve_path.display(),
        plot_path.display()
    );
    Ok(())
}

/// PPO iterations that train only the value network when starting from --init.
const INIT_VALUE_WARMUP: usize = 10;

fn curve_path(request: &Request) -> PathBuf {
    request
        .curve
        .clone()
        .unwrap_or_else(|| request.output.with_extension("curve.csv"))
}

/// `diffosi train --method imitation`: DAgger on the task's MPC expert.
fn imitate(task: &dyn Task, kind: PolicyKind, request: &Request) -> Result<(), String> {
    let config = DaggerConfig {
        seed: request.seed,
        ..DaggerConfig::default()
    };
    let bar = ProgressBar::new(config.rounds as u64).with_style(
        ProgressStyle::with_template("{bar:40} {pos}/{len} rounds {elapsed}<{eta} {msg}")
            .expect("valid template"),
    );
    let (policy, curve) = rl::train_dagger(task, kind, &config, |row| {
        bar.set_message(format!("metric {:.1}", row.mean_metric));
        bar.inc(1);
    })
    .map_err(|e| e.to_string())?;
    bar.finish_and_clear();
    let curve = Curve {
        header: RoundRow::CSV_HEADER,
        rows: curve.iter().map(RoundRow::csv).collect(),
        points: curve
            .iter()
            .map(|r| (r.env_steps as f64, r.mean_metric))
            .collect(),
    };
    let what = (
        "imitation",
        "labelled states",
        "mean task metric of the last round",
    );
    save_trained(task, &policy, request, curve, what)
}

/// A trained policy's learning curve: CSV rows and the points to plot.
struct Curve {
    header: &'static str,
    rows: Vec<String>,
    points: Vec<(f64, f64)>,
}

/// Saves `policy` and its learning curve next to it and says what was made;
/// `what` names the method, its steps and its final metric.
fn save_trained(
    task: &dyn Task,
    policy: &Policy,
    request: &Request,
    curve: Curve,
    (method, steps, metric): (&str, &str, &str),
) -> Result<(), String> {
    policy.save(request.output)?;
    let path = curve_path(request);
    let plot_path = write_curve(&path, curve.header, &curve.rows, &curve.points)?;
    let info = policy.training.as_ref().expect("set by training");
    println!(
        "{} {:?} seed {} by {method}: {} {steps} in {:.1} s, {metric} {:.1}; wrote {}, {} and {}",
        task.name(),
        policy.kind,
        request.seed,
        info.env_steps,
        info.wall_seconds,
        info.final_metric.unwrap_or(f64::NAN),
        request.output.display(),
        path.display(),
        plot_path.display()
    );
    Ok(())
}

/// `diffosi train --method apg`: analytic policy gradients from --init.
fn refine(task: &dyn Task, init: &Policy, request: &Request) -> Result<(), String> {
    let mut config = ApgConfig {
        seed: request.seed,
        ..ApgConfig::default()
    };
    if let Some(steps) = request.steps {
        config.iterations = steps.div_ceil(config.batch * config.horizon);
    }
    let bar = ProgressBar::new(config.iterations as u64).with_style(
        ProgressStyle::with_template("{bar:40} {pos}/{len} iterations {elapsed}<{eta} {msg}")
            .expect("valid template"),
    );
    let mut last = None;
    let (policy, curve) = rl::train_apg(task, init, &config, |row| {
        last = row.validation.or(last);
        bar.set_message(format!(
            "cost {:.3}, validation {}",
            row.mean_cost,
            last.map_or("-".into(), |v: f64| format!("{v:.1}"))
        ));
        bar.inc(1);
    })
    .map_err(|e| e.to_string())?;
    bar.finish_and_clear();
    let curve = Curve {
        header: ApgRow::CSV_HEADER,
        rows: curve.iter().map(ApgRow::csv).collect(),
        points: curve
            .iter()
            .filter_map(|r| Some((r.env_steps as f64, r.validation?)))
            .collect(),
    };
    let what = (
        "analytic policy gradients",
        "env steps",
        "best validation score",
    );
    save_trained(task, &policy, request, curve, what)
}

/// The narrow training range of UC-MLP-Narrow, per mu component.
const NARROW: f64 = 0.2;

fn train_mlp(request: Request) -> Result<(), String> {
    let task = tasks::by_name(request.task)?;
    let controllers = request
        .controllers
        .iter()
        .map(|p| Policy::load(p))
        .collect::<Result<Vec<_>, _>>()?;
    if controllers.is_empty() || controllers.iter().any(|p| p.kind != PolicyKind::Uc) {
        return Err("--controller: give one or more Universal Controller files".into());
    }
    let (lower, upper) = task.mu_range();
    let mut config = match request.target {
        Target::MlpNarrow => {
            MlpConfig::new(&vec![-NARROW; lower.len()], &vec![NARROW; upper.len()])
        }
        _ => MlpConfig::for_task(request.task, lower, upper),
    };
    config.seed = request.seed;
    if let Some(steps) = request.steps {
        // A smaller budget: episodes per controller of the task's horizon.
        config.episodes = steps.div_ceil(task.horizon() * controllers.len()).max(10);
    }
    let bar = ProgressBar::new(config.epochs as u64).with_style(
        ProgressStyle::with_template("{bar:40} {pos}/{len} epochs {elapsed}<{eta} {msg}")
            .expect("valid template"),
    );
    let net = mlp::train_mlp(task.as_ref(), &controllers, &config, |_, loss| {
        bar.set_message(format!("held-out mse {loss:.4}"));
        bar.inc(1);
    })
    .map_err(|e| e.to_string())?;
    bar.finish_and_clear();
    net.save(request.output)?;
    let info = net.training.as_ref().expect("set by training");
    println!(
        "{} UC-MLP on mu in {:?}..{:?}, seed {}: {} examples, held-out mse of the normalised mu {:.4} -> {:.4} in {:.1} s; wrote {}",
        request.task,
        config.mu_lower,
        config.mu_upper,
        request.seed,
        info.examples,
        info.validation_loss[0],
        info.validation_loss.last().expect("at least the initial loss"),
        info.wall_seconds,
        request.output.display()
    );
    Ok(())
}

/// Writes the learning curve's CSV (header, rows) and, next to it, its plot
/// of (env steps, mean metric) points as SVG; returns the plot's path.
fn write_curve(
    path: &Path,
    header: &str,
    rows: &[String],
    points: &[(f64, f64)],
) -> Result<PathBuf, String> {
    let io = |e: std::io::Error| format!("cannot write {}: {e}", path.display());
    let mut out = std::io::BufWriter::new(std::fs::File::create(path).map_err(io)?);
    writeln!(out, "{header}").map_err(io)?;
    for row in rows {
        writeln!(out, "{row}").map_err(io)?;
    }
    out.flush().map_err(io)?;
    let plot_path = path.with_extension("svg");
    std::fs::write(&plot_path, curve_svg(points))
        .map_err(|e| format!("cannot write {}: {e}", plot_path.display()))?;
    Ok(plot_path)
}

/// The learning curve (mean task metric against environment steps) as a
/// small self-contained SVG line plot; the y axis spans min(0, lowest) to
/// max(1, highest).
fn curve_svg(points: &[(f64, f64)]) -> String {
    let (w, h, pad) = (640.0, 360.0, 50.0);
    let points: Vec<(f64, f64)> = points.iter().filter(|p| p.1.is_finite()).copied().collect();
    let x_max = points.iter().map(|p| p.0).fold(1.0, f64::max);
    let y_max = points.iter().map(|p| p.1).fold(1.0, f64::max);
    let y_min = points.iter().map(|p| p.1).fold(0.0, f64::min);
    let sx = |x: f64| pad + x / x_max * (w - 2.0 * pad);
    let sy = |y: f64| h - pad - (y - y_min) / (y_max - y_min) * (h - 2.0 * pad);
    let line: Vec<String> = points
        .iter()
        .map(|&(x, y)| format!("{:.1},{:.1}", sx(x), sy(y)))
        .collect();
    format!(
        r##"<svg xmlns="http://www.w3.org/2000/svg" width="{w}" height="{h}" font-family="sans-serif" font-size="12">
<rect width="100%" height="100%" fill="white"/>
<path d="M{pad},{top} V{bottom} H{right}" stroke="black" fill="none"/>
<polyline points="{points}" stroke="#1f77b4" stroke-width="1.5" fill="none"/>
<text x="{pad}" y="{label_y}">0</text><text x="{right}" y="{label_y}" text-anchor="end">{x_max} env steps</text>
<text x="{left}" y="{top}" text-anchor="end">{y_max:.0}</text><text x="{left}" y="{bottom}" text-anchor="end">{y_min:.0}</text>
<text x="{mid}" y="20" text-anchor="middle">mean task metric of recent training episodes</text>
</svg>
"##,
        points = line.join(" "),
        top = sy(y_max),
        bottom = sy(y_min),
        right = sx(x_max),
        label_y = h - pad + 18.0,
        left = pad - 6.0,
        mid = w / 2.0,
    )
}
