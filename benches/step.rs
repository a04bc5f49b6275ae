//! Step and rigid-body algorithm timings on the reference models (contact-free).
//! `make bench` runs this and then times MuJoCo on the same files for the ratio.

mod common;

use common::{load, state};
use criterion::{criterion_group, criterion_main, Criterion};
use diffosi::dynamics::{aba, crba, rnea, step};
use std::hint::black_box;

fn bench_model(c: &mut Criterion, name: &str) {
    let model = load(name);
    let tree = model.tree();
    let mut data = model.data();
    let (q, v, tau) = state(&model);
    let n = model.nv();
    let (mut q1, mut v1, mut out) = (vec![0.0; n], vec![0.0; n], vec![0.0; n]);
    c.bench_function(&format!("step/{name}"), |b| {
        b.iter(|| {
            step(
                tree,
                &model.opt,
                &mut data,
                (black_box(&q), &v, &tau),
                (&mut q1, &mut v1),
            )
            .unwrap()
        })
    });
    c.bench_function(&format!("aba/{name}"), |b| {
        b.iter(|| aba(tree, &mut data, black_box(&q), &v, &tau, None, &mut out))
    });
    c.bench_function(&format!("rnea/{name}"), |b| {
        b.iter(|| rnea(tree, &mut data, black_box(&q), &v, &tau, &mut out))
    });
    c.bench_function(&format!("crba/{name}"), |b| {
        b.iter(|| crba(tree, &mut data, black_box(&q)))
    });
}

fn benches(c: &mut Criterion) {
    for name in ["cartpole", "half_cheetah"] {
        bench_model(c, name);
    }
}

criterion_group!(step_benches, benches);
criterion_main!(step_benches);
