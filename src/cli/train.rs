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
    let plot_path = curve_path.with_extension("svg");
    std::fs::write(&plot_path, curve_svg(&trained.curve))
        .map_err(|e| format!("cannot write {}: {e}", plot_path.display()))?;
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
        "wrote {}, {} and {}",
        request.output.display(),
        curve_path.display(),
        plot_path.display()
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

/// The learning curve (mean task metric against environment steps) as a
/// small self-contained SVG line plot.
fn curve_svg(curve: &[CurveRow]) -> String {
    let (w, h, pad) = (640.0, 360.0, 50.0);
    let points: Vec<(f64, f64)> = curve
        .iter()
        .filter(|r| r.mean_metric.is_finite())
        .map(|r| (r.env_steps as f64, r.mean_metric))
        .collect();
    let x_max = points.iter().map(|p| p.0).fold(1.0, f64::max);
    let y_max = points.iter().map(|p| p.1).fold(1.0, f64::max);
    let sx = |x: f64| pad + x / x_max * (w - 2.0 * pad);
    let sy = |y: f64| h - pad - y / y_max * (h - 2.0 * pad);
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
<text x="{left}" y="{top}" text-anchor="end">{y_max:.0}</text><text x="{left}" y="{bottom}" text-anchor="end">0</text>
<text x="{mid}" y="20" text-anchor="middle">mean task metric of recent training episodes</text>
</svg>
"##,
        points = line.join(" "),
        top = sy(y_max),
        bottom = sy(0.0),
        right = sx(x_max),
        label_y = h - pad + 18.0,
        left = pad - 6.0,
        mid = w / 2.0,
    )
}
