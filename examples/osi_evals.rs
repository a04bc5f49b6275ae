//! Evaluations to tolerance: DiffOSI's bounded Levenberg-Marquardt against
//! the paper's Adam and the derivative-free CMA-ES, on the benchmark problems
//! (`benches/osi_problems/mod.rs`: cartpole pole COM offset at the 12 truths
//! +-0.1, ..., +-0.6, half cheetah torso mass 4.9 -> 7.0), noise-free, cold
//! start from the prior.
//!
//! Run: `cargo run --release --example osi_evals`.
//!
//! An evaluation is one pass over the window: residuals and Jacobian for LM
//! and Adam (the work of one Gauss-Newton step), residuals alone for a
//! CMA-ES sample (plus one pass with the Jacobian at its answer). For each solver and window the table gives the
//! median (and maximum) number of evaluations after which |mu - truth| is
//! below the tolerance, found by running the deterministic solver under an
//! iteration cap k (CMA-ES: an evaluation cap), doubling k and then bisecting,
//! and how many cases never got there within the solver's own stopping rules
//! (medians are over the cases that did). LM runs without restarts under the
//! cap; a case whose single solve ends in a second basin is charged the
//! evaluations of the default solver with its restarts, all solves counted.

#[path = "../benches/osi_problems/mod.rs"]
mod osi_problems;

use diffosi::osi::{Adam, AdamOptions, CmaEs, CmaEsOptions, Identifier, Lm, LmOptions, Problem};
use osi_problems::{cartpole, half_cheetah, Task};

/// Evaluations until the error drops below `tol`, or None. `run(cap)` runs
/// the solver under an iteration (or evaluation) cap and returns the error,
/// whether the solver stopped on its own (not on the cap) and its
/// evaluations.
fn evaluations_to(
    run: &mut dyn FnMut(usize) -> (f64, bool, usize),
    tol: f64,
    cap: usize,
) -> Option<usize> {
    // Doubling to a cap where the error is below tol...
    let mut hi = 1;
    loop {
        let (err, stopped, _) = run(hi);
        if err < tol {
            break;
        }
        if stopped || hi >= cap {
            return None; // stopped on its own, or out of budget, above tol
        }
        hi *= 2;
    }
    // ... then bisection for the smallest such cap.
    let mut lo = hi / 2;
    while hi - lo > 1 {
        let mid = (lo + hi) / 2;
        if run(mid).0 < tol {
            hi = mid;
        } else {
            lo = mid;
        }
    }
    Some(run(hi).2)
}

/// LM: a single solve under an iteration cap (restarts off, so a capped
/// solve does not trigger them); if that solve never gets within `tol` (a
/// second basin), the default solver with its restarts, counting the
/// evaluations of every solve.
fn lm_evaluations(
    problem: &mut Problem,
    window: &[diffosi::derivatives::Transition],
    prior: f64,
    truth: f64,
    tol: f64,
) -> Option<usize> {
    let mut run = |cap: usize| {
        let options = LmOptions {
            max_iterations: cap,
            restarts: 0,
            ..LmOptions::default()
        };
        let e = Lm { options }.identify(problem, window, &[prior]).unwrap();
        (
            (e.mu[0] - truth).abs(),
            !e.flags.not_converged,
            e.evaluations,
        )
    };
    evaluations_to(&mut run, tol, 200).or_else(|| {
        let e = Lm::default().identify(problem, window, &[prior]).unwrap();
        ((e.mu[0] - truth).abs() < tol).then_some(e.evaluations)
    })
}

fn median(mut x: Vec<usize>) -> usize {
    x.sort_unstable();
    x[x.len() / 2]
}

fn cases(task: &Task) -> Vec<f64> {
    match task.name {
        // The 12 nonzero truths of the paper's range (0 is the prior itself).
        "cartpole" => (1..=6)
            .flat_map(|k| [k as f64 / 10.0, -(k as f64) / 10.0])
            .collect(),
        _ => vec![7.0],
    }
}

fn main() {
    println!("| model | W | tolerance | LM evaluations (median / max) | Adam (median / max) | CMA-ES (median / max) | not reached LM / Adam / CMA-ES |");
    println!("|---|---|---|---|---|---|---|");
    for task in [cartpole(), half_cheetah()] {
        let mut problem: Problem = task.problem();
        for w in [1, 2, 10, 50] {
            for tol in [1e-3, 1e-6] {
                let mut counts = [vec![], vec![], vec![]];
                let mut missed = [0, 0, 0];
                for (k, &mu) in cases(&task).iter().enumerate() {
                    let window = task.window(mu, w, 2000 + k as u64);
                    for (s, counts) in counts.iter_mut().enumerate() {
                        let start = [task.prior];
                        let found = match s {
                            0 => lm_evaluations(&mut problem, &window, task.prior, mu, tol),
                            1 => {
                                let mut run = |cap: usize| {
                                    let options = AdamOptions {
                                        max_iterations: cap,
                                        ..AdamOptions::default()
                                    };
                                    let e = Adam { options }
                                        .identify(&mut problem, &window, &start)
                                        .unwrap();
                                    ((e.mu[0] - mu).abs(), !e.flags.not_converged, e.evaluations)
                                };
                                evaluations_to(&mut run, tol, 4096)
                            }
                            _ => {
                                // Capped by evaluations (whole generations).
                                let mut run = |cap: usize| {
                                    let options = CmaEsOptions {
                                        max_evaluations: cap,
                                        ..CmaEsOptions::default()
                                    };
                                    let e = CmaEs { options }
                                        .identify(&mut problem, &window, &start)
                                        .unwrap();
                                    ((e.mu[0] - mu).abs(), !e.flags.not_converged, e.evaluations)
                                };
                                evaluations_to(&mut run, tol, 20_000)
                            }
                        };
                        match found {
                            Some(n) => counts.push(n),
                            None => missed[s] += 1,
                        }
                    }
                }
                let cell = |c: &Vec<usize>| {
                    if c.is_empty() {
                        "—".to_string()
                    } else {
                        format!("{} / {}", median(c.clone()), c.iter().max().unwrap())
                    }
                };
                println!(
                    "| {} | {w} | {tol:.0e} | {} | {} | {} | {} / {} / {} |",
                    task.name,
                    cell(&counts[0]),
                    cell(&counts[1]),
                    cell(&counts[2]),
                    missed[0],
                    missed[1],
                    missed[2]
                );
            }
        }
    }
}
