//! Step Jacobians next to the plain step and to finite differences of our own
//! step, on the contact-free cartpole and half cheetah; and the half cheetah's
//! step Jacobians standing on its floor (contacts and limits on) under both contact models.

mod common;

use common::{load, load_with_contact, settled, state};
use criterion::{criterion_group, criterion_main, Criterion};
use diffosi::derivatives::{
    step_jacobians, transition_jacobians, TransitionJacobians, Workspace, Wrt,
};
use diffosi::model::{ContactModel, Inputs, State};
use diffosi::Model;
use std::hint::black_box;

/// Forward differences of the step over (q, v, tau): 3n + 1 steps.
fn finite_difference_jacobian(
    model: &Model,
    data: &mut diffosi::dynamics::Data<f64>,
    x: [&[f64]; 3],
    out: &mut [f64],
) {
    let n = model.nv();
    let State { q: q0, v: v0, .. } = model
        .step(
            data,
            &State::new(x[0].to_vec(), x[1].to_vec()),
            &Inputs::tau(x[2]),
        )
        .unwrap();
    let mut inputs = [x[0].to_vec(), x[1].to_vec(), x[2].to_vec()];
    for k in 0..3 * n {
        let eps = 1e-7;
        inputs[k / n][k % n] += eps;
        let State { q: q1, v: v1, .. } = model
            .step(
                data,
                &State::new(inputs[0].to_vec(), inputs[1].to_vec()),
                &Inputs::tau(&inputs[2]),
            )
            .unwrap();
        inputs[k / n][k % n] -= eps;
        for i in 0..n {
            out[k * 2 * n + i] = (q1[i] - q0[i]) / eps;
            out[k * 2 * n + n + i] = (v1[i] - v0[i]) / eps;
        }
    }
}

fn bench_model(c: &mut Criterion, name: &str, param: &str) {
    let model = load(name);
    let (q, v, tau) = state(&model);
    let mut ws = Workspace::new(&model);
    let mut data = model.data();
    let one = [model.param(param).unwrap()];
    let one_param = Wrt {
        params: &one,
        ..Wrt::default()
    };
    c.bench_function(&format!("jacobian_step/{name}"), |b| {
        let (x, u) = (State::new(q.clone(), v.clone()), Inputs::tau(&tau));
        b.iter(|| model.step(&mut data, black_box(&x), &u).unwrap())
    });
    let mut transition = TransitionJacobians::new(model.nq(), model.nv());
    c.bench_function(&format!("jacobian_full/{name}"), |b| {
        b.iter(|| {
            let x = (black_box(&q[..]), &v[..], &tau[..]);
            transition_jacobians(&model, &mut ws, x, &mut transition).unwrap()
        })
    });
    c.bench_function(&format!("jacobian_param/{name}"), |b| {
        b.iter(|| step_jacobians(&model, &mut ws, (black_box(&q), &v, &tau), &one_param).unwrap())
    });
    let mut out = vec![0.0; 6 * model.nv() * model.nv()];
    c.bench_function(&format!("jacobian_fd/{name}"), |b| {
        b.iter(|| {
            finite_difference_jacobian(&model, &mut data, [black_box(&q), &v, &tau], &mut out)
        })
    });
}

/// The half cheetah standing on its floor (both feet in contact) under the
/// smooth contact model: the full step Jacobian, and the one of the torso
/// mass and the contact parameters.
fn bench_contact(c: &mut Criterion) {
    let model = load_with_contact("half_cheetah", ContactModel::Smooth);
    let (q, v, tau) = settled(&model, 300);
    let mut ws = Workspace::new(&model);
    let params = [
        "body/torso/mass",
        "contact/stiffness",
        "contact/damping",
        "contact/friction",
    ]
    .map(|p| model.param(p).unwrap());
    let full = Wrt {
        state: true,
        control: true,
        params: &[],
    };
    let with_params = Wrt {
        params: &params,
        ..Wrt::default()
    };
    c.bench_function("jacobian_full_contact/half_cheetah", |b| {
        b.iter(|| step_jacobians(&model, &mut ws, (black_box(&q), &v, &tau), &full).unwrap())
    });
    c.bench_function("jacobian_params_contact/half_cheetah", |b| {
        b.iter(|| step_jacobians(&model, &mut ws, (black_box(&q), &v, &tau), &with_params).unwrap())
    });
}

/// The half cheetah standing on its floor under the constraint model (the
/// MJCF default): the full step Jacobian (analytic implicit derivative, in
/// MuJoCo's layout as `harness bench` calls it from Python),
/// the torso mass's (dual numbers) and a plain step, side by side.
fn bench_constraint(c: &mut Criterion) {
    let model = load_with_contact("half_cheetah", ContactModel::Constraint);
    let (q, v, tau) = settled(&model, 300);
    let mut ws = Workspace::new(&model);
    let mut data = model.data();
    let torso = [model.param("body/torso/mass").unwrap()];
    let one_param = Wrt {
        params: &torso,
        ..Wrt::default()
    };
    c.bench_function("constraint_step/half_cheetah", |b| {
        let (x, u) = (State::new(q.clone(), v.clone()), Inputs::tau(&tau));
        b.iter(|| model.step(&mut data, black_box(&x), &u).unwrap())
    });
    let mut transition = TransitionJacobians::new(model.nq(), model.nv());
    c.bench_function("constraint_jacobian_full/half_cheetah", |b| {
        b.iter(|| {
            let x = (black_box(&q[..]), &v[..], &tau[..]);
            transition_jacobians(&model, &mut ws, x, &mut transition).unwrap()
        })
    });
    c.bench_function("constraint_jacobian_param/half_cheetah", |b| {
        b.iter(|| step_jacobians(&model, &mut ws, (black_box(&q), &v, &tau), &one_param).unwrap())
    });
}

fn benches(c: &mut Criterion) {
    bench_model(c, "cartpole", "body/pole/mass");
    bench_model(c, "half_cheetah", "body/torso/mass");
    bench_contact(c);
    bench_constraint(c);
}

criterion_group!(jacobian_benches, benches);
criterion_main!(jacobian_benches);
