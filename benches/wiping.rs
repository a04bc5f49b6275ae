//! The wiping task's identification (issue 9), side by side in one run:
//!
//! - `wiping/diffosi_identify`: one DiffOSI identification of the tool's
//!   (k_p, k_d) from 50 closed-loop segments of 5 steps, LM from the middle of
//!   the box (the target: under 50 ms);
//! - `wiping/cmaes_identify`: CMA-ES on the same segments with Table 3's
//!   budget of 300 evaluations;
//! - `wiping/fit` and `wiping/loss`: one evaluation of the segments with the
//!   dual-number Jacobian, and without it;
//! - `wiping/episode`: one 3 s episode (3000 closed-loop steps).

use criterion::{criterion_group, criterion_main, Criterion};
use diffosi::experiments::wiping::{SEGMENTS, SEGMENT_STEPS};
use diffosi::osi::{CmaEs, CmaEsOptions, Lm};
use diffosi::tasks::wiping::{Segments, Wiping, CANONICAL, STEPS};
use rand::rngs::StdRng;
use rand::SeedableRng;
use std::hint::black_box;
use std::time::Duration;

fn bench_wiping(c: &mut Criterion) {
    let task = Wiping::new();
    let truth = [30.0, 70.0];
    let episode = task.episode(&truth, CANONICAL, STEPS).unwrap();
    let mut rng = StdRng::seed_from_u64(0);
    let counts = (SEGMENTS, SEGMENT_STEPS);
    let segments = Segments::sample(
        &task,
        (&episode.states, &episode.xi, &episode.forces, CANONICAL),
        counts,
        &mut rng,
    )
    .unwrap();
    let prior = task.prior();
    let mut problem = task.problem();
    let mut group = c.benchmark_group("wiping");
    group
        .measurement_time(Duration::from_secs(10))
        .sample_size(20);
    group.bench_function("diffosi_identify", |b| {
        b.iter(|| {
            Lm::default()
                .identify_on(&mut problem, black_box(&segments), &prior)
                .unwrap()
        })
    });
    let cmaes = CmaEsOptions {
        max_evaluations: 300,
        ..CmaEsOptions::default()
    };
    group.bench_function("cmaes_identify", |b| {
        b.iter(|| {
            CmaEs { options: cmaes }
                .identify_on(&mut problem, black_box(&segments), &prior)
                .unwrap()
        })
    });
    group.bench_function("fit", |b| {
        b.iter(|| problem.fit(&prior, black_box(&segments)).unwrap())
    });
    group.bench_function("loss", |b| {
        b.iter(|| problem.loss(&prior, black_box(&segments)).unwrap())
    });
    group.bench_function("episode", |b| {
        b.iter(|| task.episode(black_box(&truth), CANONICAL, STEPS).unwrap())
    });
    group.finish();
}

criterion_group!(benches, bench_wiping);
criterion_main!(benches);
