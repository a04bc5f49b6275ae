//! Links become bodies, in the tree's depth-first order, each with the joint
//! that leads to it and its collision geoms; a root named `world` is the
//! world itself.

use std::collections::HashMap;

use nalgebra::{Matrix3, Rotation3, Vector3};

use super::attributes::{identity, Pose};
use super::tree::{Edge, Link, Tree};
use super::{child, Node, Reader, Result};
use crate::model::params::inertia_from_six;
use crate::model::{check_inertial, Body, Geom, Joint};

/// What the links and joints become.
pub(super) struct Parts<'a> {
    pub bodies: Vec<Body>,
    pub joints: Vec<Joint>,
    pub geoms: Vec<Geom>,
    /// Per URDF joint name, its dof (`None` for a fixed joint).
    pub dofs: HashMap<&'a str, Option<usize>>,
}

/// Mass, COM, inertia about the COM in link axes, and the axes it was given in.
type Inertial = (f64, Vector3<f64>, Matrix3<f64>, Rotation3<f64>);

impl Reader<'_> {
    pub(super) fn parts<'a>(
        &self,
        links: &[Link<'a>],
        edges: &[Edge<'a>],
        tree: &Tree,
    ) -> Result<Parts<'a>> {
        let mut parts = Parts {
            bodies: vec![Body::world()],
            joints: Vec::new(),
            geoms: Vec::new(),
            dofs: HashMap::new(),
        };
        let mut body_of_link = vec![0; links.len()];
        for &l in &tree.order {
            let link = links[l];
            if l == tree.root && link.name == "world" {
                parts.geoms.extend(self.geoms(link.node, 0)?);
                continue;
            }
            if link.name == "world" {
                return Err(self.error(link.node, "only the root link may be named 'world'"));
            }
            body_of_link[l] = parts.bodies.len();
            let edge = tree.parent_edge[l].map(|e| &edges[e]);
            let parent = edge.map_or(0, |e| body_of_link[e.parent]);
            self.add_body(&mut parts, link, edge, parent)?;
        }
        Ok(parts)
    }

    /// Adds the body of `link`, a child of body `parent` through `edge` (the
    /// root has none), with its joint and geoms.
    fn add_body<'a>(
        &self,
        parts: &mut Parts<'a>,
        link: Link,
        edge: Option<&Edge<'a>>,
        parent: usize,
    ) -> Result<()> {
        let body = parts.bodies.len();
        let first_joint = parts.joints.len();
        let (pos, rot) = match edge {
            None => identity(),
            Some(edge) => self.add_joint(parts, edge, body)?,
        };
        let (mass, com, inertia, inertia_frame) = self.inertial(link)?;
        parts.bodies.push(Body {
            name: link.name.to_string(),
            parent,
            pos,
            rot,
            mass,
            com,
            inertia,
            inertia_frame,
            joints: first_joint..parts.joints.len(),
            gravcomp: 0.0,
        });
        parts.geoms.extend(self.geoms(link.node, body)?);
        Ok(())
    }

    /// Adds the joint of `edge` moving `body` (none if fixed) and returns the
    /// body's pose in its parent.
    fn add_joint<'a>(&self, parts: &mut Parts<'a>, edge: &Edge<'a>, body: usize) -> Result<Pose> {
        let joint = self.joint(edge, body)?;
        let dof = joint.as_ref().map(|_| parts.joints.len());
        parts.dofs.insert(edge.name, dof);
        parts.joints.extend(joint);
        self.origin(edge.node)
    }

    fn inertial(&self, link: Link) -> Result<Inertial> {
        let Some(inertial) = child(link.node, "inertial") else {
            return Ok((
                0.0,
                Vector3::zeros(),
                Matrix3::zeros(),
                Rotation3::identity(),
            ));
        };
        let mass = self.mass(inertial)?;
        let tensor = self.inertia(inertial)?;
        let (com, rot) = self.origin(inertial)?;
        let inertia = rot.matrix() * tensor * rot.matrix().transpose();
        check_inertial(link.name, mass, &com, &inertia)
            .map_err(|e| self.error(inertial, e.to_string()))?;
        Ok((mass, com, inertia, rot))
    }

    fn mass(&self, inertial: Node) -> Result<f64> {
        let node = self.required_child(inertial, "mass")?;
        let mass = self.required_number(node, "value")?;
        if mass < 0.0 {
            return Err(self.error(node, format!("negative mass {mass}")));
        }
        Ok(mass)
    }

    /// `<inertia>`, in the axes of the `<inertial>` origin.
    fn inertia(&self, inertial: Node) -> Result<Matrix3<f64>> {
        let node = self.required_child(inertial, "inertia")?;
        let mut six = [0.0; 6];
        for (value, name) in six
            .iter_mut()
            .zip(["ixx", "iyy", "izz", "ixy", "ixz", "iyz"])
        {
            *value = self.required_number(node, name)?;
        }
        Ok(inertia_from_six(&six))
    }
}

#[cfg(test)]
mod tests {
    use std::f64::consts::FRAC_PI_2;

    use nalgebra::{Matrix3, Vector3};

    use super::super::test_util::*;

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
}
