//! URDF loader: [`parse`] builds a [`Spec`] from URDF text.
//!
//! How URDF maps onto the model (see the `model` module for its frames):
//! - Every link is a body whose frame is the link frame. A joint's `<origin>`
//!   is its child body's `pos`/`rot` in the parent body at q = 0 (`reference`
//!   0); the joint turns about, or slides along, `<axis>` (default x,
//!   normalised) through the body origin (`anchor` 0).
//! - `rpy` is fixed-axis roll-pitch-yaw: R = Rz(yaw) Ry(pitch) Rx(roll).
//! - `<inertial>`: the COM is its origin `xyz`; `<inertia>` is about the COM in
//!   the axes of its origin `rpy`, turned into link axes as R I R^T. The
//!   tensor is used as written where it is only rounding-level indefinite or
//!   its principal moments violate the triangle inequality (as PyBullet and
//!   Pinocchio use it; MuJoCo's compiler refuses the latter), with a warning
//!   naming the link. A link with no `<inertial>` is massless, as the URDF
//!   spec and Pinocchio read it (MuJoCo's importer gives it the inertia of
//!   its collision geoms at density 1000), with a warning naming it; a
//!   moving link with nothing massive at or below it is refused, since its
//!   dof has no inertia (Pinocchio's ABA gives NaN, MuJoCo refuses it: "mass
//!   and inertia of moving bodies must be larger than mjMINVAL").
//!   [`LoadOptions::inertials`] = [`Inertials::PyBullet`] reads every
//!   `<inertial>` as PyBullet's importer does instead (`pybullet_inertia.rs`:
//!   mass 1 and unit inertia where there is none, principal axes by Bullet's
//!   Jacobi iteration, unphysical moments zeroed with a warning).
//! - Joint types: revolute and continuous are hinges, prismatic is a slide,
//!   fixed welds the child to its parent (a body with no joint), floating is a
//!   free joint (its child's parent must be the world; the `<origin>` is the
//!   reference configuration); spherical (PyBullet's) is an unlimited ball
//!   joint, as PyBullet and MuJoCo's importer read it (PyBullet's swing-twist
//!   limit is ignored with a warning); planar is rejected. A root link other than
//!   `world` is welded to the world by default, as MuJoCo's importer and
//!   Pinocchio's `buildModelFromUrdf` read it (PyBullet's useFixedBase=1);
//!   [`LoadOptions::floating_base`] gives it a free joint named `root_joint`
//!   (Pinocchio's name) at the world origin, as PyBullet's loadURDF default
//!   (useFixedBase=0) and Pinocchio's `JointModelFreeFlyer` root do.
//! - A revolute or prismatic joint is limited when its `<limit>` has
//!   lower < upper; absent bounds are 0 (the URDF default), so a `<limit>`
//!   without them means unlimited, as in PyBullet. `effort` and `velocity` are
//!   ignored. Continuous joints are never limited.
//! - `<dynamics damping friction>` are the joint's damping and frictionloss.
//! - Bodies are numbered depth-first from the root link (the one link that is
//!   no joint's child), children in the document order of their joints. A
//!   root named `world` is the world (body 0; its `<inertial>` is ignored, its
//!   collisions are world geoms); any other root becomes body 1, welded to the
//!   world or floating (above). Joints, and so q and v, follow the bodies:
//!   depth-first, the root's free joint first, fixed joints taking no place
//!   (Pinocchio's order; PyBullet's is the document order of the joints,
//!   the same for files that list each joint after its parent's). A joint's
//!   first q and v index by name: [`crate::Model::joint_address_of`].
//! - `<collision>` box, sphere, cylinder (along z, `length` the full length) and
//!   PyBullet's capsule (`length` between the sphere centres) become geoms with
//!   contype = conaffinity = 1; a mesh collision becomes a mesh geom as
//!   MuJoCo's importer makes it (see `geoms.rs`), and `<visual>` is ignored. Friction comes from PyBullet's `<contact>` element
//!   of the link (lateral, spinning, rolling), default PyBullet's (0.5, 0, 0).
//! - A `<transmission>` with one `<joint>` that moves is an actuator on that
//!   joint: gear = `<mechanicalReduction>` (default 1), name = its
//!   `<actuator name>`, else the transmission's name. Any other transmission
//!   (several joints, a fixed joint) is ignored with a warning, as PyBullet
//!   and Pinocchio ignore every transmission.
//! - Options: gravity -9.81 z, timestep 0.002 s, semi-implicit Euler with
//!   implicit damping, limits and contacts under the constraint model with
//!   MuJoCo's default solref/solimp: a URDF runs as MuJoCo's URDF importer
//!   runs it. PyBullet's way (explicit passive forces) and the smooth model
//!   are named options (`passive="explicit"`, `contact="smooth"`).
//! - Warnings (what was taken as written, what was ignored) are returned with
//!   the spec ([`Loaded`]); the model keeps them ([`crate::Model::warnings`]).
//!
//! What URDF cannot say is carried by extensions in the namespace [`NAMESPACE`]
//! (declare `xmlns:diffosi="urn:diffosi:urdf"` on `<robot>`), which PyBullet and
//! DART ignore:
//! - `<diffosi:options timestep="0.01" gravity="0 0 -9.81" integrator="Euler|RK4"
//!   passive="explicit|implicit_damping|implicit_damping_stiffness"
//!   contact="constraint|smooth"/>` in `<robot>`, every attribute optional;
//! - `diffosi:stiffness`, `diffosi:springref`, `diffosi:armature` on `<dynamics>`;
//! - `diffosi:contype`, `diffosi:conaffinity` on `<collision>` (MJCF bitmasks);
//! - `diffosi:ctrlrange="lo hi"` on a transmission's `<actuator>`.
//!
//! Anything else in that namespace is an error, so a typo is never dropped.
//! Errors name the file, the 1-based line and the element.
//!
//! Files are read as PyBullet reads them where it finds an evident meaning in
//! what a strict reader refuses, each with a warning naming the line: an XML
//! declaration after blank lines and NUL bytes ending the file (tinyxml2's
//! reading, `xml.rs`); a stray ',' or '.' after a number, more than three
//! numbers for a 3-vector, an unexpanded xacro `$(optenv NAME default)`
//! (`pybullet_numbers.rs`). Other malformed numbers are errors.
//!
//! Where each part is read: the link tree in `tree.rs`, links and their
//! inertia in `links.rs`, joints in `joints.rs`, collisions in `geoms.rs`,
//! transmissions in `actuators.rs`, the extension namespace and the options in
//! `extensions.rs`, attributes and origins in `attributes.rs`, `package://`
//! paths in `package.rs`.

mod actuators;
mod attributes;
mod extensions;
mod geoms;
mod joints;
mod links;
mod package;
mod pybullet_inertia;
mod pybullet_numbers;
#[cfg(test)]
mod test_util;
mod tree;

use std::path::PathBuf;

pub use package::resolve;

use super::{xml, InertiaRule, ModelError, Spec};

/// The namespace of diffosi's URDF extensions.
pub const NAMESPACE: &str = "urn:diffosi:urdf";

type Node<'a> = roxmltree::Node<'a, 'a>;
type Result<T> = std::result::Result<T, ModelError>;

/// How to read a URDF, beyond what the file says.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct LoadOptions {
    /// A free joint on the root link (PyBullet's loadURDF default); off, the
    /// default, welds the root link to the world (MuJoCo's importer,
    /// Pinocchio).
    pub floating_base: bool,
    /// Where `package://NAME/...` paths are looked for first (see [`resolve`]).
    pub package_dirs: Vec<PathBuf>,
    /// Whose reading of `<inertial>`: Pinocchio's, the default, or PyBullet's.
    pub inertials: Inertials,
}

/// Whose reading of the links' `<inertial>` a URDF gets (see the module doc).
///
/// The default is the file as written, a link without `<inertial>`
/// massless: what the URDF spec says and Pinocchio reads. PyBullet's
/// importer departs from the file (1 kg where a link has no inertial, its
/// principal axes to 1e-6, some tensors zeroed), so its reading is an option
/// for comparing with PyBullet, not a default.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Inertials {
    /// As written; a link without `<inertial>` has mass and inertia 0.
    #[default]
    Pinocchio,
    /// As PyBullet's loadURDF with URDF_USE_INERTIA_FROM_FILE reads it.
    PyBullet,
}

impl std::str::FromStr for Inertials {
    type Err = String;

    /// "pinocchio" or "pybullet".
    fn from_str(name: &str) -> std::result::Result<Self, String> {
        match name {
            "pinocchio" => Ok(Inertials::Pinocchio),
            "pybullet" => Ok(Inertials::PyBullet),
            other => Err(format!(
                "inertial: expected 'pinocchio' or 'pybullet', got '{other}'"
            )),
        }
    }
}

/// A URDF read: the spec and what the reader warns about (each names its
/// link, joint or transmission).
#[derive(Clone, Debug)]
pub struct Loaded {
    pub spec: Spec,
    pub warnings: Vec<String>,
}

/// Parses URDF text; `file` names it in errors (and is where relative and
/// `package://` paths start).
pub fn parse(text: &str, file: &str, options: &LoadOptions) -> Result<Loaded> {
    let (text, notes) = xml::as_tinyxml2_reads(text);
    let doc = xml::document(&text, file)?;
    let robot = doc.root_element();
    let reader = Reader {
        file,
        options,
        warnings: Default::default(),
        meshes: Default::default(),
    };
    for (line, note) in notes {
        reader
            .warnings
            .borrow_mut()
            .push(format!("{file}:{line}: {note}"));
    }
    if !is(robot, "robot") {
        return Err(reader.error(robot, "the root element must be <robot>"));
    }
    reader.check_extensions(robot)?;
    let name = reader.attr(robot, "name")?.to_string();
    let links = reader.links(robot)?;
    let edges = reader.edges(robot, &links)?;
    let tree = reader.tree(robot, &links, &edges)?;
    let parts = reader.parts(&links, &edges, &tree)?;
    let actuators = reader.actuators(robot, &parts.dofs)?;
    let opt = reader.options(robot)?;
    let spec = Spec {
        name,
        bodies: parts.bodies,
        joints: parts.joints,
        actuators,
        geoms: parts.geoms,
        opt,
        pairs: vec![],
        excludes: vec![],
        keyframes: vec![],
        inertia_rule: InertiaRule::SemiDefinite,
        sites: vec![],
        sensors: vec![],
        meshes: reader.meshes.take().into_iter().map(|m| m.mesh).collect(),
        hfields: vec![],
        equalities: vec![],
        tendons: vec![],
    };
    Ok(Loaded {
        spec,
        warnings: reader.warnings.into_inner(),
    })
}

/// Reads the elements of one file. Its methods live with the elements they
/// read.
struct Reader<'f> {
    file: &'f str,
    options: &'f LoadOptions,
    warnings: std::cell::RefCell<Vec<String>>,
    /// The meshes of the collision geoms so far (see `geoms.rs`).
    meshes: std::cell::RefCell<Vec<geoms::UrdfMesh>>,
}

impl Reader<'_> {
    fn error(&self, node: Node, message: impl Into<String>) -> ModelError {
        xml::invalid(self.file, node, message)
    }

    /// Records a warning about `node`, worded as an error is (file, line,
    /// element).
    fn warn(&self, node: Node, message: impl Into<String>) {
        let warning = self.error(node, message).to_string();
        self.warnings.borrow_mut().push(warning);
    }
}

/// A URDF element (not one of our extensions) named `name`.
fn is(node: Node, name: &str) -> bool {
    node.is_element() && node.tag_name().name() == name && !ours(node)
}

/// Whether `node` is in our extension namespace.
fn ours(node: Node) -> bool {
    node.tag_name().namespace() == Some(NAMESPACE)
}

/// The URDF elements named `name` among the children of `node`.
fn children<'a, 'n>(node: Node<'a>, name: &'n str) -> impl Iterator<Item = Node<'a>> + 'n
where
    'a: 'n,
{
    node.children().filter(move |n| is(*n, name))
}

/// The first URDF element named `name` among the children of `node`.
fn child<'a>(node: Node<'a>, name: &str) -> Option<Node<'a>> {
    children(node, name).next()
}

#[cfg(test)]
mod tests {
    use super::test_util::*;
    use super::*;

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
                    joint("j", "planar", "world", "a", "")
                ),
                3,
                "joint",
                "planar joints are not supported",
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
    fn a_late_declaration_and_trailing_nuls_load_with_warnings_naming_their_lines() {
        let text = format!("\n\n<?xml version=\"1.0\"?>\n{}\0\r\n", urdf(&link("a")));
        let loaded = parse(&text, "late.urdf", &Default::default()).unwrap();
        let lines: Vec<&str> = loaded
            .warnings
            .iter()
            .map(|w| w.split(": ").next().unwrap())
            .collect();
        assert_eq!(
            lines,
            ["late.urdf:6", "late.urdf:3"],
            "{:?}",
            loaded.warnings
        );
        let error = parse(&format!("{text}<link/>"), "late.urdf", &Default::default());
        assert!(matches!(error, Err(ModelError::Xml { .. })), "{error:?}");
    }

    #[test]
    fn truncated_files_never_panic() {
        let text = include_str!("../../../reference_models/cartpole.urdf");
        for end in (0..text.len()).filter(|&i| text.is_char_boundary(i)) {
            let _ = parse(&text[..end], "cut.urdf", &Default::default());
        }
        assert!(parse(text, "cartpole.urdf", &Default::default()).is_ok());
    }
}
