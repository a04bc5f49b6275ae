//! `<joint>`: type, `<axis>`, `<limit>` and `<dynamics>` with our passive
//! extensions. Its `<origin>` places the child body (see `links.rs`).

use nalgebra::Vector3;

use super::tree::Edge;
use super::{child, Node, Reader, Result};
use crate::model::{Joint, JointKind};

impl Reader<'_> {
    /// The joint of `edge` moving `body`; `None` for a fixed joint.
    pub(super) fn joint(&self, edge: &Edge, body: usize) -> Result<Option<Joint>> {
        let node = edge.node;
        let ty = self.attr(node, "type")?;
        let Some(kind) = self.joint_kind(node, ty)? else {
            return Ok(None);
        };
        let axis = self.axis(node)?;
        let range = match ty {
            "continuous" | "floating" => None,
            "spherical" => self.spherical_limit(node)?,
            _ => self.limit(node)?,
        };
        let [damping, frictionloss, stiffness, springref, armature] = self.dynamics(node)?;
        Ok(Some(Joint {
            name: edge.name.to_string(),
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
            margin: 0.0,
            limit_sol: Default::default(),
            friction_sol: Default::default(),
            springdamper: None,
        }))
    }

    /// The kind of joint type `ty`; `None` for fixed.
    fn joint_kind(&self, node: Node, ty: &str) -> Result<Option<JointKind>> {
        match ty {
            "revolute" | "continuous" => Ok(Some(JointKind::Hinge)),
            "prismatic" => Ok(Some(JointKind::Slide)),
            "fixed" => Ok(None),
            "floating" => Ok(Some(JointKind::Free)),
            "spherical" => Ok(Some(JointKind::Ball)),
            "planar" => Err(self.error(
                node,
                "planar joints are not supported: write them as two prismatic joints and a \
                 revolute one through massless links",
            )),
            _ => Err(self.error(node, format!("unknown joint type '{ty}'"))),
        }
    }

    /// The unit `<axis>`, x if absent.
    fn axis(&self, joint: Node) -> Result<Vector3<f64>> {
        let Some(axis) = child(joint, "axis") else {
            return Ok(Vector3::x());
        };
        let [x, y, z] = self.required_numbers(axis, "xyz")?;
        Vector3::new(x, y, z)
            .try_normalize(0.0)
            .ok_or_else(|| self.error(axis, "the axis must not be zero"))
    }

    /// The range of `<limit>` if it has lower < upper.
    fn limit(&self, joint: Node) -> Result<Option<(f64, f64)>> {
        let Some(limit) = child(joint, "limit") else {
            return Ok(None);
        };
        let lower = self.number(limit, "lower")?.unwrap_or(0.0);
        let upper = self.number(limit, "upper")?.unwrap_or(0.0);
        Ok((lower < upper).then_some((lower, upper)))
    }

    /// No range: PyBullet limits a spherical joint only where `<limit>` has
    /// lower, upper, twist and effort all positive, as swing angles about x
    /// and y and a twist (btMultiBodySphericalJointLimit), which a ball joint
    /// cannot express; such a limit is ignored with a warning.
    fn spherical_limit(&self, joint: Node) -> Result<Option<(f64, f64)>> {
        let Some(limit) = child(joint, "limit") else {
            return Ok(None);
        };
        let mut values = vec![];
        for name in ["lower", "upper", "twist", "effort"] {
            values.push(self.number(limit, name)?.unwrap_or(0.0));
        }
        if values.iter().all(|&v| v > 0.0) {
            self.warn(
                limit,
                format!(
                    "PyBullet's spherical joint limit (swing {} about x, {} about y, twist {}) \
                     is not supported: the ball joint is unlimited",
                    values[0], values[1], values[2]
                ),
            );
        }
        Ok(None)
    }

    /// `<dynamics>`: damping, frictionloss, stiffness, springref, armature.
    fn dynamics(&self, joint: Node) -> Result<[f64; 5]> {
        let Some(node) = child(joint, "dynamics") else {
            return Ok([0.0; 5]);
        };
        Ok([
            self.nonnegative(node, "damping")?,
            self.nonnegative(node, "friction")?,
            self.nonnegative(node, "diffosi:stiffness")?,
            self.number(node, "diffosi:springref")?.unwrap_or(0.0),
            self.nonnegative(node, "diffosi:armature")?,
        ])
    }
}

/// The free joint that floats the root link's `body`
/// ([`super::LoadOptions::floating_base`]), named as Pinocchio names it.
pub(super) fn free_root(body: usize) -> Joint {
    Joint::free("root_joint".to_string(), body)
}

#[cfg(test)]
mod tests {
    use nalgebra::Vector3;

    use super::super::test_util::*;
    use crate::model::JointKind;

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
    fn a_spherical_joint_is_an_unlimited_ball_joint_with_a_warning_for_its_limit() {
        let limit =
            r#"<origin xyz="0 0 1"/><limit effort="1000" lower="0.2" upper=".8" twist=".3"/>"#;
        let text = format!(
            "<link name=\"world\"/>{}{}",
            link("neck"),
            joint("neck", "spherical", "world", "neck", limit)
        );
        let m = load(&text).unwrap();
        let j = &m.joints[0];
        assert_eq!(
            (j.kind, j.range, m.nq(), m.nv()),
            (JointKind::Ball, None, 4, 3)
        );
        assert_eq!(m.reference_q(), [1.0, 0.0, 0.0, 0.0]);
        assert_eq!(m.bodies[1].pos, Vector3::new(0.0, 0.0, 1.0));
        let [warning] = m.warnings() else {
            panic!("one warning expected: {:?}", m.warnings())
        };
        assert!(warning.contains("test.urdf:2: <limit>: PyBullet's spherical joint limit (swing 0.2 about x, 0.8 about y, twist 0.3)"), "{warning}");

        // PyBullet applies no limit without an effort: nothing is ignored.
        let text = text.replace("effort=\"1000\"", "");
        assert!(load(&text).unwrap().warnings().is_empty());
    }

    #[test]
    fn a_floating_joint_is_a_free_joint_placed_at_its_origin() {
        let origin = r#"<origin xyz="0.1 0.2 0.7" rpy="0.3 0 0"/>"#;
        let text = format!(
            "<link name=\"world\"/>{}{}",
            link("base"),
            joint("float", "floating", "world", "base", origin)
        );
        let m = load(&text).unwrap();
        assert_eq!((m.joints[0].kind, m.nq(), m.nv()), (JointKind::Free, 7, 6));
        let q0 = m.reference_q();
        assert_eq!(q0[..3], [0.1, 0.2, 0.7]);
        let half = 0.15f64;
        assert!((q0[3] - half.cos()).abs() < 1e-15 && (q0[4] - half.sin()).abs() < 1e-15);
    }
}
