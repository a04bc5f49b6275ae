//! `<transmission>`: an actuator on the one joint it drives.

use std::collections::HashMap;

use super::{child, children, Node, Reader, Result};
use crate::model::Actuator;

impl Reader<'_> {
    /// The actuators of the transmissions; `dofs` gives each joint's dof
    /// (`None` if fixed).
    pub(super) fn actuators(
        &self,
        robot: Node,
        dofs: &HashMap<&str, Option<usize>>,
    ) -> Result<Vec<Actuator>> {
        children(robot, "transmission")
            .map(|node| self.actuator(node, dofs))
            .collect()
    }

    fn actuator(
        &self,
        transmission: Node,
        dofs: &HashMap<&str, Option<usize>>,
    ) -> Result<Actuator> {
        let joint = self.driven_dof(transmission, dofs)?;
        let actuator = child(transmission, "actuator");
        let gear = match actuator.and_then(|a| child(a, "mechanicalReduction")) {
            None => 1.0,
            Some(reduction) => self.reduction(reduction)?,
        };
        let ctrl_range = match actuator {
            None => None,
            Some(a) => self.ctrl_range(a)?,
        };
        let name = match actuator.and_then(|a| a.attribute("name")) {
            Some(name) => name,
            None => self.attr(transmission, "name")?,
        };
        Ok(Actuator::motor(name.to_string(), joint, gear, ctrl_range))
    }

    /// The dof of the one `<joint>` a transmission drives.
    fn driven_dof(&self, transmission: Node, dofs: &HashMap<&str, Option<usize>>) -> Result<usize> {
        let joints: Vec<_> = children(transmission, "joint").collect();
        let [node] = joints[..] else {
            let msg = "a transmission must drive exactly one <joint>";
            return Err(self.error(transmission, msg));
        };
        let name = self.attr(node, "name")?;
        match dofs.get(name) {
            Some(Some(dof)) => Ok(*dof),
            Some(None) => Err(self.error(node, format!("joint '{name}' is fixed"))),
            None => Err(self.error(node, format!("unknown joint '{name}'"))),
        }
    }

    /// The gear: the text of `<mechanicalReduction>`.
    fn reduction(&self, node: Node) -> Result<f64> {
        let text = node.text().unwrap_or_default();
        Ok(self.parse_numbers::<1>(node, "mechanicalReduction", text)?[0])
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
