//! Shared helpers of the integration tests: random trees and states.
#![allow(dead_code)]

use diffosi::derivatives::Transition;
use diffosi::dynamics::{bias_forces, body_poses, crba, Data};
use diffosi::model::{Body, Integrator, Joint, JointKind, Options, ParamMap, PassiveMode, State};
use diffosi::Model;
use nalgebra::{DMatrix, DVector};
use nalgebra::{Matrix3, Rotation3, Vector3};
use rand::rngs::StdRng;
use rand::{RngExt, SeedableRng};

pub fn rng(seed: u64) -> StdRng {
    StdRng::seed_from_u64(seed)
}

pub fn uniform(rng: &mut StdRng, lo: f64, hi: f64) -> f64 {
    rng.random_range(lo..hi)
}

pub fn vector(rng: &mut StdRng, scale: f64) -> Vector3<f64> {
    Vector3::from_fn(|_, _| uniform(rng, -scale, scale))
}

pub fn unit(rng: &mut StdRng) -> Vector3<f64> {
    vector(rng, 1.0).normalize()
}

pub fn rotation(rng: &mut StdRng) -> Rotation3<f64> {
    Rotation3::from_scaled_axis(vector(rng, 3.0))
}

/// A physical inertia tensor about the COM: a random rotation of positive
/// principal moments that satisfy the triangle inequality.
pub fn inertia(rng: &mut StdRng) -> Matrix3<f64> {
    let a = uniform(rng, 0.05, 1.0);
    let b = uniform(rng, 0.05, 1.0);
    let c = uniform(rng, (a - b).abs() + 0.01, a + b);
    let r = rotation(rng);
    r.matrix() * Matrix3::from_diagonal(&Vector3::new(a, b, c)) * r.matrix().transpose()
}

/// A random tree of `n` bodies: random parents, 0-3 joints per body (hinges and
/// slides with random axes and anchors), random inertial properties and
/// passive parameters.
pub fn random_model(seed: u64, n: usize, passive: PassiveMode, integrator: Integrator) -> Model {
    let mut r = rng(seed);
    let mut bodies = vec![Body::world()];
    let mut joints = vec![];
    for b in 1..=n {
        let parent = r.random_range(0..b);
        let count = if b == 1 { 2 } else { r.random_range(0..4) };
        let start = joints.len();
        for k in 0..count {
            joints.push(Joint {
                name: format!("j{b}_{k}"),
                kind: if r.random_bool(0.7) {
                    JointKind::Hinge
                } else {
                    JointKind::Slide
                },
                body: b,
                axis: unit(&mut r),
                anchor: vector(&mut r, 0.5),
                reference: uniform(&mut r, -0.3, 0.3),
                damping: uniform(&mut r, 0.0, 0.5),
                stiffness: uniform(&mut r, 0.0, 2.0),
                springref: uniform(&mut r, -0.5, 0.5),
                armature: if r.random_bool(0.5) {
                    uniform(&mut r, 0.0, 0.2)
                } else {
                    0.0
                },
                frictionloss: 0.0,
                range: None,
                margin: 0.0,
                limit_sol: Default::default(),
                friction_sol: Default::default(),
                springdamper: None,
            });
        }
        bodies.push(Body {
            name: format!("b{b}"),
            parent,
            pos: vector(&mut r, 1.0),
            rot: rotation(&mut r),
            mass: uniform(&mut r, 0.2, 3.0),
            com: vector(&mut r, 0.3),
            inertia: inertia(&mut r),
            inertia_frame: Rotation3::identity(),
            joints: start..joints.len(),
            gravcomp: 0.0,
            mocap: false,
        });
    }
    let opt = Options {
        timestep: 0.001,
        gravity: Vector3::new(0.0, 0.0, -9.81),
        integrator,
        passive,
        ..Options::default()
    };
    Model::new(format!("random{seed}"), bodies, joints, vec![], vec![], opt).unwrap()
}

/// A random state and force: q near the reference, v and tau in [-1, 1].
pub fn random_state(model: &Model, seed: u64) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
    let mut r = rng(seed);
    let n = model.nv();
    let q = model
        .reference_q()
        .iter()
        .map(|q0| q0 + uniform(&mut r, -1.0, 1.0))
        .collect();
    let v = (0..n).map(|_| uniform(&mut r, -1.0, 1.0)).collect();
    let tau = (0..n).map(|_| uniform(&mut r, -1.0, 1.0)).collect();
    (q, v, tau)
}

/// Resolves a model path of the golden data: relative to the repository, or
/// `gymnasium:NAME` for gymnasium's MuJoCo assets in the project's venv
/// (or in `$DIFFOSI_GYM_ASSETS`). A missing venv is a failure, not a skip.
/// Runs the `diffosi` binary from the repository root, as a user runs it:
/// (success, stdout, stderr).
pub fn run_cli(args: &[&str]) -> (bool, String, String) {
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_diffosi"))
        .args(args)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .unwrap();
    let text = |b: Vec<u8>| String::from_utf8(b).unwrap();
    (out.status.success(), text(out.stdout), text(out.stderr))
}

/// `name` in a temporary directory of this test process's own, `tag` naming
/// the test file.
pub fn temp_path(tag: &str, name: &str) -> std::path::PathBuf {
    let dir = std::env::temp_dir().join(format!("diffosi-{tag}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir.join(name)
}

/// The names of the geom pairs that may touch, [a, b] as the contact code
/// orders them (b the plane when there is one).
pub fn contact_pair_names(model: &Model) -> Vec<[&str; 2]> {
    diffosi::compile::contact_pairs(model)
        .into_iter()
        .map(|p| p.map(|g| model.geoms[g].name.as_str()))
        .collect()
}

pub fn model_path(name: &str) -> std::path::PathBuf {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
    match name.strip_prefix("gymnasium:") {
        Some(file) => gym_assets().join(file),
        None => root.join(name),
    }
}

pub fn gym_assets() -> std::path::PathBuf {
    if let Ok(dir) = std::env::var("DIFFOSI_GYM_ASSETS") {
        return dir.into();
    }
    let lib = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join(".venv/lib");
    let found = std::fs::read_dir(&lib).ok().and_then(|entries| {
        entries
            .flatten()
            .map(|e| e.path().join("site-packages/gymnasium/envs/mujoco/assets"))
            .find(|p| p.is_dir())
    });
    found.unwrap_or_else(|| {
        panic!("gymnasium's MuJoCo assets not found under {}: run `make setup` (or set DIFFOSI_GYM_ASSETS)", lib.display())
    })
}

/// The paper's cartpole and its mu (the task's map: the pole COM at
/// (mu, 0, 0.5 + 0.2 mu)), loaded from the repository's file.
pub fn cartpole_with_mu() -> (Model, ParamMap) {
    let model = Model::load(model_path("reference_models/cartpole.xml")).unwrap();
    let map = diffosi::tasks::Cartpole::mu_map_of(&model).unwrap();
    (model, map)
}

/// The mass matrix M(q), armature included (CRBA).
pub fn mass_matrix(model: &Model, q: &[f64]) -> DMatrix<f64> {
    let mut data = Data::new(model.tree());
    crba(model.tree(), &mut data, q);
    data.mass_matrix.clone()
}

/// The bias forces c(q, v): Coriolis, centrifugal and gravity.
pub fn bias(model: &Model, q: &[f64], v: &[f64]) -> DVector<f64> {
    let mut data = Data::new(model.tree());
    let mut c = DVector::zeros(model.nv());
    bias_forces(model.tree(), &mut data, q, v, c.as_mut_slice());
    c
}

/// Kinetic energy 1/2 v^T M v (armature included) plus gravitational and
/// spring potential energy.
pub fn energy(model: &Model, q: &[f64], v: &[f64]) -> f64 {
    let m = mass_matrix(model, q);
    let v = DVector::from_column_slice(v);
    let kinetic = 0.5 * v.dot(&(&m * &v));
    let poses = body_poses(model.tree(), q);
    let potential: f64 = model
        .bodies
        .iter()
        .zip(&poses)
        .map(|(b, (axes, origin))| -b.mass * model.opt.gravity.dot(&(axes * b.com + origin)))
        .sum();
    let spring: f64 = model
        .joints
        .iter()
        .zip(q)
        .map(|(j, q)| 0.5 * j.stiffness * (q - j.springref).powi(2))
        .sum();
    kinetic + potential + spring
}

/// MJCF of a body "thing" at `pos` with one geom (`shape` attributes, `mass`)
/// that moves freely: slides x, y, z then hinges rx, ry, rz.
fn free_thing(shape: &str, mass: f64, [x, y, z]: [f64; 3]) -> String {
    format!(
        r#"<body name="thing" pos="{x} {y} {z}">
      <joint name="x" type="slide" axis="1 0 0"/>
      <joint name="y" type="slide" axis="0 1 0"/>
      <joint name="z" type="slide" axis="0 0 1"/>
      <joint name="rx" type="hinge" axis="1 0 0"/>
      <joint name="ry" type="hinge" axis="0 1 0"/>
      <joint name="rz" type="hinge" axis="0 0 1"/>
      <geom name="thing" {shape} mass="{mass}"/>
    </body>"#
    )
}

/// The free "thing" at `height` above the floor plane z = 0.
pub fn dropped(shape: &str, mass: f64, height: f64) -> Model {
    let thing = free_thing(shape, mass, [0.0, 0.0, height]);
    let text = format!(
        r#"<mujoco model="dropped">
  <option timestep="0.002"/>
  <worldbody>
    <geom name="floor" type="plane" size="5 5 0.1"/>
    {thing}
  </worldbody>
</mujoco>"#
    );
    smooth(Model::from_mjcf(&text, "dropped.xml").unwrap())
}

/// A capsule "bar" (radius 0.05, half length 0.2) along y at height 0.3, on
/// a hinge about x through its centre (joint 0), and a geom `shape` on a
/// free body "thing" at `at` (slides x y z, hinges x y z: joints 1-6).
pub fn crossing(shape: &str, at: [f64; 3]) -> Model {
    let thing = free_thing(shape, 1.0, at);
    let text = format!(
        r#"<mujoco model="crossing">
  <option timestep="0.002"/>
  <worldbody>
    <body name="bar" pos="0 0 0.3">
      <joint name="tilt" type="hinge" axis="1 0 0"/>
      <geom name="bar" type="capsule" size="0.05 0.2" axisangle="1 0 0 90" mass="2"/>
    </body>
    {thing}
  </worldbody>
</mujoco>"#
    );
    smooth(Model::from_mjcf(&text, "crossing.xml").unwrap())
}

/// The model under the smooth contact model (the penalty forces whose
/// properties and derivatives the smooth-contact tests check).
pub fn smooth(model: Model) -> Model {
    model
        .edited(|s| s.opt.contact_model = diffosi::model::ContactModel::Smooth)
        .unwrap()
}

/// Largest error relative to max(1, |reference|), elementwise.
pub fn rel_err<'a>(
    ours: impl IntoIterator<Item = &'a f64>,
    theirs: impl IntoIterator<Item = &'a f64>,
) -> f64 {
    ours.into_iter()
        .zip(theirs)
        .map(|(a, b)| (a - b).abs() / b.abs().max(1.0))
        .fold(0.0, f64::max)
}

/// `len` transitions of a half cheetah `truth` dropped on its floor under random leg torques
/// (held for 5 steps, as the task does), every step kept.
pub fn cheetah_walk(truth: &Model, len: usize, seed: u64) -> Vec<Transition> {
    let mut rng: StdRng = rng(seed);
    let n = truth.nv();
    let mut data = truth.data();
    let mut x = State::new(vec![0.0; n], vec![0.0; n]);
    let mut tau = vec![0.0; n];
    let gears = [120.0, 90.0, 60.0, 120.0, 60.0, 30.0];
    (0..len)
        .map(|k| {
            if k % 5 == 0 {
                for (i, g) in gears.iter().enumerate() {
                    tau[3 + i] = g * uniform(&mut rng, -1.0, 1.0);
                }
            }
            let t = Transition::simulated(truth, &mut data, x.clone(), tau.clone()).unwrap();
            x = t.next.clone();
            t
        })
        .collect()
}

/// The JSON files of a golden data directory (relative to the repository), sorted.
pub fn golden_files(dir: &str) -> Vec<std::path::PathBuf> {
    let dir = model_path(dir);
    let mut files: Vec<_> = std::fs::read_dir(&dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .flatten()
        .map(|e| e.path())
        .filter(|p| p.extension().is_some_and(|x| x == "json"))
        .collect();
    files.sort();
    assert!(!files.is_empty(), "no golden data in {}", dir.display());
    files
}

/// A recorded rollout: the start, the generalized forces of each step and the
/// T + 1 states visited.
#[derive(serde::Deserialize)]
pub struct Rollout {
    pub q0: Vec<f64>,
    pub v0: Vec<f64>,
    pub taus: Vec<Vec<f64>>,
    pub q: Vec<Vec<f64>>,
    pub v: Vec<Vec<f64>>,
}

/// The value a golden file's name stands for, in the library's table of
/// names (`Integrator::NAMES`, `PassiveMode::NAMES`), case aside.
pub fn named<T: Copy>(names: &[(&str, T)], name: &str) -> T {
    names
        .iter()
        .find(|(n, _)| n.eq_ignore_ascii_case(name))
        .unwrap_or_else(|| panic!("unknown name {name}"))
        .1
}
