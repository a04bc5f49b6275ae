//! The MJCF writer against the loader: load, `mjcf::write`, load again gives
//! back the same Spec.
//!
//! Models: the reference models (MJCF and URDF twins), the loader's feature
//! files in `tests/data`, every gymnasium model the loader accepts, and random
//! trees. The two Specs must agree exactly in structure, names and options.
//! Numbers written as they are (or, for joint axes, normalised again) must
//! agree to 1e-15 relative. What the loader rebuilds from another form must
//! agree to 1e-14: rotation matrices from quaternions (absolute; up to 1.1e-15
//! over 3000 random trees) and inertia tensors, relative to their largest
//! entry (a non-diagonal one is written as `fullinertia`, which the loader,
//! like MuJoCo, turns into principal moments and axes and back: up to 4.4e-15,
//! 20 ulps, over those trees; diagonal ones come back exactly). The written
//! files are kept in `target/tmp/roundtrip/` for
//! `scripts/check_written_mjcf.py`, which compiles them with MuJoCo.

mod common;

use std::path::{Path, PathBuf};

use diffosi::model::{
    mjcf, Actuator, Body, Geom, InertiaRule, Integrator, Joint, ModelError, Options, PassiveMode,
    Site, SoftOptions, Spec,
};
use diffosi::Model;
use nalgebra::{Matrix3, Rotation3};

const TOL: f64 = 1e-15;
const REBUILT_TOL: f64 = 1e-14;

/// Models MJCF cannot express, and why.
const UNWRITABLE: [(&str, &str); 2] = [
    (
        // Two massless helper links carry the planar root joints.
        "reference_half_cheetah_urdf",
        "a body with joints needs mass and inertia",
    ),
    (
        // Five massless helper links carry the box's six joints.
        "reference_box_urdf",
        "a body with joints needs mass and inertia",
    ),
];

fn written_dir() -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("roundtrip");
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// Every model file to round-trip, with the name its written file gets
/// (`<reference|data|gym>_<stem>[_urdf]`).
fn sources() -> Vec<(String, PathBuf)> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let dirs = [
        ("reference", root.join("reference_models")),
        ("data", root.join("tests/data")),
        ("gym", common::gym_assets()),
    ];
    let mut sources = vec![];
    for (prefix, dir) in dirs {
        for entry in std::fs::read_dir(&dir).unwrap() {
            let path = entry.unwrap().path();
            let stem = path.file_stem().unwrap().to_string_lossy().to_string();
            match path.extension().and_then(|e| e.to_str()) {
                Some("xml") => sources.push((format!("{prefix}_{stem}"), path)),
                Some("urdf") => sources.push((format!("{prefix}_{stem}_urdf"), path)),
                _ => {}
            }
        }
    }
    sources.sort();
    sources
}

/// Writes `model`, keeps the file as `name`.xml and loads it again.
fn round_trip(name: &str, model: &Spec) -> Model {
    let text = mjcf::write(model).unwrap_or_else(|e| panic!("{name}: {e}"));
    std::fs::write(written_dir().join(format!("{name}.xml")), &text).unwrap();
    Model::from_mjcf(&text, name).unwrap_or_else(|e| panic!("{name}: the written file: {e}"))
}

/// The largest error seen and where.
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

    /// Relative error of each number.
    fn numbers(&mut self, at: impl Fn() -> String, ours: &[f64], theirs: &[f64]) {
        assert_eq!(ours.len(), theirs.len(), "{}", at());
        for (a, b) in ours.iter().zip(theirs) {
            let error = if a == b {
                0.0
            } else {
                (a - b).abs() / a.abs().max(b.abs())
            };
            self.note(&at, error);
        }
    }

    fn number(&mut self, at: impl Fn() -> String, ours: f64, theirs: f64) {
        self.numbers(at, &[ours], &[theirs]);
    }

    fn rotation(
        &mut self,
        at: impl Fn() -> String,
        ours: &Rotation3<f64>,
        theirs: &Rotation3<f64>,
    ) {
        self.note(at, (ours.matrix() - theirs.matrix()).abs().max());
    }

    /// Error relative to the largest entry.
    fn tensor(&mut self, at: impl Fn() -> String, ours: &Matrix3<f64>, theirs: &Matrix3<f64>) {
        let scale = ours.abs().max().max(theirs.abs().max());
        let error = (ours - theirs).abs().max();
        self.note(at, if error == 0.0 { 0.0 } else { error / scale });
    }
}

/// Asserts that `theirs` is `ours` read back; returns the worst errors of the
/// numbers written as they are and of the rotations and inertia tensors the
/// loader rebuilds. Every field is destructured, so none goes unchecked.
fn compare(model: &str, ours: &Spec, theirs: &Spec) -> (Worst, Worst) {
    let Spec {
        name,
        bodies,
        joints,
        actuators,
        geoms,
        opt,
        pairs,
        excludes,
        keyframes,
        inertia_rule,
        sites,
        sensors,
        meshes,
        hfields,
        equalities,
        tendons,
    } = ours;
    assert_eq!(name, &theirs.name, "{model}: model name");
    assert_eq!(keyframes, &theirs.keyframes, "{model}: keyframes");
    assert_eq!(sensors, &theirs.sensors, "{model}: sensors");
    assert_eq!(meshes, &theirs.meshes, "{model}: meshes");
    assert_eq!(hfields, &theirs.hfields, "{model}: height fields");
    assert_eq!(equalities, &theirs.equalities, "{model}: equalities");
    assert_eq!(tendons, &theirs.tendons, "{model}: tendons");
    assert_eq!(
        (pairs, excludes),
        (&theirs.pairs, &theirs.excludes),
        "{model}: contact pairs"
    );
    // MJCF has no setting for it: read back, MuJoCo's rule holds (a URDF's
    // tensors that violate it would be refused there, as MuJoCo refuses them).
    let _ = inertia_rule;
    assert_eq!(
        theirs.inertia_rule,
        InertiaRule::Triangle,
        "{model}: inertia rule"
    );
    let Options {
        timestep,
        gravity,
        integrator,
        passive,
        contact,
        limits,
        contact_model,
        soft,
        solver,
        fluid,
        magnetic,
    } = opt;
    let o = &theirs.opt;
    assert_eq!(
        (timestep, gravity, integrator, passive, fluid, magnetic),
        (
            &o.timestep,
            &o.gravity,
            &o.integrator,
            &o.passive,
            &o.fluid,
            &o.magnetic
        ),
        "{model}: options"
    );
    assert_eq!(
        (contact, limits, contact_model, soft, solver),
        (&o.contact, &o.limits, &o.contact_model, &o.soft, &o.solver),
        "{model}: contact options"
    );
    let mut worst = Worst::default();
    let mut rebuilt = Worst::default();
    assert_eq!(bodies.len(), theirs.bodies.len(), "{model}: bodies");
    for (a, b) in bodies.iter().zip(&theirs.bodies) {
        let Body {
            name,
            parent,
            pos,
            rot,
            mass,
            com,
            inertia,
            inertia_frame,
            joints,
            gravcomp,
            mocap,
        } = a;
        let at = |what: &str| format!("body '{name}' {what}");
        assert_eq!(
            (name, parent, joints),
            (&b.name, &b.parent, &b.joints),
            "{model}"
        );
        worst.numbers(|| at("pos"), pos.as_slice(), b.pos.as_slice());
        rebuilt.rotation(|| at("rot"), rot, &b.rot);
        worst.number(|| at("mass"), *mass, b.mass);
        assert_eq!(*gravcomp, b.gravcomp, "{model}: body '{name}' gravcomp");
        assert_eq!(*mocap, b.mocap, "{model}: body '{name}' mocap");
        worst.numbers(|| at("com"), com.as_slice(), b.com.as_slice());
        rebuilt.tensor(|| at("inertia"), inertia, &b.inertia);
        // The inertial frame survives where the inertia is diagonal in it (written
        // as its quat and moments); else the file holds the tensor alone.
        let axes = inertia_frame.matrix();
        let local = axes.transpose() * inertia * axes;
        if (local - Matrix3::from_diagonal(&local.diagonal()))
            .abs()
            .max()
            <= 1e-12 * local.abs().max()
        {
            rebuilt.rotation(|| at("inertia_frame"), inertia_frame, &b.inertia_frame);
        }
    }
    assert_eq!(joints.len(), theirs.joints.len(), "{model}: joints");
    for (a, b) in joints.iter().zip(&theirs.joints) {
        let Joint {
            name,
            kind,
            body,
            axis,
            anchor,
            reference,
            damping,
            stiffness,
            springref,
            armature,
            frictionloss,
            range,
            margin,
            limit_sol,
            friction_sol,
            springdamper,
        } = a;
        assert_eq!(springdamper, &b.springdamper, "{model}");
        let at = |what: &str| format!("joint '{name}' {what}");
        assert_eq!(
            (name, kind, body, range.is_some()),
            (&b.name, &b.kind, &b.body, b.range.is_some()),
            "{model}"
        );
        assert_eq!(
            (margin, limit_sol, friction_sol),
            (&b.margin, &b.limit_sol, &b.friction_sol),
            "{model}: joint '{name}' solver parameters"
        );
        worst.numbers(|| at("axis"), axis.as_slice(), b.axis.as_slice());
        worst.numbers(|| at("anchor"), anchor.as_slice(), b.anchor.as_slice());
        let scalars = [
            reference,
            damping,
            stiffness,
            springref,
            armature,
            frictionloss,
        ];
        let theirs_scalars = [
            b.reference,
            b.damping,
            b.stiffness,
            b.springref,
            b.armature,
            b.frictionloss,
        ];
        worst.numbers(|| at("scalars"), &scalars.map(|x| *x), &theirs_scalars);
        if let (Some((lo, hi)), Some((blo, bhi))) = (range, b.range) {
            worst.numbers(|| at("range"), &[*lo, *hi], &[blo, bhi]);
        }
    }
    assert_eq!(
        actuators.len(),
        theirs.actuators.len(),
        "{model}: actuators"
    );
    for (a, b) in actuators.iter().zip(&theirs.actuators) {
        let Actuator {
            name,
            target,
            gear,
            ctrl_range,
            force_range,
            act_range,
            gain,
            bias,
            dynamics,
            act_early,
            damping,
            armature,
        } = a;
        assert_eq!(
            (name, target, ctrl_range, force_range, act_range),
            (
                &b.name,
                &b.target,
                &b.ctrl_range,
                &b.force_range,
                &b.act_range
            ),
            "{model}"
        );
        assert_eq!(
            (gain, bias, dynamics, act_early),
            (&b.gain, &b.bias, &b.dynamics, &b.act_early),
            "{model}"
        );
        for (k, (g, h)) in gear.iter().zip(&b.gear).enumerate() {
            worst.number(|| format!("actuator '{name}' gear[{k}]"), *g, *h);
        }
        worst.number(|| format!("actuator '{name}' damping"), *damping, b.damping);
        worst.number(
            || format!("actuator '{name}' armature"),
            *armature,
            b.armature,
        );
    }
    assert_eq!(geoms.len(), theirs.geoms.len(), "{model}: geoms");
    for (a, b) in geoms.iter().zip(&theirs.geoms) {
        let Geom {
            name,
            body,
            shape,
            pos,
            rot,
            contype,
            conaffinity,
            friction,
            contact,
            fluid,
        } = a;
        let at = |what: &str| format!("geom '{name}' {what}");
        assert_eq!(
            (
                name,
                body,
                shape,
                contype,
                conaffinity,
                friction,
                contact,
                fluid
            ),
            (
                &b.name,
                &b.body,
                &b.shape,
                &b.contype,
                &b.conaffinity,
                &b.friction,
                &b.contact,
                &b.fluid
            ),
            "{model}"
        );
        worst.numbers(|| at("pos"), pos.as_slice(), b.pos.as_slice());
        rebuilt.rotation(|| at("rot"), rot, &b.rot);
    }
    assert_eq!(sites.len(), theirs.sites.len(), "{model}: sites");
    for (a, b) in sites.iter().zip(&theirs.sites) {
        let Site {
            name,
            body,
            pos,
            rot,
        } = a;
        let at = |what: &str| format!("site '{name}' {what}");
        assert_eq!((name, body), (&b.name, &b.body), "{model}");
        worst.numbers(|| at("pos"), pos.as_slice(), b.pos.as_slice());
        rebuilt.rotation(|| at("rot"), rot, &b.rot);
    }
    (worst, rebuilt)
}

fn assert_round_trips(name: &str, model: &Spec) {
    let again = round_trip(name, model);
    let (worst, rebuilt) = compare(name, model, &again);
    println!(
        "{name}: worst error {:.1e} ({}), rebuilt {:.1e} ({})",
        worst.error, worst.at, rebuilt.error, rebuilt.at
    );
    for (w, tol) in [(worst, TOL), (rebuilt, REBUILT_TOL)] {
        assert!(w.error <= tol, "{name}: {:.3e} at {}", w.error, w.at);
    }
}

#[test]
fn every_model_file_round_trips() {
    let mut gym = 0;
    for (name, path) in sources() {
        let model = match Model::load(&path) {
            Ok(model) => model,
            Err(e @ ModelError::Invalid { .. }) if name.starts_with("gym_") => {
                println!("{name}: not loaded ({e})");
                continue;
            }
            Err(e) => panic!("{e}"),
        };
        gym += usize::from(name.starts_with("gym_"));
        match UNWRITABLE.iter().find(|(n, _)| *n == name) {
            Some((_, why)) => match mjcf::write(&model) {
                Err(e @ ModelError::Unwritable(_)) => {
                    println!("{name}: not written ({e})");
                    assert!(e.to_string().contains(why), "{name}: {e}");
                }
                other => panic!("{name}: expected an Unwritable error, got {other:?}"),
            },
            None => assert_round_trips(&name, &model),
        }
    }
    assert!(gym > 0, "no gymnasium model loaded");
}

#[test]
fn random_trees_round_trip() {
    let cases = [
        (PassiveMode::Explicit, Integrator::Euler),
        (PassiveMode::ImplicitDamping, Integrator::Euler),
        (PassiveMode::Explicit, Integrator::Rk4),
    ];
    for seed in 0..20 {
        let (passive, integrator) = cases[seed as usize % cases.len()];
        let model = common::random_model(seed, 8, passive, integrator);
        // Depth-first parents (MJCF's numbering), with some branching.
        let model = model
            .edited(|s| {
                for (i, b) in s.bodies.iter_mut().enumerate().skip(1) {
                    b.parent = if i % 3 == 0 { 0 } else { i - 1 };
                }
            })
            .unwrap();
        assert_round_trips(&format!("random{seed}"), &model);
    }
}

/// A geom's ellipsoid fluid model is written as `fluidshape` and `fluidcoef`.
#[test]
fn ellipsoid_fluid_round_trips() {
    let text = r#"<mujoco><option density="1.2" viscosity="0.1"/><worldbody>
        <body><joint/><geom type="capsule" size="0.1 0.2" fluidshape="ellipsoid"/>
          <geom type="box" size="0.1 0.2 0.3" pos="0.2 0 0" fluidshape="ellipsoid"
                fluidcoef="0.1 0.2 0.3 0.4 0.5"/><geom size="0.1"/></body>
        </worldbody></mujoco>"#;
    let model = Model::from_mjcf(text, "fluid.xml").unwrap();
    let fluid: Vec<_> = model
        .geoms
        .iter()
        .map(|g| g.fluid.map(|c| c.to_array()))
        .collect();
    let given = [0.1, 0.2, 0.3, 0.4, 0.5];
    assert_eq!(fluid, [Some([0.5, 0.25, 1.5, 1.0, 1.0]), Some(given), None]);
    assert!(mjcf::write(&model)
        .unwrap()
        .contains("fluidshape=\"ellipsoid\""));
    assert_round_trips("ellipsoid_fluid", &model);
}

/// `implicitfast` and `implicit` are their MuJoCo names, gravcomp a body attribute.
#[test]
fn implicit_integrators_and_gravcomp_round_trip() {
    for (seed, integrator) in [(3, Integrator::ImplicitFast), (4, Integrator::Implicit)] {
        let model = common::random_model(seed, 6, PassiveMode::ImplicitDamping, integrator);
        let model = model
            .edited(|s| {
                for (i, b) in s.bodies.iter_mut().enumerate().skip(1) {
                    b.parent = i - 1;
                    b.gravcomp = if i % 2 == 0 { 0.25 * i as f64 } else { 0.0 };
                }
            })
            .unwrap();
        assert!(model.has_gravcomp());
        let text = mjcf::write(&model).unwrap();
        let name = Integrator::NAMES.iter().find(|(_, i)| *i == integrator);
        assert!(text.contains(&format!("integrator=\"{}\"", name.unwrap().0)));
        assert_round_trips(&format!("{integrator:?}"), &model);
        assert_eq!(round_trip("again", &model).opt.integrator, integrator);
    }
}

#[test]
fn rk4_reads_back_with_explicit_passive_forces() {
    let model = Model::load(common::model_path("reference_models/pendulum.xml")).unwrap();
    let model = model
        .edited(|s| {
            s.opt.integrator = Integrator::Rk4;
            s.opt.passive = PassiveMode::ImplicitDamping;
        })
        .unwrap();
    let again = Model::from_mjcf(&mjcf::write(&model).unwrap(), "rk4").unwrap();
    assert_eq!(again.opt.passive, PassiveMode::Explicit);
    let again = again.edited(|s| s.opt.passive = model.opt.passive).unwrap();
    let (worst, rebuilt) = compare("rk4", &model, &again);
    assert_eq!((worst.error, rebuilt.error), (0.0, 0.0));
}

#[test]
fn what_mjcf_cannot_express_is_an_error() {
    let model = Model::load(common::model_path("reference_models/double_pendulum.xml")).unwrap();
    let dart = model
        .edited(|s| s.opt.passive = PassiveMode::ImplicitDampingStiffness)
        .unwrap();
    // link2 moved to the world, then a body under link1: MJCF would number
    // that body before link2.
    let not_depth_first = model
        .edited(|s| {
            s.bodies[2].parent = 0;
            s.bodies.push(Body {
                name: "late".into(),
                parent: 1,
                joints: s.joints.len()..s.joints.len(),
                ..s.bodies[2].clone()
            })
        })
        .unwrap();
    let geoms_out_of_order = model.edited(|s| s.geoms.reverse()).unwrap();
    for (spec, expected) in [
        (&dart, "implicit joint stiffness"),
        (&not_depth_first, "body 'late' is not in depth-first order"),
        (&geoms_out_of_order, "geoms must be grouped by body"),
    ] {
        match mjcf::write(spec) {
            Err(e @ ModelError::Unwritable(_)) => {
                let message = e.to_string();
                assert!(message.contains(expected), "{message}");
            }
            other => panic!("expected an Unwritable error, got {other:?}"),
        }
    }
}

#[test]
fn save_writes_mjcf_to_xml_paths_only() {
    let model = Model::load(common::model_path("reference_models/cartpole.urdf")).unwrap();
    let path = written_dir().join("saved_cartpole.xml");
    model.save(&path).unwrap();
    let again = Model::load(&path).unwrap();
    let (worst, rebuilt) = compare("saved", &model, &again);
    assert_eq!((worst.error, rebuilt.error), (0.0, 0.0));
    let urdf = written_dir().join("saved_cartpole.urdf");
    assert!(matches!(model.save(urdf), Err(ModelError::Unwritable(_))));
}

#[test]
fn soft_settings_round_trip_as_custom_numerics() {
    let model = Model::load(common::model_path("reference_models/half_cheetah.xml")).unwrap();
    let soft = SoftOptions {
        stiffness: 2.5e4,
        damping: 75.0,
        friction: 0.8,
        width: 2e-3,
        slip: 0.3,
        limit_stiffness: 500.0,
        limit_damping: 5.5,
        limit_width: 1.5e-3,
    };
    let model = model.edited(|s| s.opt.soft = soft).unwrap();
    let text = mjcf::write(&model).unwrap();
    assert!(text.contains(r#"<numeric name="diffosi:contact_slip" data="0.3"/>"#));
    assert_eq!(Model::from_mjcf(&text, "soft").unwrap().opt.soft, soft);
    assert_round_trips("half_cheetah, soft settings", &model);
}
