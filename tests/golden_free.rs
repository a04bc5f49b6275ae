//! Ball and free joints and fluid forces against MuJoCo's own steps
//! (reference_models/golden/free/*.json, written by `python -m harness golden-free --seed 0`):
//! our free_ball model under Euler and RK4 and in a fluid with wind, and gymnasium's ant,
//! humanoid, humanoidstandup and swimmer (its fluid) as their files have them, contacts and
//! limits off. One step to 1e-12 from every recorded state, and the 50-step rollouts to 1e-9
//! (relative to max(1, |x|)).

mod common;

use common::{rel_err, Rollout};
use diffosi::model::{Fluid, Integrator, Model, PassiveMode};
use serde::Deserialize;

#[derive(Deserialize)]
struct Golden {
    model: String,
    integrator: String,
    fluid: Medium,
    nq: usize,
    nv: usize,
    one_step: Vec<Step>,
    rollout: Rollout,
}

#[derive(Deserialize)]
struct Medium {
    density: f64,
    viscosity: f64,
    wind: [f64; 3],
}

#[derive(Deserialize)]
struct Step {
    q: Vec<f64>,
    v: Vec<f64>,
    tau: Vec<f64>,
    q_next: Vec<f64>,
    v_next: Vec<f64>,
}

fn cases() -> Vec<(String, Golden)> {
    common::golden_files("reference_models/golden/free")
        .into_iter()
        .map(|p| {
            let text = std::fs::read_to_string(&p).unwrap();
            let name = p.file_stem().unwrap().to_string_lossy().into_owned();
            (name, serde_json::from_str(&text).unwrap())
        })
        .collect()
}

/// The case's model as MuJoCo stepped it: contacts and limits off, its integrator and
/// fluid, MuJoCo's passive convention for it (Euler: damping implicit; RK4: explicit).
fn model(golden: &Golden) -> Model {
    let model = Model::load(common::model_path(&golden.model)).unwrap_or_else(|e| panic!("{e}"));
    let (integrator, passive) = match golden.integrator.as_str() {
        "Euler" => (Integrator::Euler, PassiveMode::ImplicitDamping),
        "RK4" => (Integrator::Rk4, PassiveMode::Explicit),
        other => panic!("integrator {other}"),
    };
    model
        .edited(|s| {
            s.opt.contact = false;
            s.opt.limits = false;
            s.opt.integrator = integrator;
            s.opt.passive = passive;
            s.opt.fluid = Fluid {
                density: golden.fluid.density,
                viscosity: golden.fluid.viscosity,
                wind: golden.fluid.wind.into(),
            };
        })
        .unwrap()
}

#[test]
fn one_step_equals_mujoco_with_quaternions() {
    let cases = cases();
    assert_eq!(
        cases.len(),
        7,
        "free_ball (Euler, RK4, fluid), ant, humanoids, swimmer"
    );
    for (name, golden) in &cases {
        let model = model(golden);
        assert_eq!((model.nq(), model.nv()), (golden.nq, golden.nv), "{name}");
        assert!(model.nq() > model.nv() || model.opt.fluid.acts(), "{name}");
        let mut data = model.data();
        let mut worst = 0.0f64;
        for s in &golden.one_step {
            let (q1, v1) = model.step(&mut data, &s.q, &s.v, &s.tau).unwrap();
            worst = worst
                .max(rel_err(&q1, &s.q_next))
                .max(rel_err(&v1, &s.v_next));
        }
        println!("{name}: one step within {worst:.1e} of MuJoCo");
        assert!(worst <= 1e-12, "{name}: {worst:e}");
    }
}

#[test]
fn rollouts_follow_mujoco() {
    for (name, golden) in &cases() {
        let model = model(golden);
        let r = &golden.rollout;
        let states = model
            .rollout(&r.q0, &r.v0, r.taus.iter().map(Vec::as_slice))
            .unwrap();
        let worst = states
            .iter()
            .zip(r.q.iter().zip(&r.v))
            .map(|((q, v), (gq, gv))| rel_err(q, gq).max(rel_err(v, gv)))
            .fold(0.0, f64::max);
        println!("{name}: {}-step rollout within {worst:.1e}", r.taus.len());
        assert!(worst <= 1e-9, "{name}: {worst:e}");
    }
}
