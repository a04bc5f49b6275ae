//! The wiping task from the command line: `diffosi wipe` (one episode as CSV,
//! optionally identified), `diffosi train-wiping` (the UC's dataset and
//! weights, DR's gains, UC-MLP) and `diffosi reproduce wiping` (Table 3).

use std::io::Write;
use std::path::Path;
use std::time::Instant;

use diffosi::compile::contact_pairs;
use diffosi::control::admittance::Gains;
use diffosi::experiments::wiping::{self as exp, Controllers, Uc};
use diffosi::experiments::wiping_dims as dims;
use diffosi::model::State;
use diffosi::osi::mlp::MuMlp;
use diffosi::osi::Lm;
use diffosi::tasks::wiping::{Segments, Wiping, CANONICAL};
use indicatif::{ProgressBar, ProgressStyle};
use rand::rngs::StdRng;
use rand::SeedableRng;

fn bar(len: usize, what: &str) -> ProgressBar {
    let template = format!("{what:>12} {{bar:40}} {{pos}}/{{len}} {{elapsed}}<{{eta}}");
    ProgressBar::new(len as u64)
        .with_style(ProgressStyle::with_template(&template).expect("valid template"))
}

fn write(path: &Path, text: &str) -> Result<(), String> {
    std::fs::write(path, text).map_err(|e| format!("cannot write {}: {e}", path.display()))?;
    println!("wrote {}", path.display());
    Ok(())
}

/// `diffosi wipe`: one episode at mu under `gains` (the canonical ones by
/// default) written as CSV: `t, q_<joint>..., v_<joint>..., tau_<joint>...`
/// (the generalized forces the step from the row applies; on the last row
/// the controller's output there), `fn_<tip>_<table>` (the normal force the
/// controller sensed at the row, over the step into it, N) and `xi` (the
/// admittance offset, m); with `model_out`, the arm
/// at mu as MJCF. With `identify`, DiffOSI then identifies mu from 50
/// segments of the episode.
pub fn wipe(
    mu: &[f64],
    gains: Option<Gains>,
    (steps, seed): (usize, u64),
    (output, model_out): (&Path, Option<&Path>),
    identify: bool,
) -> Result<(), String> {
    let task = Wiping::new();
    let gains = gains.unwrap_or(CANONICAL);
    let episode = task.episode(mu, gains, steps).map_err(|e| e.to_string())?;
    if let Some(path) = model_out {
        let at_mu = task.model_at(mu).map_err(|e| e.to_string())?;
        at_mu.save(path).map_err(|e| e.to_string())?;
        println!("wrote {} (the arm at mu)", path.display());
    }
    let model = task.model();
    let h = model.opt.timestep;
    let names: Vec<&str> = model.joints.iter().map(|j| j.name.as_str()).collect();
    let [a, b] = *contact_pairs(model)
        .first()
        .ok_or("the arm has no contact pair")?;
    let header: Vec<String> = ["q", "v", "tau"]
        .iter()
        .flat_map(|p| names.iter().map(move |n| format!("{p}_{n}")))
        .chain([
            format!("fn_{}_{}", model.geoms[a].name, model.geoms[b].name),
            "xi".into(),
        ])
        .collect();
    let file = std::fs::File::create(output)
        .map_err(|e| format!("cannot write {}: {e}", output.display()))?;
    let mut out = std::io::BufWriter::new(file);
    let io = |e: std::io::Error| format!("cannot write {}: {e}", output.display());
    writeln!(out, "t,{}", header.join(",")).map_err(io)?;
    for (k, (State { q, v, .. }, tau)) in episode.states.iter().zip(&episode.taus).enumerate() {
        let row: Vec<String> = q
            .iter()
            .chain(v)
            .chain(tau)
            .chain([&episode.forces[k], &episode.xi[k]])
            .map(|x| format!("{x:?}"))
            .collect();
        writeln!(out, "{},{}", k as f64 * h, row.join(",")).map_err(io)?;
    }
    out.flush().map_err(io)?;
    println!(
        "wrote {} ({} steps); task metric {:.4} N^2 (MSE of the normal force against 3 N over the steps in contact)",
        output.display(),
        steps,
        episode.metric
    );
    if identify {
        let mut rng = StdRng::seed_from_u64(seed);
        let counts = (exp::SEGMENTS, exp::SEGMENT_STEPS);
        let segments = Segments::sample(
            &task,
            (&episode.states, &episode.xi, &episode.forces, gains),
            counts,
            &mut rng,
        )?;
        let prior = task.prior();
        let mut problem = task.problem();
        let started = Instant::now();
        let e = Lm::default()
            .identify_on(&mut problem, &segments, &prior)
            .map_err(|e| e.to_string())?;
        let seconds = started.elapsed().as_secs_f64();
        println!(
            "DiffOSI from {} segments of {} steps: mu = {:?} (true {mu:?}), loss {:.3e}, {} iterations, {} evaluations, {:.1} ms, flags {:?}",
            exp::SEGMENTS,
            exp::SEGMENT_STEPS,
            e.mu,
            e.loss,
            e.iterations,
            e.evaluations,
            1e3 * seconds,
            e.flags
        );
    }
    Ok(())
}

/// Evaluations per theta* search, and epochs of the UC's fit.
const PAIR_BUDGET: usize = 150;
const DR_BUDGET: usize = 150;
const UC_EPOCHS: usize = 3000;
/// UC-MLP: episodes, stride between the transitions kept, epochs.
const MLP_DATA: (usize, usize, usize) = (60, 10, 40);

/// `diffosi train-wiping`: writes into `dir` the UC's dataset
/// (dataset.json), the UC (uc.json), DR's gains (dr.json) and UC-MLP
/// (uc-mlp.json).
pub fn train(dir: &Path, (pairs, seed): (usize, u64), threads: usize) -> Result<(), String> {
    let started = Instant::now();
    let task = Wiping::new();
    std::fs::create_dir_all(dir).map_err(|e| format!("cannot create {}: {e}", dir.display()))?;
    let progress = bar(pairs, "theta*(mu)");
    let data = exp::dataset(&task, (pairs, PAIR_BUDGET, seed), threads, &|_| {
        progress.inc(1)
    });
    progress.finish_and_clear();
    let text = serde_json::to_string_pretty(&serde_json::json!({
        "format": "diffosi-wiping-dataset/1",
        "seed": seed,
        "budget_per_pair": PAIR_BUDGET,
        "pairs": data,
    }))
    .expect("serialises");
    write(&dir.join("dataset.json"), &text)?;
    let uc = Uc::train(&task, &data, UC_EPOCHS, seed);
    uc.save(&dir.join("uc.json"))?;
    println!("wrote {}", dir.join("uc.json").display());
    let mut rng = StdRng::seed_from_u64(seed ^ 0xd5);
    let mus: Vec<Vec<f64>> = (0..exp::DR_ENVIRONMENTS)
        .map(|_| task.sample_mu(&mut rng))
        .collect();
    let (dr, metric, evaluations) = exp::optimise_gains(&task, &mus, DR_BUDGET, seed);
    let text = serde_json::to_string_pretty(&serde_json::json!({
        "format": "diffosi-wiping-dr/1",
        "k_tau": dr.k_tau,
        "k_xi": dr.k_xi,
        "mean_metric": metric,
        "environments": mus,
        "evaluations": evaluations,
    }))
    .expect("serialises");
    write(&dir.join("dr.json"), &text)?;
    let mlp = exp::train_uc_mlp(&task, MLP_DATA, seed, threads)?;
    mlp.save(&dir.join("uc-mlp.json"))?;
    println!("wrote {}", dir.join("uc-mlp.json").display());
    println!("train-wiping: {:.1} s", started.elapsed().as_secs_f64());
    Ok(())
}

/// DR's gains from its file.
fn load_dr(path: &Path) -> Result<Gains, String> {
    let text = std::fs::read_to_string(path)
        .map_err(|e| format!("cannot read {}: {e}", path.display()))?;
    let v: serde_json::Value =
        serde_json::from_str(&text).map_err(|e| format!("{}: {e}", path.display()))?;
    let get = |k: &str| {
        v[k].as_f64()
            .ok_or_else(|| format!("{}: no number '{k}'", path.display()))
    };
    Gains {
        k_tau: get("k_tau")?,
        k_xi: get("k_xi")?,
    }
    .check()
}

/// CMA-ES's budget per identification in Table 3.
pub const CMAES_BUDGET: usize = 300;

/// Table 3 from the weights in `policies/wiping`.
pub fn table3(
    (policies, reports): (&Path, &Path),
    (runs, seed): (usize, u64),
    threads: usize,
) -> Result<(), String> {
    let started = Instant::now();
    let task = Wiping::new();
    let dir = policies.join("wiping");
    let uc = Uc::load(&dir.join("uc.json"))?;
    let mlp = MuMlp::load(&dir.join("uc-mlp.json"))?;
    let controllers = Controllers {
        uc: &uc,
        dr: load_dr(&dir.join("dr.json"))?,
        mlp: &mlp,
        cmaes_budget: CMAES_BUDGET,
    };
    let progress = bar(runs, "Table 3");
    let results = exp::table3(&task, &controllers, (runs, seed), threads, &|_| {
        progress.inc(1)
    })?;
    progress.finish_and_clear();
    let settings = format!(
        "{runs} runs (seed {seed}), true mu = (tool k_p in N/cm, k_d in N s/m) uniform in [1, 100]^2; \
         identification from {} closed-loop segments of {} steps of one episode with the canonical gains \
         (k_tau {}, k_xi {}); UC-CMA-ES budget {CMAES_BUDGET} evaluations; task metric = MSE of the \
         normal force against 3 N over the steps in contact, N^2.",
        exp::SEGMENTS,
        exp::SEGMENT_STEPS,
        CANONICAL.k_tau,
        CANONICAL.k_xi
    );
    let md = exp::markdown(&results, &settings);
    println!("{md}");
    std::fs::create_dir_all(reports)
        .map_err(|e| format!("cannot create {}: {e}", reports.display()))?;
    write(&reports.join("table3-wiping.md"), &md)?;
    let json = exp::json(
        &results,
        serde_json::json!({"runs": runs, "seed": seed,
        "segments": exp::SEGMENTS, "segment_steps": exp::SEGMENT_STEPS, "cmaes_budget": CMAES_BUDGET}),
    );
    write(
        &reports.join("table3-wiping.json"),
        &serde_json::to_string(&json).expect("serialises"),
    )?;
    println!("reproduce wiping: {:.1} s", started.elapsed().as_secs_f64());
    Ok(())
}

/// Runs per dimension of the study (the paper's 3).
const DIMS_RUNS: usize = 3;

/// The higher-dimension study (paper Fig. 6) into reports/wiping-dims.{md,json}.
pub fn dims_study(reports: &Path, seed: u64) -> Result<(), String> {
    let started = Instant::now();
    let progress = bar(dims::DIMENSIONS.len() * DIMS_RUNS, "dimensions");
    let budgets = (&dims::LM_BUDGETS[..], &dims::CMAES_BUDGETS[..]);
    let result = dims::study(&dims::DIMENSIONS, (DIMS_RUNS, seed), budgets, &|| {
        progress.inc(1)
    })?;
    progress.finish_and_clear();
    let settings = format!(
        "{DIMS_RUNS} runs per dimension (seed {seed}), true mu uniform in [1, 100] per component; \
         {} closed-loop segments of {} steps of one canonical-gain episode; both solvers start at the \
         middle of the box. Error: mean over mu's components of |mu_hat - mu| (mu units), mean over runs. \
         LM budgets {:?} iterations, CMA-ES budgets {:?} evaluations; one evaluation = one pass over the \
         segments (DiffOSI's with its dual-number Jacobian, whose cost in plain passes is the last column).",
        exp::SEGMENTS,
        exp::SEGMENT_STEPS,
        dims::LM_BUDGETS,
        dims::CMAES_BUDGETS
    );
    let md = dims::markdown(&result, &settings);
    println!("{md}");
    std::fs::create_dir_all(reports)
        .map_err(|e| format!("cannot create {}: {e}", reports.display()))?;
    write(&reports.join("wiping-dims.md"), &md)?;
    let json = dims::json(
        &result,
        serde_json::json!({"runs": DIMS_RUNS, "seed": seed,
        "segments": exp::SEGMENTS, "segment_steps": exp::SEGMENT_STEPS}),
    );
    write(
        &reports.join("wiping-dims.json"),
        &serde_json::to_string(&json).expect("serialises"),
    )?;
    println!(
        "reproduce wiping-dims: {:.1} s",
        started.elapsed().as_secs_f64()
    );
    Ok(())
}
