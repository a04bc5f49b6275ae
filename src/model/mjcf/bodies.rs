//! The walk over `<worldbody>` and nested `<body>` elements. A body is
//! static when it and all its ancestors have no joints (only static bodies
//! may hold planes).

use nalgebra::{Matrix3, Rotation3};

use super::attributes::Attrs;
use super::compiler::FromGeom;
use super::inertial::Principal;
use super::schema::{check_attributes, BODY_ATTRS};
use super::tree::{Kind, Tree};
use super::{children, elements, tag, unrecognized, unsupported, Node, Reader, Result};
use crate::model::{Body, JointKind};

impl<'a> Reader<'a> {
    /// All `<worldbody>` sections: their geoms belong to the world, then come
    /// their bodies.
    pub(super) fn read_world(&self, tree: &mut Tree<'a>, sections: &[Node<'a>]) -> Result<()> {
        let mut contents = vec![];
        for section in sections {
            if let Some(attr) = section.attributes().next() {
                let msg = format!("the world body cannot have attributes ('{}')", attr.name());
                return Err(self.error(*section, msg));
            }
            contents.extend(elements(*section));
        }
        for node in &contents {
            match tag(*node) {
                "joint" | "freejoint" => {
                    return Err(self.error(*node, "the world cannot have joints"))
                }
                "inertial" => return Err(self.error(*node, "the world cannot have an inertial")),
                _ => self.check_body_child(*node)?,
            }
        }
        self.read_geoms(tree, &contents, 0, "main", true, false)?;
        self.read_child_bodies(tree, &contents, 0, "main", true)
    }

    /// Rejects body children we do not read.
    fn check_body_child(&self, node: Node<'a>) -> Result<()> {
        match tag(node) {
            "body" | "joint" | "freejoint" | "geom" | "inertial" | "site" | "camera" | "light" => {
                Ok(())
            }
            "frame" | "replicate" | "composite" | "flexcomp" | "attach" | "plugin" => Err(
                unsupported(self.file, node, "write the bodies out explicitly"),
            ),
            _ => Err(unrecognized(self.file, node)),
        }
    }

    fn read_child_bodies(
        &self,
        tree: &mut Tree<'a>,
        contents: &[Node<'a>],
        parent: usize,
        class: &'a str,
        parent_static: bool,
    ) -> Result<()> {
        for node in contents.iter().filter(|n| n.has_tag_name("body")) {
            self.read_body(tree, *node, parent, class, parent_static)?;
        }
        Ok(())
    }

    /// A `<body>`: its joints, geoms and inertia, then its child bodies.
    fn read_body(
        &self,
        tree: &mut Tree<'a>,
        node: Node<'a>,
        parent: usize,
        parent_class: &'a str,
        parent_static: bool,
    ) -> Result<()> {
        check_attributes(self.file, node, BODY_ATTRS)?;
        let class = self.class_name(node, "childclass")?.unwrap_or(parent_class);
        let a = Attrs::of(self.file, node);
        check_body_attributes(&a)?;
        let contents: Vec<Node<'a>> = elements(node).collect();
        for child in &contents {
            self.check_body_child(*child)?;
        }
        let index = tree.bodies.len();
        let name = tree.claim(self.file, node, Kind::Body)?;
        let first_joint = tree.joints.len();
        for node in &contents {
            let joint = match tag(*node) {
                "joint" => self.read_joint(tree, *node, index, class)?,
                "freejoint" => self.read_freejoint(tree, *node, index)?,
                _ => continue,
            };
            let alone = parent == 0 && first_joint == tree.joints.len();
            let last = !contents
                .iter()
                .skip_while(|n| n != &node)
                .skip(1)
                .any(|n| matches!(tag(*n), "joint" | "freejoint"));
            if joint.kind == JointKind::Free && !(alone && last) {
                let msg = "a free joint must be the only joint of a body whose parent is the world";
                return Err(self.error(*node, msg));
            }
            tree.joints.push(joint);
        }
        let joints = first_joint..tree.joints.len();
        let is_static = parent_static && joints.is_empty();
        let inertial = self.explicit_inertial(node)?;
        let geoms_count = self.compiler.inertia_from_geom == FromGeom::True || inertial.is_none();
        let parts = self.read_geoms(tree, &contents, index, class, is_static, geoms_count)?;
        let principal = self.body_inertial(node, inertial, &parts)?;
        tree.bodies.push(Body {
            name,
            parent,
            pos: a.vector("pos")?.unwrap_or_default(),
            rot: self.orientation(&a)?,
            mass: principal.mass,
            com: principal.com,
            inertia: Matrix3::zeros(),
            inertia_frame: Rotation3::identity(),
            joints,
            gravcomp: a.number("gravcomp")?.unwrap_or(0.0),
        });
        tree.inertials.push(principal);
        tree.nodes.push(Some(node));
        self.read_child_bodies(tree, &contents, index, class, is_static)
    }

    /// The body's `<inertial>`, if it has one.
    fn explicit_inertial(&self, body: Node<'a>) -> Result<Option<Principal>> {
        match children(body, "inertial").as_slice() {
            [] => Ok(None),
            [one] => self.read_inertial(*one).map(Some),
            [_, second, ..] => Err(self.error(*second, "a body has at most one <inertial>")),
        }
    }
}

/// Mocap bodies (not supported yet) and gravity compensation (finite).
fn check_body_attributes(a: &Attrs) -> Result<()> {
    if a.flag("mocap")? == Some(true) {
        return Err(a.error(a.element, "mocap bodies are not supported"));
    }
    if let Some(g) = a.number("gravcomp")?.filter(|g| !g.is_finite()) {
        return Err(a.error(a.element, format!("gravcomp must be finite, got {g}")));
    }
    Ok(())
}
