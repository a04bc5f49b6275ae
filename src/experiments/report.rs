//! Writers for the studies: Markdown tables like the paper's, results JSON
//! and the window study's JSON and SVG (layouts in the module docs above).

use serde_json::{json, Value};

use super::{MethodResult, Results, WindowStudy};

/// `mean ± std`, in fixed notation with two decimals unless the mean is
/// below 0.005 (then in scientific notation, so a tiny error stays visible).
fn pm((mean, std): (f64, f64)) -> String {
    if mean != 0.0 && mean.abs() < 0.005 {
        format!("{mean:.1e} ± {std:.1e}")
    } else {
        format!("{mean:.2} ± {std:.2}")
    }
}

fn opt_pm(x: Option<(f64, f64)>) -> String {
    x.map_or("N/A".into(), pm)
}

/// The study as a Markdown table: our rows, then the paper's numbers.
pub fn markdown(results: &Results, title: &str) -> String {
    let mut out = format!(
        "# {title}\n\n{} models ({}) x {} episodes, seed {}{}. Mean ± std over the {} pooled episodes; \
         errors of mu averaged over each episode's steps; relative error with |mu| floored at a \
         tenth of the range's half-width; task performance = {}.\n\n",
        results.models.len(),
        results.models.join(", "),
        results.study.episodes,
        results.study.seed,
        results.study.change_at.map_or(String::new(), |t| format!(
            ", mu changes at t = {t} to a new uniform mu'"
        )),
        results.models.len() * results.study.episodes,
        crate::tasks::by_name(&results.task).map_or(String::new(), |t| t.metric_description()),
    );
    out += "| Approach | Mean Abs. Error (mu) | Mean Abs. Rel. Error (mu) | Task Performance | of UC-Oracle | Paper: MAE / rel. / task |\n";
    out += "|---|---|---|---|---|---|\n";
    for m in &results.methods {
        let paper = m
            .method
            .paper
            .map_or("—".into(), |[a, r, t]| format!("{a} / {r} / {t}"));
        let fraction = results
            .fraction_of_oracle(m)
            .map_or("—".into(), |f| format!("{:.1}%", 100.0 * f));
        out += &format!(
            "| {} | {} | {} | {} | {} | {} |\n",
            m.method.label,
            opt_pm(m.summary.mu_mae),
            opt_pm(m.summary.mu_mare),
            pm(m.summary.task),
            fraction,
            paper
        );
    }
    out
}

/// A number rounded to 4 significant digits (shorter JSON).
fn round4(x: f64) -> f64 {
    if x == 0.0 || !x.is_finite() {
        return x;
    }
    format!("{x:.3e}")
        .parse()
        .expect("a formatted float parses")
}

fn pair(x: Option<(f64, f64)>) -> Value {
    x.map_or(Value::Null, |(m, s)| json!([m, s]))
}

fn method_json(results: &Results, m: &MethodResult) -> Value {
    let episodes: Vec<Value> = m
        .episodes
        .iter()
        .map(|e| {
            let errors: Vec<Vec<f64>> = e
                .trace
                .mu_hat
                .iter()
                .zip(&e.trace.mu_true)
                .map(|(h, t)| h.iter().zip(t).map(|(h, t)| round4(h - t)).collect())
                .collect();
            json!({
                "model": e.model,
                "mu": e.episode.mu,
                "change": e.episode.change,
                "score": e.score,
                "mu_mae": e.mu_mae,
                "mu_mae_by_component": e.mu_mae_by_component,
                "mu_mare": e.mu_mare,
                "fell": e.trace.fell,
                "metric": e.trace.metric,
                "mu_error": errors,
            })
        })
        .collect();
    json!({
        "label": m.method.label,
        "policy": m.method.policy,
        "source": m.method.source,
        "summary": {
            "mu_mae": pair(m.summary.mu_mae),
            "mu_mae_by_component": m.summary.mu_mae_by_component,
            "mu_mare": pair(m.summary.mu_mare),
            "task": [m.summary.task.0, m.summary.task.1],
            "fall_fraction": m.summary.fall_fraction,
            "by_mu": m.summary.by_mu,
            "fraction_of_oracle": results.fraction_of_oracle(m),
        },
        "paper": m.method.paper,
        "episodes": episodes,
    })
}

pub fn results_json(results: &Results) -> Value {
    let methods: Vec<Value> = results
        .methods
        .iter()
        .map(|m| method_json(results, m))
        .collect();
    json!({
        "experiment": results.study.name,
        "task": results.task,
        "seed": results.study.seed,
        "models": results.models,
        "episodes_per_model": results.study.episodes,
        "change_at": results.study.change_at,
        "methods": methods,
    })
}

pub fn window_json(study: &WindowStudy) -> Value {
    let curves: Vec<Value> = study
        .curves
        .iter()
        .map(|(n, mean, running)| {
            json!({
                "context_window": n,
                "transitions": n - 1,
                "mean_abs_error": mean,
                "running": running,
            })
        })
        .collect();
    json!({
        "task": study.task,
        "seed": study.seed,
        "models": study.models,
        "episodes_per_model": study.episodes,
        "steps": study.steps,
        "curves": curves,
    })
}

/// The window study as an SVG line plot: mean |mu error| (log scale, floored
/// at 1e-16) against the control step, one line per context window.
pub fn window_svg(study: &WindowStudy) -> String {
    let (w, h, pad) = (720.0, 400.0, 60.0);
    let floor = 1e-16_f64;
    let values = study.curves.iter().flat_map(|c| c.1.iter().flatten());
    let top = values.fold(floor * 10.0, |a, &b| a.max(b)).log10().ceil();
    let bottom = floor.log10();
    let sx = |t: f64| pad + t / study.steps.max(1) as f64 * (w - 2.0 * pad);
    let sy = |e: f64| {
        let l = e.max(floor).log10();
        h - pad - (l - bottom) / (top - bottom) * (h - 2.0 * pad)
    };
    let colours = ["#1f77b4", "#d62728", "#2ca02c", "#9467bd", "#ff7f0e"];
    let mut lines = String::new();
    for (i, (n, mean, _)) in study.curves.iter().enumerate() {
        let points: Vec<String> = mean
            .iter()
            .enumerate()
            .filter_map(|(t, e)| e.map(|e| format!("{:.1},{:.1}", sx(t as f64), sy(e))))
            .collect();
        let colour = colours[i % colours.len()];
        lines += &format!(
            "<polyline points=\"{}\" stroke=\"{colour}\" stroke-width=\"1.5\" fill=\"none\"/>\n\
             <text x=\"{}\" y=\"{}\" fill=\"{colour}\">N = {n} ({} transition{})</text>\n",
            points.join(" "),
            w - pad - 150.0,
            pad + 18.0 * (i as f64 + 1.0),
            n - 1,
            if *n == 2 { "" } else { "s" },
        );
    }
    let mut ticks = String::new();
    let mut decade = bottom;
    while decade <= top {
        ticks += &format!(
            "<text x=\"{}\" y=\"{:.1}\" text-anchor=\"end\">1e{decade}</text>\n",
            pad - 6.0,
            sy(10f64.powf(decade)) + 4.0
        );
        decade += 4.0;
    }
    format!(
        r##"<svg xmlns="http://www.w3.org/2000/svg" width="{w}" height="{h}" font-family="sans-serif" font-size="12">
<rect width="100%" height="100%" fill="white"/>
<path d="M{pad},{pad} V{y0} H{x1}" stroke="black" fill="none"/>
{ticks}{lines}<text x="{pad}" y="{label_y}">0</text><text x="{x1}" y="{label_y}" text-anchor="end">{steps} control steps</text>
<text x="{mid}" y="24" text-anchor="middle">UC-DiffOSI on the {task}: mean |mu_hat - mu| per step, {episodes} episodes per model, {models} models</text>
</svg>
"##,
        y0 = h - pad,
        x1 = w - pad,
        label_y = h - pad + 18.0,
        steps = study.steps,
        mid = w / 2.0,
        task = study.task,
        episodes = study.episodes,
        models = study.models.len(),
    )
}
