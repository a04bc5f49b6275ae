//! Links become bodies, in the tree's depth-first order, each with the joint
//! that leads to it and its collision geoms; a root named `world` is the
//! world itself. Also the checks of their masses (see the module doc).

use std::collections::HashMap;

use nalgebra::{Matrix3, Rotation3, Vector3};

use super::attributes::{identity, Pose};
use super::joints::free_root;
use super::tree::{Edge, Link, Tree};
use super::{child, pybullet_inertia, Inertials, Node, Reader, Result};
use crate::model::params::inertia_from_six;
use crate::model::{check_inertial, Body, Geom, InertiaRule, Joint};

/// What the links and joints become.
pub(super) struct Parts<'a> {
    pub bodies: Vec<Body>,
    pub joints: Vec<Joint>,
    pub geoms: Vec<Geom>,
    /// Per URDF joint name, its dof (`None` for a fixed joint).
    pub dofs: HashMap<&'a str, Option<usize>>,
}

impl Parts<'_> {
    /// Whether `body` moves: a joint on it or on one of its ancestors.
    fn moving(&self, body: usize) -> bool {
        let mut b = body;
        while b > 0 {
            if !self.bodies[b].joints.is_empty() {
                return true;
            }
            b = self.bodies[b].parent;
        }
        false
    }
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
        let root = links[tree.root];
        if self.options.floating_base {
            self.check_floatable(root, edges)?;
        }
        let mut body_of_link = vec![0; links.len()];
        let mut link_of_body = vec![root];
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
            link_of_body.push(link);
            let edge = tree.parent_edge[l].map(|e| &edges[e]);
            let parent = edge.map_or(0, |e| body_of_link[e.parent]);
            self.add_body(&mut parts, link, edge, parent)?;
        }
        self.check_masses(&parts, &link_of_body)?;
        Ok(parts)
    }

    /// A free joint can float the root: it is not the world, and its name
    /// is free.
    fn check_floatable(&self, root: Link, edges: &[Edge]) -> Result<()> {
        if root.name == "world" {
            let msg = "floating_base: the root link 'world' is the world itself; float the \
                       robot by a floating joint from it, or name the root link otherwise";
            return Err(self.error(root.node, msg));
        }
        match edges.iter().find(|e| e.name == "root_joint") {
            Some(e) => Err(self.error(
                e.node,
                "floating_base names the root's free joint 'root_joint', which this joint's \
                 name already is",
            )),
            None => Ok(()),
        }
    }

    /// Refuses a moving link whose dofs would have no inertia (it and every
    /// link below it massless, its joints without armature), and warns about
    /// moving links without `<inertial>` (see the module doc).
    fn check_masses(&self, parts: &Parts, link_of_body: &[Link]) -> Result<()> {
        let bodies = &parts.bodies;
        let moves = |b: usize| !bodies[b].joints.is_empty();
        let mut heavy: Vec<bool> = bodies
            .iter()
            .map(|b| b.mass > 0.0 || b.inertia != Matrix3::zeros())
            .collect();
        for b in (1..bodies.len()).rev() {
            let armature = bodies[b]
                .joints
                .clone()
                .all(|j| parts.joints[j].armature > 0.0);
            if moves(b) && !heavy[b] && !armature {
                let link = link_of_body[b];
                let joint = &parts.joints[bodies[b].joints.start].name;
                let msg = format!(
                    "link '{}' moves (joint '{joint}') but neither it nor any link below it has \
                     mass or inertia, so that joint has no inertia (Pinocchio's ABA gives NaN, \
                     MuJoCo refuses it, PyBullet gives the joint no acceleration); give the link an \
                     <inertial>",
                    link.name
                );
                return Err(self.error(link.node, msg));
            }
            heavy[bodies[b].parent] |= heavy[b];
        }
        let without: Vec<Link> = (1..bodies.len())
            .filter(|&b| parts.moving(b) && child(link_of_body[b].node, "inertial").is_none())
            .map(|b| link_of_body[b])
            .collect();
        if let Some(first) = without.first() {
            let names: Vec<&str> = without.iter().map(|l| l.name).collect();
            let reading = match self.options.inertials {
                Inertials::Pinocchio => {
                    "are massless, as the URDF spec and Pinocchio read them (PyBullet gives each \
                     1 kg and unit inertia)"
                }
                Inertials::PyBullet => {
                    "get PyBullet's 1 kg and unit inertia at the link origin (the URDF spec and \
                     Pinocchio: massless)"
                }
            };
            self.warn(
                first.node,
                format!(
                    "moving links without <inertial> {reading}: {}",
                    names.join(", ")
                ),
            );
        }
        Ok(())
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
            None if self.options.floating_base => {
                parts.joints.push(free_root(body));
                identity()
            }
            None => identity(),
            Some(edge) => self.add_joint(parts, edge, body)?,
        };
        let moves = parts.joints.len() > first_joint || parts.moving(parent);
        let (mass, com, inertia, inertia_frame) = self.inertial(link, moves)?;
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
            mocap: false,
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

    /// The link's inertial, read as [`LoadOptions::inertials`] says. As
    /// written (Pinocchio's reading) it is checked: a tensor MuJoCo's
    /// compiler would refuse is used as written where it is positive
    /// semi-definite to rounding, with a warning; one that is not is refused
    /// on a link that `moves`, and dropped, with a warning, on one welded to
    /// the world, where it takes no part in the dynamics.
    ///
    /// [`LoadOptions::inertials`]: super::LoadOptions::inertials
    fn inertial(&self, link: Link, moves: bool) -> Result<Inertial> {
        let pybullet = self.options.inertials == Inertials::PyBullet;
        let Some(inertial) = child(link.node, "inertial") else {
            let (mass, inertia) = if pybullet {
                (1.0, pybullet_inertia::missing())
            } else {
                (0.0, Matrix3::zeros())
            };
            return Ok((mass, Vector3::zeros(), inertia, Rotation3::identity()));
        };
        let mass = self.mass(inertial)?;
        let tensor = self.inertia(inertial)?;
        let (com, rot) = self.origin(inertial)?;
        let tensor = if pybullet {
            self.pybullet_tensor(link, inertial, &tensor)
        } else {
            tensor
        };
        let inertia = rot.matrix() * tensor * rot.matrix().transpose();
        if pybullet {
            return Ok((mass, com, inertia, rot));
        }
        let massless = (
            0.0,
            Vector3::zeros(),
            Matrix3::zeros(),
            Rotation3::identity(),
        );
        let check = |rule| check_inertial(link.name, mass, &com, &inertia, rule);
        match check(InertiaRule::SemiDefinite) {
            Err(e) if moves => return Err(self.error(inertial, e.to_string())),
            Err(e) => {
                let msg = format!(
                    "{e}; dropped (mass and inertia 0): the link is welded to the world, so it \
                     takes no part in the dynamics"
                );
                self.warn(inertial, msg);
                return Ok(massless);
            }
            Ok(()) => {}
        }
        if let Err(e) = check(InertiaRule::Triangle) {
            let msg = format!("{e}; used as written, as PyBullet and Pinocchio use it");
            self.warn(inertial, msg);
        }
        Ok((mass, com, inertia, rot))
    }

    /// The tensor (in the `<inertial>` origin's axes) as PyBullet reads it,
    /// with a warning where PyBullet zeroes it.
    fn pybullet_tensor(&self, link: Link, inertial: Node, tensor: &Matrix3<f64>) -> Matrix3<f64> {
        let (read, zeroed) = pybullet_inertia::reading(tensor);
        if zeroed {
            let msg = format!(
                "link '{}': its principal moments are negative or violate the triangle \
                 inequality, so its inertia is zeroed (the mass kept), as PyBullet does",
                link.name
            );
            self.warn(inertial, msg);
        }
        read
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
    use super::super::{Inertials, LoadOptions};
    use crate::model::JointKind;

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

    #[test]
    fn a_floating_base_is_a_free_joint_on_the_root_link() {
        let text = format!(
            "{}{}{}",
            link("base"),
            link("arm"),
            joint(
                "shoulder",
                "revolute",
                "base",
                "arm",
                "<origin xyz=\"0 0 1\"/>"
            )
        );
        let options = LoadOptions {
            floating_base: true,
            ..Default::default()
        };
        let m = load_with(&text, &options).unwrap();
        let joints: Vec<_> = m
            .joints
            .iter()
            .map(|j| (j.name.as_str(), j.kind, j.body))
            .collect();
        assert_eq!(
            joints,
            [
                ("root_joint", JointKind::Free, 1),
                ("shoulder", JointKind::Hinge, 2)
            ]
        );
        assert_eq!(m.reference_q(), [0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0]);
        assert_eq!(m.joint_address_of("shoulder"), Some((7, 6)));
        assert_eq!(
            load(&text).unwrap().joint_address_of("shoulder"),
            Some((0, 0))
        );

        // The world cannot float, and the free joint's name must be free.
        let world = format!(
            "<link name=\"world\"/>{}",
            joint("j", "fixed", "world", "base", "")
        );
        let clash = joint("root_joint", "fixed", "base", "arm", "");
        for (text, line, message) in [
            (
                format!("{}\n{world}", link("base")),
                3,
                "the root link 'world' is the world",
            ),
            (
                format!("{}{}\n{clash}", link("base"), link("arm")),
                3,
                "'root_joint'",
            ),
        ] {
            let e = load_with(&text, &options).unwrap_err().to_string();
            assert!(e.starts_with(&format!("test.urdf:{line}:")), "{e}");
            assert!(e.contains(message), "{e}");
        }
    }

    #[test]
    fn links_without_inertial_are_massless_and_a_massless_moving_leaf_is_refused() {
        let text = format!(
            "<link name=\"world\"/><link name=\"virtual\"/>\n{}{}\n{}",
            link("arm"),
            joint("a", "revolute", "world", "virtual", ""),
            joint("b", "revolute", "virtual", "arm", "")
        );
        let m = load(&text).unwrap();
        assert_eq!(
            (m.bodies[1].mass, m.bodies[1].inertia),
            (0.0, Matrix3::zeros())
        );
        let [warning] = m.warnings() else {
            panic!("one warning expected, got {:?}", m.warnings());
        };
        assert!(warning.starts_with("test.urdf:2: <link>:"), "{warning}");
        assert!(warning.ends_with("unit inertia): virtual"), "{warning}");

        let leaf = format!(
            "<link name=\"world\"/>{}\n<link name=\"tip\"/>{}{}",
            link("arm"),
            joint("a", "revolute", "world", "arm", ""),
            joint("b", "revolute", "arm", "tip", "")
        );
        let e = load(&leaf).unwrap_err().to_string();
        assert!(
            e.starts_with("test.urdf:3: <link>: link 'tip' moves (joint 'b')"),
            "{e}"
        );
        // Armature gives the joint its inertia.
        let armature = leaf.replace(
            "<parent link=\"arm\"/>",
            "<parent link=\"arm\"/><dynamics diffosi:armature=\"0.1\"/>",
        );
        assert!(load(&armature).is_ok());
    }

    #[test]
    fn pybullets_reading_gives_missing_inertials_a_unit_mass_and_zeroes_unphysical_tensors() {
        let go1_base =
            "<link name=\"tip\">\n<inertial><origin xyz=\"0 0 0.1\"/><mass value=\"3\"/>\
                        <inertia ixx=\"0\" iyy=\"0\" izz=\"3e-6\" ixy=\"0\" ixz=\"0\" iyz=\"0\"/>\
                        </inertial></link>";
        let text = format!(
            "<link name=\"world\"/><link name=\"virtual\"/>\n{go1_base}{}{}",
            joint("a", "revolute", "world", "virtual", ""),
            joint("b", "revolute", "virtual", "tip", "")
        );
        let options = LoadOptions {
            inertials: Inertials::PyBullet,
            ..Default::default()
        };
        let m = load_with(&text, &options).unwrap();
        let (virt, tip) = (&m.bodies[1], &m.bodies[2]);
        assert_eq!((virt.mass, virt.com), (1.0, Vector3::zeros()));
        assert_eq!(virt.inertia, Matrix3::identity());
        assert_eq!((tip.mass, tip.inertia), (3.0, Matrix3::zeros()));
        let [zeroed, without] = m.warnings() else {
            panic!("two warnings expected, got {:?}", m.warnings());
        };
        assert!(
            zeroed.starts_with("test.urdf:4: <inertial>: link 'tip'"),
            "{zeroed}"
        );
        assert!(zeroed.ends_with("as PyBullet does"), "{zeroed}");
        assert!(without.starts_with("test.urdf:2: <link>:"), "{without}");
        assert!(
            without.ends_with("Pinocchio: massless): virtual"),
            "{without}"
        );
        // As written (the default), the same file keeps the tensor.
        assert_eq!(load(&text).unwrap().bodies[2].inertia[(2, 2)], 3e-6);
    }

    #[test]
    fn inertias_are_taken_as_written_with_a_warning_unless_clearly_indefinite() {
        let body = |six: &str| {
            let [xx, yy, zz, xy] = six.split(' ').collect::<Vec<_>>()[..] else {
                panic!()
            };
            format!(
                "<link name=\"a\">\n<inertial><mass value=\"1\"/><inertia ixx=\"{xx}\" \
                 iyy=\"{yy}\" izz=\"{zz}\" ixy=\"{xy}\" ixz=\"0\" iyz=\"0\"/></inertial></link>"
            )
        };
        // Go1's base (triangle inequality) and iCub's ankle (1e-20 off the
        // diagonal): used as written, with a warning naming the link.
        for six in ["0 0 3e-6 0", "0 0 0 1.35525e-20"] {
            let m = load(&body(six)).unwrap();
            assert_eq!(
                m.bodies[1].inertia[(2, 2)],
                six.split(' ').nth(2).unwrap().parse::<f64>().unwrap()
            );
            let [warning] = m.warnings() else {
                panic!("{:?}", m.warnings())
            };
            assert!(
                warning.starts_with("test.urdf:3: <inertial>: model is not physical: body 'a'"),
                "{warning}"
            );
            assert!(
                warning.ends_with("used as written, as PyBullet and Pinocchio use it"),
                "{warning}"
            );
        }
        // Romeo's 'body': an eigenvalue of -0.02 is no rounding. Refused where
        // the link moves; dropped where it is welded to the world.
        let romeo = body("0.05 0.05 0.1 0.07");
        let moving = format!(
            "<link name=\"world\"/>{romeo}{}",
            joint("j", "revolute", "world", "a", "")
        );
        let e = load(&moving).unwrap_err().to_string();
        assert!(e.starts_with("test.urdf:3: <inertial>:"), "{e}");
        assert!(e.contains("not positive semi-definite"), "{e}");
        let m = load(&romeo).unwrap();
        assert_eq!(
            (m.bodies[1].mass, m.bodies[1].inertia),
            (0.0, Matrix3::zeros())
        );
        let [warning] = m.warnings() else {
            panic!("{:?}", m.warnings())
        };
        assert!(
            warning.ends_with("welded to the world, so it takes no part in the dynamics"),
            "{warning}"
        );
        assert!(load(&body("1 1 1 0")).unwrap().warnings().is_empty());
    }
}
