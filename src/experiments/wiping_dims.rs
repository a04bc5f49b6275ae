//! The higher-dimensional identification study on the wiping task (the
//! paper's Fig. 6): more joints with unknown stiffness and damping
//! ([`Unknown::first`]: 2-D the tool's (k_p, k_d), then a6's damping and
//! stiffness, then a4's), DiffOSI against CMA-ES on the same 50 closed-loop
//! segments of one canonical-gain episode, both from the middle of the box.
//!
//! Convergence curves: a solver run with a budget b (LM: at most b
//! iterations; CMA-ES: at most b evaluations) is seeded and deterministic,
//! so the curve is the sequence of runs with growing budgets, each point
//! (evaluations spent, mean over mu's components of |mu_hat - mu|, the same
//! relative to mu, wall time). One evaluation is one pass over the 50
//! segments; LM's evaluations carry the dual-number Jacobian, whose cost
//! relative to a plain pass is measured and reported.

use std::time::Instant;

use rand::rngs::StdRng;
use rand::SeedableRng;
use serde::Serialize;

use super::wiping::{SEGMENTS, SEGMENT_STEPS};
use crate::osi::{CmaEs, CmaEsOptions, Estimate, Lm, LmOptions};
use crate::tasks::wiping::{Segments, Unknown, Wiping, CANONICAL, STEPS};

/// Dimensions of the study.
pub const DIMENSIONS: [usize; 4] = [2, 3, 4, 6];
/// LM iteration budgets and CMA-ES evaluation budgets of the curves.
pub const LM_BUDGETS: [usize; 8] = [1, 2, 3, 4, 5, 6, 8, 12];
pub const CMAES_BUDGETS: [usize; 9] = [10, 20, 40, 80, 160, 320, 640, 1280, 2560];

/// One point of a convergence curve.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Point {
    pub evaluations: usize,
    pub abs_error: f64,
    pub rel_error: f64,
    /// Wall time (s): not part of the deterministic numbers.
    #[serde(skip)]
    pub seconds: f64,
}

/// One run: the true mu and both solvers' curves.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Run {
    pub mu: Vec<f64>,
    pub diffosi: Vec<Point>,
    pub cmaes: Vec<Point>,
}

/// All runs of one dimension, with the measured cost of one dual-number
/// evaluation in plain evaluations.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Dimension {
    pub dimension: usize,
    pub unknowns: Vec<String>,
    pub runs: Vec<Run>,
    #[serde(skip)]
    pub jacobian_cost: f64,
}

fn point(truth: &[f64], e: &Estimate, seconds: f64) -> Point {
    let n = truth.len() as f64;
    let abs = e.mu.iter().zip(truth).map(|(h, m)| (h - m).abs());
    let rel = e.mu.iter().zip(truth).map(|(h, m)| (h - m).abs() / m);
    Point {
        evaluations: e.evaluations,
        abs_error: abs.sum::<f64>() / n,
        rel_error: rel.sum::<f64>() / n,
        seconds,
    }
}

/// Runs the study: `runs` runs per dimension in `dims`, budgets capped by
/// `max_lm` and `max_cmaes`; `done` sees each finished run.
pub fn study(
    dims: &[usize],
    (runs, seed): (usize, u64),
    (lm_budgets, cmaes_budgets): (&[usize], &[usize]),
    done: &dyn Fn(),
) -> Result<Vec<Dimension>, String> {
    dims.iter()
        .map(|&d| {
            let task = Wiping::with_unknowns(&Unknown::first(d)?).map_err(|e| e.to_string())?;
            let mut rng = StdRng::seed_from_u64(seed ^ d as u64);
            let mut cost = vec![];
            let runs = (0..runs)
                .map(|r| {
                    let truth = task.sample_mu(&mut rng);
                    let run = one_run(&task, &truth, seed + r as u64, (lm_budgets, cmaes_budgets));
                    done();
                    run.map(|(run, c)| {
                        cost.push(c);
                        run
                    })
                })
                .collect::<Result<Vec<_>, String>>()?;
            Ok(Dimension {
                dimension: d,
                unknowns: task.unknowns().iter().map(|u| u.label()).collect(),
                runs,
                jacobian_cost: cost.iter().sum::<f64>() / cost.len().max(1) as f64,
            })
        })
        .collect()
}

fn one_run(
    task: &Wiping,
    truth: &[f64],
    seed: u64,
    (lm_budgets, cmaes_budgets): (&[usize], &[usize]),
) -> Result<(Run, f64), String> {
    let err = |e: &dyn std::fmt::Display| e.to_string();
    let episode = task.episode(truth, CANONICAL, STEPS).map_err(|e| err(&e))?;
    let mut rng = StdRng::seed_from_u64(seed);
    let counts = (SEGMENTS, SEGMENT_STEPS);
    let segments = Segments::sample(
        task,
        (&episode.states, &episode.xi, &episode.forces, CANONICAL),
        counts,
        &mut rng,
    )?;
    let prior = task.prior();
    let mut problem = task.problem();
    let timed = |f: &mut dyn FnMut() -> Result<Estimate, String>| {
        let t = Instant::now();
        f().map(|e| (e, t.elapsed().as_secs_f64()))
    };
    let mut diffosi = vec![];
    for &b in lm_budgets {
        let mut lm = Lm {
            options: LmOptions {
                max_iterations: b,
                restarts: 0,
                ..LmOptions::default()
            },
        };
        let (e, s) = timed(&mut || {
            lm.identify_on(&mut problem, &segments, &prior)
                .map_err(|e| err(&e))
        })?;
        diffosi.push(point(truth, &e, s));
    }
    let mut cmaes = vec![];
    for &b in cmaes_budgets {
        let mut cma = CmaEs {
            options: CmaEsOptions {
                max_evaluations: b,
                seed,
                ..CmaEsOptions::default()
            },
        };
        let (e, s) = timed(&mut || {
            cma.identify_on(&mut problem, &segments, &prior)
                .map_err(|e| err(&e))
        })?;
        cmaes.push(point(truth, &e, s));
    }
    let t = Instant::now();
    problem.loss(&prior, &segments).map_err(|e| err(&e))?;
    let plain = t.elapsed().as_secs_f64();
    let t = Instant::now();
    problem.fit(&prior, &segments).map_err(|e| err(&e))?;
    let dual = t.elapsed().as_secs_f64();
    let run = Run {
        mu: truth.to_vec(),
        diffosi,
        cmaes,
    };
    Ok((run, dual / plain))
}

/// Per dimension: CMA-ES's final mean error, DiffOSI's, the evaluations each
/// needs to reach CMA-ES's final error (mean over runs; DiffOSI's first
/// point at or below it), and their ratio.
pub struct Summary {
    pub dimension: usize,
    pub cmaes_final: f64,
    pub diffosi_final: f64,
    pub cmaes_evaluations: f64,
    pub diffosi_evaluations: Option<f64>,
    pub cmaes_seconds: f64,
    pub diffosi_seconds: Option<f64>,
    pub jacobian_cost: f64,
}

pub fn summarise(dims: &[Dimension]) -> Vec<Summary> {
    dims.iter()
        .map(|d| {
            let n = d.runs.len().max(1) as f64;
            let last = |c: &[Point]| c.last().map_or(f64::NAN, |p| p.abs_error);
            let reach: Vec<Option<&Point>> = d
                .runs
                .iter()
                .map(|r| {
                    let target = last(&r.cmaes);
                    r.diffosi.iter().find(|p| p.abs_error <= target)
                })
                .collect();
            let all = reach.iter().all(|p| p.is_some());
            let mean = |f: &dyn Fn(&Point) -> f64| {
                all.then(|| reach.iter().flatten().map(|p| f(p)).sum::<f64>() / n)
            };
            let cma_last = |f: &dyn Fn(&Point) -> f64| {
                d.runs
                    .iter()
                    .filter_map(|r| r.cmaes.last())
                    .map(f)
                    .sum::<f64>()
                    / n
            };
            Summary {
                dimension: d.dimension,
                cmaes_final: d.runs.iter().map(|r| last(&r.cmaes)).sum::<f64>() / n,
                diffosi_final: d.runs.iter().map(|r| last(&r.diffosi)).sum::<f64>() / n,
                cmaes_evaluations: cma_last(&|p| p.evaluations as f64),
                diffosi_evaluations: mean(&|p| p.evaluations as f64),
                cmaes_seconds: cma_last(&|p| p.seconds),
                diffosi_seconds: mean(&|p| p.seconds),
                jacobian_cost: d.jacobian_cost,
            }
        })
        .collect()
}

/// The study's table as markdown.
pub fn markdown(dims: &[Dimension], settings: &str) -> String {
    let mut out = format!(
        "# Wiping: identification in higher dimensions (paper Fig. 6)\n\n{settings}\n\n\
         | dim | CMA-ES final error | its evaluations | its time | DiffOSI final error | DiffOSI evaluations to CMA-ES's final error | its time | evaluation ratio | time ratio | dual / plain evaluation cost |\n\
         |---|---|---|---|---|---|---|---|---|---|\n"
    );
    for s in summarise(dims) {
        let (evals, time, ratio, tratio) = match (s.diffosi_evaluations, s.diffosi_seconds) {
            (Some(e), Some(t)) => (
                format!("{e:.1}"),
                format!("{:.1} ms", 1e3 * t),
                format!("1/{:.0}", s.cmaes_evaluations / e),
                format!("1/{:.0}", s.cmaes_seconds / t),
            ),
            _ => ("not reached".into(), "-".into(), "-".into(), "-".into()),
        };
        out += &format!(
            "| {} | {:.2e} | {:.0} | {:.0} ms | {:.2e} | {evals} | {time} | {ratio} | {tratio} | {:.1} |\n",
            s.dimension,
            s.cmaes_final,
            s.cmaes_evaluations,
            1e3 * s.cmaes_seconds,
            s.diffosi_final,
            s.jacobian_cost
        );
    }
    out
}

/// The study as JSON (wall times apart under `timing`, not deterministic).
pub fn json(dims: &[Dimension], settings: serde_json::Value) -> serde_json::Value {
    let timing: Vec<serde_json::Value> = dims
        .iter()
        .map(|d| {
            let secs = |c: &[Point]| c.iter().map(|p| p.seconds).collect::<Vec<_>>();
            serde_json::json!({
                "dimension": d.dimension,
                "jacobian_cost": d.jacobian_cost,
                "diffosi_seconds": d.runs.iter().map(|r| secs(&r.diffosi)).collect::<Vec<_>>(),
                "cmaes_seconds": d.runs.iter().map(|r| secs(&r.cmaes)).collect::<Vec<_>>(),
            })
        })
        .collect();
    serde_json::json!({
        "experiment": "wiping-dims",
        "settings": settings,
        "dimensions": dims,
        "timing": timing,
    })
}
