//! `<transmission>`: an actuator on the one moving joint it drives; any other
//! transmission (several joints, a fixed or unknown one, a reduction that is
//! no number) is ignored with a warning.

use std::collections::HashMap;

use super::{child, children, xml, Node, Reader, Result};
use crate::model::Actuator;

impl Reader<'_> {
    /// The actuators of the transmissions; `dofs` gives each joint's dof
    /// (`None` if fixed).
    pub(super) fn actuators(
        &self,
        robot: Node,
        dofs: &HashMap<&str, Option<usize>>,
    ) -> Result<Vec<Actuator>> {
        let mut actuators = Vec::new();
        for node in children(robot, "transmission") {
            actuators.extend(self.actuator(node, dofs)?);
        }
        Ok(actuators)
    }

    /// The actuator of `transmission`; `None`, with a warning, for one that
    /// does not drive one moving joint by a numeric reduction.
    fn actuator(
        &self,
        transmission: Node,
        dofs: &HashMap<&str, Option<usize>>,
    ) -> Result<Option<Actuator>> {
        let ignore = |why: String| {
            let msg = format!("{why}: ignored, as PyBullet and Pinocchio ignore transmissions");
            self.warn(transmission, msg);
            Ok(None)
        };
        let joint = match self.driven_dof(transmission, dofs)? {
            Ok(joint) => joint,
            Err(why) => return ignore(why),
        };
        let actuator = child(transmission, "actuator");
        let gear = match actuator.and_then(|a| child(a, "mechanicalReduction")) {
            None => 1.0,
            Some(reduction) => match reduction_of(reduction) {
                Ok(gear) => gear,
                Err(why) => return ignore(why),
            },
        };
        let ctrl_range = match actuator {
            None => None,
            Some(a) => self.ctrl_range(a)?,
        };
        let name = match actuator.and_then(|a| a.attribute("name")) {
            Some(name) => name,
            None => self.attr(transmission, "name")?,
        };
        Ok(Some(Actuator::motor(
            name.to_string(),
            joint,
            gear,
            ctrl_range,
        )))
    }

    /// The dof of the one moving `<joint>` a transmission drives, or why
    /// there is none.
    fn driven_dof(
        &self,
        transmission: Node,
        dofs: &HashMap<&str, Option<usize>>,
    ) -> Result<std::result::Result<usize, String>> {
        let joints: Vec<_> = children(transmission, "joint").collect();
        let [node] = joints[..] else {
            return Ok(Err(format!("drives {} joints, not one", joints.len())));
        };
        let name = self.attr(node, "name")?;
        Ok(match dofs.get(name) {
            Some(Some(dof)) => Ok(*dof),
            Some(None) => Err(format!("joint '{name}' is fixed")),
            None => Err(format!("unknown joint '{name}'")),
        })
    }

    /// `diffosi:ctrlrange` of an `<actuator>`, which must not be empty.
    fn ctrl_range(&self, actuator: Node) -> Result<Option<(f64, f64)>> {
        match self.numbers::<2>(actuator, "diffosi:ctrlrange")? {
            Some([lo, hi]) if lo >= hi => {
                Err(self.error(actuator, format!("ctrlrange {lo} {hi} is empty")))
            }
            range => Ok(range.map(|[lo, hi]| (lo, hi))),
        }
    }
}

/// The gear: the text of `<mechanicalReduction>`, a finite number.
fn reduction_of(node: Node) -> std::result::Result<f64, String> {
    let text = node.text().unwrap_or_default();
    match xml::numbers(text).as_deref() {
        Some(&[gear]) => Ok(gear),
        _ => Err(format!(
            "mechanicalReduction '{}' is not a number",
            text.trim()
        )),
    }
}

#[cfg(test)]
mod tests {
    use super::super::test_util::*;

    #[test]
    fn only_a_transmission_of_one_moving_joint_is_an_actuator() {
        let transmission = |name: &str, joints: &[&str], reduction: &str| {
            let joints: String = joints
                .iter()
                .map(|j| format!("<joint name=\"{j}\"/>"))
                .collect();
            format!(
                "<transmission name=\"{name}\">{joints}<actuator name=\"m_{name}\">\
                 <mechanicalReduction>{reduction}</mechanicalReduction></actuator></transmission>\n"
            )
        };
        let text = format!(
            "<link name=\"world\"/>{}{}{}{}\n",
            link("a"),
            link("b"),
            joint("hinge", "revolute", "world", "a", ""),
            joint("weld", "fixed", "a", "b", "")
        ) + &transmission("ok", &["hinge"], "20")
            + &transmission("two", &["hinge", "weld"], "1")
            + &transmission("fixed", &["weld"], "1")
            + &transmission("unknown", &["elbow"], "1")
            + &transmission("word", &["hinge"], "reduction");
        let m = load(&text).unwrap();
        let actuators: Vec<_> = m
            .actuators
            .iter()
            .map(|a| (a.name.as_str(), a.joint(), a.gear[0]))
            .collect();
        assert_eq!(actuators, [("m_ok", Some(0), 20.0)]);
        let why: Vec<&str> = m
            .warnings()
            .iter()
            .map(|w| w.split("<transmission>: ").nth(1).unwrap())
            .collect();
        let ignored = ": ignored, as PyBullet and Pinocchio ignore transmissions";
        assert_eq!(
            why,
            [
                format!("drives 2 joints, not one{ignored}"),
                format!("joint 'weld' is fixed{ignored}"),
                format!("unknown joint 'elbow'{ignored}"),
                format!("mechanicalReduction 'reduction' is not a number{ignored}"),
            ]
        );
        assert!(
            m.warnings()[0].starts_with("test.urdf:4:"),
            "{}",
            m.warnings()[0]
        );
    }
}
