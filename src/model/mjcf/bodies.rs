//! The walk over `<worldbody>` and nested `<body>` elements, whose
//! `<frame>`s and `<replicate>`s are unfolded first (`frames.rs`). A body
//! is static when it and all its ancestors have no joints (only static
//! bodies may hold planes).

use nalgebra::{Matrix3, Rotation3};

use super::attributes::Attrs;
use super::compiler::FromGeom;
use super::frames::Member;
use super::inertial::Principal;
use super::schema::{check_attributes, BODY_ATTRS};
use super::tree::{Kind, Tree};
use super::{children, tag, unrecognized, unsupported, Node, Reader, Result};
use crate::model::{Body, JointKind};

impl<'a> Reader<'a> {
    /// All `<worldbody>` sections: their geoms belong to the world, then come
    /// their bodies.
    pub(super) fn read_world(&self, tree: &mut Tree<'a>, sections: &[Node<'a>]) -> Result<()> {
        let mut members = vec![];
        for section in sections {
            if let Some(attr) = section.attributes().next() {
                let msg = format!("the world body cannot have attributes ('{}')", attr.name());
                return Err(self.error(*section, msg));
            }
            members.extend(self.members(*section, "main", "")?);
        }
        for m in &members {
            match tag(m.node) {
                "joint" | "freejoint" => {
                    return Err(self.error(m.node, "the world cannot have joints"))
                }
                "inertial" => return Err(self.error(m.node, "the world cannot have an inertial")),
                _ => self.check_body_child(m)?,
            }
        }
        self.read_geoms(tree, &members, 0, true, false)?;
        self.read_sites(tree, &members, 0)?;
        self.read_child_bodies(tree, &members, 0, true)
    }

    /// Rejects body children we do not read.
    fn check_body_child(&self, m: &Member<'a>) -> Result<()> {
        match tag(m.node) {
            "inertial" if m.framed => Err(unsupported(
                self.file,
                m.node,
                "an <inertial> inside a <frame> or <replicate> (give it in the body)",
            )),
            "body" | "joint" | "freejoint" | "geom" | "inertial" | "site" | "camera" | "light" => {
                Ok(())
            }
            "composite" | "flexcomp" | "attach" | "plugin" => Err(unsupported(
                self.file,
                m.node,
                "write the bodies out explicitly",
            )),
            _ => Err(unrecognized(self.file, m.node)),
        }
    }

    fn read_child_bodies(
        &self,
        tree: &mut Tree<'a>,
        members: &[Member<'a>],
        parent: usize,
        parent_static: bool,
    ) -> Result<()> {
        for m in members.iter().filter(|m| m.node.has_tag_name("body")) {
            self.read_body(tree, m, parent, parent_static)?;
        }
        Ok(())
    }

    /// A `<body>`: its joints, geoms and inertia, then its child bodies.
    fn read_body(
        &self,
        tree: &mut Tree<'a>,
        member: &Member<'a>,
        parent: usize,
        parent_static: bool,
    ) -> Result<()> {
        let node = member.node;
        check_attributes(self.file, node, BODY_ATTRS)?;
        let class = self.class_name(node, "childclass")?.unwrap_or(member.class);
        let a = Attrs::of(self.file, node);
        check_body_attributes(&a)?;
        let mocap = a.flag("mocap")? == Some(true);
        let members = self.members(node, class, &member.suffix)?;
        for child in &members {
            self.check_body_child(child)?;
        }
        let index = tree.bodies.len();
        let name = tree.claim(self.file, node, Kind::Body, &member.suffix)?;
        let first_joint = tree.joints.len();
        let is_joint = |m: &Member| matches!(tag(m.node), "joint" | "freejoint");
        for (i, m) in members.iter().enumerate().filter(|(_, m)| is_joint(m)) {
            let joint = match tag(m.node) {
                "joint" => self.read_joint(tree, m, index)?,
                _ => self.read_freejoint(tree, m, index)?,
            };
            let alone = parent == 0 && first_joint == tree.joints.len();
            let last = !members[i + 1..].iter().any(is_joint);
            if joint.kind == JointKind::Free && !(alone && last) {
                let msg = "a free joint must be the only joint of a body whose parent is the world";
                return Err(self.error(m.node, msg));
            }
            tree.joints.push(joint);
        }
        let joints = first_joint..tree.joints.len();
        if mocap && (parent != 0 || !joints.is_empty()) {
            let msg = format!("mocap body '{name}' is not a fixed child of world");
            return Err(self.error(node, msg));
        }
        if let Some(child) = members.iter().find(|m| mocap && tag(m.node) == "body") {
            return Err(unsupported(
                self.file,
                child.node,
                "bodies inside a mocap body",
            ));
        }
        let is_static = parent_static && joints.is_empty();
        let inertial = self.explicit_inertial(node)?;
        let geoms_count = self.compiler.inertia_from_geom == FromGeom::True || inertial.is_none();
        let parts = self.read_geoms(tree, &members, index, is_static, geoms_count)?;
        self.read_sites(tree, &members, index)?;
        let principal = self.body_inertial(node, inertial, &parts)?;
        let pos = a.vector("pos")?.unwrap_or_default();
        tree.bodies.push(Body {
            name,
            parent,
            pos: member.frame.point(&pos),
            rot: member.frame.rot * self.orientation(&a)?,
            mass: principal.mass,
            com: principal.com,
            inertia: Matrix3::zeros(),
            inertia_frame: Rotation3::identity(),
            joints,
            gravcomp: a.number("gravcomp")?.unwrap_or(0.0),
            mocap,
        });
        tree.inertials.push(principal);
        tree.nodes.push(Some(node));
        self.read_child_bodies(tree, &members, index, is_static)
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

/// Gravity compensation (finite).
fn check_body_attributes(a: &Attrs) -> Result<()> {
    if let Some(g) = a.number("gravcomp")?.filter(|g| !g.is_finite()) {
        return Err(a.error(a.element, format!("gravcomp must be finite, got {g}")));
    }
    Ok(())
}
