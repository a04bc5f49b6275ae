//! Long runs keep memory flat: a 10^6-step simulation and a 10^5-update online
//! identification, with the process's resident set read at checkpoints.
//!
//! Run: `cargo run --release --example long_runs > reports/long-runs.md`
//! (optional arguments: simulation steps, then online updates).
//!
//! - Simulation: `reference_models/double_pendulum.xml` (dt 0.001 s, damped)
//!   under tau = (sin t, cos 2t) N m through [`Model::step`], one reused
//!   [`Data`](diffosi::dynamics::Data) buffer, as a user's loop calls it.
//! - Online identification: the cartpole task's mu by [`Online`] with
//!   bounded Levenberg-Marquardt on windows of 8 transitions drawn uniformly
//!   from the 200 most recent, change detection on; each update pushes one
//!   transition of the true model from a random state and cart force (seeded),
//!   and the true mu jumps every 10^4 updates, so the detector empties the
//!   buffer now and then and it refills.
//!
//! Memory: VmRSS (resident now) and VmHWM (peak resident so far) from
//! /proc/self/status, in kB, at 10 evenly spaced checkpoints after a warm-up
//! of 1% of the run. Flat means VmHWM stops growing after the warm-up.

use std::time::Instant;

use diffosi::derivatives::Transition;
use diffosi::model::{Inputs, State};
use diffosi::osi::{ChangeDetection, Lm, Online, Problem, Sampling};
use diffosi::tasks::{average_mu, by_name};
use diffosi::Model;
use rand::rngs::StdRng;
use rand::{RngExt, SeedableRng};

const CHECKPOINTS: usize = 10;

/// (VmRSS, VmHWM) in kB, read from /proc/self/status (Linux).
fn memory_kb() -> (u64, u64) {
    let status = std::fs::read_to_string("/proc/self/status").expect("/proc/self/status (Linux)");
    let field = |name: &str| {
        status
            .lines()
            .find_map(|l| l.strip_prefix(name))
            .and_then(|rest| rest.trim().trim_end_matches("kB").trim().parse().ok())
            .unwrap_or_else(|| panic!("{name} in /proc/self/status"))
    };
    (field("VmRSS:"), field("VmHWM:"))
}

/// One checkpoint: iterations done, seconds since the start, VmRSS, VmHWM.
struct Checkpoint {
    done: usize,
    seconds: f64,
    rss: u64,
    hwm: u64,
}

/// Runs `step(i)` for i in 0..n, reading memory after a 1% warm-up and at
/// every tenth of the run.
fn measured(n: usize, mut step: impl FnMut(usize)) -> Vec<Checkpoint> {
    let start = Instant::now();
    let warmup = (n / 100).max(1);
    let mut marks: Vec<usize> = (1..=CHECKPOINTS).map(|k| k * n / CHECKPOINTS).collect();
    marks.insert(0, warmup);
    let mut out = Vec::with_capacity(marks.len());
    let mut i = 0;
    for mark in marks {
        while i < mark {
            step(i);
            i += 1;
        }
        let (rss, hwm) = memory_kb();
        let seconds = start.elapsed().as_secs_f64();
        out.push(Checkpoint {
            done: i,
            seconds,
            rss,
            hwm,
        });
    }
    out
}

fn simulate(steps: usize) -> (Vec<Checkpoint>, String) {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/reference_models/double_pendulum.xml"
    );
    let model = Model::load(path).expect("the shipped double pendulum loads");
    let mut data = model.data();
    let mut x = State::new(vec![0.5, -0.3], vec![0.0, 0.0]);
    let dt = model.opt.timestep;
    let series = measured(steps, |i| {
        let t = i as f64 * dt;
        let tau = [t.sin(), (2.0 * t).cos()];
        x = model
            .step(&mut data, &x, &Inputs::tau(&tau))
            .expect("a finite step");
    });
    (series, format!("final q = {:.6?}, v = {:.6?}", x.q, x.v))
}

/// The true mu of update i: it jumps every `every` updates.
fn true_mu(i: usize, every: usize) -> f64 {
    [0.3, -0.4, 0.5, -0.1][(i / every) % 4]
}

fn identify(updates: usize) -> (Vec<Checkpoint>, String) {
    let task = by_name("cartpole").expect("the cartpole task");
    let (lo, hi) = task.mu_range();
    let scale = [2e-8, 2e-8, 1e-6, 1e-6]; // noise-free data: rounding level (q then v)
    let problem = Problem::new(
        task.model(),
        task.mu_map().clone(),
        lo,
        hi,
        &average_mu(task.as_ref()),
        &scale,
    )
    .expect("a valid problem");
    let sampling = Sampling::Uniform { history: 200 };
    let mut online = Online::new(problem, Lm::default(), 8, sampling, 0)
        .and_then(|o| o.with_change_detection(ChangeDetection::default()))
        .expect("valid online options");
    let mut truth = task.model().clone();
    let mut data = truth.data();
    let mut rng = StdRng::seed_from_u64(0);
    let every = (updates / 10).clamp(1, 10_000);
    let (mut changes, mut worst) = (0, 0.0f64);
    let series = measured(updates, |i| {
        let mu = true_mu(i, every);
        task.mu_map().apply(&mut truth, &[mu]).expect("mu in range");
        let mut draw = |h: f64| rng.random_range(-h..=h);
        let (q, v) = (vec![draw(1.0), draw(0.5)], vec![draw(1.0), draw(2.0)]);
        let tau = vec![draw(10.0), 0.0];
        let transition =
            Transition::simulated(&truth, &mut data, State::new(q, v), tau).expect("a finite step");
        let estimate = online.push(transition).expect("an estimate");
        changes += usize::from(estimate.flags.changed);
        if i % every >= every / 2 {
            worst = worst.max((estimate.mu[0] - mu).abs());
        }
    });
    let jumps = updates.saturating_sub(1) / every;
    let summary = format!(
        "{changes} changes detected for {jumps} jumps of mu; largest |mu_hat - mu| over the second half of \
         every segment {worst:.1e}"
    );
    (series, summary)
}

fn table(series: &[Checkpoint], unit: &str) {
    println!("| {unit} | seconds | VmRSS kB | VmHWM kB |");
    println!("|---|---|---|---|");
    for c in series {
        println!("| {} | {:.2} | {} | {} |", c.done, c.seconds, c.rss, c.hwm);
    }
    let (first, last) = (&series[0], &series[series.len() - 1]);
    println!();
    println!(
        "Peak resident set after the warm-up ({} {unit}): {} kB; at the end: {} kB (growth {} kB).",
        first.done,
        first.hwm,
        last.hwm,
        last.hwm as i64 - first.hwm as i64
    );
}

fn main() {
    let mut args = std::env::args().skip(1).map(|a| {
        a.parse::<usize>()
            .unwrap_or_else(|_| panic!("arguments are counts, got '{a}'"))
    });
    let steps = args.next().unwrap_or(1_000_000);
    let updates = args.next().unwrap_or(100_000);
    let command = if (steps, updates) == (1_000_000, 100_000) {
        String::new()
    } else {
        format!(" {steps} {updates}")
    };

    println!("# Long runs: memory stays flat");
    println!();
    println!(
        "Written by `cargo run --release --example long_runs{command} > reports/long-runs.md` \
         (examples/long_runs.rs; its docs describe both runs). Memory is the process's own \
         (/proc/self/status): VmRSS resident now, VmHWM peak resident so far, in kB; seconds \
         are wall clock on a shared machine (indicative only)."
    );
    println!();
    let (series, end) = simulate(steps);
    println!("## Simulation: double pendulum, {steps} steps of Model::step");
    println!();
    table(&series, "steps");
    println!("{end}.");
    println!();
    let (series, end) = identify(updates);
    println!("## Online identification: cartpole mu, {updates} updates of Online<Lm>");
    println!();
    table(&series, "updates");
    println!("{end}.");
}
