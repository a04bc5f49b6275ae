//! `diffosi reproduce`: the paper's cartpole results (Tables 1 and 4) and half
//! cheetah results (Table 2), each with its context-window study, on the
//! shipped controllers and UC-MLP weights.

use std::path::{Path, PathBuf};
use std::time::Instant;

use diffosi::control::Source;
use diffosi::experiments::{self, Models, Results, Study};
use diffosi::rl::Policy;
use diffosi::tasks::{self, Task};
use indicatif::{ProgressBar, ProgressStyle};

use super::eval::sources_for;

pub struct Request<'a> {
    /// "cartpole", "cheetah" (or "half_cheetah"), "wiping", "wiping-dims" or "all".
    pub what: &'a str,
    pub policies: &'a Path,
    pub reports: &'a Path,
    pub episodes: usize,
    pub models: usize,
    pub seed: u64,
    pub threads: usize,
}

/// Context windows N of the window study.
const WINDOWS: [usize; 3] = [2, 3, 5];

pub fn reproduce(request: Request) -> Result<(), String> {
    match request.what {
        "cartpole" => cartpole(&request),
        "cheetah" | "half_cheetah" => cheetah(&request),
        "wiping" => wiping(&request),
        "wiping-dims" => super::wiping::dims_study(request.reports, request.seed),
        "all" => cartpole(&request)
            .and_then(|()| cheetah(&request))
            .and_then(|()| wiping(&request))
            .and_then(|()| super::wiping::dims_study(request.reports, request.seed)),
        other => Err(format!(
            "unknown experiment '{other}' (known: cartpole, cheetah, wiping, wiping-dims, all)"
        )),
    }
}

/// Tables 1 and 4 and the window study on the cartpole, and Table 1's
/// methods on ten times the episodes (`table1-by-mu`: enough poles per bin
/// of the true mu for the performance-against-mu figure).
fn cartpole(request: &Request) -> Result<(), String> {
    let by_mu = Study {
        name: "table1-by-mu".into(),
        ..Study::table1(request.seed)
    };
    let tables = [
        (Study::table1(request.seed), "Table 1", 1),
        (Study::table4(request.seed), "Table 4", 1),
        (by_mu, "Table 1's methods, 10x the episodes", 10),
    ];
    paper_task(
        request,
        "cartpole",
        &tables,
        &[Source::Mlp, Source::MlpNarrow],
    )
}

/// Table 3 on the wiping task: --episodes runs (the paper's 10).
fn wiping(request: &Request) -> Result<(), String> {
    let paths = (request.policies, request.reports);
    super::wiping::table3(paths, (request.episodes, request.seed), request.threads)
}

/// Table 2 and the window study on the half cheetah.
fn cheetah(request: &Request) -> Result<(), String> {
    let tables = [(Study::table2(request.seed), "Table 2", 1)];
    paper_task(request, "half_cheetah", &tables, &[Source::Mlp])
}

fn write(path: PathBuf, text: &str) -> Result<(), String> {
    std::fs::write(&path, text).map_err(|e| format!("cannot write {}: {e}", path.display()))?;
    println!("wrote {}", path.display());
    Ok(())
}

fn bar(len: usize, what: &str) -> ProgressBar {
    let template = format!("{what:>12} {{bar:40}} {{pos}}/{{len}} episodes {{elapsed}}<{{eta}}");
    ProgressBar::new(len as u64)
        .with_style(ProgressStyle::with_template(&template).expect("valid template"))
}

/// Runs `tables` (each with --episodes times its factor per model) and the
/// window study on the shipped weights of a task
/// (policies/<task>/{uc,dr}-seed<k>.json, uc-mlp.json, uc-mlp-narrow.json as
/// the `mlp` sources need).
fn paper_task(
    request: &Request,
    name: &str,
    tables: &[(Study, &str, usize)],
    mlp: &[Source],
) -> Result<(), String> {
    let started = Instant::now();
    let task = tasks::by_name(name)?;
    let dir = request.policies.join(task.name());
    let load = |kind: &str| -> Result<Vec<Policy>, String> {
        (0..request.models)
            .map(|k| Policy::load(&dir.join(format!("{kind}-seed{k}.json"))))
            .collect()
    };
    let (uc, dr) = (load("uc")?, load("dr")?);
    let models = Models {
        names: (0..request.models).map(|k| format!("seed{k}")).collect(),
        uc: &uc,
        dr: &dr,
    };
    let sources = sources_for(
        mlp,
        &dir.join("uc-mlp.json"),
        &dir.join("uc-mlp-narrow.json"),
        4,
    )?;
    std::fs::create_dir_all(request.reports)
        .map_err(|e| format!("cannot create {}: {e}", request.reports.display()))?;
    for (study, title, factor) in tables {
        let study = Study {
            episodes: factor * request.episodes,
            ..study.clone()
        };
        let progress = bar(
            study.methods.len() * request.models * study.episodes,
            &study.name,
        );
        let results = experiments::run(
            task.as_ref(),
            &models,
            &sources,
            &study,
            request.threads,
            &|| progress.inc(1),
        )?;
        progress.finish_and_clear();
        report_table(task.as_ref(), &results, title, request.reports)?;
    }
    let progress = bar(WINDOWS.len() * request.models * request.episodes, "window");
    let study = experiments::window_study(
        task.as_ref(),
        &models,
        &WINDOWS,
        request.episodes,
        request.seed,
        request.threads,
        &|| progress.inc(1),
    )?;
    progress.finish_and_clear();
    for (n, mean, _) in &study.curves {
        let at = |t: usize| {
            mean.get(t)
                .copied()
                .flatten()
                .map_or("-".into(), |e| format!("{e:.1e}"))
        };
        println!(
            "window N = {n}: mean |mu error| at steps 0, 1, 2, 5, 50: {}, {}, {}, {}, {}",
            at(0),
            at(1),
            at(2),
            at(5),
            at(50)
        );
    }
    let json = serde_json::to_string(&experiments::window_json(&study)).expect("serialises");
    write(request.reports.join(format!("window-{name}.json")), &json)?;
    write(
        request.reports.join(format!("window-{name}.svg")),
        &experiments::window_svg(&study),
    )?;
    println!(
        "reproduce {name}: {:.1} s wall time on {} threads",
        started.elapsed().as_secs_f64(),
        request.threads
    );
    Ok(())
}

fn report_table(task: &dyn Task, results: &Results, title: &str, dir: &Path) -> Result<(), String> {
    let name = &results.study.name;
    let md = experiments::markdown(results, &format!("{title} ({})", task.name()));
    println!("{md}");
    write(dir.join(format!("{name}-{}.md", task.name())), &md)?;
    let json = serde_json::to_string(&experiments::results_json(results)).expect("serialises");
    write(dir.join(format!("{name}-{}.json", task.name())), &json)
}
