//! The physical model: a tree of rigid bodies connected by joints.
//!
//! Conventions, stated once here and used everywhere:
//! - SI units; angles in radians (loaders convert MJCF degrees).
//! - Body 0 is the world. Every other body has a parent with a smaller index.
//! - A body's frame sits in its parent's frame at `pos`, rotated by `rot`
//!   (columns of `rot` are the body axes in parent coordinates), when every joint
//!   of the body is at its reference position `Joint::reference`.
//! - A body has zero or more joints, applied in order, each in the body's own
//!   (already moved) frame: a hinge turns the body by `q - reference` about
//!   `axis` through `anchor`; a slide moves it by `(q - reference) * axis`.
//!   A ball turns the body about `anchor` by a unit quaternion. A free joint
//!   places the body in the world absolutely (its `pos`/`rot` are only its
//!   reference configuration), so it is the only joint of a body whose parent
//!   is the world. This is MJCF's meaning; a URDF joint is a body with one
//!   joint whose anchor is the body origin. A body with no joint is welded to
//!   its parent ("fixed").
//! - Positions q have nq coordinates and velocities v have nv (MuJoCo's qpos
//!   and qvel): joints own consecutive slices of both, in joint order.
//!   Hinge and slide: one coordinate, one dof. Ball: a unit quaternion
//!   (w, x, y, z), 3 dofs, the angular velocity in the body frame. Free: the
//!   body origin's world position, then a unit quaternion of its axes; 6
//!   dofs, the linear velocity in world coordinates, then the angular
//!   velocity in the body frame. So nq = nv unless a model has ball or free
//!   joints. A quaternion need not be normalised on input (the dynamics read
//!   it normalised); the step returns it normalised, as MuJoCo does.
//! - A body's inertial properties are its mass, its centre of mass `com` in body
//!   coordinates, and its inertia tensor about the COM in body axes.
//! - Generalized forces tau have length nv. An actuator maps a control u to
//!   tau[joint's dof] += gear * u (hinge and slide joints only).

pub mod constraint;
pub mod equality;
pub mod geom_inertia;
pub mod hfield;
mod keyframe;
pub mod mesh;
pub mod mjcf;
pub mod params;
pub mod sensor;
mod state;
pub mod tendon;
pub mod urdf;
mod xml;

use nalgebra::{Matrix3, Rotation3, Vector3};

pub use constraint::{
    Ccd, Cone, ContactModel, ContactPair, GeomContact, NoSlip, PairParams, SolParams, SolverOptions,
};
pub use equality::{Equality, EqualityKind, Objects};
pub use keyframe::Keyframe;
pub use params::{MapEntry, Param, ParamError, ParamMap};
pub use sensor::{
    ActuatorQuantity, FrameObject, FrameQuantity, JointQuantity, RayField, Sensor, SensorKind,
    SiteQuantity, TendonQuantity,
};
pub use state::{Inputs, State};
pub use tendon::{Tendon, Wrap};

/// Errors from building, loading or editing a model.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ModelError {
    #[error("cannot read {path}: {source}")]
    Io {
        path: String,
        source: std::io::Error,
    },
    #[error("{file}: XML syntax error: {message}")]
    Xml { file: String, message: String },
    /// A file that parses as XML but describes something we reject.
    #[error("{file}:{line}: <{element}>: {message}")]
    Invalid {
        file: String,
        line: u32,
        element: String,
        message: String,
    },
    #[error("unsupported model file extension in {0}: expected .xml (MJCF) or .urdf")]
    UnknownFormat(String),
    #[error("model is not physical: {0}")]
    NotPhysical(String),
    /// A model that is valid but needs what is not implemented yet.
    #[error("not supported: {0}")]
    Unsupported(String),
    /// A model a file format cannot express, or a file we cannot write.
    #[error("cannot write {0}")]
    Unwritable(String),
    /// A load option the file's format has no use for.
    #[error("{0}")]
    NotApplicable(String),
}

/// A rigid body. See the module documentation for frames.
#[derive(Clone, Debug, PartialEq)]
pub struct Body {
    pub name: String,
    /// Index of the parent body; the world (body 0) is its own parent.
    pub parent: usize,
    pub pos: Vector3<f64>,
    pub rot: Rotation3<f64>,
    pub mass: f64,
    pub com: Vector3<f64>,
    /// Inertia tensor about the COM, in body axes (kg m^2).
    pub inertia: Matrix3<f64>,
    /// The body's inertial frame (columns: its axes in body coordinates),
    /// where the loader found the inertia diagonal: MuJoCo's body_iquat,
    /// the frame its fluid forces act in. Where principal moments are equal
    /// it tells the axes apart; elsewhere any principal frame is the same.
    pub inertia_frame: Rotation3<f64>,
    /// The joints of this body, as a range of joint (= dof) indices.
    pub joints: std::ops::Range<usize>,
    /// MuJoCo's gravity compensation: the body feels -gravcomp m g at its
    /// COM ([`crate::dynamics::gravcomp`]); 0 (none) by default.
    pub gravcomp: f64,
    /// A mocap body (MJCF `mocap="true"`): a jointless child of the world
    /// whose pose is an input of the step (MuJoCo's mocap_pos, mocap_quat;
    /// [`Spec::mocap_bodies`]), `pos` and `rot` its default. It carries its
    /// geoms and sites, no dofs; child bodies under it are not supported.
    pub mocap: bool,
}

impl Body {
    /// Body 0: named "world", at the origin, without mass or joints.
    pub fn world() -> Body {
        Body {
            name: "world".to_string(),
            parent: 0,
            pos: Vector3::zeros(),
            rot: Rotation3::identity(),
            mass: 0.0,
            com: Vector3::zeros(),
            inertia: Matrix3::zeros(),
            inertia_frame: Rotation3::identity(),
            joints: 0..0,
            gravcomp: 0.0,
            mocap: false,
        }
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum JointKind {
    /// Revolute: rotation about an axis (MJCF hinge, URDF revolute/continuous).
    Hinge,
    /// Prismatic: translation along an axis (MJCF slide, URDF prismatic).
    Slide,
    /// Spherical: rotation about the anchor (MJCF ball).
    Ball,
    /// Six dofs relative to the world (MJCF free, URDF floating).
    Free,
}

impl JointKind {
    /// Its number of position coordinates.
    pub fn nq(self) -> usize {
        match self {
            JointKind::Hinge | JointKind::Slide => 1,
            JointKind::Ball => 4,
            JointKind::Free => 7,
        }
    }

    /// Its number of dofs (velocity coordinates).
    pub fn nv(self) -> usize {
        match self {
            JointKind::Hinge | JointKind::Slide => 1,
            JointKind::Ball => 3,
            JointKind::Free => 6,
        }
    }
}

/// A joint. Axis and anchor are in the coordinates of its body's frame. A
/// ball uses its anchor alone, a free joint neither; for both the reference
/// and the spring's rest position are the reference configuration (the
/// identity, the body's `pos`/`rot`), and the damping, armature and spring
/// apply to each dof alike (MuJoCo's).
#[derive(Clone, Debug, PartialEq)]
pub struct Joint {
    pub name: String,
    pub kind: JointKind,
    pub body: usize,
    /// Unit axis.
    pub axis: Vector3<f64>,
    /// A point on the axis (hinges turn about it).
    pub anchor: Vector3<f64>,
    /// The q at which the body sits at its `pos`/`rot` (MJCF `ref`, qpos0).
    pub reference: f64,
    /// Viscous damping: force -damping * v.
    pub damping: f64,
    /// Spring: force -stiffness * (q - springref).
    pub stiffness: f64,
    pub springref: f64,
    /// Rotor inertia added to the mass-matrix diagonal (MuJoCo armature).
    pub armature: f64,
    /// Dry friction: a constraint row of the constraint model (MuJoCo's
    /// `frictionloss`); the smooth model ignores it.
    pub frictionloss: f64,
    /// Position limits, if the joint is limited.
    pub range: Option<(f64, f64)>,
    /// The constraint model's settings of the limit (MJCF `margin`,
    /// `solreflimit`, `solimplimit`) and of the dry friction
    /// (`solreffriction`, `solimpfriction`).
    pub margin: f64,
    pub limit_sol: SolParams,
    pub friction_sol: SolParams,
    /// MuJoCo's `springdamper` (time constant, damping ratio), both
    /// positive: the compiler replaces `stiffness` and `damping` from them
    /// and the dof's invweight0 ([`crate::compile`], module `springdamper`),
    /// then clears it.
    pub springdamper: Option<[f64; 2]>,
}

impl Joint {
    /// A free joint of `body` without damping, spring, armature, dry
    /// friction or limits (MJCF `<freejoint>`, a URDF floating base); its
    /// axis is MuJoCo's default z, unused by a free joint.
    pub fn free(name: String, body: usize) -> Joint {
        Joint {
            name,
            kind: JointKind::Free,
            body,
            axis: Vector3::z(),
            anchor: Vector3::zeros(),
            reference: 0.0,
            damping: 0.0,
            stiffness: 0.0,
            springref: 0.0,
            armature: 0.0,
            frictionloss: 0.0,
            range: None,
            margin: 0.0,
            limit_sol: SolParams::default(),
            friction_sol: SolParams::default(),
            springdamper: None,
        }
    }
}

/// MuJoCo's actuator on a hinge or slide joint, a tendon or a site
/// ([`Transmission`]): on a joint or tendon its length is l = gear\[0\] x and
/// its velocity l' = gear\[0\] x' (x the joint's coordinate or the tendon's
/// length L(q), x' = dx/dt), its moment (the generalized force per unit
/// force, nv) gear\[0\] dx/dq; on a site, gear is a wrench (force, torque) in
/// the site's frame, or in the reference site's (mj_transmission's
/// mjTRN_SITE: the length the site's position and rotation vector relative
/// to the reference site, dotted with gear; the moment the relative
/// Jacobian projected on the wrench, l' = moment v);
/// its scalar force is f = gain(l, l') w + bias(l, l'), w = ctrl without
/// activation dynamics, else the activation act, clamped to `force_range`;
/// its generalized force is moment f. ctrl is clamped to `ctrl_range` first.
/// Units: SI; f in N or N m per unit of gear.
#[derive(Clone, Debug, PartialEq)]
pub struct Actuator {
    pub name: String,
    pub target: Transmission,
    pub gear: [f64; 6],
    pub ctrl_range: Option<(f64, f64)>,
    pub force_range: Option<(f64, f64)>,
    pub act_range: Option<(f64, f64)>,
    pub gain: Gain,
    pub bias: Bias,
    pub dynamics: ActDynamics,
    /// Force from the next activation instead of the current one
    /// (MuJoCo's actearly).
    pub act_early: bool,
    /// MuJoCo 4's actuator damping and armature: the joint's damping and
    /// armature gain damping gear^2 and armature gear^2 (mj_actuatorDamping,
    /// mj_actuatorArmature; [`Spec::actuator_passive`]).
    pub damping: f64,
    pub armature: f64,
}

/// What an actuator drives (MuJoCo's trntype and trnid): a hinge or slide
/// joint, a tendon ([`Spec::tendons`]), or a site with an optional
/// reference site ([`Spec::sites`]), by index.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Transmission {
    Joint(usize),
    Tendon(usize),
    Site { site: usize, refsite: Option<usize> },
}

/// MuJoCo's gain types: fixed `gainprm[0]`, or affine
/// `gainprm[0] + gainprm[1] l + gainprm[2] l'`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Gain {
    Fixed(f64),
    Affine([f64; 3]),
}

/// MuJoCo's bias types: none, or affine `biasprm[0] + biasprm[1] l +
/// biasprm[2] l'`. In a [`Spec`], an affine bias with `biasprm[1] =
/// -gain` and a positive `biasprm[2]` holds a damping ratio (MuJoCo's
/// `dampratio`), which compiling turns into `-kv` ([`crate::Model`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Bias {
    None,
    Affine([f64; 3]),
}

/// MuJoCo's activation dynamics (dyntype): none (the force reads ctrl),
/// or one activation state with act' = ctrl (integrator) or
/// act' = (ctrl - act) / tau (filter, integrated by the step's method;
/// filterexact, integrated exactly over a step).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ActDynamics {
    None,
    Integrator,
    Filter(f64),
    FilterExact(f64),
}

impl Actuator {
    /// A motor: fixed gain 1, no bias, no activation.
    pub fn motor(name: String, joint: usize, gear: f64, ctrl_range: Option<(f64, f64)>) -> Self {
        Actuator {
            name,
            target: Transmission::Joint(joint),
            gear: [gear, 0.0, 0.0, 0.0, 0.0, 0.0],
            ctrl_range,
            force_range: None,
            act_range: None,
            gain: Gain::Fixed(1.0),
            bias: Bias::None,
            dynamics: ActDynamics::None,
            act_early: false,
            damping: 0.0,
            armature: 0.0,
        }
    }

    /// The generalized force per unit control, gear\[0] times a fixed gain, for
    /// an actuator whose force is that alone (no bias, activation or force
    /// limit); None for any other.
    pub fn force_per_control(&self) -> Option<f64> {
        match (self.gain, self.bias, self.dynamics, self.force_range) {
            (Gain::Fixed(g), Bias::None, ActDynamics::None, None) => Some(self.gear[0] * g),
            _ => None,
        }
    }

    /// The joint it drives, if its transmission is a joint.
    pub fn joint(&self) -> Option<usize> {
        match self.target {
            Transmission::Joint(j) => Some(j),
            Transmission::Tendon(_) | Transmission::Site { .. } => None,
        }
    }

    /// Whether it has an activation state.
    pub fn has_act(&self) -> bool {
        self.dynamics != ActDynamics::None
    }

    /// Finite parameters, ranges in increasing order, non-negative time
    /// constants.
    fn check(&self) -> Result<(), String> {
        let prm = |g: Gain| match g {
            Gain::Fixed(x) => [x, 0.0, 0.0],
            Gain::Affine(p) => p,
        };
        let bias = match self.bias {
            Bias::None => [0.0; 3],
            Bias::Affine(p) => p,
        };
        let tau = match self.dynamics {
            ActDynamics::Filter(t) | ActDynamics::FilterExact(t) => t,
            _ => 0.0,
        };
        let finite = prm(self.gain).iter().chain(&bias).all(|x| x.is_finite());
        if !finite || tau.is_nan() || tau < 0.0 {
            return Err("gain, bias and time constant must be finite (tau >= 0)".into());
        }
        let ranges = [
            ("ctrlrange", self.ctrl_range),
            ("forcerange", self.force_range),
            ("actrange", self.act_range),
        ];
        for (name, range) in ranges {
            if let Some((lo, hi)) = range {
                if lo >= hi || !lo.is_finite() || !hi.is_finite() {
                    return Err(format!(
                        "{name} must be finite and increasing, got ({lo}, {hi})"
                    ));
                }
            }
        }
        Ok(())
    }
}

/// Collision and visual shape, in the frame of its body.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Shape {
    /// The z = 0 plane of the geom frame (infinite).
    Plane,
    Sphere {
        radius: f64,
    },
    /// Along the geom's z axis; `half_length` of the cylindrical part.
    Capsule {
        radius: f64,
        half_length: f64,
    },
    /// Along the geom's z axis.
    Cylinder {
        radius: f64,
        half_length: f64,
    },
    Box {
        half: Vector3<f64>,
    },
    Ellipsoid {
        radii: Vector3<f64>,
    },
    /// The triangle mesh `Spec::meshes[mesh]`, in its mesh frame (centred
    /// at its centre of mass, along its principal axes: see [`mesh`]).
    /// Colliders see its convex hull.
    Mesh {
        mesh: usize,
    },
    /// The height field `Spec::hfields[hfield]`, with its `size` (the
    /// table's, copied: the extent, bounding radius, mass and inertia need
    /// no elevations). Its mass and inertia are those of the box of
    /// half-sizes [`hfield::HField::geom_size`], as MuJoCo's.
    HField {
        hfield: usize,
        size: [f64; 4],
    },
}

#[derive(Clone, Debug, PartialEq)]
pub struct Geom {
    pub name: String,
    pub body: usize,
    pub shape: Shape,
    pub pos: Vector3<f64>,
    pub rot: Rotation3<f64>,
    /// MJCF contype/conaffinity bitmasks (URDF collision geoms get 1/1).
    pub contype: u32,
    pub conaffinity: u32,
    /// Sliding, torsional, rolling friction (MJCF order); the smooth model
    /// uses only the sliding coefficient (see [`SoftOptions::friction`]).
    pub friction: [f64; 3],
    /// How the constraint model makes and solves this geom's contacts.
    pub contact: GeomContact,
    /// MuJoCo's ellipsoid fluid model on this geom (MJCF
    /// `fluidshape="ellipsoid"`); None: `fluidshape="none"`.
    pub fluid: Option<FluidCoefs>,
}

/// A site: a frame fixed to a body, where sensors sit (MJCF `<site>`). Its
/// origin `pos` and axes `rot` (columns) are in the body's frame; its shape
/// and size are visual only and not kept.
#[derive(Clone, Debug, PartialEq)]
pub struct Site {
    pub name: String,
    pub body: usize,
    pub pos: Vector3<f64>,
    pub rot: Rotation3<f64>,
}

/// How velocities and positions advance over one timestep.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Integrator {
    /// Semi-implicit Euler: v' = v + h a(q, v), q' = q + h v'.
    Euler,
    /// Classic fourth-order Runge-Kutta on (q, v); passive forces explicit.
    Rk4,
    /// MuJoCo's `implicitfast`: v' = v + h qdd, q' = q (+) h v', with
    /// (M - h D) qdd = f, D the velocity derivative of the passive and
    /// actuator forces (MuJoCo's qDeriv without the Coriolis term, its lower
    /// triangle mirrored), f the forces at (q, v) with the constraint forces
    /// solved under M; a standalone free body's block adds its exact
    /// gyroscopic derivative. See [`crate::dynamics::implicit`].
    ImplicitFast,
    /// MuJoCo's `implicit`: as [`Integrator::ImplicitFast`] with the full
    /// qDeriv, Coriolis and centrifugal forces' velocity derivative included
    /// (an unsymmetric matrix, solved by LU).
    Implicit,
}

impl Integrator {
    /// The spelling in files and at the Python boundary (MuJoCo's).
    pub const NAMES: [(&'static str, Integrator); 4] = [
        ("Euler", Integrator::Euler),
        ("RK4", Integrator::Rk4),
        ("implicitfast", Integrator::ImplicitFast),
        ("implicit", Integrator::Implicit),
    ];

    /// Whether the step solves with MuJoCo's implicit matrix M - h qDeriv
    /// (`implicitfast`, `implicit`).
    pub fn is_implicit(self) -> bool {
        matches!(self, Integrator::ImplicitFast | Integrator::Implicit)
    }
}

/// How joint damping and stiffness enter a semi-implicit Euler step.
/// (Under RK4 passive forces are always explicit, as in MuJoCo; under
/// `implicitfast` and `implicit` damping enters through qDeriv and the
/// mode is not read.)
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PassiveMode {
    /// Forces at the current state: PyBullet, MuJoCo with eulerdamp disabled.
    Explicit,
    /// Damping at the next velocity, stiffness at the current position:
    /// MuJoCo's Euler integrator.
    ImplicitDamping,
    /// Damping at the next velocity and stiffness at the next position: DART.
    ImplicitDampingStiffness,
}

impl PassiveMode {
    /// The spelling in files (`<diffosi:options passive=..>`) and at the Python boundary.
    pub const NAMES: [(&'static str, PassiveMode); 3] = [
        ("explicit", PassiveMode::Explicit),
        ("implicit_damping", PassiveMode::ImplicitDamping),
        (
            "implicit_damping_stiffness",
            PassiveMode::ImplicitDampingStiffness,
        ),
    ];
}

#[derive(Clone, Debug, PartialEq)]
pub struct Options {
    pub timestep: f64,
    pub gravity: Vector3<f64>,
    pub integrator: Integrator,
    pub passive: PassiveMode,
    /// Soft contact between geoms (on by default; a model without a pair of
    /// geoms that may touch has none either way). See [`crate::dynamics::contact`].
    pub contact: bool,
    /// Soft joint limits on joints with a `range` (on by default).
    pub limits: bool,
    /// Which law contacts, limits and dry friction follow.
    pub contact_model: ContactModel,
    /// The smooth model's constants.
    pub soft: SoftOptions,
    /// The constraint model's solver.
    pub solver: SolverOptions,
    /// The medium the bodies move in ([`crate::dynamics::fluid`]).
    pub fluid: Fluid,
    /// The magnetic field (world coordinates), which only magnetometers
    /// read (MuJoCo's `magnetic`, default (0, -0.5, 0)).
    pub magnetic: Vector3<f64>,
}

/// MuJoCo's fluid: density (kg/m^3), viscosity (Pa s) and wind (m/s, world
/// frame), all zero by default (no fluid forces).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Fluid {
    pub density: f64,
    pub viscosity: f64,
    pub wind: Vector3<f64>,
}

/// The coefficients of MuJoCo's ellipsoid fluid model on a geom (MJCF
/// `fluidcoef`, in its order; see [`crate::dynamics::fluid`]): a body with
/// such a geom feels the ellipsoid model on each of them, and not the
/// inertia-box model.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FluidCoefs {
    pub blunt_drag: f64,
    pub slender_drag: f64,
    pub angular_drag: f64,
    pub kutta_lift: f64,
    pub magnus_lift: f64,
}

impl Default for FluidCoefs {
    /// MuJoCo's defaults (0.5 0.25 1.5 1 1).
    fn default() -> Self {
        FluidCoefs {
            blunt_drag: 0.5,
            slender_drag: 0.25,
            angular_drag: 1.5,
            kutta_lift: 1.0,
            magnus_lift: 1.0,
        }
    }
}

impl FluidCoefs {
    /// The coefficients in MJCF's `fluidcoef` order, and back.
    pub fn to_array(&self) -> [f64; 5] {
        [
            self.blunt_drag,
            self.slender_drag,
            self.angular_drag,
            self.kutta_lift,
            self.magnus_lift,
        ]
    }

    pub fn from_array(
        [blunt_drag, slender_drag, angular_drag, kutta_lift, magnus_lift]: [f64; 5],
    ) -> Self {
        FluidCoefs {
            blunt_drag,
            slender_drag,
            angular_drag,
            kutta_lift,
            magnus_lift,
        }
    }
}

impl Fluid {
    /// Whether the medium exerts any force (MuJoCo's test: density or viscosity).
    pub fn acts(&self) -> bool {
        self.density != 0.0 || self.viscosity != 0.0
    }
}

impl Default for Options {
    /// MuJoCo's defaults; contacts and limits on, under the smooth model
    /// with [`SoftOptions::default`] (the MJCF loader picks the constraint model).
    fn default() -> Self {
        Options {
            timestep: 0.002,
            gravity: Vector3::new(0.0, 0.0, -9.81),
            integrator: Integrator::Euler,
            passive: PassiveMode::ImplicitDamping,
            contact: true,
            limits: true,
            contact_model: ContactModel::Smooth,
            soft: SoftOptions::default(),
            solver: SolverOptions::default(),
            fluid: Fluid::default(),
            magnetic: Vector3::new(0.0, -0.5, 0.0),
        }
    }
}

/// The constants of the smooth contact and joint-limit forces (see
/// [`crate::dynamics::contact`] for the force laws). The first three are the
/// named parameters `contact/stiffness`, `contact/damping`, `contact/friction`,
/// global to the model; the others are fixed settings.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SoftOptions {
    /// Normal stiffness k (N/m).
    pub stiffness: f64,
    /// Normal damping c (N s/m).
    pub damping: f64,
    /// Dimensionless scale f of the Coulomb friction coefficients: a pair's
    /// coefficient is f times the larger sliding friction of its two geoms
    /// ([`Geom::friction`], MuJoCo's rule); 1 keeps the geoms' own.
    pub friction: f64,
    /// Width w (m) of the softplus activation of penetration depth.
    pub width: f64,
    /// Tangential speed (m/s) below which friction is regularised (viscous-like).
    pub slip: f64,
    /// Joint-limit stiffness (N m/rad or N/m), damping (N m s/rad or N s/m)
    /// and activation width (rad or m).
    pub limit_stiffness: f64,
    pub limit_damping: f64,
    pub limit_width: f64,
}

/// A way to one setting of [`SoftOptions`].
pub type SoftField = fn(&mut SoftOptions) -> &mut f64;

impl SoftOptions {
    /// Each setting's name in files (MJCF `<custom><numeric name="diffosi:..">`)
    /// with a way to it.
    pub const NAMES: [(&'static str, SoftField); 8] = [
        ("contact_stiffness", |s| &mut s.stiffness),
        ("contact_damping", |s| &mut s.damping),
        ("contact_friction", |s| &mut s.friction),
        ("contact_width", |s| &mut s.width),
        ("contact_slip", |s| &mut s.slip),
        ("limit_stiffness", |s| &mut s.limit_stiffness),
        ("limit_damping", |s| &mut s.limit_damping),
        ("limit_width", |s| &mut s.limit_width),
    ];
}

impl Default for SoftOptions {
    /// Chosen for explicit (semi-implicit Euler) stability at the half
    /// cheetah's 0.01 s step: a 1 kg point on a 1e4 N/m spring has period
    /// 0.063 s (h sqrt(k/m) = 1 < 2); damping 100 N s/m is half of critical
    /// for 1 kg and keeps h c / m <= 1 down to 1 kg; a 1 mm width sits well
    /// below a typical 5-10 mm resting depth. Friction scale 1 keeps the
    /// geoms' coefficients (MuJoCo's default geom friction is 1). Explicit friction is stable while h mu N / (slip m) < 2
    /// for the normal load N on a contact and the effective mass m there:
    /// the cheetah's feet (N ~ 100 N on ~1 kg) chatter at slip 0.1 m/s and
    /// stand still at 0.5 m/s, so keep mu / slip <= 2 s/m at that step.
    /// Limits: 1000 N m/rad, 10 N m s/rad, 1 mrad, stable for joint
    /// inertias (armature included) down to about 0.05 kg m^2.
    fn default() -> Self {
        SoftOptions {
            stiffness: 1e4,
            damping: 100.0,
            friction: 1.0,
            width: 1e-3,
            slip: 0.5,
            limit_stiffness: 1000.0,
            limit_damping: 10.0,
            limit_width: 1e-3,
        }
    }
}

/// The description of a model as plain data: what the loaders produce and what
/// an edit changes (MuJoCo's mjSpec plays the same part).
#[derive(Clone, Debug, PartialEq)]
pub struct Spec {
    pub name: String,
    pub bodies: Vec<Body>,
    pub joints: Vec<Joint>,
    pub actuators: Vec<Actuator>,
    pub geoms: Vec<Geom>,
    pub opt: Options,
    /// Explicit contact pairs (MJCF `<contact><pair>`), and pairs of bodies
    /// whose geoms never collide (`<exclude>`, body indices).
    pub pairs: Vec<ContactPair>,
    pub excludes: Vec<[usize; 2]>,
    /// Named states the file ships with (MJCF `<keyframe>`).
    pub keyframes: Vec<Keyframe>,
    /// Which body inertias are accepted ([`check_inertial`]).
    pub inertia_rule: InertiaRule,
    /// Frames on bodies (MJCF `<site>`), and what the model measures
    /// (`<sensor>`); neither changes the dynamics.
    pub sites: Vec<Site>,
    pub sensors: Vec<Sensor>,
    /// The meshes that [`Shape::Mesh`] geoms index.
    pub meshes: Vec<mesh::Mesh>,
    /// The height fields that [`Shape::HField`] geoms index.
    pub hfields: Vec<hfield::HField>,
    /// Equality constraints (MJCF `<equality>`), rows of the constraint model.
    pub equalities: Vec<Equality>,
    /// Tendons (MJCF `<tendon>`): fixed and spatial.
    pub tendons: Vec<Tendon>,
}

/// Which inertia tensors a model accepts, beyond finite, symmetric and
/// positive semi-definite (to rounding, 1e-9 of the largest entry).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum InertiaRule {
    /// Principal moments also satisfy the triangle inequality A + B >= C, as
    /// MuJoCo's compiler demands (MJCF files, models built in code).
    #[default]
    Triangle,
    /// Any positive semi-definite tensor, as PyBullet and Pinocchio take a
    /// URDF's `<inertia>` (URDF files); eigenvalues down to -[`MINVAL`]
    /// count as zero.
    SemiDefinite,
}

/// The unit quaternion (w x y z) of a rotation.
fn quaternion(rot: &Rotation3<f64>) -> [f64; 4] {
    let u = nalgebra::UnitQuaternion::from_rotation_matrix(rot);
    [u.w, u.i, u.j, u.k]
}

/// Checks geom `owner`'s ellipsoid fluid model: finite coefficients, a
/// primitive solid (its semi-axes are MuJoCo's mju_geomSemiAxes) and an
/// explicit integrator (the implicit integrators' qDeriv would need the
/// model's velocity derivative, MuJoCo's mjd_ellipsoidFluid, not written).
fn check_ellipsoid_fluid(
    c: &FluidCoefs,
    shape: &Shape,
    integrator: Integrator,
    owner: &str,
) -> Result<(), ModelError> {
    let coefs = c.to_array();
    if !coefs.iter().all(|x| x.is_finite()) {
        let msg = format!("{owner}: fluidcoef must be finite, got {coefs:?}");
        return Err(ModelError::NotPhysical(msg));
    }
    let unsupported = |what: &str| {
        let msg = format!("{owner}: the ellipsoid fluid model (fluidshape) {what}");
        Err(ModelError::Unsupported(msg))
    };
    if matches!(
        shape,
        Shape::Plane | Shape::Mesh { .. } | Shape::HField { .. }
    ) {
        return unsupported("on a plane, mesh or height field");
    }
    if integrator.is_implicit() {
        return unsupported("under the implicit integrators (implicitfast, implicit)");
    }
    Ok(())
}

/// MuJoCo's mjMINVAL: the size below which it takes a mass or an inertia
/// for zero.
pub const MINVAL: f64 = 1e-15;

/// MuJoCo's default ccd_iterations and ccd_tolerance: the iteration budget
/// and distance tolerance of its convex collider (GJK and EPA), the only
/// ones ours runs ([`constraint::Ccd`]).
pub const CCD_ITERATIONS: usize = 35;
pub const CCD_TOLERANCE: f64 = 1e-6;

impl Spec {
    pub fn nq(&self) -> usize {
        self.joints.iter().map(|j| j.kind.nq()).sum()
    }

    /// The number of activation states: one per actuator with dynamics.
    pub fn na(&self) -> usize {
        self.actuators.iter().filter(|a| a.has_act()).count()
    }

    pub fn nv(&self) -> usize {
        self.joints.iter().map(|j| j.kind.nv()).sum()
    }

    /// What the actuators on joint `joint` add to its damping and armature:
    /// the sums of their damping gear^2 and armature gear^2 in actuator
    /// order (zero without any), as MuJoCo adds them to dof_damping and
    /// dof_armature wherever those act.
    pub fn actuator_passive(&self, joint: usize) -> (f64, f64) {
        let on = self.actuators.iter().filter(|a| a.joint() == Some(joint));
        on.fold((0.0, 0.0), |(d, r), a| {
            let gear2 = a.gear[0] * a.gear[0];
            (d + a.damping * gear2, r + a.armature * gear2)
        })
    }

    /// The mocap bodies in body order (their index here is MuJoCo's
    /// body_mocapid, nmocap their count).
    pub fn mocap_bodies(&self) -> Vec<usize> {
        (0..self.bodies.len())
            .filter(|&b| self.bodies[b].mocap)
            .collect()
    }

    /// The mocap bodies' compiled poses, the step's default mocap input:
    /// positions (3 each) and quaternions (4 each, w x y z), MuJoCo's
    /// body_pos and body_quat of each.
    pub fn mocap_default(&self) -> (Vec<f64>, Vec<f64>) {
        let bodies = self.mocap_bodies().into_iter().map(|b| &self.bodies[b]);
        let pos = bodies.clone().flat_map(|b| b.pos.iter().copied()).collect();
        let quat = bodies.flat_map(|b| quaternion(&b.rot)).collect();
        (pos, quat)
    }

    /// The radius of a sphere about a geom's centre that holds `shape`
    /// (MuJoCo's geom_rbound; [`Shape::rbound`] for primitives, a mesh's
    /// [`mesh::Mesh::rbound`]).
    pub fn rbound(&self, shape: &Shape) -> f64 {
        match *shape {
            Shape::Mesh { mesh } => self.meshes[mesh].rbound(),
            _ => shape.rbound(),
        }
    }

    /// Whether every joint is a hinge or a slide (then nq = nv and joint i
    /// owns `q[i]` and `v[i]`).
    pub fn one_dof_joints(&self) -> bool {
        self.joints.iter().all(|j| j.kind.nv() == 1)
    }

    /// Whether a tendon has a spring or a damper.
    pub fn has_tendon_springs(&self) -> bool {
        self.tendons
            .iter()
            .any(|t| t.stiffness != 0.0 || t.damping != 0.0)
    }

    /// Whether a body with joints above it has gravity compensation.
    pub fn has_gravcomp(&self) -> bool {
        let moves = |b: &Body| {
            let mut k = b;
            while k.joints.is_empty() && k.parent != 0 {
                k = &self.bodies[k.parent];
            }
            !k.joints.is_empty()
        };
        self.bodies
            .iter()
            .skip(1)
            .any(|b| b.gravcomp != 0.0 && moves(b))
    }

    /// Names of q's coordinates and of the dofs (v's entries): a hinge's or
    /// slide's joint name; for a ball or free joint its name with a suffix
    /// (`:qw`, `:qx`, ... for the quaternion, `:x`, `:y`, `:z` for a free
    /// joint's position; `:wx`, ... and `:vx`, ... for the velocities).
    pub fn coordinate_names(&self) -> (Vec<String>, Vec<String>) {
        let (mut q, mut v) = (vec![], vec![]);
        for j in &self.joints {
            let (qs, vs): (&[&str], &[&str]) = match j.kind {
                JointKind::Hinge | JointKind::Slide => (&[""], &[""]),
                JointKind::Ball => (&[":qw", ":qx", ":qy", ":qz"], &[":wx", ":wy", ":wz"]),
                JointKind::Free => (
                    &[":x", ":y", ":z", ":qw", ":qx", ":qy", ":qz"],
                    &[":vx", ":vy", ":vz", ":wx", ":wy", ":wz"],
                ),
            };
            q.extend(qs.iter().map(|s| format!("{}{s}", j.name)));
            v.extend(vs.iter().map(|s| format!("{}{s}", j.name)));
        }
        (q, v)
    }

    /// Joint j's first position coordinate and first dof.
    pub fn joint_address(&self, j: usize) -> (usize, usize) {
        self.joints[..j].iter().fold((0, 0), |(q, v), joint| {
            (q + joint.kind.nq(), v + joint.kind.nv())
        })
    }

    /// The configuration at which every body sits at its modelled pose
    /// (MuJoCo's qpos0).
    pub fn reference_q(&self) -> Vec<f64> {
        let mut q = Vec::with_capacity(self.nq());
        for j in &self.joints {
            let body = &self.bodies[j.body];
            match j.kind {
                JointKind::Hinge | JointKind::Slide => q.push(j.reference),
                JointKind::Ball => q.extend([1.0, 0.0, 0.0, 0.0]),
                JointKind::Free => {
                    q.extend(body.pos.iter());
                    q.extend(quaternion(&body.rot));
                }
            }
        }
        q
    }

    /// Checks the parts for consistency (what MuJoCo's compiler refuses).
    pub fn validate(&self) -> Result<(), ModelError> {
        let bad = |msg: String| Err(ModelError::NotPhysical(msg));
        if self.bodies.is_empty() {
            return bad("a model needs at least the world body".into());
        }
        let o = &self.opt;
        if !(o.timestep.is_finite() && o.timestep > 0.0) {
            return bad(format!("timestep must be positive, got {}", o.timestep));
        }
        if !o.gravity.iter().all(|g| g.is_finite()) {
            return bad(format!("gravity must be finite, got {:?}", o.gravity));
        }
        check_soft(&o.soft)?;
        o.solver.check().map_err(ModelError::NotPhysical)?;
        let f = &o.fluid;
        if !([f.density, f.viscosity]
            .iter()
            .all(|x| x.is_finite() && *x >= 0.0)
            && f.wind.iter().all(|x| x.is_finite()))
        {
            return bad(format!(
                "fluid density and viscosity must be finite and >= 0, wind finite, got {f:?}"
            ));
        }
        let mut next_joint = 0;
        for (i, b) in self.bodies.iter().enumerate().skip(1) {
            if !b.gravcomp.is_finite() {
                return bad(format!("body '{}': gravcomp must be finite", b.name));
            }
            if b.parent >= i {
                return bad(format!("body '{}' must come after its parent", b.name));
            }
            if b.joints.start != next_joint || b.joints.end < b.joints.start {
                return bad(format!("joints of body '{}' are not in body order", b.name));
            }
            next_joint = b.joints.end;
            if b.mocap && (b.parent != 0 || !b.joints.is_empty()) {
                return bad(format!(
                    "mocap body '{}' is not a fixed child of world",
                    b.name
                ));
            }
            if self.bodies[b.parent].mocap {
                let msg = format!("body '{}': bodies inside a mocap body", b.name);
                return Err(ModelError::Unsupported(msg));
            }
            check_inertial(&b.name, b.mass, &b.com, &b.inertia, self.inertia_rule)?;
        }
        if next_joint != self.joints.len() {
            return bad("joint list does not match the bodies' joint ranges".into());
        }
        for (i, j) in self.joints.iter().enumerate() {
            if !self.bodies[j.body].joints.contains(&i) {
                return bad(format!("joint '{}' does not belong to its body", j.name));
            }
            if (j.axis.norm() - 1.0).abs() > 1e-9 {
                return bad(format!("joint '{}' axis is not a unit vector", j.name));
            }
            check_kind(j, &self.bodies[j.body])?;
            check_passive(j)?;
            let owner = format!("joint '{}'", j.name);
            j.limit_sol.check(&owner).map_err(ModelError::NotPhysical)?;
            j.friction_sol
                .check(&owner)
                .map_err(ModelError::NotPhysical)?;
            if !(j.margin.is_finite() && j.margin >= 0.0) {
                return bad(format!("{owner}: margin must be finite and >= 0"));
            }
        }
        for g in &self.geoms {
            let owner = format!("geom '{}'", g.name);
            if let Shape::Mesh { mesh } = g.shape {
                if mesh >= self.meshes.len() {
                    return bad(format!("{owner}: mesh {mesh} does not exist"));
                }
            }
            if let Shape::HField { hfield, size } = g.shape {
                if self.hfields.get(hfield).is_none_or(|h| h.size != size) {
                    return bad(format!(
                        "{owner}: hfield {hfield} does not exist or has another size"
                    ));
                }
            }
            constraint::check_friction(&g.friction, &owner)
                .and_then(|()| g.contact.check(&owner))
                .map_err(ModelError::NotPhysical)?;
            if let Some(c) = &g.fluid {
                check_ellipsoid_fluid(c, &g.shape, o.integrator, &owner)?;
            }
        }
        for p in &self.pairs {
            p.check(self.geoms.len()).map_err(ModelError::NotPhysical)?;
        }
        let nbody = self.bodies.len();
        if self.excludes.iter().flatten().any(|b| *b >= nbody) {
            return bad("an excluded body pair names a body that does not exist".into());
        }

        for s in &self.sites {
            let finite = s
                .pos
                .iter()
                .chain(s.rot.matrix().iter())
                .all(|x| x.is_finite());
            if s.body >= nbody || !finite {
                return bad(format!("site '{}' has a bad body or pose", s.name));
            }
        }
        for s in &self.sensors {
            s.check(self).map_err(ModelError::NotPhysical)?;
        }
        for t in &self.tendons {
            t.check(&self.joints).map_err(ModelError::NotPhysical)?;
            let rows = t.range.is_some() || t.frictionloss > 0.0;
            if rows && o.contact_model == ContactModel::Smooth {
                return Err(ModelError::Unsupported(format!(
                    "tendon '{}': tendon limits and frictionloss need the constraint contact model",
                    t.name
                )));
            }
        }
        for e in &self.equalities {
            e.check(self).map_err(ModelError::NotPhysical)?;
        }
        if !self.equalities.is_empty() && o.contact_model == ContactModel::Smooth {
            return Err(ModelError::Unsupported(
                "equality constraints need the constraint contact model".into(),
            ));
        }

        for a in &self.actuators {
            if let Err(why) = a.check().and_then(|()| self.check_transmission(a)) {
                return bad(format!("actuator '{}': {why}", a.name));
            }
        }
        Ok(())
    }
}

impl Spec {
    /// An actuator's target exists: a hinge or slide joint, or a tendon
    /// without actuator damping or armature (MuJoCo 4 adds those to the
    /// tendon's, not reproduced here) or a site; a finite gear.
    fn check_transmission(&self, a: &Actuator) -> Result<(), String> {
        if !a.gear.iter().all(|g| g.is_finite()) {
            return Err("gear must be finite".into());
        }
        match a.target {
            Transmission::Joint(j) => match self.joints.get(j) {
                None => Err(format!("no joint {j}")),
                Some(joint) if joint.kind.nv() != 1 => Err(format!(
                    "joint '{}' is a ball or free joint; actuators drive hinges and slides",
                    joint.name
                )),
                Some(_) => Ok(()),
            },
            Transmission::Tendon(t) if t >= self.tendons.len() => Err(format!("no tendon {t}")),
            Transmission::Tendon(_) | Transmission::Site { .. }
                if a.damping != 0.0 || a.armature != 0.0 =>
            {
                Err(
                    "damping and armature of an actuator on a tendon or site are not supported"
                        .into(),
                )
            }
            Transmission::Site { site, refsite } => {
                match [Some(site), refsite]
                    .into_iter()
                    .flatten()
                    .find(|&s| s >= self.sites.len())
                {
                    Some(s) => Err(format!("no site {s}")),
                    None => Ok(()),
                }
            }
            Transmission::Tendon(_) => Ok(()),
        }
    }
}

/// Checks that the soft contact and limit constants are finite and
/// non-negative, the widths and the slip speed positive.
pub fn check_soft(s: &SoftOptions) -> Result<(), ModelError> {
    let non_negative = [
        s.stiffness,
        s.damping,
        s.friction,
        s.limit_stiffness,
        s.limit_damping,
    ];
    let positive = [s.width, s.slip, s.limit_width];
    if non_negative.iter().any(|x| !(x.is_finite() && *x >= 0.0))
        || positive.iter().any(|x| !(x.is_finite() && *x > 0.0))
    {
        return Err(ModelError::NotPhysical(format!(
            "contact and limit constants must be finite and >= 0 (widths, slip > 0), got {s:?}"
        )));
    }
    Ok(())
}

/// Checks what a ball or free joint may have: a free joint only on a body of
/// the world and as its only joint; neither with limits or dry friction.
fn check_kind(j: &Joint, body: &Body) -> Result<(), ModelError> {
    let bad = |msg: &str| {
        Err(ModelError::NotPhysical(format!(
            "joint '{}': {msg}",
            j.name
        )))
    };
    match j.kind {
        JointKind::Hinge | JointKind::Slide => Ok(()),
        JointKind::Free if body.parent != 0 || body.joints.len() != 1 => {
            bad("a free joint must be the only joint of a body whose parent is the world")
        }
        _ if j.range.is_some() => bad("ball and free joints cannot be limited (not supported)"),
        _ if j.frictionloss > 0.0 => bad("dry friction on ball and free joints is not supported"),
        _ => Ok(()),
    }
}

/// Checks that a joint's damping, stiffness, armature and frictionloss are
/// finite and non-negative.
pub fn check_passive(j: &Joint) -> Result<(), ModelError> {
    let passive = [j.damping, j.stiffness, j.armature, j.frictionloss];
    if passive.iter().any(|x| !(x.is_finite() && *x >= 0.0)) {
        return Err(ModelError::NotPhysical(format!(
            "joint '{}': damping, stiffness, armature and frictionloss must be finite and >= 0",
            j.name
        )));
    }
    Ok(())
}

/// Checks that a body's inertial properties describe a physical rigid body:
/// finite, mass >= 0, inertia symmetric positive semi-definite, under
/// [`InertiaRule::Triangle`] also satisfying the triangle inequality of its
/// principal moments.
pub fn check_inertial(
    name: &str,
    mass: f64,
    com: &Vector3<f64>,
    inertia: &Matrix3<f64>,
    rule: InertiaRule,
) -> Result<(), ModelError> {
    let bad = |msg: String| Err(ModelError::NotPhysical(format!("body '{name}': {msg}")));
    if !(mass.is_finite() && mass >= 0.0) {
        return bad(format!("mass must be finite and >= 0, got {mass}"));
    }
    if !com.iter().all(|c| c.is_finite()) || !inertia.iter().all(|c| c.is_finite()) {
        return bad("COM and inertia must be finite".into());
    }
    let scale = inertia.abs().max().max(f64::MIN_POSITIVE);
    if (inertia - inertia.transpose()).abs().max() > 1e-9 * scale {
        return bad("inertia tensor is not symmetric".into());
    }
    let mut eig: Vec<f64> = inertia.symmetric_eigenvalues().iter().copied().collect();
    eig.sort_by(f64::total_cmp);
    let tol = 1e-9 * scale;
    let floor = match rule {
        InertiaRule::Triangle => tol,
        InertiaRule::SemiDefinite => tol.max(MINVAL),
    };
    if eig[0] < -floor {
        return bad(format!(
            "inertia tensor is not positive semi-definite (eigenvalues {eig:?})"
        ));
    }
    if rule == InertiaRule::Triangle && eig[0] + eig[1] < eig[2] - tol {
        return bad(format!(
            "principal moments {eig:?} violate the triangle inequality"
        ));
    }
    Ok(())
}
