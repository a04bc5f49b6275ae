//! Step and rigid-body algorithm timings on the reference models (contact-free).
//! `make bench` runs this and then times MuJoCo on the same files for the ratio.

use criterion::{criterion_group, criterion_main, Criterion};
use diffosi::dynamics::{aba, crba, rnea, step};
use diffosi::Model;
use std::hint::black_box;

fn load(name: &str) -> Model {
    Model::load(format!(
        "{}/reference_models/{name}.xml",
        env!("CARGO_MANIFEST_DIR")
    ))
    .unwrap()
}

/// A fixed, non-trivial state: q a little off the reference, v and tau nonzero.
fn state(model: &Model) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
    let n = model.nv();
    let q = model
        .reference_q()
        .iter()
        .enumerate()
        .map(|(i, q)| q + 0.1 * (i as f64 + 1.0).sin())
        .collect();
    let v = (0..n).map(|i| 0.5 * (i as f64 + 2.0).cos()).collect();
    let tau = (0..n).map(|i| (i as f64 + 3.0).sin()).collect();
    (q, v, tau)
}

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
