//! The quadruped task's model: Unitree Go1 from `reference_models/go1/go1.urdf`
//! (example-robot-data's file without its visuals) with what a URDF cannot
//! say added in code, the same way for every engine:
//!
//! - a free base (the `root_joint` on link `base`) over a floor, the plane
//!   z = 0 (geom `floor`, friction 1, 0.005, 0.0001: MuJoCo's default);
//! - every collision primitive of the robot collides with the floor and with
//!   nothing else: no self-collision (legged_gym's setting; the hip
//!   cylinders against the trunk box have no collider here yet);
//! - the file's twelve transmissions become MuJoCo position servos, force =
//!   kp (ctrl - q) - kd q', kp = 20 N m/rad and kd = 0.5 N m s/rad
//!   (legged_gym's Go1/A1 and walk-these-ways' gains), clamped to the joint's
//!   URDF `effort` (23.7 N m at hips and thighs, 35.55 N m at the knees);
//! - the `base` link's inertia: the file's is the rank-one tensor 1e-6 [1 1 1;
//!   1 1 1; 1 1 1] kg m^2, which MuJoCo's compiler refuses ("inertia must
//!   have positive eigenvalues"); it becomes 1e-6 I (the link weighs 1e-6 kg,
//!   welded to the 5.2 kg trunk);
//! - a payload: a jointless body `payload` welded to the trunk, a box of
//!   0.2 x 0.1 x 0.05 m (x y z) lying on the trunk's top face, its COM at
//!   (x_p, 0, 0.082) m in trunk coordinates. A welded body adds its mass,
//!   moves the trunk's composite COM and adds its own box inertia and the
//!   parallel-axis terms: the named-parameter rules (`body/trunk/mass`,
//!   `com`, `inertia`) applied to the composite, while staying affine in
//!   mu = (payload mass, x_p) (`body/payload/mass`, `com`, `inertia`);
//! - options: the URDF's (Euler with implicit joint damping, MuJoCo's
//!   default contact solver settings) at timestep 0.005 s.
//!
//! The joints keep the file's damping 0.01 and friction 0.2 (frictionloss),
//! and its limits.

use nalgebra::{Matrix3, Rotation3, Vector3};

use crate::model::urdf::{self, LoadOptions};
use crate::model::{Bias, Body, Gain, Geom, GeomContact, Shape, Spec};
use crate::Model;

/// The model file, compiled in so the task needs no path at run time.
const URDF: &str = include_str!("../../../reference_models/go1/go1.urdf");
pub const FILE: &str = "reference_models/go1/go1.urdf";

/// The servos' stiffness (N m/rad) and damping (N m s/rad).
pub const KP: f64 = 20.0;
pub const KD: f64 = 0.5;
/// The physics timestep (s).
pub const TIMESTEP: f64 = 0.005;
/// The payload box's edge lengths (m) and its COM's height above the trunk
/// origin: on the trunk box's top face (half height 0.057 m).
pub const PAYLOAD_BOX: [f64; 3] = [0.2, 0.1, 0.05];
pub const PAYLOAD_HEIGHT: f64 = 0.057 + 0.025;

/// The Go1 model of the task (see the module docs), payload mass 0. The
/// file is compiled in: that it loads is checked by the tests.
pub fn model() -> Model {
    let options = LoadOptions {
        floating_base: true,
        ..LoadOptions::default()
    };
    let mut spec = urdf::parse(URDF, FILE, &options)
        .expect("the shipped Go1 URDF loads")
        .spec;
    spec.opt.timestep = TIMESTEP;
    let base = body(&spec, "base");
    spec.bodies[base].inertia = Matrix3::identity() * 1e-6;
    for geom in &mut spec.geoms {
        (geom.contype, geom.conaffinity) = (1, 0);
    }
    spec.geoms.push(floor());
    servos(&mut spec);
    add_payload(&mut spec);
    Model::from_spec(spec).expect("the Go1 task model compiles")
}

fn body(spec: &Spec, name: &str) -> usize {
    let found = spec.bodies.iter().position(|b| b.name == name);
    found.unwrap_or_else(|| panic!("{FILE} has a link '{name}'"))
}

fn floor() -> Geom {
    Geom {
        name: "floor".into(),
        body: 0,
        shape: Shape::Plane,
        pos: Vector3::zeros(),
        rot: Rotation3::identity(),
        contype: 0,
        conaffinity: 1,
        friction: [1.0, 0.005, 0.0001],
        contact: GeomContact::default(),
        fluid: None,
    }
}

/// The transmissions' motors as position servos limited to the joint's effort.
fn servos(spec: &mut Spec) {
    assert_eq!(spec.actuators.len(), 12, "{FILE} has 12 transmissions");
    for a in &mut spec.actuators {
        let effort =
            effort_of(&spec.joints[a.joint().expect("the task's servos sit on joints")].name);
        a.gain = Gain::Fixed(KP);
        a.bias = Bias::Affine([0.0, -KP, -KD]);
        a.force_range = Some((-effort, effort));
    }
}

/// The URDF `effort` of a leg joint (N m).
pub fn effort_of(joint: &str) -> f64 {
    match joint.rsplit('_').nth(1) {
        Some("hip" | "thigh") => 23.7,
        Some("calf") => 35.55,
        _ => panic!("{FILE}: a transmission on '{joint}', not a leg joint"),
    }
}

/// The payload's box inertia per kg about its COM (kg m^2 / kg), diagonal.
pub fn payload_inertia_per_kg() -> [f64; 3] {
    let [a, b, c] = PAYLOAD_BOX.map(|s| s * s / 12.0);
    [b + c, a + c, a + b]
}

/// The payload body, massless, as the trunk's last child.
fn add_payload(spec: &mut Spec) {
    let trunk = body(spec, "trunk");
    let nj = spec.joints.len();
    spec.bodies.push(Body {
        name: "payload".into(),
        parent: trunk,
        com: Vector3::new(0.0, 0.0, PAYLOAD_HEIGHT),
        joints: nj..nj,
        ..Body::world()
    });
}
