//! URDF loader: [`parse`] builds a [`Model`] from URDF text.
//!
//! How URDF maps onto the model (see the `model` module for its frames):
//! - Every link is a body whose frame is the link frame. A joint's `<origin>`
//!   is its child body's `pos`/`rot` in the parent body at q = 0 (`reference`
//!   0); the joint turns about, or slides along, `<axis>` (default x,
//!   normalised) through the body origin (`anchor` 0).
//! - `rpy` is fixed-axis roll-pitch-yaw: R = Rz(yaw) Ry(pitch) Rx(roll).
//! - `<inertial>`: the COM is its origin `xyz`; `<inertia>` is about the COM in
//!   the axes of its origin `rpy`, turned into link axes as R I R^T. A link with
//!   no `<inertial>` has mass 0 and zero inertia, as the URDF spec says
//!   (PyBullet and DART give it 1 kg and identity inertia instead).
//! - Joint types: revolute and continuous are hinges, prismatic is a slide,
//!   fixed welds the child to its parent (a body with no joint); floating and
//!   planar are rejected.
//! - A revolute or prismatic joint is limited when its `<limit>` has
//!   lower < upper; absent bounds are 0 (the URDF default), so a `<limit>`
//!   without them means unlimited, as in PyBullet. `effort` and `velocity` are
//!   ignored. Continuous joints are never limited.
//! - `<dynamics damping friction>` are the joint's damping and frictionloss.
//! - Bodies are numbered depth-first from the root link (the one link that is
//!   no joint's child), children in the document order of their joints. A
//!   root named `world` is the world (body 0; its `<inertial>` is ignored, its
//!   collisions are world geoms); any other root becomes body 1, welded to the
//!   world.
//! - `<collision>` box, sphere, cylinder (along z, `length` the full length) and
//!   PyBullet's capsule (`length` between the sphere centres) become geoms with
//!   contype = conaffinity = 1; mesh collisions are skipped (no geom), and
//!   `<visual>` is ignored. Friction comes from PyBullet's `<contact>` element
//!   of the link (lateral, spinning, rolling), default PyBullet's (0.5, 0, 0).
//! - A `<transmission>` with one `<joint>` is an actuator on that joint: gear =
//!   `<mechanicalReduction>` (default 1), name = its `<actuator name>`, else
//!   the transmission's name.
//! - Options: gravity -9.81 z, timestep 0.002 s, semi-implicit Euler and
//!   explicit passive forces (a URDF model runs as PyBullet runs it).
//!
//! What URDF cannot say is carried by extensions in the namespace [`NAMESPACE`]
//! (declare `xmlns:diffosi="urn:diffosi:urdf"` on `<robot>`), which PyBullet and
//! DART ignore:
//! - `<diffosi:options timestep="0.01" gravity="0 0 -9.81" integrator="Euler|RK4"
//!   passive="explicit|implicit_damping|implicit_damping_stiffness"/>` in
//!   `<robot>`, every attribute optional;
//! - `diffosi:stiffness`, `diffosi:springref`, `diffosi:armature` on `<dynamics>`;
//! - `diffosi:contype`, `diffosi:conaffinity` on `<collision>` (MJCF bitmasks);
//! - `diffosi:ctrlrange="lo hi"` on a transmission's `<actuator>`.
//!
//! Anything else in that namespace is an error, so a typo is never dropped.
//! Errors name the file, the 1-based line and the element.

use std::collections::HashMap;

use nalgebra::{Matrix3, Rotation3, Vector3};

use super::params::inertia_from_six;
use roxmltree::{Document, Node};

use super::{
    check_inertial, xml, Actuator, Body, Geom, Integrator, Joint, JointKind, Model, ModelError,
    Options, PassiveMode, Shape,
};

/// The namespace of diffosi's URDF extensions.
pub const NAMESPACE: &str = "urn:diffosi:urdf";

/// Extension attributes allowed on each URDF element.
const EXTENSION_ATTRIBUTES: [(&str, &[&str]); 3] = [
    ("dynamics", &["stiffness", "springref", "armature"]),
    ("collision", &["contype", "conaffinity"]),
    ("actuator", &["ctrlrange"]),
];

/// Parses URDF text; `file` is only used in error messages.
pub fn parse(text: &str, file: &str) -> Result<Model, ModelError> {
    let doc = xml::document(text, file)?;
    Loader { doc: &doc, file }.model()
}

type Xml<'a, 'i> = Node<'a, 'i>;

/// A joint as an edge of the link tree.
struct Edge<'a, 'i> {
    node: Xml<'a, 'i>,
    name: &'a str,
    parent: usize,
    child: usize,
}

/// The link tree: its root and the links in depth-first order, each with the
/// edge (joint) that leads to it.
struct Tree {
    root: usize,
    order: Vec<usize>,
    parent_edge: Vec<Option<usize>>,
}

struct Loader<'a, 'i> {
    doc: &'a Document<'i>,
    file: &'a str,
}

impl<'a, 'i> Loader<'a, 'i> {
    fn model(&self) -> Result<Model, ModelError> {
        let robot = self.doc.root_element();
        if !is(robot, "robot") {
            return Err(self.error(robot, "the root element must be <robot>"));
        }
        self.check_extensions(robot)?;
        let name = self.attr(robot, "name")?.to_string();
        let links: Vec<_> = robot.children().filter(|n| is(*n, "link")).collect();
        let edges = self.edges(robot, &links)?;
        let tree = self.tree(robot, &links, &edges)?;

        let mut bodies = vec![Body::world()];
        let mut joints = Vec::new();
        let mut geoms = Vec::new();
        let mut dof_of_joint: HashMap<&str, Option<usize>> = HashMap::new();
        let mut body_of_link = vec![0; links.len()];
        for &l in &tree.order {
            let link = links[l];
            let link_name = self.attr(link, "name")?;
            if l == tree.root && link_name == "world" {
                geoms.extend(self.geoms(link, 0)?);
                continue;
            }
            if link_name == "world" {
                return Err(self.error(link, "only the root link may be named 'world'"));
            }
            let body = bodies.len();
            body_of_link[l] = body;
            let first_joint = joints.len();
            let (parent, pos, rot) = match tree.parent_edge[l] {
                None => (0, Vector3::zeros(), Rotation3::identity()),
                Some(e) => {
                    let edge = &edges[e];
                    let joint = self.joint(edge.node, body)?;
                    dof_of_joint.insert(edge.name, joint.as_ref().map(|_| joints.len()));
                    joints.extend(joint);
                    let (pos, rot) = self.origin(edge.node)?;
                    (body_of_link[edge.parent], pos, rot)
                }
            };
            let (mass, com, inertia) = self.inertial(link)?;
            bodies.push(Body {
                name: link_name.to_string(),
                parent,
                pos,
                rot,
                mass,
                com,
                inertia,
                joints: first_joint..joints.len(),
            });
            geoms.extend(self.geoms(link, body)?);
        }
        let actuators = self.actuators(robot, &dof_of_joint)?;
        let opt = self.options(robot)?;
        Model::new(name, bodies, joints, actuators, geoms, opt)
    }

    // ---- the link tree ----

    /// The joints as edges between link indices.
    fn edges(
        &self,
        robot: Xml<'a, 'i>,
        links: &[Xml<'a, 'i>],
    ) -> Result<Vec<Edge<'a, 'i>>, ModelError> {
        let mut link_index = HashMap::new();
        for (i, &link) in links.iter().enumerate() {
            if link_index.insert(self.attr(link, "name")?, i).is_some() {
                return Err(self.error(link, "duplicate link name"));
            }
        }
        let mut edges: Vec<Edge> = Vec::new();
        for node in robot.children().filter(|n| is(*n, "joint")) {
            let name = self.attr(node, "name")?;
            if edges.iter().any(|e| e.name == name) {
                return Err(self.error(node, format!("duplicate joint name '{name}'")));
            }
            let end = |role: &str| -> Result<usize, ModelError> {
                let element = self.required_child(node, role)?;
                let link = self.attr(element, "link")?;
                link_index.get(link).copied().ok_or_else(|| {
                    self.error(
                        element,
                        format!("joint '{name}' names unknown link '{link}'"),
                    )
                })
            };
            let (parent, child) = (end("parent")?, end("child")?);
            edges.push(Edge {
                node,
                name,
                parent,
                child,
            });
        }
        Ok(edges)
    }

    /// Checks that the links form one tree and orders them depth-first.
    fn tree(
        &self,
        robot: Xml<'a, 'i>,
        links: &[Xml<'a, 'i>],
        edges: &[Edge],
    ) -> Result<Tree, ModelError> {
        let mut parent_edge: Vec<Option<usize>> = vec![None; links.len()];
        for (e, edge) in edges.iter().enumerate() {
            if let Some(first) = parent_edge[edge.child].replace(e) {
                return Err(self.error(
                    edge.node,
                    format!(
                        "link '{}' has two parents: joints '{}' and '{}'",
                        self.attr(links[edge.child], "name")?,
                        edges[first].name,
                        edge.name
                    ),
                ));
            }
        }
        let roots: Vec<usize> = (0..links.len())
            .filter(|&l| parent_edge[l].is_none())
            .collect();
        let root = match roots[..] {
            [root] => root,
            [] if links.is_empty() => return Err(self.error(robot, "the robot has no links")),
            [] => return Err(self.error(robot, "no root link: the joints form a cycle")),
            [first, second, ..] => {
                return Err(self.error(
                    links[second],
                    format!(
                        "two root links '{}' and '{}' (neither is a joint's child)",
                        self.attr(links[first], "name")?,
                        self.attr(links[second], "name")?
                    ),
                ))
            }
        };
        let mut order = Vec::with_capacity(links.len());
        let mut stack = vec![root];
        while let Some(l) = stack.pop() {
            order.push(l);
            stack.extend(
                edges
                    .iter()
                    .rev()
                    .filter(|e| e.parent == l)
                    .map(|e| e.child),
            );
        }
        if order.len() < links.len() {
            let lost = (0..links.len())
                .find(|l| !order.contains(l))
                .unwrap_or(root);
            let edge = parent_edge[lost].map_or(robot, |e| edges[e].node);
            return Err(self.error(
                edge,
                format!(
                    "link '{}' is not reachable from the root link: the joints form a cycle",
                    self.attr(links[lost], "name")?
                ),
            ));
        }
        Ok(Tree {
            root,
            order,
            parent_edge,
        })
    }

    // ---- links ----

    /// Mass, COM and inertia about the COM in link axes.
    fn inertial(&self, link: Xml<'a, 'i>) -> Result<(f64, Vector3<f64>, Matrix3<f64>), ModelError> {
        let Some(inertial) = child(link, "inertial") else {
            return Ok((0.0, Vector3::zeros(), Matrix3::zeros()));
        };
        let mass_node = self.required_child(inertial, "mass")?;
        let mass = self.required_number(mass_node, "value")?;
        if mass < 0.0 {
            return Err(self.error(mass_node, format!("negative mass {mass}")));
        }
        let node = self.required_child(inertial, "inertia")?;
        let mut i = [0.0; 6];
        for (value, name) in i.iter_mut().zip(["ixx", "iyy", "izz", "ixy", "ixz", "iyz"]) {
            *value = self.required_number(node, name)?;
        }
        let tensor = inertia_from_six(&i);
        let (com, rot) = self.origin(inertial)?;
        let inertia = rot.matrix() * tensor * rot.matrix().transpose();
        let name = self.attr(link, "name")?;
        check_inertial(name, mass, &com, &inertia)
            .map_err(|e| self.error(inertial, e.to_string()))?;
        Ok((mass, com, inertia))
    }

    fn geoms(&self, link: Xml<'a, 'i>, body: usize) -> Result<Vec<Geom>, ModelError> {
        let friction = self.friction(link)?;
        let mut geoms = Vec::new();
        for collision in link.children().filter(|n| is(*n, "collision")) {
            let geometry = self.required_child(collision, "geometry")?;
            let Some(shape) = self.shape(geometry)? else {
                continue;
            };
            let (pos, rot) = self.origin(collision)?;
            geoms.push(Geom {
                name: collision.attribute("name").unwrap_or_default().to_string(),
                body,
                shape,
                pos,
                rot,
                contype: self.bitmask(collision, "contype")?,
                conaffinity: self.bitmask(collision, "conaffinity")?,
                friction,
            });
        }
        Ok(geoms)
    }

    /// The shape inside `<geometry>`; `None` for a mesh.
    fn shape(&self, geometry: Xml<'a, 'i>) -> Result<Option<Shape>, ModelError> {
        let Some(node) = geometry.children().find(|n| n.is_element()) else {
            return Err(self.error(geometry, "empty <geometry>"));
        };
        let size = |name: &str| -> Result<f64, ModelError> {
            let value = self.required_number(node, name)?;
            if value > 0.0 {
                Ok(value)
            } else {
                Err(self.error(node, format!("{name} must be positive, got {value}")))
            }
        };
        let shape = match node.tag_name().name() {
            "box" => {
                let [x, y, z] = self.required_numbers(node, "size")?;
                if x.min(y).min(z) <= 0.0 {
                    return Err(self.error(node, "box size must be positive"));
                }
                Shape::Box {
                    half: Vector3::new(x, y, z) / 2.0,
                }
            }
            "sphere" => Shape::Sphere {
                radius: size("radius")?,
            },
            "cylinder" => Shape::Cylinder {
                radius: size("radius")?,
                half_length: size("length")? / 2.0,
            },
            "capsule" => Shape::Capsule {
                radius: size("radius")?,
                half_length: size("length")? / 2.0,
            },
            "mesh" => return Ok(None),
            other => return Err(self.error(node, format!("unknown geometry '{other}'"))),
        };
        Ok(Some(shape))
    }

    /// Sliding, torsional, rolling friction from PyBullet's `<contact>`.
    fn friction(&self, link: Xml<'a, 'i>) -> Result<[f64; 3], ModelError> {
        let mut friction = [0.5, 0.0, 0.0];
        let Some(contact) = child(link, "contact") else {
            return Ok(friction);
        };
        for (value, name) in
            friction
                .iter_mut()
                .zip(["lateral_friction", "spinning_friction", "rolling_friction"])
        {
            if let Some(node) = child(contact, name) {
                *value = self.required_number(node, "value")?;
            }
        }
        Ok(friction)
    }

    fn bitmask(&self, collision: Xml<'a, 'i>, name: &str) -> Result<u32, ModelError> {
        match collision.attribute((NAMESPACE, name)) {
            None => Ok(1),
            Some(text) => text.trim().parse().map_err(|_| {
                self.error(
                    collision,
                    format!("diffosi:{name} must be an unsigned integer, got '{text}'"),
                )
            }),
        }
    }

    // ---- joints ----

    /// The joint of a `<joint>` element moving `body`; `None` for a fixed joint.
    fn joint(&self, node: Xml<'a, 'i>, body: usize) -> Result<Option<Joint>, ModelError> {
        let ty = self.attr(node, "type")?;
        let kind = match ty {
            "revolute" | "continuous" => JointKind::Hinge,
            "prismatic" => JointKind::Slide,
            "fixed" => return Ok(None),
            other @ ("floating" | "planar") => {
                return Err(self.error(
                    node,
                    format!(
                        "{other} joints are not supported: every joint has one dof \
                         (revolute, continuous, prismatic or fixed)"
                    ),
                ))
            }
            other => return Err(self.error(node, format!("unknown joint type '{other}'"))),
        };
        let axis = match child(node, "axis") {
            None => Vector3::x(),
            Some(axis) => {
                let [x, y, z] = self.required_numbers(axis, "xyz")?;
                Vector3::new(x, y, z)
                    .try_normalize(0.0)
                    .ok_or_else(|| self.error(axis, "the axis must not be zero"))?
            }
        };
        let range = match child(node, "limit") {
            Some(limit) if ty != "continuous" => {
                let lower = self.number(limit, "lower")?.unwrap_or(0.0);
                let upper = self.number(limit, "upper")?.unwrap_or(0.0);
                (lower < upper).then_some((lower, upper))
            }
            _ => None,
        };
        let [damping, frictionloss, stiffness, springref, armature] = self.dynamics(node)?;
        Ok(Some(Joint {
            name: self.attr(node, "name")?.to_string(),
            kind,
            body,
            axis,
            anchor: Vector3::zeros(),
            reference: 0.0,
            damping,
            stiffness,
            springref,
            armature,
            frictionloss,
            range,
        }))
    }

    /// `<dynamics>`: damping, frictionloss, stiffness, springref, armature.
    fn dynamics(&self, joint: Xml<'a, 'i>) -> Result<[f64; 5], ModelError> {
        let Some(node) = child(joint, "dynamics") else {
            return Ok([0.0; 5]);
        };
        let nonnegative = |name: &str, value: Option<f64>| match value.unwrap_or(0.0) {
            v if v < 0.0 => Err(self.error(node, format!("{name} must be >= 0, got {v}"))),
            v => Ok(v),
        };
        Ok([
            nonnegative("damping", self.number(node, "damping")?)?,
            nonnegative("friction", self.number(node, "friction")?)?,
            nonnegative(
                "diffosi:stiffness",
                self.extension_number(node, "stiffness")?,
            )?,
            self.extension_number(node, "springref")?.unwrap_or(0.0),
            nonnegative("diffosi:armature", self.extension_number(node, "armature")?)?,
        ])
    }

    fn actuators(
        &self,
        robot: Xml<'a, 'i>,
        dof_of_joint: &HashMap<&str, Option<usize>>,
    ) -> Result<Vec<Actuator>, ModelError> {
        let mut actuators = Vec::new();
        for node in robot.children().filter(|n| is(*n, "transmission")) {
            let joints: Vec<_> = node.children().filter(|n| is(*n, "joint")).collect();
            let [joint_node] = joints[..] else {
                return Err(self.error(node, "a transmission must drive exactly one <joint>"));
            };
            let joint_name = self.attr(joint_node, "name")?;
            let joint = match dof_of_joint.get(joint_name) {
                Some(Some(dof)) => *dof,
                Some(None) => {
                    return Err(self.error(joint_node, format!("joint '{joint_name}' is fixed")))
                }
                None => return Err(self.error(joint_node, format!("unknown joint '{joint_name}'"))),
            };
            let actuator = child(node, "actuator");
            let gear = match actuator.and_then(|a| child(a, "mechanicalReduction")) {
                None => 1.0,
                Some(reduction) => {
                    let text = reduction.text().unwrap_or_default();
                    self.parse_numbers::<1>(reduction, "mechanicalReduction", text)?[0]
                }
            };
            let ctrl_range = match actuator {
                None => None,
                Some(a) => self.extension_numbers::<2>(a, "ctrlrange")?,
            };
            if let Some([lo, hi]) = ctrl_range.filter(|[lo, hi]| lo >= hi) {
                return Err(self.error(
                    actuator.unwrap_or(node),
                    format!("ctrlrange {lo} {hi} is empty"),
                ));
            }
            let name = match actuator.and_then(|a| a.attribute("name")) {
                Some(name) => name,
                None => self.attr(node, "name")?,
            };
            actuators.push(Actuator {
                name: name.to_string(),
                joint,
                gear,
                ctrl_range: ctrl_range.map(|[lo, hi]| (lo, hi)),
            });
        }
        Ok(actuators)
    }

    fn options(&self, robot: Xml<'a, 'i>) -> Result<Options, ModelError> {
        let mut opt = Options {
            passive: PassiveMode::Explicit,
            ..Options::default()
        };
        let Some(node) = robot.children().find(|n| is_extension(*n, "options")) else {
            return Ok(opt);
        };
        if let Some(timestep) = self.number(node, "timestep")? {
            if timestep <= 0.0 {
                return Err(self.error(node, format!("timestep must be positive, got {timestep}")));
            }
            opt.timestep = timestep;
        }
        if let Some([x, y, z]) = self.numbers::<3>(node, "gravity")? {
            opt.gravity = Vector3::new(x, y, z);
        }
        opt.integrator = match node.attribute("integrator") {
            None | Some("Euler") => Integrator::Euler,
            Some("RK4") => Integrator::Rk4,
            Some(other) => {
                return Err(self.error(
                    node,
                    format!("integrator must be Euler or RK4, got '{other}'"),
                ))
            }
        };
        opt.passive = match node.attribute("passive") {
            None | Some("explicit") => PassiveMode::Explicit,
            Some("implicit_damping") => PassiveMode::ImplicitDamping,
            Some("implicit_damping_stiffness") => PassiveMode::ImplicitDampingStiffness,
            Some(other) => {
                return Err(self.error(
                    node,
                    format!(
                        "passive must be explicit, implicit_damping or \
                         implicit_damping_stiffness, got '{other}'"
                    ),
                ))
            }
        };
        Ok(opt)
    }

    /// Rejects extension elements and attributes that this loader would not read.
    fn check_extensions(&self, robot: Xml<'a, 'i>) -> Result<(), ModelError> {
        let mut options = 0;
        for node in robot.descendants().filter(|n| n.is_element()) {
            if node.tag_name().namespace() == Some(NAMESPACE) {
                options += 1;
                if node.tag_name().name() != "options" || node.parent() != Some(robot) {
                    return Err(self.error(
                        node,
                        "unknown diffosi element (only <diffosi:options> in <robot>)",
                    ));
                }
                if options > 1 {
                    return Err(self.error(node, "more than one <diffosi:options>"));
                }
            }
            let allowed = EXTENSION_ATTRIBUTES
                .iter()
                .find(|(element, _)| is(node, element))
                .map_or(&[][..], |(_, names)| *names);
            for attribute in node
                .attributes()
                .filter(|a| a.namespace() == Some(NAMESPACE))
            {
                if !allowed.contains(&attribute.name()) {
                    return Err(self.error(
                        node,
                        format!("unknown extension attribute diffosi:{}", attribute.name()),
                    ));
                }
            }
        }
        Ok(())
    }

    // ---- attributes and numbers ----

    /// `xyz` and `rpy` of the `<origin>` child of `node` (identity if absent).
    fn origin(&self, node: Xml<'a, 'i>) -> Result<(Vector3<f64>, Rotation3<f64>), ModelError> {
        let Some(origin) = child(node, "origin") else {
            return Ok((Vector3::zeros(), Rotation3::identity()));
        };
        let [x, y, z] = self.numbers(origin, "xyz")?.unwrap_or_default();
        let [roll, pitch, yaw] = self.numbers(origin, "rpy")?.unwrap_or_default();
        Ok((
            Vector3::new(x, y, z),
            Rotation3::from_euler_angles(roll, pitch, yaw),
        ))
    }

    fn attr(&self, node: Xml<'a, 'i>, name: &str) -> Result<&'a str, ModelError> {
        node.attribute(name)
            .ok_or_else(|| self.error(node, format!("missing attribute '{name}'")))
    }

    fn required_child(&self, node: Xml<'a, 'i>, name: &str) -> Result<Xml<'a, 'i>, ModelError> {
        child(node, name).ok_or_else(|| self.error(node, format!("missing <{name}>")))
    }

    fn number(&self, node: Xml<'a, 'i>, name: &str) -> Result<Option<f64>, ModelError> {
        Ok(self.numbers::<1>(node, name)?.map(|[x]| x))
    }

    fn required_number(&self, node: Xml<'a, 'i>, name: &str) -> Result<f64, ModelError> {
        Ok(self.required_numbers::<1>(node, name)?[0])
    }

    fn extension_number(&self, node: Xml<'a, 'i>, name: &str) -> Result<Option<f64>, ModelError> {
        Ok(self.extension_numbers::<1>(node, name)?.map(|[x]| x))
    }

    fn required_numbers<const K: usize>(
        &self,
        node: Xml<'a, 'i>,
        name: &str,
    ) -> Result<[f64; K], ModelError> {
        self.parse_numbers(node, name, self.attr(node, name)?)
    }

    fn numbers<const K: usize>(
        &self,
        node: Xml<'a, 'i>,
        name: &str,
    ) -> Result<Option<[f64; K]>, ModelError> {
        node.attribute(name)
            .map(|text| self.parse_numbers(node, name, text))
            .transpose()
    }

    fn extension_numbers<const K: usize>(
        &self,
        node: Xml<'a, 'i>,
        name: &str,
    ) -> Result<Option<[f64; K]>, ModelError> {
        node.attribute((NAMESPACE, name))
            .map(|text| self.parse_numbers(node, &format!("diffosi:{name}"), text))
            .transpose()
    }

    /// Exactly `K` finite numbers separated by whitespace; `what` names them in errors.
    fn parse_numbers<const K: usize>(
        &self,
        node: Xml<'a, 'i>,
        what: &str,
        text: &str,
    ) -> Result<[f64; K], ModelError> {
        let bad = || {
            let expected = if K == 1 {
                "a finite number".to_string()
            } else {
                format!("{K} finite numbers")
            };
            self.error(node, format!("{what}: expected {expected}, got '{text}'"))
        };
        xml::numbers(text)
            .and_then(|v| v.try_into().ok())
            .ok_or_else(bad)
    }

    fn error(&self, node: Xml<'a, 'i>, message: impl Into<String>) -> ModelError {
        xml::invalid(self.file, node, message)
    }
}

/// A URDF element (not one of our extensions) with this local name.
fn is(node: Xml, name: &str) -> bool {
    node.is_element()
        && node.tag_name().name() == name
        && node.tag_name().namespace() != Some(NAMESPACE)
}

fn is_extension(node: Xml, name: &str) -> bool {
    node.is_element()
        && node.tag_name().name() == name
        && node.tag_name().namespace() == Some(NAMESPACE)
}

fn child<'a, 'i>(node: Xml<'a, 'i>, name: &str) -> Option<Xml<'a, 'i>> {
    node.children().find(|n| is(*n, name))
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::FRAC_PI_2;

    fn load(body: &str) -> Result<Model, ModelError> {
        parse(&urdf(body), "test.urdf")
    }

    fn urdf(body: &str) -> String {
        format!("<robot name=\"r\" xmlns:diffosi=\"{NAMESPACE}\">\n{body}\n</robot>")
    }

    /// A link with a unit mass and inertia.
    fn link(name: &str) -> String {
        format!(
            "<link name=\"{name}\"><inertial><mass value=\"1\"/>\
             <inertia ixx=\"1\" iyy=\"1\" izz=\"1\" ixy=\"0\" ixz=\"0\" iyz=\"0\"/></inertial></link>"
        )
    }

    fn joint(name: &str, kind: &str, parent: &str, child: &str, extra: &str) -> String {
        format!(
            "<joint name=\"{name}\" type=\"{kind}\"><parent link=\"{parent}\"/>\
             <child link=\"{child}\"/>{extra}</joint>"
        )
    }

    fn close(a: &Matrix3<f64>, b: &Matrix3<f64>) -> bool {
        (a - b).abs().max() < 1e-15
    }

    #[test]
    fn rpy_is_fixed_axis_roll_then_pitch_then_yaw() {
        let origin = "<origin xyz=\"1 2 3\" rpy=\"0.3 -0.7 1.1\"/>";
        let text = format!(
            "<link name=\"world\"/>{}{}",
            link("a"),
            joint("j", "fixed", "world", "a", origin)
        );
        let m = load(&text).unwrap();
        let about = |axis: Vector3<f64>, angle: f64| {
            Rotation3::from_axis_angle(&nalgebra::Unit::new_normalize(axis), angle)
        };
        let expected =
            about(Vector3::z(), 1.1) * about(Vector3::y(), -0.7) * about(Vector3::x(), 0.3);
        assert!(close(m.bodies[1].rot.matrix(), expected.matrix()));
        assert_eq!(m.bodies[1].pos, Vector3::new(1.0, 2.0, 3.0));

        // A known rotation: roll 90 degrees turns the body's y axis onto world z.
        let origin = format!("<origin rpy=\"{FRAC_PI_2} 0 0\"/>");
        let text = format!(
            "<link name=\"world\"/>{}{}",
            link("a"),
            joint("j", "fixed", "world", "a", &origin)
        );
        let m = load(&text).unwrap();
        assert!((m.bodies[1].rot * Vector3::y() - Vector3::z()).norm() < 1e-15);
    }

    #[test]
    fn inertia_is_turned_into_link_axes() {
        let text = format!(
            "<link name=\"a\"><inertial><origin xyz=\"0.1 0.2 0.3\" rpy=\"0 0 {FRAC_PI_2}\"/>\
             <mass value=\"2\"/><inertia ixx=\"1\" iyy=\"2\" izz=\"2.5\" ixy=\"0\" ixz=\"0\" iyz=\"0\"/>\
             </inertial></link>"
        );
        let b = &load(&text).unwrap().bodies[1];
        assert_eq!((b.mass, b.com), (2.0, Vector3::new(0.1, 0.2, 0.3)));
        // Yaw 90 degrees: the inertial x axis is the link's y axis.
        assert!(close(
            &b.inertia,
            &Matrix3::from_diagonal(&Vector3::new(2.0, 1.0, 2.5))
        ));
    }

    #[test]
    fn errors_name_line_and_element() {
        let two_roots = format!("{}\n{}", link("a"), link("b"));
        let cycle = format!(
            "<link name=\"world\"/>{}{}\n{}\n{}",
            link("a"),
            link("b"),
            joint("ab", "fixed", "a", "b", ""),
            joint("ba", "fixed", "b", "a", "")
        );
        let two_parents = format!(
            "<link name=\"world\"/>{}\n{}\n{}",
            link("a"),
            joint("j1", "fixed", "world", "a", ""),
            joint("j2", "fixed", "world", "a", "")
        );
        let negative_mass = "<link name=\"a\"><inertial>\n<mass value=\"-1\"/>\
                             <inertia ixx=\"1\" iyy=\"1\" izz=\"1\" ixy=\"0\" ixz=\"0\" iyz=\"0\"/></inertial></link>";
        let cases: Vec<(String, u32, &str, &str)> = vec![
            ("<link/>".into(), 2, "link", "missing attribute 'name'"),
            (
                "<link name=\"a\"><inertial><mass value=\"1 kg\"/></inertial></link>".into(),
                2,
                "mass",
                "value: expected a finite number, got '1 kg'",
            ),
            (
                format!(
                    "<link name=\"world\"/>\n{}",
                    joint("j", "fixed", "world", "nowhere", "")
                ),
                3,
                "child",
                "unknown link 'nowhere'",
            ),
            (two_roots, 3, "link", "two root links 'a' and 'b'"),
            (
                cycle,
                4,
                "joint",
                "link 'a' is not reachable from the root link: the joints form a cycle",
            ),
            (
                two_parents,
                4,
                "joint",
                "link 'a' has two parents: joints 'j1' and 'j2'",
            ),
            (negative_mass.into(), 3, "mass", "negative mass -1"),
            (
                format!(
                    "<link name=\"world\"/>{}\n{}",
                    link("a"),
                    joint("j", "floating", "world", "a", "")
                ),
                3,
                "joint",
                "floating joints are not supported",
            ),
            (
                format!(
                    "<link name=\"world\"/>{}\n{}",
                    link("a"),
                    joint("j", "revolute", "world", "a", "<axis xyz=\"0 0\"/>")
                ),
                3,
                "axis",
                "xyz: expected 3 finite numbers, got '0 0'",
            ),
            (
                format!(
                    "<link name=\"world\"/>{}\n{}",
                    link("a"),
                    joint(
                        "j",
                        "prismatic",
                        "world",
                        "a",
                        "<dynamics diffosi:stifness=\"1\"/>"
                    )
                ),
                3,
                "dynamics",
                "unknown extension attribute diffosi:stifness",
            ),
        ];
        for (body, line, element, message) in cases {
            match load(&body) {
                Err(ModelError::Invalid {
                    file,
                    line: l,
                    element: e,
                    message: m,
                }) => {
                    assert_eq!(
                        (file.as_str(), l, e.as_str()),
                        ("test.urdf", line, element),
                        "{m}"
                    );
                    assert!(m.contains(message), "'{m}' should contain '{message}'");
                }
                other => panic!("expected an Invalid error for {body}, got {other:?}"),
            }
        }
        assert!(matches!(
            load("<link name=\"a\">"),
            Err(ModelError::Xml { .. })
        ));
    }

    #[test]
    fn fixed_joints_weld_and_a_root_not_named_world_is_welded_to_the_world() {
        let text = format!(
            "{}{}{}{}{}",
            link("base"),
            link("arm"),
            link("tool"),
            joint(
                "shoulder",
                "revolute",
                "base",
                "arm",
                "<axis xyz=\"0 0 2\"/>"
            ),
            joint(
                "flange",
                "fixed",
                "arm",
                "tool",
                "<origin xyz=\"0 0 0.5\"/>"
            )
        );
        let m = load(&text).unwrap();
        let names: Vec<_> = m.bodies.iter().map(|b| b.name.as_str()).collect();
        assert_eq!(names, ["world", "base", "arm", "tool"]);
        assert_eq!((m.bodies[1].parent, m.bodies[1].joints.clone()), (0, 0..0));
        assert_eq!((m.bodies[3].parent, m.bodies[3].joints.clone()), (2, 1..1));
        assert_eq!(m.bodies[3].pos, Vector3::new(0.0, 0.0, 0.5));
        assert_eq!((m.nq(), m.joints[0].body), (1, 2));
        assert_eq!(m.joints[0].axis, Vector3::z());
    }

    #[test]
    fn continuous_joints_are_unlimited_hinges() {
        let limit = "<limit lower=\"-1\" upper=\"1\" effort=\"1\" velocity=\"1\"/>";
        let text = format!(
            "<link name=\"world\"/>{}{}{}{}{}",
            link("a"),
            link("b"),
            link("c"),
            joint("free", "continuous", "world", "a", limit),
            joint("bounded", "revolute", "a", "b", limit),
        ) + &joint(
            "slide",
            "prismatic",
            "b",
            "c",
            "<limit effort=\"1\" velocity=\"1\"/>",
        );
        let m = load(&text).unwrap();
        let kinds: Vec<_> = m.joints.iter().map(|j| (j.kind, j.range)).collect();
        assert_eq!(
            kinds,
            [
                (JointKind::Hinge, None),
                (JointKind::Hinge, Some((-1.0, 1.0))),
                (JointKind::Slide, None)
            ]
        );
        assert_eq!(m.joints[0].axis, Vector3::x());
    }

    #[test]
    fn extensions_carry_what_urdf_cannot_say() {
        let dynamics = "<dynamics damping=\"0.5\" friction=\"0.2\" diffosi:stiffness=\"3\" \
                        diffosi:springref=\"-0.1\" diffosi:armature=\"0.1\"/>";
        let text = format!(
            "<diffosi:options timestep=\"0.01\" gravity=\"0 0 -1\" integrator=\"RK4\" passive=\"implicit_damping\"/>\
             <link name=\"world\"/>{}{}\
             <transmission name=\"t\"><joint name=\"j\"/>\
             <actuator name=\"motor\" diffosi:ctrlrange=\"-2 2\"><mechanicalReduction>50</mechanicalReduction></actuator>\
             </transmission>",
            link("a"),
            joint("j", "revolute", "world", "a", dynamics)
        );
        let m = load(&text).unwrap();
        let j = &m.joints[0];
        let passive = (
            j.damping,
            j.frictionloss,
            j.stiffness,
            j.springref,
            j.armature,
        );
        assert_eq!(passive, (0.5, 0.2, 3.0, -0.1, 0.1));
        let a = &m.actuators[0];
        assert_eq!(
            (a.name.as_str(), a.joint, a.gear, a.ctrl_range),
            ("motor", 0, 50.0, Some((-2.0, 2.0)))
        );
        let o = &m.opt;
        assert_eq!(
            (o.timestep, o.gravity.z, o.integrator, o.passive),
            (0.01, -1.0, Integrator::Rk4, PassiveMode::ImplicitDamping)
        );

        let defaults = load(&link("a")).unwrap().opt.clone();
        assert_eq!(
            (defaults.timestep, defaults.passive),
            (0.002, PassiveMode::Explicit)
        );
    }

    #[test]
    fn collisions_become_geoms_and_meshes_are_skipped() {
        let text = "<link name=\"world\">\
            <collision name=\"floor\" diffosi:conaffinity=\"0\"><origin xyz=\"0 0 -0.5\"/><geometry><box size=\"2 4 1\"/></geometry></collision>\
            <collision><geometry><cylinder radius=\"0.1\" length=\"1\"/></geometry></collision>\
            <collision><geometry><capsule radius=\"0.1\" length=\"0.4\"/></geometry></collision>\
            <collision><geometry><mesh filename=\"x.stl\"/></geometry></collision>\
            <contact><lateral_friction value=\"0.9\"/></contact></link>";
        let m = load(text).unwrap();
        let shapes: Vec<_> = m.geoms.iter().map(|g| g.shape).collect();
        assert_eq!(
            shapes,
            [
                Shape::Box {
                    half: Vector3::new(1.0, 2.0, 0.5)
                },
                Shape::Cylinder {
                    radius: 0.1,
                    half_length: 0.5
                },
                Shape::Capsule {
                    radius: 0.1,
                    half_length: 0.2
                },
            ]
        );
        let floor = &m.geoms[0];
        assert_eq!(
            (
                floor.name.as_str(),
                floor.body,
                floor.contype,
                floor.conaffinity
            ),
            ("floor", 0, 1, 0)
        );
        assert_eq!((floor.pos.z, floor.friction), (-0.5, [0.9, 0.0, 0.0]));
    }

    #[test]
    fn truncated_files_never_panic() {
        let text = include_str!("../../reference_models/cartpole.urdf");
        for end in (0..text.len()).filter(|&i| text.is_char_boundary(i)) {
            let _ = parse(&text[..end], "cut.urdf");
        }
        assert!(parse(text, "cartpole.urdf").is_ok());
    }
}
