//! `<sensor>`: every MuJoCo sensor element is read, checked as MuJoCo's
//! compiler checks it (known objects of the right kind, non-negative cutoff
//! and noise) and laid out with MuJoCo's size. Those [`crate::model::sensor`]
//! computes become their [`SensorKind`]; the others (camera rangefinders,
//! rangefinders that may meet a height field, contact, distance, normal,
//! fromto, camprojection, clock (the state has no time), user sensors,
//! the potential energy of a model with springs on ball or free joints,
//! frame and insidesite sensors on cameras, and any sensor whose readings
//! are delayed or sampled at an interval) are kept as
//! [`SensorKind::Unsupported`], so that a model using them loads and only
//! evaluating its sensors fails, naming the sensor (a sensor never changes
//! the dynamics); so are all sensors of a model that disables them
//! (`<flag sensor="disable"/>`, where MuJoCo leaves sensordata unset).
//! Tactile and plugin sensors are refused: their size depends on meshes and
//! plugins, which are not read.

use std::collections::HashSet;

use super::attributes::{value, Attrs};
use super::compiler::FromGeom;
use super::schema::{check_attributes, SENSOR_ATTRS};
use super::tree::Tree;
use super::{children, elements, tag, unrecognized, unsupported, Node, Reader, Result};
use crate::model::{
    ActuatorQuantity, FrameObject, FrameQuantity, JointKind, JointQuantity, RayField, Sensor,
    SensorKind, Shape, SiteQuantity, TendonQuantity,
};

/// The sensors MuJoCo computes that are not computed here, with their own
/// attributes and sizes (0: the size depends on attributes).
#[rustfmt::skip]
const OTHERS: &[(&str, &[&str], usize)] = &[
    ("camprojection", &["site", "camera"], 2),
    ("rangefinder", &["site", "camera", "data"], 0),
    ("distance", &["body1", "geom1", "body2", "geom2"], 1),
    ("normal", &["body1", "geom1", "body2", "geom2"], 3),
    ("fromto", &["body1", "geom1", "body2", "geom2"], 6),
    ("contact", &["site", "body1", "subtree1", "geom1", "body2", "subtree2", "geom2", "num",
                  "data", "reduce"], 0),
    ("clock", &[], 1),
    ("user", &["objtype", "objname", "datatype", "needstage", "dim"], 0),
];

/// The frame sensors and what they read; the last two take no reference.
const FRAMES: [(&str, FrameQuantity); 9] = [
    ("framepos", FrameQuantity::Pos),
    ("framequat", FrameQuantity::Quat),
    ("framexaxis", FrameQuantity::Axis(0)),
    ("frameyaxis", FrameQuantity::Axis(1)),
    ("framezaxis", FrameQuantity::Axis(2)),
    ("framelinvel", FrameQuantity::LinVel),
    ("frameangvel", FrameQuantity::AngVel),
    ("framelinacc", FrameQuantity::LinAcc),
    ("frameangacc", FrameQuantity::AngAcc),
];

const SITES: [(&str, SiteQuantity); 6] = [
    ("accelerometer", SiteQuantity::Accelerometer),
    ("velocimeter", SiteQuantity::Velocimeter),
    ("gyro", SiteQuantity::Gyro),
    ("magnetometer", SiteQuantity::Magnetometer),
    ("force", SiteQuantity::Force),
    ("torque", SiteQuantity::Torque),
];

const ACTUATORS: [(&str, ActuatorQuantity); 3] = [
    ("actuatorpos", ActuatorQuantity::Pos),
    ("actuatorvel", ActuatorQuantity::Vel),
    ("actuatorfrc", ActuatorQuantity::Force),
];

const TENDONS: [(&str, TendonQuantity); 5] = [
    ("tendonpos", TendonQuantity::Pos),
    ("tendonvel", TendonQuantity::Vel),
    ("tendonlimitpos", TendonQuantity::LimitPos),
    ("tendonlimitvel", TendonQuantity::LimitVel),
    ("tendonlimitfrc", TendonQuantity::LimitForce),
];

const JOINTS: [(&str, JointQuantity); 7] = [
    ("jointpos", JointQuantity::Pos),
    ("jointvel", JointQuantity::Vel),
    ("ballquat", JointQuantity::BallQuat),
    ("ballangvel", JointQuantity::BallAngVel),
    ("jointlimitpos", JointQuantity::LimitPos),
    ("jointlimitvel", JointQuantity::LimitVel),
    ("jointlimitfrc", JointQuantity::LimitForce),
];

/// The sizes of the fields of a contact sensor's and a rangefinder's
/// `data`, in MuJoCo's order.
const CONTACT_DATA: [(&str, usize); 7] = [
    ("found", 1),
    ("force", 3),
    ("torque", 3),
    ("dist", 1),
    ("pos", 3),
    ("normal", 3),
    ("tangent", 3),
];
const RAY_DATA: [(&str, RayField); 6] = [
    ("dist", RayField::Dist),
    ("dir", RayField::Dir),
    ("origin", RayField::Origin),
    ("point", RayField::Point),
    ("normal", RayField::Normal),
    ("depth", RayField::Depth),
];

/// The objects sensors name, as the file names them (unnamed ones
/// cannot be named).
pub(super) struct Named<'n> {
    pub actuators: &'n [String],
    pub tendons: &'n [String],
    /// Whether each tendon is limited.
    pub limited: &'n [bool],
}

impl<'a> Reader<'a> {
    /// Every sensor in document order; explicit names must differ.
    pub(super) fn read_sensors(
        &self,
        tree: &Tree<'a>,
        named: &Named,
        root: Node<'a>,
    ) -> Result<Vec<Sensor>> {
        let mut names = HashSet::new();
        let mut sensors = vec![];
        let disabled = children(root, "option")
            .into_iter()
            .flat_map(|o| children(o, "flag"))
            .any(|f| value(f, "sensor") == Some("disable"));
        for section in children(root, "sensor") {
            check_attributes(self.file, section, &[])?;
            for node in elements(section) {
                let mut sensor = self.read_sensor(tree, named, root, node)?;
                if disabled {
                    let why = "sensors are disabled (<flag sensor=\"disable\"/>)";
                    sensor.kind = other(tag(node), why);
                }
                if !sensor.name.is_empty() && !names.insert(sensor.name.clone()) {
                    return Err(self.error(node, format!("repeated name '{}'", sensor.name)));
                }
                sensors.push(sensor);
            }
        }
        Ok(sensors)
    }

    fn read_sensor(
        &self,
        tree: &Tree<'a>,
        named: &Named,
        root: Node<'a>,
        node: Node<'a>,
    ) -> Result<Sensor> {
        let a = Attrs::of(self.file, node);
        let element = tag(node);
        let kind = match self.computed_kind(tree, named, root, node)? {
            Some(kind) => kind,
            None => self.other_kind(tree, node)?,
        };
        let dim = match kind.dim() {
            Some(dim) => dim,
            None => self.other_dim(node)?,
        };
        let mut cutoff = 0.0;
        for (name, value) in [("cutoff", &mut cutoff), ("noise", &mut 0.0)] {
            *value = a.number(name)?.unwrap_or(0.0);
            if !(value.is_finite() && *value >= 0.0) {
                return Err(self.error(node, format!("{name} must be finite and >= 0")));
            }
        }
        let delay = a.number("delay")?.unwrap_or(0.0);
        let interval = a.leading::<2>("interval", [0.0; 2])?[0];
        let kind = if delay > 0.0 || interval > 0.0 {
            let why = "readings delayed or sampled at an interval need the sensor's history";
            other(element, why)
        } else {
            kind
        };
        Ok(Sensor {
            name: value(node, "name").unwrap_or("").to_string(),
            kind,
            dim,
            cutoff,
        })
    }

    /// The kind of a sensor that is computed (None for the others).
    fn computed_kind(
        &self,
        tree: &Tree<'a>,
        named: &Named,
        root: Node<'a>,
        node: Node<'a>,
    ) -> Result<Option<SensorKind>> {
        let element = tag(node);
        let attrs = |own: &[&'static str]| [SENSOR_ATTRS, own].concat();
        let actuators = named.actuators;
        if let Some((_, quantity)) = ACTUATORS.iter().find(|(t, _)| *t == element) {
            check_attributes(self.file, node, &attrs(&["actuator"]))?;
            let name = value(node, "actuator").filter(|n| !n.is_empty());
            let Some(name) = name else {
                return Err(self.error(node, "the sensor needs 'actuator'"));
            };
            let Some(i) = actuators.iter().position(|a| a == name) else {
                return Err(self.error(node, format!("unknown actuator '{name}'")));
            };
            return Ok(Some(SensorKind::Actuator(*quantity, i)));
        }
        if element == "jointactuatorfrc" {
            check_attributes(self.file, node, &attrs(&["joint"]))?;
            let j = self.named(tree, node, "joint", "joint")?;
            if tree.joints[j].kind.nv() != 1 {
                return Err(self.error(node, "joint must be slide or hinge in sensor"));
            }
            return Ok(Some(SensorKind::JointActuatorForce(j)));
        }
        if let Some((_, quantity)) = JOINTS.iter().find(|(t, _)| *t == element) {
            check_attributes(self.file, node, &attrs(&["joint"]))?;
            let j = self.named(tree, node, "joint", "joint")?;
            let joint = &tree.joints[j];
            let (fits, need) = match quantity {
                JointQuantity::Pos | JointQuantity::Vel => (joint.kind.nv() == 1, "slide or hinge"),
                JointQuantity::BallQuat | JointQuantity::BallAngVel => {
                    (joint.kind == JointKind::Ball, "ball")
                }
                _ => (joint.range.is_some(), "limited"),
            };
            if !fits {
                return Err(self.error(node, format!("joint must be {need} in sensor")));
            }
            return Ok(Some(SensorKind::Joint(*quantity, j)));
        }
        if let Some((_, quantity)) = SITES.iter().find(|(t, _)| *t == element) {
            check_attributes(self.file, node, &attrs(&["site"]))?;
            let site = self.named(tree, node, "site", "site")?;
            return Ok(Some(SensorKind::Site(*quantity, site)));
        }
        if let Some(i) = FRAMES.iter().position(|(t, _)| *t == element) {
            let referenced = i < 7;
            let own: &[&str] = if referenced {
                &["objtype", "objname", "reftype", "refname"]
            } else {
                &["objtype", "objname"]
            };
            check_attributes(self.file, node, &attrs(own))?;
            let quantity = FRAMES[i].1;
            let cameras = "frame sensors on cameras are not computed (cameras are not read)";
            let Some(object) = self.frame_object(tree, node, "objtype", "objname")? else {
                return Ok(Some(other(element, cameras)));
            };
            let reference = match value(node, "reftype") {
                Some(_) if referenced => {
                    match self.frame_object(tree, node, "reftype", "refname")? {
                        Some(r) => Some(r),
                        None => return Ok(Some(other(element, cameras))),
                    }
                }
                _ => None,
            };
            let unknown_axes = |f: &FrameObject| matches!(f, FrameObject::Body(b) if !self.principal_axes_known(tree, *b));
            let axes = matches!(quantity, FrameQuantity::Quat | FrameQuantity::Axis(_));
            if (axes && unknown_axes(&object)) || reference.as_ref().is_some_and(unknown_axes) {
                let why = "the inertial axes of a body with a full inertia tensor (fullinertia, \
                           or several geoms) are not MuJoCo's (its eigenvector order and signs)";
                return Ok(Some(other(element, why)));
            }
            return Ok(Some(SensorKind::Frame {
                quantity,
                object,
                reference,
            }));
        }
        if element == "insidesite" {
            check_attributes(self.file, node, &attrs(&["site", "objtype", "objname"]))?;
            let site = self.named(tree, node, "site", "site")?;
            let Some(object) = self.frame_object(tree, node, "objtype", "objname")? else {
                let why = "insidesite on a camera is not computed (cameras are not read)";
                return Ok(Some(other(element, why)));
            };
            let zone = tree.site_zones[site];
            return Ok(Some(SensorKind::InsideSite { site, zone, object }));
        }
        if element == "tendonactuatorfrc" {
            check_attributes(self.file, node, &attrs(&["tendon"]))?;
            let t = self.tendon(named, node)?;
            return Ok(Some(SensorKind::TendonActuatorForce(t)));
        }
        if let Some((_, quantity)) = TENDONS.iter().find(|(t, _)| *t == element) {
            check_attributes(self.file, node, &attrs(&["tendon"]))?;
            let t = self.tendon(named, node)?;
            let limit = !matches!(quantity, TendonQuantity::Pos | TendonQuantity::Vel);
            if limit && !named.limited[t] {
                return Err(self.error(node, "tendon must be limited in sensor"));
            }
            return Ok(Some(SensorKind::Tendon(*quantity, t)));
        }
        if let Some(potential) = match element {
            "e_potential" => Some(true),
            "e_kinetic" => Some(false),
            _ => None,
        } {
            check_attributes(self.file, node, SENSOR_ATTRS)?;
            let sprung = |j: &&crate::model::Joint| j.stiffness != 0.0 && j.kind.nv() != 1;
            if potential && tree.joints.iter().any(|j| sprung(&j)) {
                let why = "the spring energy of a ball or free joint is not computed";
                return Ok(Some(other(element, why)));
            }
            return Ok(Some(SensorKind::Energy { potential }));
        }
        if element == "touch" {
            check_attributes(self.file, node, &attrs(&["site"]))?;
            let site = self.named(tree, node, "site", "site")?;
            let zone = tree.site_zones[site];
            return Ok(Some(SensorKind::Touch { site, zone }));
        }
        if element == "rangefinder" && value(node, "camera").is_none() {
            return self.rangefinder(tree, root, node).map(Some);
        }
        let subtree = match element {
            "subtreecom" => SensorKind::SubtreeCom,
            "subtreelinvel" => SensorKind::SubtreeLinVel,
            "subtreeangmom" => SensorKind::SubtreeAngMom,
            _ => return Ok(None),
        };
        check_attributes(self.file, node, &attrs(&["body"]))?;
        Ok(Some(subtree(self.named(tree, node, "body", "body")?)))
    }

    /// The tendon a sensor's `tendon` names.
    fn tendon(&self, named: &Named, node: Node<'a>) -> Result<usize> {
        let name = value(node, "tendon").filter(|n| !n.is_empty());
        let Some(name) = name else {
            return Err(self.error(node, "the sensor needs 'tendon'"));
        };
        let found = named.tendons.iter().position(|t| t == name);
        found.ok_or_else(|| self.error(node, format!("unknown tendon '{name}'")))
    }

    /// A rangefinder on a site: its fields, and the geoms its ray may hit
    /// (see [`SensorKind::Rangefinder`]); a ray that may meet a height
    /// field is not computed.
    fn rangefinder(&self, tree: &Tree<'a>, root: Node<'a>, node: Node<'a>) -> Result<SensorKind> {
        check_attributes(self.file, node, &[SENSOR_ATTRS, &["site", "data"]].concat())?;
        let site = self.named(tree, node, "site", "site")?;
        let fields = self.data_fields(node, &RAY_DATA, "dist")?;
        let body = tree.sites[site].body;
        let mut targets = vec![];
        for (g, (geom, looks)) in tree.geoms.iter().zip(&tree.geom_looks).enumerate() {
            let alpha = match looks.material {
                Some(name) => material_alpha(root, name),
                None => Some(looks.alpha),
            };
            let Some(alpha) = alpha else {
                let why = format!("the alpha of geom {g}'s material is set by a default class");
                return Ok(other("rangefinder", &why));
            };
            if geom.body == body || alpha == 0.0 {
                continue;
            }
            if matches!(geom.shape, Shape::HField { .. }) {
                let why = "rays against height fields are not computed";
                return Ok(other("rangefinder", why));
            }
            targets.push((g, looks.plane));
        }
        Ok(SensorKind::Rangefinder {
            site,
            fields,
            targets,
        })
    }

    /// The fields a `data` attribute lists (`default` without one), each
    /// known and in the table's order.
    fn data_fields<F: Copy>(
        &self,
        node: Node<'a>,
        table: &[(&str, F)],
        default: &str,
    ) -> Result<Vec<F>> {
        let text = value(node, "data").unwrap_or(default);
        let mut last = None;
        let mut out = vec![];
        for word in text.split_whitespace() {
            let Some(i) = table.iter().position(|(k, _)| *k == word) else {
                return Err(self.error(node, format!("unknown data field '{word}'")));
            };
            if last.is_some_and(|l| i <= l) {
                let order: Vec<&str> = table.iter().map(|(k, _)| *k).collect();
                let msg = format!("data attributes must be in order: {}", order.join(", "));
                return Err(self.error(node, msg));
            }
            last = Some(i);
            out.push(table[i].1);
        }
        Ok(out)
    }

    /// A frame sensor's object (or reference) given by the attributes
    /// `type_attr` and `name_attr`; None for a camera (cameras are not read).
    fn frame_object(
        &self,
        tree: &Tree<'a>,
        node: Node<'a>,
        type_attr: &str,
        name_attr: &str,
    ) -> Result<Option<FrameObject>> {
        let a = Attrs::of(self.file, node);
        let types = ["body", "xbody", "geom", "site", "camera"];
        let Some(kind) = a.keyword(type_attr, &types)? else {
            return Err(self.error(node, format!("a frame sensor needs '{type_attr}'")));
        };
        Ok(Some(match kind {
            "body" => FrameObject::Body(self.named(tree, node, name_attr, "body")?),
            "xbody" => FrameObject::XBody(self.named(tree, node, name_attr, "body")?),
            "geom" => FrameObject::Geom(self.named(tree, node, name_attr, "geom")?),
            "site" => FrameObject::Site(self.named(tree, node, name_attr, "site")?),
            _ => return Ok(None),
        }))
    }

    /// Whether body `b`'s inertial axes ([`crate::model::Body::inertia_frame`])
    /// are MuJoCo's body_iquat: those of a diagonal `<inertial>` or of a
    /// single geom, not the principal axes of a full tensor.
    fn principal_axes_known(&self, tree: &Tree<'a>, b: usize) -> bool {
        let Some(body) = tree.nodes[b] else {
            return true;
        };
        let inertial = children(body, "inertial");
        if self.compiler.inertia_from_geom == FromGeom::True || inertial.is_empty() {
            tree.geoms.iter().filter(|g| g.body == b).count() <= 1
        } else {
            inertial.iter().all(|i| value(*i, "fullinertia").is_none())
        }
    }

    /// The index of the `kind` (body, joint, geom, site) that attribute
    /// `attr` names, by its name in the file.
    fn named(&self, tree: &Tree<'a>, node: Node<'a>, attr: &str, kind: &str) -> Result<usize> {
        let Some(name) = value(node, attr).filter(|n| !n.is_empty()) else {
            return Err(self.error(node, format!("the sensor needs '{attr}'")));
        };
        let found = match kind {
            "body" => tree.bodies.iter().position(|b| b.name == name),
            "joint" => tree.joints.iter().position(|j| j.name == name),
            "geom" => tree.geoms.iter().position(|g| g.name == name),
            _ => tree.sites.iter().position(|s| s.name == name),
        };
        found.ok_or_else(|| self.error(node, format!("unknown {kind} '{name}'")))
    }

    /// A sensor that is read but not computed, its references to bodies,
    /// joints, geoms and sites checked.
    fn other_kind(&self, tree: &Tree<'a>, node: Node<'a>) -> Result<SensorKind> {
        let element = tag(node);
        let Some((_, own, _)) = OTHERS.iter().find(|(t, ..)| *t == element) else {
            return Err(match element {
                "tactile" | "plugin" => unsupported(
                    self.file,
                    node,
                    "its size depends on meshes or plugins, which are not read",
                ),
                _ => unrecognized(self.file, node),
            });
        };
        check_attributes(self.file, node, &[SENSOR_ATTRS, own].concat())?;
        let references = [
            ("site", "site"),
            ("joint", "joint"),
            ("body", "body"),
            ("body1", "body"),
            ("body2", "body"),
            ("subtree1", "body"),
            ("subtree2", "body"),
            ("geom1", "geom"),
            ("geom2", "geom"),
        ];
        for (attr, kind) in references {
            if value(node, attr).is_some() {
                self.named(tree, node, attr, kind)?;
            }
        }
        let why = match element {
            "clock" => "it reads the simulation time, which the state (q, v, act) does not hold",
            "camprojection" | "rangefinder" => "cameras are not read",
            "user" => "user sensors are computed by the user's callback",
            _ => "this sensor type is not computed yet",
        };
        Ok(other(element, why))
    }

    /// The size MuJoCo gives a sensor that is not computed.
    fn other_dim(&self, node: Node<'a>) -> Result<usize> {
        let element = tag(node);
        if FRAMES.iter().any(|(t, _)| *t == element) {
            return Ok(if element == "framequat" { 4 } else { 3 });
        }
        let a = Attrs::of(self.file, node);
        let rays = || -> Result<usize> {
            let fields = self.data_fields(node, &RAY_DATA, "dist")?;
            Ok(fields.iter().map(|f| f.dim()).sum())
        };
        match element {
            "rangefinder" if value(node, "site").is_none() => Err(unsupported(
                self.file,
                node,
                "a camera rangefinder's size depends on the camera, which is not read",
            )),
            "rangefinder" => rays(),
            "contact" => {
                let num = a.int("num")?.unwrap_or(1);
                if num <= 0 {
                    return Err(self.error(node, "'num' must be positive in sensor"));
                }
                let fields = self.data_fields(node, &CONTACT_DATA, "found")?;
                Ok(num as usize * fields.iter().sum::<usize>())
            }
            "user" => {
                let dim = a.int("dim")?.unwrap_or(0);
                usize::try_from(dim)
                    .map_err(|_| self.error(node, "sensor dim must be non-negative in sensor"))
            }
            _ => Ok(OTHERS
                .iter()
                .find(|(t, ..)| *t == element)
                .map_or(0, |(.., dim)| *dim)),
        }
    }
}

/// The alpha of material `name` (its `rgba`, else the default 1); None
/// where a default class may set it (a `<default>` giving materials an
/// rgba), which is not followed.
fn material_alpha(root: Node, name: &str) -> Option<f64> {
    let classes = root.descendants().filter(|n| n.has_tag_name("default"));
    let class_rgba = classes
        .flat_map(|d| children(d, "material"))
        .any(|m| value(m, "rgba").is_some());
    let materials = children(root, "asset")
        .into_iter()
        .flat_map(|a| children(a, "material"));
    let found = materials
        .filter(|m| value(*m, "name") == Some(name))
        .find_map(|m| value(m, "rgba"));
    match found {
        Some(rgba) => rgba.split_whitespace().nth(3)?.parse().ok(),
        None if class_rgba => None,
        None => Some(1.0),
    }
}

fn other(element: &str, why: &str) -> SensorKind {
    SensorKind::Unsupported {
        element: element.to_string(),
        why: why.to_string(),
    }
}

#[cfg(test)]
mod tests {
    use super::super::test_util::*;
    use crate::model::{FrameObject, FrameQuantity, JointQuantity, SensorKind};

    const BODIES: &str = r#"
        <body name="b"><joint name="j"/><joint name="ball" type="ball"/><geom name="g" size=".1"/>
          <site name="s"/></body>
        <body name="c"><joint/><inertial pos="0 0 0" mass="1" fullinertia="1 1 1 0.1 0 0"/></body>"#;

    fn sensors(list: &str) -> String {
        model("", BODIES, &format!("<sensor>{list}</sensor>"))
    }

    #[test]
    fn sensors_are_laid_out_as_in_mujoco() {
        let list = r#"<jointpos joint="j" cutoff="0.5" noise="0.1"/><ballquat joint="ball"/>
            <framequat objtype="geom" objname="g"/><touch site="s"/>
            <rangefinder site="s" data="dist dir"/><contact num="2" data="found force"/>
            <user dim="5"/><framexaxis objtype="body" objname="c"/><subtreeangmom body="b"/>
            <fromto geom1="g" body2="c"/>
            <framequat objtype="site" objname="s" reftype="body" refname="c"/>
            <jointvel joint="j" delay="0.01" nsample="3"/><accelerometer site="s"/><clock/>"#;
        let m = load(&sensors(list));
        // MuJoCo 4.0.0's sensor_dim and sensor_adr.
        let (adr, dim): (Vec<usize>, Vec<usize>) = m.sensor_layout().into_iter().unzip();
        assert_eq!(dim, [1, 4, 4, 1, 4, 8, 5, 3, 3, 6, 4, 1, 3, 1]);
        assert_eq!(adr, [0, 1, 5, 9, 10, 14, 22, 27, 30, 33, 39, 43, 44, 47]);
        assert_eq!(m.sensors[0].kind, SensorKind::Joint(JointQuantity::Pos, 0));
        assert_eq!(m.sensors[0].cutoff, 0.5);
        let quat = SensorKind::Frame {
            quantity: FrameQuantity::Quat,
            object: FrameObject::Geom(0),
            reference: None,
        };
        assert_eq!(m.sensors[2].kind, quat);
        assert!(matches!(
            m.sensors[3].kind,
            SensorKind::Touch { site: 0, .. }
        ));
        assert!(matches!(
            m.sensors[4].kind,
            SensorKind::Rangefinder { site: 0, .. }
        ));
        assert_eq!(m.sensors[8].kind, SensorKind::SubtreeAngMom(1));
        // Read but not computed: other types, a full tensor's axes, history.
        for i in [5, 6, 7, 9, 10, 11, 13] {
            let kind = &m.sensors[i].kind;
            assert!(
                matches!(kind, SensorKind::Unsupported { .. }),
                "{i}: {kind:?}"
            );
        }
        assert_eq!(m.sensors[13].name, "sensor13");
    }

    #[test]
    fn bad_sensors_are_rejected() {
        #[rustfmt::skip]
        let cases = [
            (r#"<jointpos joint="ball"/>"#, "joint must be slide or hinge in sensor"),
            (r#"<ballquat joint="j"/>"#, "joint must be ball in sensor"),
            (r#"<jointlimitfrc joint="j"/>"#, "joint must be limited in sensor"),
            (r#"<jointpos joint="nope"/>"#, "unknown joint 'nope'"),
            (r#"<accelerometer site="nope"/>"#, "unknown site 'nope'"),
            ("<gyro/>", "the sensor needs 'site'"),
            (r#"<jointpos joint="j" cutoff="-1"/>"#, "cutoff must be finite and >= 0"),
            (r#"<jointpos joint="j" noise="-1"/>"#, "noise must be finite and >= 0"),
            (r#"<framepos objtype="site" objname="s" reftype="joint" refname="j"/>"#,
             "attribute 'reftype' must be one of"),
            (r#"<jointpos name="a" joint="j"/><jointvel name="a" joint="j"/>"#, "repeated name 'a'"),
            (r#"<jointpos joint="j" site="s"/>"#, "unrecognized attribute 'site'"),
            (r#"<touch site="nope"/>"#, "unknown site 'nope'"),
            (r#"<actuatorfrc actuator="nope"/>"#, "unknown actuator 'nope'"),
            ("<actuatorpos/>", "the sensor needs 'actuator'"),
            (r#"<jointactuatorfrc joint="ball"/>"#, "joint must be slide or hinge in sensor"),
            (r#"<contact data="force found"/>"#, "data attributes must be in order"),
            (r#"<tactile mesh="m" geom="g"/>"#, "<tactile> is not supported"),
            ("<thermometer/>", "unrecognized element <thermometer>"),
        ];
        for (list, expected) in cases {
            assert_rejects(&sensors(list), expected);
        }
        let tendon = r#"<tendon><fixed name="t"><joint joint="j" coef="1"/></fixed></tendon>"#;
        for (list, expected) in [
            (r#"<tendonpos tendon="u"/>"#, "unknown tendon 'u'"),
            (
                r#"<tendonlimitfrc tendon="t"/>"#,
                "tendon must be limited in sensor",
            ),
        ] {
            assert_rejects(
                &model("", BODIES, &format!("{tendon}<sensor>{list}</sensor>")),
                expected,
            );
        }
        let head = r#"<option><flag sensor="disable"/></option>"#;
        let tail = r#"<sensor><jointpos joint="j"/></sensor>"#;
        let m = load(&model(head, BODIES, tail));
        assert!(matches!(m.sensors[0].kind, SensorKind::Unsupported { .. }));
    }
}
