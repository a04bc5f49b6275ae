//! Sensors: what a model measures, as MuJoCo 4 defines it (MJCF
//! `<sensor>`). A sensor never changes the dynamics.
//!
//! The readings of all sensors form one vector (MuJoCo's sensordata): the
//! sensors in document order, each taking [`Sensor::dim`] consecutive
//! entries. They are taken at the state as MuJoCo's mj_forward leaves it:
//! positions and velocities as given, accelerations and forces those of the
//! forward dynamics (the constraint solver's, with passive forces explicit).
//! Conventions are MuJoCo's:
//! - a frame sensor reads an object's frame ([`FrameObject`]) in world
//!   coordinates, or relative to a reference object's frame (position and
//!   axes in its coordinates, the quaternion conj(q_ref) q_obj, velocities
//!   relative to its motion);
//! - accelerometer, velocimeter and gyro read the site's linear
//!   acceleration, velocity and angular velocity in the site's axes; the
//!   accelerometer includes gravity as an upward acceleration (at rest it
//!   reads -g, also on a site welded to the world, where velocimeter and
//!   gyro read zero);
//! - magnetometer reads the model's magnetic field ([`crate::model::Options::magnetic`],
//!   world coordinates) in the site's axes;
//! - actuatorpos and actuatorvel read an actuator's length and velocity
//!   (for a joint transmission: gear times the joint's coordinate and
//!   velocity), actuatorfrc its scalar force (MuJoCo's actuator_force), and
//!   jointactuatorfrc the generalized force all actuators exert on a hinge
//!   or slide (MuJoCo's qfrc_actuator), tendonactuatorfrc the sum of the
//!   scalar forces of the actuators on a tendon; all at the inputs' ctrl
//!   and the state's act (zero when empty);
//! - force and torque read the force and moment (about the site) that the
//!   site's body receives from its parent, in the site's axes: everything
//!   that moves the body's subtree (inertia and gravity) less the contact
//!   forces acting on it (MuJoCo's cfrc_int);
//! - tendonpos and tendonvel read a tendon's length and its rate; the
//!   tendon limit sensors read its first active limit row as the joint
//!   limit sensors do;
//! - subtreeangmom reads the angular momentum of a body's subtree about
//!   its centre of mass (world coordinates);
//! - e_potential reads the potential energy (gravity, -sum m g . com, and
//!   the joint and tendon springs), e_kinetic 1/2 v' M v (armature
//!   included);
//! - touch sums the normal forces of the contacts on the site's body whose
//!   ray from the contact point along the normal (pointing into the body)
//!   hits the site's volume ([`SensorKind::Touch`]);
//! - rangefinder casts a ray from the site along its z axis and reads the
//!   nearest geom it hits ([`SensorKind::Rangefinder`]); -1 for no hit;
//! - insidesite reads 1 when an object's frame origin lies strictly inside
//!   the site's volume, else 0 ([`SensorKind::InsideSite`]);
//! - `cutoff` > 0 clips each real-valued reading to [-cutoff, cutoff]
//!   (quaternions and axes are not clipped; touch, positive, only above);
//!   `noise` is never applied (mj_forward does not).

use super::{JointKind, Shape, Spec};

/// A frame a frame sensor can read (MJCF objtype and reftype).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FrameObject {
    /// A body's inertial frame: origin at its COM, axes its
    /// `inertia_frame` (MJCF "body").
    Body(usize),
    /// A body's own frame (MJCF "xbody").
    XBody(usize),
    Geom(usize),
    Site(usize),
}

/// What a frame sensor reads of its object.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FrameQuantity {
    /// The origin (3).
    Pos,
    /// The orientation as a quaternion (w, x, y, z) (4).
    Quat,
    /// One axis (0: x, 1: y, 2: z) (3).
    Axis(usize),
    /// The origin's linear velocity, the angular velocity (3 each).
    LinVel,
    AngVel,
    /// The origin's linear acceleration (gravity included, as the
    /// accelerometer's), the angular acceleration; world axes (3 each).
    LinAcc,
    AngAcc,
}

/// What a joint sensor reads.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum JointQuantity {
    /// A hinge's or slide's position, velocity (1 each).
    Pos,
    Vel,
    /// A ball's normalised quaternion (4), its angular velocity (3).
    BallQuat,
    BallAngVel,
    /// A limited hinge's or slide's first active limit row (lower side
    /// first; 0 without one), under the constraint model: its distance less
    /// the margin, its velocity J v and its force (1 each).
    LimitPos,
    LimitVel,
    LimitForce,
}

/// What a sensor on a site reads (3 each).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SiteQuantity {
    Accelerometer,
    Velocimeter,
    Gyro,
    Magnetometer,
    Force,
    Torque,
}

/// What a tendon sensor reads (1 each): its length and rate, and its
/// first active limit row under the constraint model (the lower side
/// first; 0 without one): distance less the margin, velocity J v, force.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TendonQuantity {
    Pos,
    Vel,
    LimitPos,
    LimitVel,
    LimitForce,
}

/// A field of a rangefinder's readings, in MuJoCo's order (MJCF `data`):
/// the distance along the ray (-1: no hit), the ray's direction and
/// origin, the point hit, the surface normal there, the depth (the
/// distance for a site's ray); all world coordinates, zeros without a hit
/// (but the origin, and depth -1).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RayField {
    Dist,
    Dir,
    Origin,
    Point,
    Normal,
    Depth,
}

impl RayField {
    /// Its number of entries.
    pub fn dim(self) -> usize {
        match self {
            RayField::Dist | RayField::Depth => 1,
            _ => 3,
        }
    }
}

/// What an actuator sensor reads (1 each).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ActuatorQuantity {
    Pos,
    Vel,
    Force,
}

#[derive(Clone, Debug, PartialEq)]
pub enum SensorKind {
    Joint(JointQuantity, usize),
    Frame {
        quantity: FrameQuantity,
        object: FrameObject,
        reference: Option<FrameObject>,
    },
    Site(SiteQuantity, usize),
    Actuator(ActuatorQuantity, usize),
    /// The actuators' generalized force on a hinge or slide (1).
    JointActuatorForce(usize),
    /// The summed scalar forces of the actuators on a tendon (1).
    TendonActuatorForce(usize),
    /// Whether `object`'s origin is inside `zone`, the site's volume (its
    /// MJCF type and size, in the site's frame): 1 or 0 (1). A body's
    /// origin (MJCF "body": its centre of mass) is its subtree's centre of
    /// mass when the body is massless but its subtree is not, as MuJoCo's.
    InsideSite {
        site: usize,
        zone: Shape,
        object: FrameObject,
    },
    /// The centre of mass of a body's subtree (3), and its linear velocity
    /// (total momentum over total mass, 3).
    SubtreeCom(usize),
    SubtreeLinVel(usize),
    /// The angular momentum of a body's subtree about its centre of mass (3).
    SubtreeAngMom(usize),
    Tendon(TendonQuantity, usize),
    /// The potential (true) or kinetic energy (1).
    Energy {
        potential: bool,
    },
    /// The normal forces on the site's body from the contacts whose ray
    /// hits `zone`: the site's volume (its MJCF type and size, in the
    /// site's frame) (1).
    Touch {
        site: usize,
        zone: Shape,
    },
    /// A ray from the site's origin along its z axis against `targets`:
    /// the geoms it may hit (MuJoCo's mj_ray: not on the site's body, not
    /// invisible by rgba alpha 0), each with the half-extents of a plane's
    /// rendered rectangle (0: unbounded; unused by other shapes). Reads
    /// `fields` in order.
    Rangefinder {
        site: usize,
        fields: Vec<RayField>,
        targets: Vec<(usize, [f64; 2])>,
    },
    /// A sensor that is read and laid out but not computed: its MJCF
    /// element and why.
    Unsupported {
        element: String,
        why: String,
    },
}

#[derive(Clone, Debug, PartialEq)]
pub struct Sensor {
    pub name: String,
    pub kind: SensorKind,
    /// Its number of entries in the readings.
    pub dim: usize,
    /// 0: no clipping (see the module documentation).
    pub cutoff: f64,
}

impl SensorKind {
    /// The number of readings of a computed kind (None: unsupported, whose
    /// reader knows its size).
    pub fn dim(&self) -> Option<usize> {
        Some(match self {
            SensorKind::Joint(
                JointQuantity::Pos
                | JointQuantity::Vel
                | JointQuantity::LimitPos
                | JointQuantity::LimitVel
                | JointQuantity::LimitForce,
                _,
            )
            | SensorKind::Actuator(..)
            | SensorKind::Tendon(..)
            | SensorKind::Energy { .. }
            | SensorKind::Touch { .. }
            | SensorKind::JointActuatorForce(_)
            | SensorKind::TendonActuatorForce(_)
            | SensorKind::InsideSite { .. } => 1,
            SensorKind::Rangefinder { fields, .. } => fields.iter().map(|f| f.dim()).sum(),
            SensorKind::Joint(JointQuantity::BallQuat, _) => 4,
            SensorKind::Frame {
                quantity: FrameQuantity::Quat,
                ..
            } => 4,
            SensorKind::Unsupported { .. } => return None,
            _ => 3,
        })
    }

    /// A reading `x` clipped by `cutoff` > 0 as MuJoCo clips it: real
    /// values to [-cutoff, cutoff], positive ones (touch, kinetic energy)
    /// from above; quaternions and axes are not clipped.
    pub fn clip(&self, x: f64, cutoff: f64) -> f64 {
        match self {
            SensorKind::Joint(JointQuantity::BallQuat, _)
            | SensorKind::Frame {
                quantity: FrameQuantity::Quat | FrameQuantity::Axis(_),
                ..
            } => x,
            SensorKind::Touch { .. } | SensorKind::Energy { potential: false } => x.min(cutoff),
            _ => x.clamp(-cutoff, cutoff),
        }
    }
}

impl Sensor {
    /// Checks that the sensor refers to objects of `spec` of the right kind
    /// and that its size and cutoff are consistent.
    pub fn check(&self, spec: &Spec) -> Result<(), String> {
        let bad = |what: &str| Err(format!("sensor '{}': {what}", self.name));
        if !(self.cutoff.is_finite() && self.cutoff >= 0.0) {
            return bad("cutoff must be finite and >= 0");
        }
        if self.kind.dim().is_some_and(|d| d != self.dim) {
            return bad("its dimension does not match its kind");
        }
        let frame_ok = |f: &FrameObject| match *f {
            FrameObject::Body(b) | FrameObject::XBody(b) => b < spec.bodies.len(),
            FrameObject::Geom(g) => g < spec.geoms.len(),
            FrameObject::Site(s) => s < spec.sites.len(),
        };
        let ok = match &self.kind {
            SensorKind::Joint(quantity, j) => spec.joints.get(*j).is_some_and(|j| {
                let ball = j.kind == JointKind::Ball;
                let one_dof = j.kind.nv() == 1;
                match quantity {
                    JointQuantity::Pos | JointQuantity::Vel => one_dof,
                    JointQuantity::BallQuat | JointQuantity::BallAngVel => ball,
                    _ => one_dof && j.range.is_some(),
                }
            }),
            SensorKind::Frame {
                object, reference, ..
            } => frame_ok(object) && reference.as_ref().is_none_or(frame_ok),
            SensorKind::Site(_, s) => *s < spec.sites.len(),
            SensorKind::Actuator(_, a) => *a < spec.actuators.len(),
            SensorKind::JointActuatorForce(j) => {
                spec.joints.get(*j).is_some_and(|j| j.kind.nv() == 1)
            }
            SensorKind::SubtreeCom(b)
            | SensorKind::SubtreeLinVel(b)
            | SensorKind::SubtreeAngMom(b) => *b < spec.bodies.len(),
            SensorKind::Tendon(quantity, t) => spec.tendons.get(*t).is_some_and(|t| {
                matches!(quantity, TendonQuantity::Pos | TendonQuantity::Vel) || t.range.is_some()
            }),
            SensorKind::Energy { .. } => true,
            SensorKind::Touch { site, .. } => *site < spec.sites.len(),
            SensorKind::TendonActuatorForce(t) => *t < spec.tendons.len(),
            SensorKind::InsideSite { site, object, .. } => {
                *site < spec.sites.len() && frame_ok(object)
            }
            SensorKind::Rangefinder { site, targets, .. } => {
                *site < spec.sites.len() && targets.iter().all(|(g, _)| *g < spec.geoms.len())
            }
            SensorKind::Unsupported { .. } => true,
        };
        if !ok {
            return bad("it refers to an object that does not exist or has the wrong kind");
        }
        Ok(())
    }
}
