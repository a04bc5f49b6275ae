//! Sensor readings on f64 states (MuJoCo's sensordata after mj_forward);
//! what each sensor reads is stated in [`crate::model::sensor`].
//!
//! The motion of every body comes from the forward dynamics at (q, v, tau):
//! the acceleration MuJoCo's mj_forward computes (passive forces explicit;
//! under the constraint model the solver's, which an implicit Euler step
//! only changes afterwards), gravity entering as an upward acceleration of
//! the world (MuJoCo's cacc). A body's interaction force with its parent
//! (MuJoCo's cfrc_int, from mj_rnePostConstraint) sums, over its subtree,
//! I a + v x* I v less the contact forces on each body. Under the smooth
//! contact model, which has no MuJoCo twin, those are the smooth model's
//! contact forces (the ones [`Model::contacts`] lists), so force and torque
//! sensors read what the penalty forces transmit.

use nalgebra::{DVector, Matrix3, Quaternion, UnitQuaternion, Vector3};

use super::ray::{ray_mesh, ray_shape};
use super::Model;
use crate::dynamics::actuation::transmissions;
use crate::dynamics::constraint::{contact_forces, ConstraintKind, Origin};
use crate::dynamics::{
    acceleration, check_actuation, check_colliders, crba, rnea_with_transforms, world_frames,
    Constrained, Contact, Data, StepError, TendonState,
};
use crate::model::MINVAL;
use crate::model::{
    ActuatorQuantity, ContactModel, FrameObject, FrameQuantity, Inputs, JointKind, JointQuantity,
    PassiveMode, RayField, Sensor, SensorKind, Shape, SiteQuantity, State, TendonQuantity,
    Transmission,
};
use crate::spatial::{Force, Inertia, Motion, Transform};

impl Model {
    /// Each sensor's first entry in the readings and its number of entries
    /// (MuJoCo's sensor_adr and sensor_dim).
    pub fn sensor_layout(&self) -> Vec<(usize, usize)> {
        let mut at = 0;
        self.sensors
            .iter()
            .map(|s| {
                at += s.dim;
                (at - s.dim, s.dim)
            })
            .collect()
    }

    /// The readings of every sensor (MuJoCo's sensordata, laid out by
    /// [`Model::sensor_layout`]) at x = (q, v, act) under u: generalized
    /// forces u.tau (MuJoCo's qfrc_applied), the actuators' forces at
    /// u.ctrl and x.act (empty: zero), the mocap bodies at u's poses (empty:
    /// the compiled ones), as mj_forward reads them. Fails on a sensor that
    /// is read but not computed, naming it.
    pub fn sensor_readings(
        &self,
        data: &mut Data<f64>,
        x: &State,
        u: &Inputs,
    ) -> Result<Vec<f64>, StepError> {
        let unsupported = self.sensors.iter().find_map(|s| match &s.kind {
            SensorKind::Unsupported { element, why } => Some((s, element, why)),
            _ => None,
        });
        if let Some((s, element, why)) = unsupported {
            return Err(StepError::SensorNotComputed {
                name: s.name.clone(),
                element: element.clone(),
                why: why.clone(),
            });
        }
        let limit = |s: &&Sensor| {
            matches!(
                s.kind,
                SensorKind::Joint(
                    JointQuantity::LimitPos | JointQuantity::LimitVel | JointQuantity::LimitForce,
                    _
                ) | SensorKind::Tendon(
                    TendonQuantity::LimitPos
                        | TendonQuantity::LimitVel
                        | TendonQuantity::LimitForce,
                    _
                )
            )
        };
        let smooth = self.opt.contact_model == ContactModel::Smooth;
        if let Some(s) = self.sensors.iter().find(limit).filter(|_| smooth) {
            return Err(StepError::SensorNotComputed {
                name: s.name.clone(),
                element: "jointlimit*, tendonlimit*".into(),
                why: "the smooth contact model has no limit rows (MuJoCo's efc)".into(),
            });
        }
        let tree = self.tree();
        check_actuation(tree, (&u.ctrl, &x.act))?;
        self.place(data, x, u)?;
        let (q, v, tau) = (&x.q[..], &x.v[..], &u.tau[..]);
        check_colliders(tree, data, (q, v))?;
        transmissions(tree, data, (q, v));
        let transmission = data.actuator.clone();
        let actuator_force = self.scalar_actuator_forces(&transmission, x, u);
        let mut applied = tau.to_vec();
        for (s, f) in transmission.iter().zip(&actuator_force) {
            s.add_dense(*f, &mut applied);
        }
        let mut qdd = vec![0.0; self.nv()];
        let mode = (PassiveMode::Explicit, self.opt.timestep);
        acceleration(tree, data, mode, (q, v, &applied), &mut qdd);
        let contacts = match self.opt.contact_model {
            ContactModel::Smooth => data.contacts.clone(),
            ContactModel::Constraint => data.constrained.as_ref().map_or(vec![], |c| {
                contact_forces(&c.contacts, &c.rows, &c.solution.force)
            }),
        };
        world_frames(tree, data, v);
        let mut unused = vec![0.0; self.nv()];
        rnea_with_transforms(tree, data, v, &qdd, &mut unused);
        let bodies = Bodies::new(self, data, q, &contacts);
        let kinetic = self.kinetic_energy(data, q, v);
        let mut out = Vec::with_capacity(self.sensors.iter().map(|s| s.dim).sum());
        for s in &self.sensors {
            let start = out.len();
            let inputs = Readings {
                bodies: &bodies,
                constrained: data.constrained.as_ref(),
                actuator_force: &actuator_force,
                transmission: &transmission,
                contacts: &contacts,
                kinetic,
            };
            self.read(&inputs, (q, v), &s.kind, &mut out);
            if s.cutoff > 0.0 {
                for x in &mut out[start..] {
                    *x = s.kind.clip(*x, s.cutoff);
                }
            }
        }
        Ok(out)
    }

    /// Each actuator's scalar force (MuJoCo's actuator_force) at x under
    /// u's controls (an empty ctrl or act is zero).
    fn scalar_actuator_forces(
        &self,
        transmission: &[TendonState<f64>],
        x: &State,
        u: &Inputs,
    ) -> Vec<f64> {
        let h = self.opt.timestep;
        let entry = |xs: &[f64], i: Option<usize>| i.and_then(|i| xs.get(i)).map_or(0.0, |&y| y);
        let tree = self.tree();
        tree.actuators
            .iter()
            .zip(transmission)
            .enumerate()
            .map(|(i, (a, s))| {
                let at = (s.length, s.velocity);
                a.scalar_force(h, at, (entry(&u.ctrl, Some(i)), entry(&x.act, a.act)))
            })
            .collect()
    }

    /// 1/2 v' M v (M with armature) when a sensor reads it, else 0.
    fn kinetic_energy(&self, data: &mut Data<f64>, q: &[f64], v: &[f64]) -> f64 {
        let kinetic = SensorKind::Energy { potential: false };
        if !self.sensors.iter().any(|s| s.kind == kinetic) {
            return 0.0;
        }
        crba(self.tree(), data, q);
        let v = DVector::from_column_slice(v);
        0.5 * v.dot(&(&data.mass_matrix * &v))
    }

    /// The potential energy at the state `b` holds: gravity's, the hinge
    /// and slide springs' and the tendon springs'.
    fn potential_energy(&self, b: &Bodies, q: &[f64]) -> f64 {
        let gravity: f64 = (self.bodies.iter().enumerate().skip(1))
            .map(|(i, body)| -body.mass * self.opt.gravity.dot(&b.com(self, i)))
            .sum();
        let joints: f64 = (self.joints.iter().enumerate())
            .filter(|(_, j)| j.stiffness != 0.0 && j.kind.nv() == 1)
            .map(|(i, j)| {
                let stretch = q[self.joint_address(i).0] - j.springref;
                0.5 * j.stiffness * stretch * stretch
            })
            .sum();
        let tendons: f64 = (self.tree().tendons.iter().zip(&b.tendon))
            .filter(|(t, _)| t.stiffness != 0.0)
            .map(|(t, &(l, _))| {
                let [lo, hi] = t.lengthspring;
                let stretch = if l > hi {
                    l - hi
                } else if l < lo {
                    l - lo
                } else {
                    0.0
                };
                0.5 * t.stiffness * stretch * stretch
            })
            .sum();
        gravity + joints + tendons
    }

    /// A tendon sensor's reading (see [`TendonQuantity`]).
    fn read_tendon(
        &self,
        (b, constrained): (&Bodies, Option<&Constrained<f64>>),
        quantity: TendonQuantity,
        t: usize,
    ) -> f64 {
        let (l, rate) = b.tendon[t];
        let origin = Origin {
            kind: ConstraintKind::TendonLimit,
            id: t,
        };
        let row = constrained.and_then(|c| {
            let r = c.rows.origin.iter().position(|o| *o == origin)?;
            Some(c.solution.force[r])
        });
        let spec = &self.tendons[t];
        let [lo, hi] = spec.range.unwrap_or_default();
        // The first row is the lower side's when that side is active.
        let lower = l - lo < spec.margin;
        match (quantity, row) {
            (TendonQuantity::Pos, _) => l,
            (TendonQuantity::Vel, _) => rate,
            (_, None) => 0.0,
            (TendonQuantity::LimitPos, _) if lower => l - lo - spec.margin,
            (TendonQuantity::LimitPos, _) => hi - l - spec.margin,
            (TendonQuantity::LimitVel, _) if lower => rate,
            (TendonQuantity::LimitVel, _) => -rate,
            (TendonQuantity::LimitForce, Some(f)) => f,
        }
    }

    /// The normal forces on the site's body of the contacts whose ray,
    /// from the contact point along the normal into that body, hits the
    /// site's `zone` (MuJoCo's touch sensor).
    fn touch(&self, b: &Bodies, contacts: &[Contact<f64>], site: usize, zone: &Shape) -> f64 {
        let frame = self.frame(b, FrameObject::Site(site));
        let on_body = contacts.iter().filter(|c| c.bodies.contains(&frame.body));
        let pressing = on_body.filter(|c| c.normal_force > 0.0);
        pressing
            .filter(|c| {
                let into = if c.bodies[1] == frame.body {
                    -c.normal
                } else {
                    c.normal
                };
                let placed = (&frame.pos, &frame.rot);
                ray_shape(zone, [0.0; 2], placed, (&c.pos, &into)).is_some()
            })
            .map(|c| c.normal_force)
            .sum()
    }

    /// Whether `object`'s origin lies strictly inside the site's `zone`
    /// (MuJoCo's mju_insideGeom; see [`SensorKind::InsideSite`]).
    fn inside_site(&self, b: &Bodies, site: usize, zone: &Shape, object: FrameObject) -> bool {
        let point = match object {
            // A massless subtree's centre is the body's own.
            FrameObject::Body(i) if self.bodies[i].mass < MINVAL && i > 0 => b.subtree(self, i).0,
            _ => self.frame(b, object).pos,
        };
        let frame = self.frame(b, FrameObject::Site(site));
        let p = frame.rot.tr_mul(&(point - frame.pos));
        let within = |x: f64, half: f64| x.abs() < half;
        match *zone {
            Shape::Sphere { radius } => p.norm_squared() < radius * radius,
            Shape::Capsule {
                radius,
                half_length,
            } => {
                let z = p.z - p.z.clamp(-half_length, half_length);
                p.x * p.x + p.y * p.y + z * z < radius * radius
            }
            Shape::Ellipsoid { radii } => p.component_div(&radii).norm_squared() < 1.0,
            Shape::Cylinder {
                radius,
                half_length,
            } => within(p.z, half_length) && p.x * p.x + p.y * p.y < radius * radius,
            Shape::Box { half } => (0..3).all(|k| within(p[k], half[k])),
            _ => false,
        }
    }

    /// A rangefinder's readings (see [`RayField`]): the ray from the site
    /// along its z axis against the nearest of `targets`.
    fn rangefinder(
        &self,
        b: &Bodies,
        site: usize,
        fields: &[RayField],
        targets: &[(usize, [f64; 2])],
        out: &mut Vec<f64>,
    ) {
        let frame = self.frame(b, FrameObject::Site(site));
        let (origin, dir) = (frame.pos, frame.rot.column(2).into_owned());
        let mut nearest: Option<(f64, Vector3<f64>)> = None;
        for &(g, plane) in targets {
            let geom = self.frame(b, FrameObject::Geom(g));
            let placed = (&geom.pos, &geom.rot);
            let hit = match self.geoms[g].shape {
                Shape::Mesh { mesh } => ray_mesh(&self.meshes[mesh], placed, (&origin, &dir)),
                ref shape => ray_shape(shape, plane, placed, (&origin, &dir)),
            };
            if let Some((x, normal)) = hit.filter(|h| nearest.is_none_or(|n| h.0 < n.0)) {
                nearest = Some((x, normal));
            }
        }
        for field in fields {
            let zero = Vector3::zeros();
            match (field, nearest) {
                (RayField::Dist | RayField::Depth, None) => out.push(-1.0),
                (RayField::Dist | RayField::Depth, Some((x, _))) => out.push(x),
                (RayField::Origin, _) => out.extend(origin.iter()),
                (_, None) => out.extend(zero.iter()),
                (RayField::Dir, Some(_)) => out.extend(dir.iter()),
                (RayField::Point, Some((x, _))) => out.extend((origin + dir * x).iter()),
                (RayField::Normal, Some((_, n))) => out.extend(n.iter()),
            }
        }
    }

    /// Appends one sensor's readings.
    fn read(
        &self,
        inputs: &Readings,
        (q, v): (&[f64], &[f64]),
        kind: &SensorKind,
        out: &mut Vec<f64>,
    ) {
        let (b, constrained) = (inputs.bodies, inputs.constrained);
        match kind {
            SensorKind::Joint(quantity, j) => {
                let (qa, va) = self.joint_address(*j);
                let joint = &self.joints[*j];
                // The first limit row of the joint's dof: its row and the
                // sign of its J (+1 below the range, -1 above).
                let row = constrained.and_then(|c| {
                    let origin = Origin {
                        kind: ConstraintKind::JointLimit,
                        id: va,
                    };
                    let r = c.rows.origin.iter().position(|o| *o == origin)?;
                    Some((r, c.rows.j[r * self.nv() + va], c.solution.force[r]))
                });
                let (lo, hi) = joint.range.unwrap_or_default();
                match quantity {
                    JointQuantity::Pos => out.push(q[qa]),
                    JointQuantity::Vel => out.push(v[va]),
                    JointQuantity::BallQuat => {
                        let u = normalized(&q[qa..qa + 4]);
                        out.extend([u.w, u.i, u.j, u.k]);
                    }
                    JointQuantity::BallAngVel => out.extend_from_slice(&v[va..va + 3]),
                    JointQuantity::LimitPos => out.push(row.map_or(0.0, |(_, sign, _)| {
                        let dist = if sign > 0.0 { q[qa] - lo } else { hi - q[qa] };
                        dist - joint.margin
                    })),
                    JointQuantity::LimitVel => out.push(row.map_or(0.0, |(_, s, _)| s * v[va])),
                    JointQuantity::LimitForce => out.push(row.map_or(0.0, |(.., f)| f)),
                }
            }
            SensorKind::Frame {
                quantity,
                object,
                reference,
            } => self.read_frame(b, *quantity, *object, *reference, out),
            SensorKind::Site(quantity, s) => {
                let frame = self.frame(b, FrameObject::Site(*s));
                let body = frame.body;
                let world = match quantity {
                    SiteQuantity::Accelerometer => b.acceleration(body, &frame.pos).lin,
                    SiteQuantity::Velocimeter => b.velocity(body, &frame.pos).lin,
                    SiteQuantity::Gyro => b.velocity(body, &frame.pos).ang,
                    SiteQuantity::Magnetometer => self.opt.magnetic,
                    SiteQuantity::Force => b.interaction[body].lin,
                    SiteQuantity::Torque => {
                        let f = &b.interaction[body];
                        f.ang - frame.pos.cross(&f.lin)
                    }
                };
                out.extend(frame.rot.tr_mul(&world).iter());
            }
            SensorKind::Actuator(quantity, i) => {
                let s = &inputs.transmission[*i];
                let (l, ld) = (s.length, s.velocity);
                out.push(match quantity {
                    ActuatorQuantity::Pos => l,
                    ActuatorQuantity::Vel => ld,
                    ActuatorQuantity::Force => inputs.actuator_force[*i],
                });
            }
            SensorKind::JointActuatorForce(j) => {
                let dof = self.joint_address(*j).1;
                let mut on_dof = vec![0.0; self.nv()];
                for (s, f) in inputs.transmission.iter().zip(inputs.actuator_force) {
                    s.add_dense(*f, &mut on_dof);
                }
                out.push(on_dof[dof]);
            }
            SensorKind::TendonActuatorForce(t) => {
                let on_tendon = (self.actuators.iter().zip(inputs.actuator_force))
                    .filter(|(a, _)| a.target == Transmission::Tendon(*t))
                    .map(|(_, f)| f)
                    .sum();
                out.push(on_tendon);
            }
            SensorKind::InsideSite { site, zone, object } => {
                let inside = self.inside_site(b, *site, zone, *object);
                out.push(if inside { 1.0 } else { 0.0 });
            }
            SensorKind::SubtreeCom(body) => out.extend(b.subtree(self, *body).0.iter()),
            SensorKind::SubtreeLinVel(body) => out.extend(b.subtree(self, *body).1.iter()),
            SensorKind::SubtreeAngMom(body) => out.extend(b.angular_momentum(self, *body).iter()),
            SensorKind::Tendon(quantity, t) => {
                out.push(self.read_tendon((b, constrained), *quantity, *t))
            }
            SensorKind::Energy { potential: true } => out.push(self.potential_energy(b, q)),
            SensorKind::Energy { potential: false } => out.push(inputs.kinetic),
            SensorKind::Touch { site, zone } => {
                out.push(self.touch(b, inputs.contacts, *site, zone))
            }
            SensorKind::Rangefinder {
                site,
                fields,
                targets,
            } => self.rangefinder(b, *site, fields, targets, out),
            SensorKind::Unsupported { .. } => unreachable!("refused before evaluating"),
        }
    }

    /// A frame sensor's readings (see [`FrameQuantity`]).
    fn read_frame(
        &self,
        b: &Bodies,
        quantity: FrameQuantity,
        object: FrameObject,
        reference: Option<FrameObject>,
        out: &mut Vec<f64>,
    ) {
        let obj = self.frame(b, object);
        let reference = reference.map(|r| self.frame(b, r));
        let in_reference = |x: Vector3<f64>| match &reference {
            Some(r) => r.rot.tr_mul(&x),
            None => x,
        };
        let vector = match quantity {
            FrameQuantity::Pos => {
                in_reference(obj.pos - reference.as_ref().map_or(Vector3::zeros(), |r| r.pos))
            }
            FrameQuantity::Axis(k) => in_reference(obj.rot.column(k).into_owned()),
            FrameQuantity::Quat => {
                let q = match &reference {
                    Some(r) => r.quat.conjugate() * obj.quat,
                    None => obj.quat,
                };
                out.extend([q.w, q.i, q.j, q.k]);
                return;
            }
            FrameQuantity::LinVel | FrameQuantity::AngVel => {
                let mut m = b.velocity(obj.body, &obj.pos);
                if let Some(r) = &reference {
                    let mr = b.velocity(r.body, &r.pos);
                    let lin = m.lin - mr.lin + (obj.pos - r.pos).cross(&mr.ang);
                    m = Motion::new(r.rot.tr_mul(&(m.ang - mr.ang)), r.rot.tr_mul(&lin));
                }
                if quantity == FrameQuantity::LinVel {
                    m.lin
                } else {
                    m.ang
                }
            }
            FrameQuantity::LinAcc => b.acceleration(obj.body, &obj.pos).lin,
            FrameQuantity::AngAcc => b.acceleration(obj.body, &obj.pos).ang,
        };
        out.extend(vector.iter());
    }

    /// Where an object's frame is at the state `b` holds.
    fn frame(&self, b: &Bodies, object: FrameObject) -> Placed {
        let (body, pos, rot) = match object {
            FrameObject::XBody(i) => (i, Vector3::zeros(), Matrix3::identity()),
            FrameObject::Body(i) => {
                let body = &self.bodies[i];
                (i, body.com, *body.inertia_frame.matrix())
            }
            FrameObject::Geom(g) => {
                let geom = &self.geoms[g];
                (geom.body, geom.pos, *geom.rot.matrix())
            }
            FrameObject::Site(s) => {
                let site = &self.sites[s];
                (site.body, site.pos, *site.rot.matrix())
            }
        };
        let axes = b.pose[body].axes();
        Placed {
            body,
            pos: b.pose[body].trans + axes * pos,
            rot: axes * rot,
            quat: b.quat[body] * local_quaternion(&rot),
        }
    }
}

/// What the readings are taken from besides the state: the bodies' motion,
/// the constraint model's rows and forces (none without rows), the
/// actuators' scalar forces, the contacts with their forces and the
/// kinetic energy (0 when no sensor reads it).
struct Readings<'a> {
    bodies: &'a Bodies,
    constrained: Option<&'a Constrained<f64>>,
    actuator_force: &'a [f64],
    /// The actuators' transmissions ([`transmissions`]).
    transmission: &'a [TendonState<f64>],
    contacts: &'a [Contact<f64>],
    kinetic: f64,
}

/// An object's frame in world coordinates: its body, origin, axes (columns)
/// and orientation as MuJoCo's quaternion.
struct Placed {
    body: usize,
    pos: Vector3<f64>,
    rot: Matrix3<f64>,
    quat: UnitQuaternion<f64>,
}

/// The bodies' motion at one state (see the module documentation).
struct Bodies {
    /// From world to body coordinates.
    pose: Vec<Transform<f64>>,
    /// The orientation as MuJoCo's xquat: the parent's times the body's
    /// own quaternion times each joint's (a free joint's alone), so that
    /// its sign is MuJoCo's.
    quat: Vec<UnitQuaternion<f64>>,
    /// Velocity and acceleration in world coordinates about the world
    /// origin (a body welded to the world has the world's: at rest,
    /// accelerating upward by -gravity, as in MuJoCo 4.0.0).
    vel: Vec<Motion<f64>>,
    acc: Vec<Motion<f64>>,
    /// The force each body receives from its parent (world coordinates,
    /// about the world origin).
    interaction: Vec<Force<f64>>,
    /// Each tendon's length and velocity ([`Data::tendon`]).
    tendon: Vec<(f64, f64)>,
}

impl Bodies {
    /// From `data` after the forward dynamics and RNEA at the accelerations.
    fn new(model: &Model, data: &Data<f64>, q: &[f64], contacts: &[Contact<f64>]) -> Self {
        let tree = model.tree();
        let n = model.bodies.len();
        let falling = Motion::new(Vector3::zeros(), -model.opt.gravity);
        let mut b = Bodies {
            pose: Vec::with_capacity(n),
            quat: quaternions(model, q, &data.mocap),
            vel: Vec::with_capacity(n),
            acc: Vec::with_capacity(n),
            interaction: Vec::with_capacity(n),
            tendon: data.tendon.iter().map(|t| (t.length, t.velocity)).collect(),
        };
        for frame in &tree.body {
            let (pose, vel, acc) = match frame.node {
                Some(k) => {
                    let world = &data.world[k];
                    let vel = world.inverse_apply_motion(&data.vel[k]);
                    (
                        frame.offset.compose(world),
                        vel,
                        world.inverse_apply_motion(&data.acc[k]),
                    )
                }
                None => {
                    let pose = match frame.mocap {
                        Some(k) => frame.offset.compose(&data.mocap[k]),
                        None => frame.offset,
                    };
                    (pose, Motion::zero(), falling)
                }
            };
            b.pose.push(pose);
            b.vel.push(vel);
            b.acc.push(acc);
        }
        for (i, body) in model.bodies.iter().enumerate() {
            let inertia =
                Inertia::from_com(body.mass, &body.com, &body.inertia).to_source(&b.pose[i]);
            let (v, a) = (b.vel[i], b.acc[i]);
            let f = inertia.mul_motion(&a) + v.cross_force(&inertia.mul_motion(&v));
            b.interaction.push(f);
        }
        for c in contacts {
            let f = c.force();
            let wrench = Force::new(c.torque + c.pos.cross(&f), f);
            b.interaction[c.bodies[1]] += -wrench;
            b.interaction[c.bodies[0]] += wrench;
        }
        b.interaction[0] = Force::zero();
        for i in (1..n).rev() {
            let f = b.interaction[i];
            b.interaction[model.bodies[i].parent] += f;
        }
        b
    }

    /// The motion of body `body`'s point p (world coordinates): angular
    /// velocity and the point's velocity.
    fn velocity(&self, body: usize, p: &Vector3<f64>) -> Motion<f64> {
        let v = &self.vel[body];
        Motion::new(v.ang, v.lin + v.ang.cross(p))
    }

    /// The angular acceleration and the classical acceleration of body
    /// `body`'s point p (world coordinates, gravity as an upward acceleration).
    fn acceleration(&self, body: usize, p: &Vector3<f64>) -> Motion<f64> {
        let a = &self.acc[body];
        let v = self.velocity(body, p);
        Motion::new(a.ang, a.lin + a.ang.cross(p) + v.ang.cross(&v.lin))
    }

    /// Body i's centre of mass (world coordinates).
    fn com(&self, model: &Model, i: usize) -> Vector3<f64> {
        self.pose[i].trans + self.pose[i].axes() * model.bodies[i].com
    }

    /// The bodies of `root`'s subtree, `root` included.
    fn members(model: &Model, root: usize) -> impl Iterator<Item = usize> + '_ {
        (0..model.bodies.len()).filter(move |&i| {
            let mut k = i;
            while k != root && k != 0 {
                k = model.bodies[k].parent;
            }
            k == root
        })
    }

    /// The centre of mass of `root`'s subtree and its linear velocity
    /// (momentum over mass); a massless subtree's centre is the root's COM.
    fn subtree(&self, model: &Model, root: usize) -> (Vector3<f64>, Vector3<f64>) {
        let (mut mass, mut moment, mut momentum) = (0.0, Vector3::zeros(), Vector3::zeros());
        for i in Self::members(model, root) {
            let (m, com) = (model.bodies[i].mass, self.com(model, i));
            mass += m;
            moment += com * m;
            momentum += self.velocity(i, &com).lin * m;
        }
        let centre = if mass < MINVAL {
            self.com(model, root)
        } else {
            moment / mass
        };
        (centre, momentum / mass.max(MINVAL))
    }

    /// The angular momentum of `root`'s subtree about its centre of mass
    /// (world coordinates): each body's spin I w plus its momentum's moment
    /// relative to the subtree's centre and motion.
    fn angular_momentum(&self, model: &Model, root: usize) -> Vector3<f64> {
        let (centre, velocity) = self.subtree(model, root);
        let mut total = Vector3::zeros();
        for i in Self::members(model, root) {
            let body = &model.bodies[i];
            let com = self.com(model, i);
            let axes = self.pose[i].axes();
            let inertia = axes * body.inertia * axes.transpose();
            let motion = self.velocity(i, &com);
            let relative = (motion.lin - velocity) * body.mass;
            total += inertia * motion.ang + (com - centre).cross(&relative);
        }
        total
    }
}

/// Every body's orientation as MuJoCo's mj_kinematics composes it (see
/// [`Bodies::quat`]), the mocap bodies' from their poses `mocap`.
fn quaternions(model: &Model, q: &[f64], mocap: &[Transform<f64>]) -> Vec<UnitQuaternion<f64>> {
    let mut quat = vec![UnitQuaternion::identity(); model.bodies.len()];
    let mut mocap = mocap.iter();
    for (i, body) in model.bodies.iter().enumerate().skip(1) {
        if body.mocap {
            quat[i] = local_quaternion(&mocap.next().expect("one per mocap body").axes());
            continue;
        }
        let mut x = quat[body.parent] * local_quaternion(body.rot.matrix());
        for j in body.joints.clone() {
            let joint = &model.joints[j];
            let at = model.joint_address(j).0;
            let stored = |at: usize| {
                UnitQuaternion::from_quaternion(Quaternion::new(
                    q[at],
                    q[at + 1],
                    q[at + 2],
                    q[at + 3],
                ))
            };
            match joint.kind {
                JointKind::Free => x = stored(at + 3),
                JointKind::Ball => x *= stored(at),
                JointKind::Hinge => {
                    let axis = nalgebra::Unit::new_unchecked(joint.axis);
                    x *= UnitQuaternion::from_axis_angle(&axis, q[at] - joint.reference);
                }
                JointKind::Slide => {}
            }
        }
        quat[i] = x;
    }
    quat
}

/// A quaternion (w, x, y, z) in q made unit as MuJoCo's mju_normalize4
/// does: the identity if its norm is below mjMINVAL.
fn normalized(w_xyz: &[f64]) -> UnitQuaternion<f64> {
    let q = Quaternion::new(w_xyz[0], w_xyz[1], w_xyz[2], w_xyz[3]);
    if q.norm() < MINVAL {
        UnitQuaternion::identity()
    } else {
        UnitQuaternion::new_normalize(q)
    }
}

/// The quaternion of a frame's orientation in its body, w >= 0 (MuJoCo
/// keeps the sign a file's `quat` gives, so a file quaternion with w < 0
/// gives framequat readings of the opposite sign: the same rotation).
fn local_quaternion(rot: &Matrix3<f64>) -> UnitQuaternion<f64> {
    let r = nalgebra::Rotation3::from_matrix_unchecked(*rot);
    let q = UnitQuaternion::from_rotation_matrix(&r);
    if q.w < 0.0 {
        UnitQuaternion::new_unchecked(-q.into_inner())
    } else {
        q
    }
}
