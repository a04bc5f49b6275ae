//! Step and rigid-body algorithm timings on the reference models (contact-free),
//! and the half cheetah's step standing on its floor (contacts and limits on).
//! `make bench` runs this and then times MuJoCo on the same files for the ratio.

mod common;

use common::{load, load_with_contact, settled, state};
use criterion::{criterion_group, criterion_main, Criterion};
use diffosi::dynamics::{aba, crba, rnea, step};
use diffosi::model::ContactModel;
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

/// One step of the half cheetah standing on its floor (both feet in contact)
/// under either contact model.
fn bench_contact(c: &mut Criterion, law: ContactModel, name: &str) {
    let model = load_with_contact("half_cheetah", law);
    let mut data = model.data();
    let (q, v, tau) = settled(&model, 300);
    let n = model.nv();
    let (mut q1, mut v1) = (vec![0.0; n], vec![0.0; n]);
    c.bench_function(name, |b| {
        b.iter(|| {
            step(
                model.tree(),
                &mut data,
                (black_box(&q), &v, &tau),
                (&mut q1, &mut v1),
            )
            .unwrap()
        })
    });
}

fn benches(c: &mut Criterion) {
    for name in ["cartpole", "half_cheetah"] {
        bench_model(c, name);
    }
    bench_contact(c, ContactModel::Constraint, "step_contact/half_cheetah");
    bench_contact(c, ContactModel::Smooth, "step_contact_smooth/half_cheetah");
}

criterion_group!(step_benches, benches);
criterion_main!(step_benches);
