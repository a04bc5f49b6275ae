//! DiffOSI timings, contact-free, at windows W = 1, 2, 5, 10, 50, for the
//! cartpole (pole COM offset) and the half cheetah (torso mass); see
//! `benches/osi_problems/mod.rs`:
//!
//! - `osi_lm/<model>/W<W>`: one identification, the bounded
//!   Levenberg-Marquardt from the prior until a tolerance stops it (a cold
//!   update);
//! - `osi_lm_warm/<model>/W<W>`: the online update when the parameter did not
//!   change, warm-started from the previous window's estimate;
//! - `osi_fit/<model>/W<W>`: one evaluation of the window's residuals and
//!   exact Jacobian (the work of one Gauss-Newton step).
//!
//! And in contact, at W = 4: `osi_lm/half_cheetah_contact/W4` and
//! `osi_lm_warm/half_cheetah_contact/W4`, the torso mass from four
//! consecutive transitions standing on the floor (constraint contact);
//! `osi_lm/half_cheetah_unknown_constraints/W4`, the same window with the
//! constraint impulses unknown (`Problem::with_unknown_constraints`).
//!
//! Divide by W for the cost per transition (`python -m harness bench` does,
//! next to the NimblePhysics anchors). Evaluations to tolerance, LM against
//! Adam and CMA-ES: `cargo run --release --example osi_evals`.

mod osi_problems;

use criterion::{criterion_group, criterion_main, Criterion};
use diffosi::derivatives::Impulses;
use diffosi::osi::{Identifier, Lm};
use osi_problems::{cartpole, half_cheetah, half_cheetah_contact, truth};
use std::hint::black_box;
use std::time::Duration;

const WINDOWS: [usize; 5] = [1, 2, 5, 10, 50];

fn bench_osi(c: &mut Criterion) {
    for task in [cartpole(), half_cheetah()] {
        let mut problem = task.problem();
        let mu = truth(&task);
        for w in WINDOWS {
            let window = task.window(mu, w, 1000 + w as u64);
            let e = Lm::default()
                .identify(&mut problem, &window, &[task.prior])
                .unwrap();
            assert!((e.mu[0] - mu).abs() < 1e-6, "{} W{w}: {e:?}", task.name);
            println!(
                "{} W{w}: error {:.1e}, {} iterations, {} evaluations",
                task.name,
                (e.mu[0] - mu).abs(),
                e.iterations,
                e.evaluations
            );
            c.bench_function(&format!("osi_lm/{}/W{w}", task.name), |b| {
                b.iter(|| {
                    Lm::default()
                        .identify(&mut problem, black_box(&window), &[task.prior])
                        .unwrap()
                })
            });
            // An online update whose parameter did not change: warm start
            // from the previous window's estimate.
            let previous = task.window(mu, w, 5000 + w as u64);
            let warm = Lm::default()
                .identify(&mut problem, &previous, &[task.prior])
                .unwrap()
                .mu;
            c.bench_function(&format!("osi_lm_warm/{}/W{w}", task.name), |b| {
                b.iter(|| {
                    Lm::default()
                        .identify(&mut problem, black_box(&window), &warm)
                        .unwrap()
                })
            });
            c.bench_function(&format!("osi_fit/{}/W{w}", task.name), |b| {
                b.iter(|| problem.fit(&[task.prior], black_box(&window[..])).unwrap())
            });
        }
    }
}

/// One DiffOSI update in contact: cold (from the prior) and warm (from the
/// previous window's estimate) at W = 4.
fn bench_osi_contact(c: &mut Criterion) {
    let task = half_cheetah_contact();
    let mut problem = task.problem();
    let mu = truth(&task);
    let window = task.standing_window(mu, 4, 4);
    let e = Lm::default()
        .identify(&mut problem, &window, &[task.prior])
        .unwrap();
    assert!((e.mu[0] - mu).abs() < 1e-6, "{}: {e:?}", task.name);
    println!(
        "{} W4: error {:.1e}, {} evaluations",
        task.name,
        (e.mu[0] - mu).abs(),
        e.evaluations
    );
    let warm = [e.mu[0] * (1.0 + 1e-9)];
    c.bench_function("osi_lm/half_cheetah_contact/W4", |b| {
        b.iter(|| {
            Lm::default()
                .identify(&mut problem, black_box(&window), &[task.prior])
                .unwrap()
        })
    });
    c.bench_function("osi_lm_warm/half_cheetah_contact/W4", |b| {
        b.iter(|| {
            Lm::default()
                .identify(&mut problem, black_box(&window), &warm)
                .unwrap()
        })
    });
    let n = task.model.nv();
    let mut unknown = task
        .problem()
        .with_unknown_constraints(0.02, &vec![1.0; n], Impulses::Model)
        .unwrap();
    let e = Lm::default()
        .identify(&mut unknown, &window, &[task.prior])
        .unwrap();
    assert!((e.mu[0] - mu).abs() < 1e-6, "unknown constraints: {e:?}");
    c.bench_function("osi_lm/half_cheetah_unknown_constraints/W4", |b| {
        b.iter(|| {
            Lm::default()
                .identify(&mut unknown, black_box(&window), &[task.prior])
                .unwrap()
        })
    });
}

criterion_group! {
    name = benches;
    config = Criterion::default()
        .sample_size(30)
        .warm_up_time(Duration::from_millis(500))
        .measurement_time(Duration::from_secs(2));
    targets = bench_osi, bench_osi_contact
}
criterion_main!(benches);
