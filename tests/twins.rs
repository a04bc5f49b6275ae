//! Every reference model exists as an MJCF file and a URDF twin; these tests
//! prove that each pair loads as the same model.
//!
//! Compared, in q order: joints (name, kind, axis and hinge anchor in world
//! coordinates at the reference configuration, reference, damping, stiffness,
//! springref, armature, frictionloss, range, the body they move); actuators;
//! options (timestep, gravity, integrator; not the passive mode, which follows
//! each format's engine: MuJoCo's implicit damping for MJCF, PyBullet's
//! explicit forces for URDF); bodies (name, parent, world pose at the
//! reference configuration, mass, COM, inertia); geoms; and the dynamics they
//! give: mass matrix, bias forces and steps at random states.
//!
//! Where the formats differ, by these explicit rules:
//! - Helper links. URDF has one joint per link, so where an MJCF body carries
//!   several joints the URDF chains helper links. A URDF body is a helper when
//!   it has zero mass, zero inertia, no geoms, exactly one child body and no
//!   MJCF body of its name; it stands for the body below it. Joints are
//!   compared through the body they finally move, bodies through their nearest
//!   non-helper ancestor, poses in world coordinates.
//! - Capsules. URDF has none: MJCF capsule "X" is URDF cylinder "X" (same
//!   radius, half-length, pose) plus spheres "X_end1" and "X_end2" of the same
//!   radius at +/- half-length along the capsule axis.
//! - Planes. URDF has none: an MJCF plane is a URDF box in the plane's frame,
//!   lowered by its half height, so its top face is the plane.
//! - Friction is compared only for geoms that can collide.

mod common;

use diffosi::dynamics::{bias_forces, body_poses, crba};
use diffosi::model::{Geom, Inputs, JointKind, Shape, State};
use diffosi::Model;
use nalgebra::{Matrix3, Rotation3, Vector3};

/// Both loaders compute the same numbers in nearly the same arithmetic: a few ulps.
const TOL: f64 = 1e-15;

fn load_twins(name: &str) -> (Model, Model) {
    let path = |ext: &str| {
        format!(
            "{}/reference_models/{name}.{ext}",
            env!("CARGO_MANIFEST_DIR")
        )
    };
    // Both under the smooth contact model (URDF's default): a contact law
    // the URDF file can state.
    let load = |p: String| Model::load(&p).unwrap_or_else(|e| panic!("{p}: {e}"));
    (common::smooth(load(path("xml"))), load(path("urdf")))
}

/// Body frames in world coordinates (rotation, origin) at the reference configuration.
fn world_poses(m: &Model) -> Vec<(Rotation3<f64>, Vector3<f64>)> {
    body_poses(m.tree(), &m.reference_q())
        .into_iter()
        .map(|(axes, origin)| (Rotation3::from_matrix_unchecked(axes), origin))
        .collect()
}

fn is_helper(urdf: &Model, mjcf: &Model, b: usize) -> bool {
    let body = &urdf.bodies[b];
    let children = urdf.bodies.iter().skip(1).filter(|c| c.parent == b).count();
    b != 0
        && body.mass == 0.0
        && body.inertia == Matrix3::zeros()
        && urdf.geoms.iter().all(|g| g.body != b)
        && children == 1
        && mjcf.body_index(&body.name).is_none()
}

/// The URDF body that `b` stands for: itself, or for a helper the body below it.
fn stands_for(urdf: &Model, mjcf: &Model, mut b: usize) -> usize {
    while is_helper(urdf, mjcf, b) {
        b = (b + 1..urdf.bodies.len())
            .find(|&c| urdf.bodies[c].parent == b)
            .expect("a helper has one child");
    }
    b
}

/// The nearest ancestor of `b` that is not a helper.
fn real_parent(urdf: &Model, mjcf: &Model, b: usize) -> usize {
    let mut p = urdf.bodies[b].parent;
    while is_helper(urdf, mjcf, p) {
        p = urdf.bodies[p].parent;
    }
    p
}

fn assert_close(what: &str, a: &[f64], b: &[f64]) {
    let err = a
        .iter()
        .zip(b)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f64::max);
    assert!(a.len() == b.len() && err <= TOL, "{what}: {a:?} vs {b:?}");
}

fn assert_same_model(name: &str) {
    let (mjcf, urdf) = load_twins(name);
    let (mp, up) = (world_poses(&mjcf), world_poses(&urdf));
    assert_eq!(mjcf.name, urdf.name);

    // Options.
    assert_eq!(mjcf.opt.timestep, urdf.opt.timestep, "{name}: timestep");
    assert_eq!(mjcf.opt.gravity, urdf.opt.gravity, "{name}: gravity");
    assert_eq!(
        mjcf.opt.integrator, urdf.opt.integrator,
        "{name}: integrator"
    );

    // Joints, in q order.
    let names = |m: &Model| m.joints.iter().map(|j| j.name.clone()).collect::<Vec<_>>();
    assert_eq!(names(&mjcf), names(&urdf), "{name}: joints");
    for (a, b) in mjcf.joints.iter().zip(&urdf.joints) {
        let what = format!("{name}: joint {}", a.name);
        let ub = stands_for(&urdf, &mjcf, b.body);
        assert_eq!(
            mjcf.bodies[a.body].name, urdf.bodies[ub].name,
            "{what}: body"
        );
        assert_eq!(a.kind, b.kind, "{what}: kind");
        let (ra, rb) = (mp[a.body].0, up[b.body].0);
        if a.kind.nv() == 1 {
            // (a ball or free joint has no axis: its `axis` is each format's default)
            assert_close(
                &format!("{what}: world axis"),
                (ra * a.axis).as_slice(),
                (rb * b.axis).as_slice(),
            );
        }
        if a.kind == JointKind::Hinge {
            let anchor_a = mp[a.body].1 + ra * a.anchor;
            let anchor_b = up[b.body].1 + rb * b.anchor;
            assert_close(
                &format!("{what}: world anchor"),
                anchor_a.as_slice(),
                anchor_b.as_slice(),
            );
        }
        let passive = |j: &diffosi::model::Joint| {
            [
                j.reference,
                j.damping,
                j.stiffness,
                j.springref,
                j.armature,
                j.frictionloss,
            ]
        };
        assert_eq!(
            passive(a),
            passive(b),
            "{what}: reference, damping, stiffness, springref, armature, frictionloss"
        );
        assert_eq!(a.range, b.range, "{what}: range");
    }

    // Actuators.
    assert_eq!(mjcf.actuators, urdf.actuators, "{name}: actuators");

    // Bodies: every MJCF body has its URDF twin; the URDF has nothing else but helpers.
    let helpers = (0..urdf.bodies.len())
        .filter(|&b| is_helper(&urdf, &mjcf, b))
        .count();
    assert_eq!(
        mjcf.bodies.len() + helpers,
        urdf.bodies.len(),
        "{name}: bodies"
    );
    for (i, a) in mjcf.bodies.iter().enumerate().skip(1) {
        let what = format!("{name}: body {}", a.name);
        let j = urdf
            .body_index(&a.name)
            .unwrap_or_else(|| panic!("{what}: not in the URDF"));
        let b = &urdf.bodies[j];
        assert_eq!(
            mjcf.bodies[a.parent].name,
            urdf.bodies[real_parent(&urdf, &mjcf, j)].name,
            "{what}: parent"
        );
        assert_close(
            &format!("{what}: world rotation"),
            mp[i].0.matrix().as_slice(),
            up[j].0.matrix().as_slice(),
        );
        assert_close(
            &format!("{what}: world position"),
            mp[i].1.as_slice(),
            up[j].1.as_slice(),
        );
        assert_close(&format!("{what}: mass"), &[a.mass], &[b.mass]);
        assert_close(&format!("{what}: com"), a.com.as_slice(), b.com.as_slice());
        assert_close(
            &format!("{what}: inertia"),
            a.inertia.as_slice(),
            b.inertia.as_slice(),
        );
    }

    assert_same_geoms(name, &mjcf, &urdf);
}

fn assert_same_geoms(name: &str, mjcf: &Model, urdf: &Model) {
    let (mp, up) = (world_poses(mjcf), world_poses(urdf));
    let world = |poses: &[(Rotation3<f64>, Vector3<f64>)], g: &Geom| {
        let (rot, pos) = poses[g.body];
        (rot * g.rot, pos + rot * g.pos)
    };
    let find = |geom_name: &str| {
        let g = urdf.geoms.iter().find(|g| g.name == geom_name);
        g.unwrap_or_else(|| panic!("{name}: geom {geom_name} is not in the URDF"))
    };
    let capsules = mjcf
        .geoms
        .iter()
        .filter(|g| matches!(g.shape, Shape::Capsule { .. }))
        .count();
    assert_eq!(
        mjcf.geoms.len() + 2 * capsules,
        urdf.geoms.len(),
        "{name}: geoms"
    );
    for a in &mjcf.geoms {
        let what = format!("{name}: geom {}", a.name);
        let b = find(&a.name);
        assert_eq!(
            mjcf.bodies[a.body].name, urdf.bodies[b.body].name,
            "{what}: body"
        );
        assert_eq!(
            (a.contype, a.conaffinity),
            (b.contype, b.conaffinity),
            "{what}: contype, conaffinity"
        );
        if a.contype | a.conaffinity != 0 {
            assert_eq!(a.friction, b.friction, "{what}: friction");
        }
        let (ra, pa) = world(&mp, a);
        let (rb, pb) = world(&up, b);
        assert_close(
            &format!("{what}: world rotation"),
            ra.matrix().as_slice(),
            rb.matrix().as_slice(),
        );
        match (a.shape, b.shape) {
            (
                Shape::Capsule {
                    radius,
                    half_length,
                },
                Shape::Cylinder { .. },
            ) => {
                assert_eq!(
                    b.shape,
                    Shape::Cylinder {
                        radius,
                        half_length
                    },
                    "{what}: cylinder"
                );
                assert_close(
                    &format!("{what}: world position"),
                    pa.as_slice(),
                    pb.as_slice(),
                );
                for (end, sign) in [("_end1", 1.0), ("_end2", -1.0)] {
                    let e = find(&format!("{}{end}", a.name));
                    assert_eq!(e.shape, Shape::Sphere { radius }, "{what}{end}: sphere");
                    assert_eq!(
                        (e.body, e.contype, e.conaffinity),
                        (b.body, b.contype, b.conaffinity),
                        "{what}{end}"
                    );
                    let tip = pa + ra * Vector3::z() * (sign * half_length);
                    assert_close(
                        &format!("{what}{end}: world position"),
                        tip.as_slice(),
                        world(&up, e).1.as_slice(),
                    );
                }
            }
            (Shape::Plane, Shape::Box { half }) => {
                let top_centre = pb + rb * Vector3::z() * half.z;
                assert_close(
                    &format!("{what}: box top face"),
                    pa.as_slice(),
                    top_centre.as_slice(),
                );
            }
            (sa, sb) => {
                assert_eq!(sa, sb, "{what}: shape");
                assert_close(
                    &format!("{what}: world position"),
                    pa.as_slice(),
                    pb.as_slice(),
                );
            }
        }
    }
}

#[test]
fn cartpole_twins_are_the_same_model() {
    assert_same_model("cartpole");
}

#[test]
fn pendulum_twins_are_the_same_model() {
    assert_same_model("pendulum");
}

#[test]
fn double_pendulum_twins_are_the_same_model() {
    assert_same_model("double_pendulum");
}

#[test]
fn half_cheetah_twins_are_the_same_model() {
    assert_same_model("half_cheetah");
}

#[test]
fn box_twins_are_the_same_model() {
    assert_same_model("box");
}

#[test]
fn wiping_arm_twins_are_the_same_model() {
    assert_same_model("wiping_arm");
}

#[test]
fn floating_arm_twins_are_the_same_model() {
    assert_same_model("floating_arm");
}

/// The helper rule must not hide anything: the half cheetah and the box have
/// exactly their documented helper links, and the other twins none.
#[test]
fn only_the_half_cheetah_root_uses_helper_links() {
    for (name, expected) in [
        ("cartpole", vec![]),
        ("pendulum", vec![]),
        ("double_pendulum", vec![]),
        ("half_cheetah", vec!["rootx_link", "rootz_link"]),
        (
            "box",
            vec!["x_link", "y_link", "z_link", "rx_link", "ry_link"],
        ),
        ("wiping_arm", vec![]),
        ("floating_arm", vec![]),
    ] {
        let (mjcf, urdf) = load_twins(name);
        let helpers: Vec<_> = (0..urdf.bodies.len())
            .filter(|&b| is_helper(&urdf, &mjcf, b))
            .map(|b| urdf.bodies[b].name.as_str())
            .collect();
        assert_eq!(helpers, expected, "{name}");
    }
}

/// Same dynamics: M(q), c(q, v) and one step (under the MJCF twin's passive
/// mode) agree at random states.
#[test]
fn twins_have_the_same_dynamics() {
    for name in [
        "cartpole",
        "pendulum",
        "double_pendulum",
        "half_cheetah",
        "box",
        "wiping_arm",
        "floating_arm",
    ] {
        let (mjcf, urdf) = load_twins(name);
        // The URDF twins have no floor: compare without contacts (limits on).
        let mjcf = mjcf.edited(|s| s.opt.contact = false).unwrap();
        let urdf = urdf.edited(|s| s.opt = mjcf.opt.clone()).unwrap();
        let (mut dm, mut du) = (mjcf.data(), urdf.data());
        for seed in 0..10 {
            let (q, v, tau) = common::random_state(&mjcf, seed);
            crba(mjcf.tree(), &mut dm, &q);
            crba(urdf.tree(), &mut du, &q);
            let m_err = (&dm.mass_matrix - &du.mass_matrix).amax();
            let (mut cm, mut cu) = (vec![0.0; q.len()], vec![0.0; q.len()]);
            bias_forces(mjcf.tree(), &mut dm, &q, &v, &mut cm);
            bias_forces(urdf.tree(), &mut du, &q, &v, &mut cu);
            let c_err = cm
                .iter()
                .zip(&cu)
                .map(|(a, b)| (a - b).abs())
                .fold(0.0, f64::max);
            let next = mjcf
                .step(
                    &mut dm,
                    &State::new(q.clone(), v.clone()),
                    &Inputs::tau(&tau),
                )
                .unwrap();
            let (qm, vm) = (next.q, next.v);
            let next = urdf
                .step(
                    &mut du,
                    &State::new(q.clone(), v.clone()),
                    &Inputs::tau(&tau),
                )
                .unwrap();
            let (qu, vu) = (next.q, next.v);
            let s_err = qm
                .iter()
                .chain(&vm)
                .zip(qu.iter().chain(&vu))
                .map(|(a, b)| (a - b).abs())
                .fold(0.0, f64::max);
            assert!(
                m_err < 1e-13 && c_err < 1e-12 && s_err < 1e-13,
                "{name} seed {seed}: M {m_err:e}, c {c_err:e}, step {s_err:e}"
            );
        }
    }
}
