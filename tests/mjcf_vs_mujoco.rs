//! Our MJCF loader against MuJoCo's own compiler.
//!
//! `scripts/mujoco_compiled.py` loads each model with MuJoCo and writes what it
//! compiled to `reference_models/golden/compiled/<name>.json`; here the same XML
//! goes through `diffosi::model::mjcf::parse` and every quantity our Model holds
//! is compared. Gymnasium's models are found in the project venv
//! (`.venv/lib/python3*/site-packages/gymnasium/envs/mujoco/assets`) or in
//! `$DIFFOSI_GYM_ASSETS`.
//!
//! Errors are relative, with a floor of 1 for lengths and for unit vectors and
//! rotation matrices (so absolute below 1 m); inertia tensors are compared
//! relative to their largest entry. All must be within 1e-12.

use std::path::{Path, PathBuf};

mod common;

use common::gym_assets;
use diffosi::model::{Gain, Integrator, JointKind, PassiveMode, Shape};
use diffosi::Model;
use nalgebra::{Matrix3, Quaternion, UnitQuaternion, Vector3};
use serde_json::Value;

const TOL: f64 = 1e-12;

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// The XML a golden file was compiled from.
fn source_path(source: &str) -> PathBuf {
    match source.strip_prefix("gymnasium:") {
        Some(file) => gym_assets().join(file),
        None => root().join(source),
    }
}

fn golden_files() -> Vec<PathBuf> {
    let dir = root().join("reference_models/golden/compiled");
    let mut files: Vec<PathBuf> = std::fs::read_dir(&dir)
        .unwrap_or_else(|e| panic!("{}: {e}; run scripts/mujoco_compiled.py", dir.display()))
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|x| x == "json"))
        .collect();
    files.sort();
    assert!(
        !files.is_empty(),
        "no golden files in {}: run scripts/mujoco_compiled.py",
        dir.display()
    );
    files
}

fn load(path: &Path) -> Model {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    Model::from_mjcf(&text, &path.display().to_string()).unwrap_or_else(|e| panic!("{e}"))
}

fn f(v: &Value) -> f64 {
    v.as_f64().expect("a number")
}

fn vec3(v: &Value) -> Vector3<f64> {
    Vector3::new(f(&v[0]), f(&v[1]), f(&v[2]))
}

fn vec_of(v: &Value) -> Vec<f64> {
    v.as_array().expect("a list").iter().map(f).collect()
}

fn rot(q: &Value) -> Matrix3<f64> {
    let q = Quaternion::new(f(&q[0]), f(&q[1]), f(&q[2]), f(&q[3]));
    *UnitQuaternion::from_quaternion(q)
        .to_rotation_matrix()
        .matrix()
}

/// The worst error seen, and where.
#[derive(Default)]
struct Worst {
    error: f64,
    at: String,
}

impl Worst {
    fn note(&mut self, at: impl FnOnce() -> String, error: f64) {
        if error > self.error || error.is_nan() {
            self.error = error;
            self.at = at();
        }
    }

    /// Relative error with the given floor on the scale.
    fn scalar(&mut self, at: &str, ours: f64, theirs: f64, floor: f64) {
        self.note(
            || at.to_string(),
            (ours - theirs).abs() / theirs.abs().max(floor),
        );
    }

    fn vector(&mut self, at: &str, ours: &Vector3<f64>, theirs: &Vector3<f64>) {
        self.note(
            || at.to_string(),
            (ours - theirs).amax() / theirs.amax().max(1.0),
        );
    }

    fn slice(&mut self, at: &str, ours: &[f64], theirs: &[f64]) {
        assert_eq!(ours.len(), theirs.len(), "{at}");
        let scale = theirs.iter().fold(1.0f64, |m, x| m.max(x.abs()));
        let gap = ours
            .iter()
            .zip(theirs)
            .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
        self.note(|| at.to_string(), gap / scale);
    }

    fn matrix(&mut self, at: &str, ours: &Matrix3<f64>, theirs: &Matrix3<f64>, floor: f64) {
        self.note(
            || at.to_string(),
            (ours - theirs).amax() / theirs.amax().max(floor),
        );
    }
}

/// Compares everything; returns the worst error per kind of quantity. Counts,
/// names, indices and kinds must match exactly.
fn compare(model: &Model, g: &Value) -> [(&'static str, Worst); 5] {
    let mut opt = Worst::default();
    let o = &g["opt"];
    opt.scalar("timestep", model.opt.timestep, f(&o["timestep"]), 0.0);
    let gravity = match o["gravity_disabled"] == true {
        true => Vector3::zeros(),
        false => vec3(&o["gravity"]),
    };
    opt.vector("gravity", &model.opt.gravity, &gravity);
    let integrator = o["integrator"].as_str().unwrap();
    let expected_integrator = Integrator::NAMES
        .iter()
        .find(|(name, _)| *name == integrator)
        .expect("MuJoCo's integrator names")
        .1;
    assert_eq!(
        model.opt.integrator, expected_integrator,
        "integrator {integrator}"
    );
    let explicit =
        integrator == "RK4" || (integrator == "Euler" && o["eulerdamp_disabled"] == true);
    let passive = if explicit {
        PassiveMode::Explicit
    } else {
        PassiveMode::ImplicitDamping
    };
    assert_eq!(
        model.opt.passive, passive,
        "passive mode under {integrator}"
    );
    let fluid = &model.opt.fluid;
    opt.scalar("density", fluid.density, f(&o["density"]), 1.0);
    opt.scalar("viscosity", fluid.viscosity, f(&o["viscosity"]), 1.0);
    opt.vector("wind", &fluid.wind, &vec3(&o["wind"]));

    let gb = g["bodies"].as_array().unwrap();
    assert_eq!(model.bodies.len(), gb.len(), "number of bodies");
    let mut bodies = Worst::default();
    for (i, (b, e)) in model.bodies.iter().zip(gb).enumerate() {
        let name = e["name"].as_str().unwrap();
        assert!(
            name.is_empty() || b.name == name,
            "body {i}: {} vs {name}",
            b.name
        );
        assert_eq!(
            b.parent as u64,
            e["parent"].as_u64().unwrap(),
            "parent of {}",
            b.name
        );
        let at = |what: &str| format!("body {} {what}", b.name);
        bodies.vector(&at("pos"), &b.pos, &vec3(&e["pos"]));
        bodies.matrix(&at("rot"), b.rot.matrix(), &rot(&e["quat"]), 1.0);
        let mass = f(&e["mass"]);
        bodies.scalar(&at("mass"), b.mass, mass, f64::MIN_POSITIVE);
        if mass > 0.0 {
            bodies.vector(&at("com"), &b.com, &vec3(&e["ipos"]));
            let r = rot(&e["iquat"]);
            let inertia = r * Matrix3::from_diagonal(&vec3(&e["inertia"])) * r.transpose();
            bodies.matrix(&at("inertia"), &b.inertia, &inertia, f64::MIN_POSITIVE);
            // The same inertial axes, each up to its sign and the axes' order.
            let overlap = (b.inertia_frame.matrix().transpose() * r).abs();
            let permutation = overlap.map(|x| if x > 0.5 { 1.0 } else { 0.0 });
            bodies.matrix(&at("inertia_frame"), &overlap, &permutation, 1.0);
        }
    }

    let gj = g["joints"].as_array().unwrap();
    assert_eq!(model.joints.len(), gj.len(), "number of joints");
    let mut joints = Worst::default();
    for (i, (j, e)) in model.joints.iter().zip(gj).enumerate() {
        let name = e["name"].as_str().unwrap();
        assert!(
            name.is_empty() || j.name == name,
            "joint {i}: {} vs {name}",
            j.name
        );
        let kind = match e["type"].as_str().unwrap() {
            "hinge" => JointKind::Hinge,
            "slide" => JointKind::Slide,
            "ball" => JointKind::Ball,
            _ => JointKind::Free,
        };
        assert_eq!(j.kind, kind, "joint {} type", j.name);
        let (adr, _) = model.joint_address(i);
        let mut q0 = model.reference_q()[adr..adr + kind.nq()].to_vec();
        let theirs = vec_of(&e["qpos0"]);
        if kind.nq() > 1
            && q0[kind.nq() - 4..]
                .iter()
                .zip(&theirs[kind.nq() - 4..])
                .map(|(a, b)| a * b)
                .sum::<f64>()
                < 0.0
        {
            // q and -q are the same orientation
            q0[kind.nq() - 4..].iter_mut().for_each(|x| *x = -*x);
        }
        joints.slice(&format!("joint {} qpos0", j.name), &q0, &theirs);
        assert_eq!(
            j.body as u64,
            e["body"].as_u64().unwrap(),
            "joint {} body",
            j.name
        );
        let at = |what: &str| format!("joint {} {what}", j.name);
        if kind.nv() == 1 {
            joints.vector(&at("axis"), &j.axis, &vec3(&e["axis"]));
            joints.scalar(&at("ref"), j.reference, f(&e["ref"]), f64::MIN_POSITIVE);
            joints.scalar(
                &at("springref"),
                j.springref,
                f(&e["springref"]),
                f64::MIN_POSITIVE,
            );
        }
        if kind != JointKind::Free {
            joints.vector(&at("anchor"), &j.anchor, &vec3(&e["pos"]));
        }
        for (what, ours, key) in [
            ("damping", j.damping, "damping"),
            ("stiffness", j.stiffness, "stiffness"),
            ("armature", j.armature, "armature"),
            ("frictionloss", j.frictionloss, "frictionloss"),
        ] {
            joints.scalar(&at(what), ours, f(&e[key]), f64::MIN_POSITIVE);
        }
        assert_eq!(
            j.range.is_some(),
            e["limited"] == true,
            "joint {} limited",
            j.name
        );
        if let Some((lo, hi)) = j.range {
            joints.scalar(&at("range[0]"), lo, f(&e["range"][0]), f64::MIN_POSITIVE);
            joints.scalar(&at("range[1]"), hi, f(&e["range"][1]), f64::MIN_POSITIVE);
        }
    }

    let ga = g["actuators"].as_array().unwrap();
    assert_eq!(model.actuators.len(), ga.len(), "number of actuators");
    let mut actuators = Worst::default();
    for (a, e) in model.actuators.iter().zip(ga) {
        assert_eq!(
            e["trntype"], 0,
            "MuJoCo actuator {} is not on a joint",
            a.name
        );
        assert_eq!(
            a.joint().map(|j| j as u64),
            e["joint"].as_u64(),
            "actuator {} joint",
            a.name
        );
        let at = |what: &str| format!("actuator {} {what}", a.name);
        actuators.scalar(&at("gear"), a.gear[0], f(&e["gear"]), f64::MIN_POSITIVE);
        let gain = match a.gain {
            Gain::Fixed(g) | Gain::Affine([g, _, _]) => g,
        };
        actuators.scalar(&at("gainprm[0]"), gain, f(&e["gain"]), f64::MIN_POSITIVE);
        assert_eq!(
            a.ctrl_range.is_some(),
            e["ctrllimited"] == true,
            "actuator {} ctrllimited",
            a.name
        );
        if let Some((lo, hi)) = a.ctrl_range {
            actuators.scalar(
                &at("ctrlrange[0]"),
                lo,
                f(&e["ctrlrange"][0]),
                f64::MIN_POSITIVE,
            );
            actuators.scalar(
                &at("ctrlrange[1]"),
                hi,
                f(&e["ctrlrange"][1]),
                f64::MIN_POSITIVE,
            );
        }
    }

    let gg = g["geoms"].as_array().unwrap();
    assert_eq!(model.geoms.len(), gg.len(), "number of geoms");
    let mut geoms = Worst::default();
    for (i, (geom, e)) in model.geoms.iter().zip(gg).enumerate() {
        let at = |what: &str| format!("geom {i} ({}) {what}", geom.name);
        assert_eq!(
            geom.body as u64,
            e["body"].as_u64().unwrap(),
            "{}",
            at("body")
        );
        let size = vec3(&e["size"]);
        let (kind, ours) = match geom.shape {
            Shape::Plane => ("plane", vec![]),
            Shape::Sphere { radius } => ("sphere", vec![(radius, size.x)]),
            Shape::Capsule {
                radius,
                half_length,
            } => ("capsule", vec![(radius, size.x), (half_length, size.y)]),
            Shape::Cylinder {
                radius,
                half_length,
            } => ("cylinder", vec![(radius, size.x), (half_length, size.y)]),
            Shape::Box { half } => (
                "box",
                half.iter().copied().zip(size.iter().copied()).collect(),
            ),
            Shape::Ellipsoid { radii } => (
                "ellipsoid",
                radii.iter().copied().zip(size.iter().copied()).collect(),
            ),
            Shape::HField { .. } => (
                "hfield",
                geom.shape
                    .size()
                    .into_iter()
                    .zip(size.iter().copied())
                    .collect(),
            ),
            // MuJoCo's size of a mesh geom: its bounding box's half-extents.
            Shape::Mesh { mesh } => {
                let [lo, hi] = &model.meshes[mesh].aabb;
                let half = lo.abs().sup(&hi.abs());
                (
                    "mesh",
                    half.iter().copied().zip(size.iter().copied()).collect(),
                )
            }
        };
        assert_eq!(kind, e["type"], "{}", at("type"));
        for (ours, theirs) in ours {
            geoms.scalar(&at("size"), ours, theirs, 1.0);
        }
        geoms.vector(&at("pos"), &geom.pos, &vec3(&e["pos"]));
        geoms.matrix(&at("rot"), geom.rot.matrix(), &rot(&e["quat"]), 1.0);
        assert_eq!(
            geom.contype as u64,
            e["contype"].as_u64().unwrap(),
            "{}",
            at("contype")
        );
        assert_eq!(
            geom.conaffinity as u64,
            e["conaffinity"].as_u64().unwrap(),
            "{}",
            at("conaffinity")
        );
        geoms.vector(
            &at("friction"),
            &Vector3::from(geom.friction),
            &vec3(&e["friction"]),
        );
    }
    [
        ("options", opt),
        ("bodies", bodies),
        ("joints", joints),
        ("actuators", actuators),
        ("geoms", geoms),
    ]
}

#[test]
fn loader_matches_mujoco_compiler() {
    let mut failures = vec![];
    for golden in golden_files() {
        let g: Value = serde_json::from_str(&std::fs::read_to_string(&golden).unwrap()).unwrap();
        let xml = source_path(g["source"].as_str().unwrap());
        let name = golden.file_stem().unwrap().to_string_lossy().to_string();
        println!("{name}: {}", xml.display());
        let model = load(&xml);
        assert_eq!(
            model.name,
            g["model"].as_str().unwrap(),
            "{name}: model name"
        );
        let worst = compare(&model, &g);
        let summary: Vec<String> = worst
            .iter()
            .map(|(kind, w)| format!("{kind} {:.1e}", w.error))
            .collect();
        println!("    {}", summary.join("  "));
        for (kind, w) in &worst {
            if w.error > TOL || w.error.is_nan() {
                failures.push(format!("{name}: {kind}: {:.3e} at {}", w.error, w.at));
            }
        }
    }
    assert!(
        failures.is_empty(),
        "errors above {TOL:e} (rerun scripts/mujoco_compiled.py if a model changed):\n{}",
        failures.join("\n")
    );
}

/// Every gymnasium MuJoCo model is compared with MuJoCo's compiled view of it.
#[test]
fn every_gym_model_is_covered() {
    let golden: Vec<String> = golden_files()
        .iter()
        .filter_map(|p| {
            p.file_stem()?
                .to_str()?
                .strip_prefix("gym_")
                .map(|s| format!("{s}.xml"))
        })
        .collect();
    let mut count = 0;
    for entry in std::fs::read_dir(gym_assets()).unwrap() {
        let file = entry.unwrap().file_name().to_string_lossy().to_string();
        if file.ends_with(".xml") {
            assert!(golden.contains(&file), "{file} is not compared");
            count += 1;
        }
    }
    assert_eq!(count, 14, "gymnasium's MuJoCo models");
}
