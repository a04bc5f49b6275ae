//! MJCF writer: [`write`] turns a [`Spec`] into an MJCF document that
//! [`parse`](super::parse) reads back as the same Spec.
//!
//! The document states everything explicitly:
//! - `<compiler angle="radian" inertiafromgeom="false">`, and every body has
//!   its `<inertial>`: `pos` is the COM, with `diaginertia` when the inertia
//!   tensor is diagonal, else `fullinertia`. Nothing is recomputed from geoms.
//! - Numbers are written in Rust's shortest round-trip form and parse back to
//!   the same bits. What the loader derives from them comes back within a few
//!   ulps: rotations (written as `quat`), joint axes (normalised again) and
//!   full inertia tensors (rebuilt from their principal axes, as MuJoCo does).
//! - Names are the Spec's; the loader names unnamed objects again (see
//!   `tree.rs`) and always calls body 0 "world". MJCF needs names unique within
//!   each kind; actuators refer to joints by name.
//! - Options: Euler with implicit damping is MuJoCo's default; explicit
//!   passive forces under Euler are `<flag eulerdamp="disable"/>`. Under RK4
//!   passive forces are always explicit, so the passive mode, which RK4 does
//!   not use, reads back as [`PassiveMode::Explicit`]; `implicitfast` and
//!   `implicit` do not use it either and read back with
//!   [`PassiveMode::ImplicitDamping`]. A body's gravcomp and mocap are its attributes. Contacts or limits
//!   switched off are `<flag contact="disable"/>`, `<flag limit="disable"/>`;
//!   the soft-contact constants ([`crate::model::SoftOptions`]) are custom
//!   numerics, `<custom><numeric name="diffosi:contact_stiffness" data=".."/>`
//!   and so on ([`SoftOptions::NAMES`]), which MuJoCo keeps and ignores.
//!   The contact model is the custom text `diffosi:contact`; the constraint
//!   model's settings are MuJoCo's own attributes (geom and joint solver
//!   parameters, `cone`, `impratio`, `iterations`, the noslip settings, flags,
//!   `<contact>`).
//!
//! - Sites are written with their pose, sensors that are computed with
//!   their objects' names and cutoff.
//!
//! What MJCF cannot express is an error ([`ModelError::Unwritable`]): implicit
//! stiffness under Euler ([`PassiveMode::ImplicitDampingStiffness`], DART's
//! scheme), bodies, geoms or sites in an order the loader would renumber
//! (bodies depth-first with children in index order, geoms and sites grouped
//! by body in body order), sensors that are read but not computed, and
//! whatever the loader, like MuJoCo, rejects in the written document (for
//! instance a body with joints but no mass, which URDF allows).

use nalgebra::{Rotation3, UnitQuaternion};

use crate::model::params::inertia_to_six;
use crate::model::{
    ActDynamics, Actuator, ActuatorQuantity, Bias, Body, Cone, ContactModel, EqualityKind,
    FrameObject, FrameQuantity, Gain, Geom, Integrator, Joint, JointKind, JointQuantity,
    ModelError, NoSlip, Objects, Options, PassiveMode, SensorKind, Shape, SiteQuantity,
    SoftOptions, SolParams, Spec, TendonQuantity, Transmission, Wrap, CCD_ITERATIONS,
    CCD_TOLERANCE,
};

/// Writes `spec` as an MJCF document, checked by reading and validating it.
pub fn write(spec: &Spec) -> Result<String, ModelError> {
    let text = document(spec)?;
    match super::parse(&text, "written MJCF").and_then(|spec| spec.validate()) {
        Ok(_) => Ok(text),
        Err(e) => {
            let line = match &e {
                ModelError::Invalid { line, .. } => text.lines().nth(*line as usize - 1),
                _ => None,
            };
            let at = line.map_or(String::new(), |l| format!(" (at {})", l.trim()));
            Err(unwritable(&format!("it would not load: {e}{at}")))
        }
    }
}

fn document(spec: &Spec) -> Result<String, ModelError> {
    if !spec.meshes.is_empty() {
        return Err(unwritable("meshes (their files are not kept)"));
    }
    if !spec.hfields.is_empty() {
        return Err(unwritable("height fields"));
    }
    let mut doc = Document::default();
    doc.open(0, Tag::new("mujoco").text("model", &spec.name));
    let compiler = Tag::new("compiler")
        .text("angle", "radian")
        .text("inertiafromgeom", "false");
    doc.empty(1, compiler);
    write_options(&mut doc, &spec.opt)?;
    write_bodies(&mut doc, spec)?;
    write_contact(&mut doc, spec);
    write_tendons(&mut doc, spec);
    write_equalities(&mut doc, spec);
    doc.open(1, Tag::new("actuator"));
    for a in &spec.actuators {
        let site = |s: usize| spec.sites[s].name.as_str();
        let target = match a.target {
            Transmission::Joint(j) => ("joint", spec.joints[j].name.as_str()),
            Transmission::Tendon(t) => ("tendon", spec.tendons[t].name.as_str()),
            Transmission::Site { site: s, .. } => ("site", site(s)),
        };
        let mut tag = actuator(a, target);
        if let Transmission::Site {
            refsite: Some(r), ..
        } = a.target
        {
            tag = tag.text("refsite", site(r));
        }
        doc.empty(2, tag);
    }
    doc.close(1, "actuator");
    write_sensors(&mut doc, spec)?;
    write_keyframes(&mut doc, spec);
    doc.open(1, Tag::new("custom"));
    let mut soft = spec.opt.soft;
    for (name, field) in SoftOptions::NAMES {
        let numeric = Tag::new("numeric")
            .text("name", &format!("diffosi:{name}"))
            .number("data", *field(&mut soft));
        doc.empty(2, numeric);
    }
    let model = ContactModel::NAMES
        .iter()
        .find(|(_, m)| *m == spec.opt.contact_model)
        .expect("listed")
        .0;
    doc.empty(
        2,
        Tag::new("text")
            .text("name", "diffosi:contact")
            .text("data", model),
    );
    doc.close(1, "custom");
    doc.close(0, "mujoco");
    Ok(doc.0)
}

/// Every keyframe with all its vectors (no section without keyframes).
fn write_keyframes(doc: &mut Document, spec: &Spec) {
    if spec.keyframes.is_empty() {
        return;
    }
    doc.open(1, Tag::new("keyframe"));
    for k in &spec.keyframes {
        let key = Tag::new("key")
            .text("name", &k.name)
            .number("time", k.time)
            .numbers("qpos", &k.q)
            .numbers("qvel", &k.v)
            .numbers("act", &k.act)
            .numbers("ctrl", &k.ctrl)
            .numbers("mpos", &k.mpos)
            .numbers("mquat", &k.mquat);
        doc.empty(2, key);
    }
    doc.close(1, "keyframe");
}

fn unwritable(why: &str) -> ModelError {
    ModelError::Unwritable(format!("MJCF: {why}"))
}

fn write_options(doc: &mut Document, opt: &Options) -> Result<(), ModelError> {
    let integrator = match opt.integrator {
        Integrator::Euler => "Euler",
        Integrator::Rk4 => "RK4",
        Integrator::ImplicitFast => "implicitfast",
        Integrator::Implicit => "implicit",
    };
    let cone = match opt.solver.cone {
        Cone::Pyramidal => "pyramidal",
        Cone::Elliptic => "elliptic",
    };
    let option = Tag::new("option")
        .number("timestep", opt.timestep)
        .numbers("gravity", opt.gravity.as_slice())
        .text("integrator", integrator)
        .text("cone", cone)
        .number("impratio", opt.solver.impratio)
        .text("iterations", &opt.solver.iterations.to_string())
        .number("density", opt.fluid.density)
        .number("viscosity", opt.fluid.viscosity)
        .numbers("wind", opt.fluid.wind.as_slice());
    let option = if opt.magnetic == Options::default().magnetic {
        option
    } else {
        option.numbers("magnetic", opt.magnetic.as_slice())
    };
    let ccd = opt.solver.ccd;
    let option = if (ccd.iterations, ccd.tolerance) == (CCD_ITERATIONS, CCD_TOLERANCE) {
        option
    } else {
        option
            .text("ccd_iterations", &ccd.iterations.to_string())
            .number("ccd_tolerance", ccd.tolerance)
    };
    let noslip = opt.solver.noslip;
    let option = if noslip == NoSlip::default() {
        option
    } else {
        option
            .text("noslip_iterations", &noslip.iterations.to_string())
            .number("noslip_tolerance", noslip.tolerance)
    };
    if (opt.integrator, opt.passive) == (Integrator::Euler, PassiveMode::ImplicitDampingStiffness) {
        return Err(unwritable(
            "MuJoCo has no implicit joint stiffness (passive mode ImplicitDampingStiffness, \
             DART's); its Euler integrator makes only damping implicit",
        ));
    }
    let mut flag = Tag::new("flag");
    let mut any = false;
    let disabled = [
        (
            "eulerdamp",
            (opt.integrator, opt.passive) == (Integrator::Euler, PassiveMode::Explicit),
        ),
        ("contact", !opt.contact),
        ("limit", !opt.limits),
        ("equality", !opt.solver.equality),
        ("frictionloss", !opt.solver.frictionloss),
        ("refsafe", !opt.solver.refsafe),
        ("filterparent", !opt.solver.filterparent),
        ("nativeccd", !opt.solver.ccd.native),
        ("multiccd", !opt.solver.ccd.multi),
    ];
    for (name, _) in disabled.into_iter().filter(|(_, off)| *off) {
        flag = flag.text(name, "disable");
        any = true;
    }
    if any {
        doc.open(1, option);
        doc.empty(2, flag);
        doc.close(1, "option");
    } else {
        doc.empty(1, option);
    }
    Ok(())
}

/// The world's geoms, then the bodies, each nested in its parent.
fn write_bodies(doc: &mut Document, spec: &Spec) -> Result<(), ModelError> {
    if !spec.geoms.is_sorted_by_key(|g| g.body) {
        return Err(unwritable(
            "geoms must be grouped by body in body order, as MJCF numbers them",
        ));
    }
    if !spec.sites.is_sorted_by_key(|s| s.body) {
        return Err(unwritable(
            "sites must be grouped by body in body order, as MJCF numbers them",
        ));
    }
    doc.open(1, Tag::new("worldbody"));
    write_geoms(doc, 2, spec, 0);
    // The bodies whose element is open, innermost last; body i's element sits
    // at depth open.len() + 1.
    let mut open = vec![0];
    for (i, body) in spec.bodies.iter().enumerate().skip(1) {
        while open.last() != Some(&body.parent) {
            if open.len() == 1 {
                return Err(unwritable(&format!(
                    "body '{}' is not in depth-first order, as MJCF numbers bodies",
                    body.name
                )));
            }
            open.pop();
            doc.close(open.len() + 1, "body");
        }
        write_body(doc, open.len() + 1, spec, i);
        open.push(i);
    }
    while open.len() > 1 {
        open.pop();
        doc.close(open.len() + 1, "body");
    }
    doc.close(1, "worldbody");
    Ok(())
}

/// Opens body `b`'s element and writes its joints, inertial and geoms.
fn write_body(doc: &mut Document, depth: usize, spec: &Spec, b: usize) {
    let body = &spec.bodies[b];
    let mut tag = Tag::new("body")
        .text("name", &body.name)
        .numbers("pos", body.pos.as_slice())
        .numbers("quat", &quat(&body.rot));
    if body.gravcomp != 0.0 {
        tag = tag.number("gravcomp", body.gravcomp);
    }
    if body.mocap {
        tag = tag.text("mocap", "true");
    }
    doc.open(depth, tag);
    for joint in &spec.joints[body.joints.clone()] {
        doc.empty(depth + 1, joint_tag(joint));
    }
    doc.empty(depth + 1, inertial(body));
    write_geoms(doc, depth + 1, spec, b);
}

fn joint_tag(j: &Joint) -> Tag {
    let kind = match j.kind {
        JointKind::Hinge => "hinge",
        JointKind::Slide => "slide",
        JointKind::Ball => "ball",
        JointKind::Free => "free",
    };
    let tag = Tag::new("joint")
        .text("name", &j.name)
        .text("type", kind)
        .numbers("axis", j.axis.as_slice())
        .numbers("pos", j.anchor.as_slice())
        .number("ref", j.reference)
        .number("damping", j.damping)
        .number("stiffness", j.stiffness)
        .number("springref", j.springref)
        .number("armature", j.armature)
        .number("frictionloss", j.frictionloss)
        .limits("limited", "range", j.range)
        .number("margin", j.margin)
        .sol("solreflimit", "solimplimit", &j.limit_sol)
        .sol("solreffriction", "solimpfriction", &j.friction_sol);
    match j.springdamper {
        Some(s) => tag.numbers("springdamper", &s),
        None => tag,
    }
}

/// `diaginertia` for a diagonal tensor (it reads back exactly), else
/// `fullinertia`.
/// The inertia as diagonal moments in the body's inertial frame where it is
/// diagonal there (to rounding), which keeps the frame; else the full tensor.
fn inertial(body: &Body) -> Tag {
    let tag = Tag::new("inertial")
        .numbers("pos", body.com.as_slice())
        .number("mass", body.mass);
    let six = inertia_to_six(&body.inertia);
    let axes = body.inertia_frame.matrix();
    let local = axes.transpose() * body.inertia * axes;
    let scale = local.diagonal().abs().max();
    let off = [local[(0, 1)], local[(0, 2)], local[(1, 2)]];
    match six {
        [xx, yy, zz, 0.0, 0.0, 0.0] if body.inertia_frame == Rotation3::identity() => {
            tag.numbers("diaginertia", &[xx, yy, zz])
        }
        _ if off.iter().all(|x| x.abs() <= 1e-12 * scale) => tag
            .numbers("quat", &quat(&body.inertia_frame))
            .numbers("diaginertia", local.diagonal().as_slice()),
        _ => tag.numbers("fullinertia", &six),
    }
}

/// The geoms and sites of `body`.
fn write_geoms(doc: &mut Document, depth: usize, spec: &Spec, body: usize) {
    for geom in spec.geoms.iter().filter(|g| g.body == body) {
        doc.empty(depth, geom_tag(geom));
    }
    for site in spec.sites.iter().filter(|s| s.body == body) {
        let tag = Tag::new("site")
            .text("name", &site.name)
            .numbers("pos", site.pos.as_slice())
            .numbers("quat", &quat(&site.rot));
        doc.empty(depth, tag);
    }
}

/// `<sensor>`: the sensors that are computed, by the names of their
/// objects; a sensor that is only read cannot be written (what it refers to
/// is not kept).
fn write_sensors(doc: &mut Document, spec: &Spec) -> Result<(), ModelError> {
    if spec.sensors.is_empty() {
        return Ok(());
    }
    doc.open(1, Tag::new("sensor"));
    for sensor in &spec.sensors {
        let tag = match &sensor.kind {
            SensorKind::Joint(quantity, j) => {
                let element = match quantity {
                    JointQuantity::Pos => "jointpos",
                    JointQuantity::Vel => "jointvel",
                    JointQuantity::BallQuat => "ballquat",
                    JointQuantity::BallAngVel => "ballangvel",
                    JointQuantity::LimitPos => "jointlimitpos",
                    JointQuantity::LimitVel => "jointlimitvel",
                    JointQuantity::LimitForce => "jointlimitfrc",
                };
                Tag::new(element).text("joint", &spec.joints[*j].name)
            }
            SensorKind::Frame {
                quantity,
                object,
                reference,
            } => {
                let element = match quantity {
                    FrameQuantity::Pos => "framepos",
                    FrameQuantity::Quat => "framequat",
                    FrameQuantity::Axis(0) => "framexaxis",
                    FrameQuantity::Axis(1) => "frameyaxis",
                    FrameQuantity::Axis(_) => "framezaxis",
                    FrameQuantity::LinVel => "framelinvel",
                    FrameQuantity::AngVel => "frameangvel",
                    FrameQuantity::LinAcc => "framelinacc",
                    FrameQuantity::AngAcc => "frameangacc",
                };
                let (kind, name) = frame_object(spec, object);
                let tag = Tag::new(element)
                    .text("objtype", kind)
                    .text("objname", name);
                match reference {
                    Some(r) => {
                        let (kind, name) = frame_object(spec, r);
                        tag.text("reftype", kind).text("refname", name)
                    }
                    None => tag,
                }
            }
            SensorKind::Site(quantity, s) => {
                let element = match quantity {
                    SiteQuantity::Accelerometer => "accelerometer",
                    SiteQuantity::Velocimeter => "velocimeter",
                    SiteQuantity::Gyro => "gyro",
                    SiteQuantity::Magnetometer => "magnetometer",
                    SiteQuantity::Force => "force",
                    SiteQuantity::Torque => "torque",
                };
                Tag::new(element).text("site", &spec.sites[*s].name)
            }
            SensorKind::Actuator(quantity, a) => {
                let element = match quantity {
                    ActuatorQuantity::Pos => "actuatorpos",
                    ActuatorQuantity::Vel => "actuatorvel",
                    ActuatorQuantity::Force => "actuatorfrc",
                };
                Tag::new(element).text("actuator", &spec.actuators[*a].name)
            }
            SensorKind::JointActuatorForce(j) => {
                Tag::new("jointactuatorfrc").text("joint", &spec.joints[*j].name)
            }
            SensorKind::SubtreeCom(b) => Tag::new("subtreecom").text("body", &spec.bodies[*b].name),
            SensorKind::SubtreeLinVel(b) => {
                Tag::new("subtreelinvel").text("body", &spec.bodies[*b].name)
            }
            SensorKind::SubtreeAngMom(b) => {
                Tag::new("subtreeangmom").text("body", &spec.bodies[*b].name)
            }
            SensorKind::Tendon(quantity, t) => {
                let element = match quantity {
                    TendonQuantity::Pos => "tendonpos",
                    TendonQuantity::Vel => "tendonvel",
                    TendonQuantity::LimitPos => "tendonlimitpos",
                    TendonQuantity::LimitVel => "tendonlimitvel",
                    TendonQuantity::LimitForce => "tendonlimitfrc",
                };
                Tag::new(element).text("tendon", &spec.tendons[*t].name)
            }
            SensorKind::Energy { potential: true } => Tag::new("e_potential"),
            SensorKind::Energy { potential: false } => Tag::new("e_kinetic"),
            SensorKind::TendonActuatorForce(t) => {
                Tag::new("tendonactuatorfrc").text("tendon", &spec.tendons[*t].name)
            }
            SensorKind::Touch { .. }
            | SensorKind::Rangefinder { .. }
            | SensorKind::InsideSite { .. } => {
                let why = format!(
                    "sensor '{}' reads a site's shape or geoms' colours, which are not kept \
                     to be written",
                    sensor.name
                );
                return Err(unwritable(&why));
            }
            SensorKind::Unsupported { element, .. } => {
                let why = format!(
                    "sensor '{}' (<{element}>) is read but not computed, and not kept to be written",
                    sensor.name
                );
                return Err(unwritable(&why));
            }
        };
        let tag = tag.text("name", &sensor.name);
        let tag = if sensor.cutoff > 0.0 {
            tag.number("cutoff", sensor.cutoff)
        } else {
            tag
        };
        doc.empty(2, tag);
    }
    doc.close(1, "sensor");
    Ok(())
}

/// A frame sensor's objtype and objname.
fn frame_object<'s>(spec: &'s Spec, object: &FrameObject) -> (&'static str, &'s str) {
    match *object {
        FrameObject::Body(b) => ("body", &spec.bodies[b].name),
        FrameObject::XBody(b) => ("xbody", &spec.bodies[b].name),
        FrameObject::Geom(g) => ("geom", &spec.geoms[g].name),
        FrameObject::Site(s) => ("site", &spec.sites[s].name),
    }
}

fn geom_tag(g: &Geom) -> Tag {
    let (kind, size) = match g.shape {
        // MuJoCo's size of an infinite plane with unit grid spacing.
        Shape::Plane => ("plane", vec![0.0, 0.0, 1.0]),
        Shape::Sphere { radius } => ("sphere", vec![radius]),
        Shape::Capsule {
            radius,
            half_length,
        } => ("capsule", vec![radius, half_length]),
        Shape::Cylinder {
            radius,
            half_length,
        } => ("cylinder", vec![radius, half_length]),
        Shape::Box { half } => ("box", half.as_slice().to_vec()),
        Shape::Ellipsoid { radii } => ("ellipsoid", radii.as_slice().to_vec()),
        Shape::Mesh { .. } => unreachable!("models with meshes are refused first"),
        Shape::HField { .. } => unreachable!("models with height fields are refused first"),
    };
    let tag = Tag::new("geom")
        .text("name", &g.name)
        .text("type", kind)
        .numbers("size", &size)
        .numbers("pos", g.pos.as_slice())
        .numbers("quat", &quat(&g.rot))
        .text("contype", &g.contype.to_string())
        .text("conaffinity", &g.conaffinity.to_string())
        .numbers("friction", &g.friction)
        .text("condim", &g.contact.condim.to_string())
        .text("priority", &g.contact.priority.to_string())
        .number("solmix", g.contact.solmix)
        .sol("solref", "solimp", &g.contact.sol)
        .number("margin", g.contact.margin)
        .number("gap", g.contact.gap);
    match &g.fluid {
        Some(c) => tag
            .text("fluidshape", "ellipsoid")
            .numbers("fluidcoef", &c.to_array()),
        None => tag,
    }
}

/// `<contact>`: explicit pairs with every attribute, and excluded body pairs.
fn write_contact(doc: &mut Document, spec: &Spec) {
    if spec.pairs.is_empty() && spec.excludes.is_empty() {
        return;
    }
    doc.open(1, Tag::new("contact"));
    for pair in &spec.pairs {
        let [g1, g2] = pair.geoms.map(|g| spec.geoms[g].name.as_str());
        let p = &pair.params;
        let pair = Tag::new("pair")
            .text("name", &pair.name)
            .text("geom1", g1)
            .text("geom2", g2)
            .text("condim", &p.condim.to_string())
            .numbers("friction", &p.friction)
            .sol("solref", "solimp", &p.sol)
            .numbers("solreffriction", &p.solreffriction)
            .number("margin", p.margin)
            .number("gap", p.gap);
        doc.empty(2, pair);
    }
    for e in &spec.excludes {
        let [b1, b2] = e.map(|b| spec.bodies[b].name.as_str());
        doc.empty(2, Tag::new("exclude").text("body1", b1).text("body2", b2));
    }
    doc.close(1, "contact");
}

fn write_tendons(doc: &mut Document, spec: &Spec) {
    if spec.tendons.is_empty() {
        return;
    }
    doc.open(1, Tag::new("tendon"));
    for t in &spec.tendons {
        let kind = if t.spatial.is_empty() {
            "fixed"
        } else {
            "spatial"
        };
        let tag = Tag::new(kind)
            .text("name", &t.name)
            .number("stiffness", t.stiffness)
            .number("damping", t.damping)
            .numbers("springlength", &t.springlength.unwrap_or([-1.0, -1.0]))
            .number("frictionloss", t.frictionloss)
            .limits("limited", "range", t.range.map(|[lo, hi]| (lo, hi)))
            .number("margin", t.margin)
            .sol("solreflimit", "solimplimit", &t.limit_sol)
            .sol("solreffriction", "solimpfriction", &t.friction_sol);
        doc.open(2, tag);
        for (j, coef) in &t.joints {
            let joint = Tag::new("joint")
                .text("joint", &spec.joints[*j].name)
                .number("coef", *coef);
            doc.empty(3, joint);
        }
        for w in &t.spatial {
            doc.empty(3, wrap_tag(spec, w));
        }
        doc.close(2, kind);
    }
    doc.close(1, "tendon");
}

/// One element of a spatial tendon's path.
fn wrap_tag(spec: &Spec, w: &Wrap) -> Tag {
    match w {
        Wrap::Site(k) => Tag::new("site").text("site", &spec.sites[*k].name),
        Wrap::Geom { geom, sidesite } => {
            let tag = Tag::new("geom").text("geom", &spec.geoms[*geom].name);
            match sidesite {
                Some(k) => tag.text("sidesite", &spec.sites[*k].name),
                None => tag,
            }
        }
        Wrap::Pulley { divisor } => Tag::new("pulley").number("divisor", *divisor),
    }
}

fn write_equalities(doc: &mut Document, spec: &Spec) {
    if spec.equalities.is_empty() {
        return;
    }
    doc.open(1, Tag::new("equality"));
    for e in &spec.equalities {
        let objects = |tag: Tag, objects: &Objects| match objects {
            Objects::Bodies([b1, b2]) => tag
                .text("body1", &spec.bodies[*b1].name)
                .text("body2", &spec.bodies[*b2].name),
            Objects::Sites([s1, s2]) => tag
                .text("site1", &spec.sites[*s1].name)
                .text("site2", &spec.sites[*s2].name),
        };
        let by_body = |o: &Objects| matches!(o, Objects::Bodies(_));
        let tag = match &e.kind {
            EqualityKind::Connect { objects: o, anchor } => {
                let tag = objects(Tag::new("connect"), o);
                if by_body(o) {
                    tag.numbers("anchor", anchor.as_slice())
                } else {
                    tag
                }
            }
            EqualityKind::Weld {
                objects: o,
                anchor,
                relpose,
                torquescale,
            } => {
                let mut tag = objects(Tag::new("weld"), o).number("torquescale", *torquescale);
                if by_body(o) {
                    tag = tag.numbers("anchor", anchor.as_slice());
                }
                match relpose {
                    Some((p, q)) => tag.numbers("relpose", &[p.x, p.y, p.z, q.w, q.i, q.j, q.k]),
                    None => tag,
                }
            }
            EqualityKind::Joint { joints, polycoef } => {
                let tag = Tag::new("joint").numbers("polycoef", polycoef);
                joints
                    .iter()
                    .zip(["joint1", "joint2"])
                    .fold(tag, |t, (j, key)| match j {
                        Some(j) => t.text(key, &spec.joints[*j].name),
                        None => t,
                    })
            }
            EqualityKind::Tendon { tendons, polycoef } => {
                let tag = Tag::new("tendon").numbers("polycoef", polycoef);
                tendons
                    .iter()
                    .zip(["tendon1", "tendon2"])
                    .fold(tag, |t, (k, key)| match k {
                        Some(k) => t.text(key, &spec.tendons[*k].name),
                        None => t,
                    })
            }
        };
        let tag = tag
            .text("name", &e.name)
            .text("active", if e.active { "true" } else { "false" })
            .sol("solref", "solimp", &e.sol);
        doc.empty(2, tag);
    }
    doc.close(1, "equality");
}

/// A motor as `<motor>`; any other actuator as the `<general>` with its
/// gain, bias and dynamics.
fn actuator(a: &Actuator, (kind, target): (&str, &str)) -> Tag {
    let general = a.force_per_control().is_none() || a.gain != Gain::Fixed(1.0);
    let tag = Tag::new(if general { "general" } else { "motor" })
        .text("name", &a.name)
        .text(kind, target)
        .numbers("gear", &a.gear)
        .limits("ctrllimited", "ctrlrange", a.ctrl_range)
        .limits("forcelimited", "forcerange", a.force_range);
    if !general {
        return tag;
    }
    let (gaintype, gainprm) = match a.gain {
        Gain::Fixed(g) => ("fixed", [g, 0.0, 0.0]),
        Gain::Affine(p) => ("affine", p),
    };
    let (biastype, biasprm) = match a.bias {
        Bias::None => ("none", [0.0; 3]),
        Bias::Affine(p) => ("affine", p),
    };
    let (dyntype, dynprm) = match a.dynamics {
        ActDynamics::None => ("none", 1.0),
        ActDynamics::Integrator => ("integrator", 1.0),
        ActDynamics::Filter(t) => ("filter", t),
        ActDynamics::FilterExact(t) => ("filterexact", t),
    };
    tag.limits("actlimited", "actrange", a.act_range)
        .text("gaintype", gaintype)
        .numbers("gainprm", &gainprm)
        .text("biastype", biastype)
        .numbers("biasprm", &biasprm)
        .text("dyntype", dyntype)
        .number("dynprm", dynprm)
        .text("actearly", if a.act_early { "true" } else { "false" })
        .number("damping", a.damping)
        .number("armature", a.armature)
}

/// The unit quaternion (w x y z) of a rotation.
fn quat(rot: &Rotation3<f64>) -> [f64; 4] {
    let q = UnitQuaternion::from_rotation_matrix(rot);
    [q.w, q.i, q.j, q.k]
}

/// The document so far, indented by two spaces per level.
#[derive(Default)]
struct Document(String);

impl Document {
    fn line(&mut self, depth: usize, text: &str) {
        self.0.push_str(&"  ".repeat(depth));
        self.0.push_str(text);
        self.0.push('\n');
    }

    fn open(&mut self, depth: usize, tag: Tag) {
        self.line(depth, &format!("{}>", tag.0));
    }

    fn empty(&mut self, depth: usize, tag: Tag) {
        self.line(depth, &format!("{}/>", tag.0));
    }

    fn close(&mut self, depth: usize, name: &str) {
        self.line(depth, &format!("</{name}>"));
    }
}

/// A start tag being built: `<name key="value" ...`.
struct Tag(String);

impl Tag {
    fn new(name: &str) -> Tag {
        Tag(format!("<{name}"))
    }

    fn text(mut self, key: &str, value: &str) -> Tag {
        let value = value
            .replace('&', "&amp;")
            .replace('<', "&lt;")
            .replace('"', "&quot;");
        self.0.push_str(&format!(" {key}=\"{value}\""));
        self
    }

    fn numbers(self, key: &str, values: &[f64]) -> Tag {
        let words: Vec<String> = values.iter().map(|x| format!("{x:?}")).collect();
        self.text(key, &words.join(" "))
    }

    fn number(self, key: &str, value: f64) -> Tag {
        self.numbers(key, &[value])
    }

    fn sol(self, solref: &str, solimp: &str, sol: &SolParams) -> Tag {
        self.numbers(solref, &sol.solref)
            .numbers(solimp, &sol.solimp)
    }

    /// MuJoCo's pair of a `limited` flag and its range.
    fn limits(self, limited: &str, key: &str, range: Option<(f64, f64)>) -> Tag {
        match range {
            Some((lo, hi)) => self.text(limited, "true").numbers(key, &[lo, hi]),
            None => self.text(limited, "false"),
        }
    }
}
