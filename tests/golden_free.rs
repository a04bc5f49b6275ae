//! Ball and free joints and fluid forces against the reference engines' own steps
//! (reference_models/golden/free/*.json, written by `python -m harness golden-free --seed 0`):
//! MuJoCo on our free_ball model under Euler and RK4 and in a fluid with wind, on the floating
//! arm, and on gymnasium's ant, humanoid, humanoidstandup and swimmer (its fluid) as their
//! files have them; PyBullet and DART on the floating arm's URDF twin (their free bases in
//! MuJoCo's convention). Contacts and limits off. One step to 1e-12 from every recorded
//! state, and the 50-step rollouts to 1e-9 (relative to max(1, |x|)).

mod common;

use common::{rel_err, Rollout};
use diffosi::model::{Fluid, Inputs, Integrator, PassiveMode, State};
use diffosi::Model;
use serde::Deserialize;

#[derive(Deserialize)]
struct Golden {
    engine: String,
    model: String,
    passive: String,
    integrator: String,
    timestep: f64,
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

/// The case's model as its engine stepped it: contacts and limits off, its integrator,
/// timestep, passive convention and fluid.
fn model(golden: &Golden) -> Model {
    let model = Model::load(common::model_path(&golden.model)).unwrap_or_else(|e| panic!("{e}"));
    let integrator = common::named(&Integrator::NAMES, &golden.integrator);
    let passive = common::named(&PassiveMode::NAMES, &golden.passive);
    model
        .edited(|s| {
            s.opt.contact = false;
            s.opt.limits = false;
            s.opt.integrator = integrator;
            s.opt.timestep = golden.timestep;
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
        10,
        "free_ball (Euler, RK4, fluid), the floating arm in three engines, ant, humanoids, swimmer"
    );
    for (name, golden) in &cases {
        let model = model(golden);
        assert_eq!((model.nq(), model.nv()), (golden.nq, golden.nv), "{name}");
        assert!(model.nq() > model.nv() || model.opt.fluid.acts(), "{name}");
        let mut data = model.data();
        let mut worst = 0.0f64;
        for s in &golden.one_step {
            let (x, u) = (State::new(s.q.clone(), s.v.clone()), Inputs::tau(&s.tau));
            let State { q: q1, v: v1, .. } = model.step(&mut data, &x, &u).unwrap();
            worst = worst
                .max(rel_err(&q1, &s.q_next))
                .max(rel_err(&v1, &s.v_next));
        }
        println!("{name}: one step within {worst:.1e} of {}", golden.engine);
        assert!(worst <= 1e-12, "{name}: {worst:e}");
    }
}

#[test]
fn rollouts_follow_mujoco() {
    for (name, golden) in &cases() {
        let model = model(golden);
        let r = &golden.rollout;
        let states = model
            .rollout(
                &State::new(r.q0.clone(), r.v0.clone()),
                r.taus.iter().map(|t| Inputs::tau(t)),
            )
            .unwrap();
        let worst = states
            .iter()
            .zip(r.q.iter().zip(&r.v))
            .map(|(x, (gq, gv))| rel_err(&x.q, gq).max(rel_err(&x.v, gv)))
            .fold(0.0, f64::max);
        println!("{name}: {}-step rollout within {worst:.1e}", r.taus.len());
        assert!(worst <= 1e-9, "{name}: {worst:e}");
    }
}
