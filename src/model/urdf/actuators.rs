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
        Ok(Some(Actuator {
            name: name.to_string(),
            joint,
            gear,
            ctrl_range,
        }))
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
