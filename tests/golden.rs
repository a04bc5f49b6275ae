//! Our engine against MuJoCo, PyBullet and DART on their recorded steps
//! (reference_models/golden/dynamics/*.json, written by `python -m harness golden`).
//! Contact-free models must agree to 1e-12 in one step: anything worse is a
//! convention bug, not an "engine difference".

mod common;

use common::{rel_err, Rollout};
use diffosi::dynamics::{bias_forces, crba, Data};
use diffosi::model::{Fluid, Inputs, Integrator, PassiveMode, State};
use diffosi::Model;
use nalgebra::Vector3;
use serde::Deserialize;
use sha2::Digest;

#[derive(Deserialize)]
struct Golden {
    engine: String,
    model: String,
    passive: String,
    integrator: String,
    timestep: f64,
    gravity: [f64; 3],
    joint_names: Vec<String>,
    #[serde(default)]
    settings: serde_json::Value,
    one_step: Vec<OneStep>,
    rollout: Rollout,
}

#[derive(Deserialize)]
struct OneStep {
    q: Vec<f64>,
    v: Vec<f64>,
    tau: Vec<f64>,
    q_next: Vec<f64>,
    v_next: Vec<f64>,
    mass_matrix: Vec<Vec<f64>>,
    bias: Vec<f64>,
}

/// The model as the reference engine ran it: its passive-force convention,
/// integrator, timestep and gravity, and without what it ignores (contacts
/// and limits among them).
fn as_run_by(golden: &Golden) -> Model {
    let path = common::model_path(&golden.model);
    let recorded = golden.settings.get("model_sha256").and_then(|v| v.as_str());
    let bytes = std::fs::read(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let actual = format!("{:x}", sha2::Sha256::digest(&bytes));
    assert_eq!(
        recorded,
        Some(actual.as_str()),
        "{} changed since its golden data was recorded: run `make golden`",
        path.display()
    );
    let model = Model::load(&path).unwrap_or_else(|e| panic!("{e}"));
    // What the engine did not simulate: {"stiffness": {"joint": value, ...}, ...}.
    let ignored: std::collections::BTreeMap<String, std::collections::BTreeMap<String, f64>> =
        golden
            .settings
            .get("ignored")
            .map(|v| {
                serde_json::from_value(v.clone())
                    .expect("settings.ignored maps parameters to joints")
            })
            .unwrap_or_default();
    model
        .edited(|s| {
            s.opt.passive = common::named(&PassiveMode::NAMES, &golden.passive);
            s.opt.integrator = common::named(&Integrator::NAMES, &golden.integrator);
            s.opt.timestep = golden.timestep;
            s.opt.gravity = Vector3::from(golden.gravity);
            // The reference engines ran with contacts and limits off, and the
            // swimmer without its fluid (tests/golden_free.rs has it with).
            (s.opt.contact, s.opt.limits) = (false, false);
            if golden.settings.get("fluid_off").is_some() {
                s.opt.fluid = Fluid::default();
            }
            for (what, joints) in &ignored {
                for j in s.joints.iter_mut().filter(|j| joints.contains_key(&j.name)) {
                    match what.as_str() {
                        "stiffness" => j.stiffness = 0.0,
                        "armature" => j.armature = 0.0,
                        "damping" => j.damping = 0.0,
                        other => panic!("unknown ignored parameter {other}"),
                    }
                }
            }
        })
        .unwrap()
}

struct Errors {
    mass: f64,
    bias: f64,
    one_step: f64,
    rollout: f64,
}

fn compare(golden: &Golden) -> Errors {
    let model = as_run_by(golden);
    let names: Vec<&str> = model.joints.iter().map(|j| j.name.as_str()).collect();
    assert_eq!(names, golden.joint_names, "{}: joint order", golden.model);
    let mut data = Data::new(model.tree());
    let (mut mass, mut bias, mut one_step) = (0.0f64, 0.0f64, 0.0f64);
    for s in &golden.one_step {
        crba(model.tree(), &mut data, &s.q);
        let theirs: Vec<f64> = s.mass_matrix.iter().flatten().copied().collect();
        mass = mass.max(rel_err(data.mass_matrix.transpose().iter(), &theirs));
        let mut c = vec![0.0; model.nv()];
        bias_forces(model.tree(), &mut data, &s.q, &s.v, &mut c);
        bias = bias.max(rel_err(&c, &s.bias));
        let (x, u) = (State::new(s.q.clone(), s.v.clone()), Inputs::tau(&s.tau));
        let State { q: q1, v: v1, .. } = model.step(&mut data, &x, &u).unwrap();
        one_step = one_step
            .max(rel_err(&q1, &s.q_next))
            .max(rel_err(&v1, &s.v_next));
    }
    let r = &golden.rollout;
    let states = model
        .rollout(
            &State::new(r.q0.clone(), r.v0.clone()),
            r.taus.iter().map(|t| Inputs::tau(t)),
        )
        .unwrap();
    let rollout = states
        .iter()
        .zip(r.q.iter().zip(&r.v))
        .map(|(x, (qr, vr))| rel_err(&x.q, qr).max(rel_err(&x.v, vr)))
        .fold(0.0, f64::max);
    Errors {
        mass,
        bias,
        one_step,
        rollout,
    }
}

#[test]
fn agrees_with_reference_engines() {
    let files = common::golden_files("reference_models/golden/dynamics");
    let mut failures = vec![];
    println!(
        "{:<48} {:>9} {:>9} {:>9} {:>9}",
        "case", "M", "bias", "1-step", "rollout"
    );
    for file in &files {
        let golden: Golden = serde_json::from_str(&std::fs::read_to_string(file).unwrap()).unwrap();
        let case = file.file_stem().unwrap().to_string_lossy();
        let e = compare(&golden);
        println!(
            "{case:<48} {:>9.1e} {:>9.1e} {:>9.1e} {:>9.1e}   ({})",
            e.mass, e.bias, e.one_step, e.rollout, golden.engine
        );
        if e.mass > 1e-12 || e.bias > 1e-12 || e.one_step > 1e-12 || e.rollout > 1e-9 {
            failures.push(case.to_string());
        }
    }
    assert!(
        failures.is_empty(),
        "disagree with their reference engine: {failures:?}"
    );
}
