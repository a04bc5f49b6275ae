//! Our extensions in [`NAMESPACE`]: which elements and attributes may carry
//! it, and `<diffosi:options>`. The extension attributes themselves are read
//! with the elements they belong to.

use nalgebra::Vector3;

use super::{is, ours, Node, Reader, Result, NAMESPACE};
use crate::model::{ContactModel, Integrator, Options, PassiveMode};

/// Extension attributes allowed on each URDF element.
const EXTENSION_ATTRIBUTES: [(&str, &[&str]); 3] = [
    ("dynamics", &["stiffness", "springref", "armature"]),
    ("collision", &["contype", "conaffinity"]),
    ("actuator", &["ctrlrange"]),
];

impl Reader<'_> {
    /// Rejects extension elements and attributes that this loader would not
    /// read.
    pub(super) fn check_extensions(&self, robot: Node) -> Result<()> {
        let mut options_seen = false;
        for node in robot.descendants().filter(|n| n.is_element()) {
            if ours(node) {
                self.check_extension_element(robot, node, options_seen)?;
                options_seen = true;
            }
            self.check_extension_attributes(node)?;
        }
        Ok(())
    }

    /// Only one `<diffosi:options>`, in `<robot>`.
    fn check_extension_element(&self, robot: Node, node: Node, options_seen: bool) -> Result<()> {
        if node.tag_name().name() != "options" || node.parent() != Some(robot) {
            let msg = "unknown diffosi element (only <diffosi:options> in <robot>)";
            return Err(self.error(node, msg));
        }
        if options_seen {
            return Err(self.error(node, "more than one <diffosi:options>"));
        }
        Ok(())
    }

    fn check_extension_attributes(&self, node: Node) -> Result<()> {
        let allowed = EXTENSION_ATTRIBUTES
            .iter()
            .find(|(element, _)| is(node, element))
            .map_or(&[][..], |(_, names)| *names);
        let mut extension = node
            .attributes()
            .filter(|a| a.namespace() == Some(NAMESPACE));
        match extension.find(|a| !allowed.contains(&a.name())) {
            Some(a) => Err(self.error(
                node,
                format!("unknown extension attribute diffosi:{}", a.name()),
            )),
            None => Ok(()),
        }
    }

    /// The options: MuJoCo's URDF importer's way of running a model (the
    /// constraint model, implicit damping) unless `<diffosi:options>` says
    /// otherwise.
    pub(super) fn options(&self, robot: Node) -> Result<Options> {
        let mut opt = Options {
            contact_model: ContactModel::Constraint,
            passive: PassiveMode::ImplicitDamping,
            ..Options::default()
        };
        let Some(node) = robot
            .children()
            .find(|n| n.is_element() && n.has_tag_name((NAMESPACE, "options")))
        else {
            return Ok(opt);
        };
        if let Some(timestep) = self.number(node, "timestep")? {
            opt.timestep = self.check_positive(node, "timestep", timestep)?;
        }
        if let Some(gravity) = self.numbers::<3>(node, "gravity")? {
            opt.gravity = Vector3::from(gravity);
        }
        if let Some(integrator) = self.keyword(node, "integrator", &Integrator::NAMES)? {
            opt.integrator = integrator;
        }
        if let Some(mode) = self.keyword(node, "passive", &PassiveMode::NAMES)? {
            opt.passive = mode;
        }
        if let Some(model) = self.keyword(node, "contact", &ContactModel::NAMES)? {
            opt.contact_model = model;
        }
        Ok(opt)
    }
}

#[cfg(test)]
mod tests {
    use super::super::test_util::*;
    use crate::model::{ContactModel, Integrator, PassiveMode};

    #[test]
    fn extensions_carry_what_urdf_cannot_say() {
        let dynamics = "<dynamics damping=\"0.5\" friction=\"0.2\" diffosi:stiffness=\"3\" \
                        diffosi:springref=\"-0.1\" diffosi:armature=\"0.1\"/>";
        let text = format!(
            "<diffosi:options timestep=\"0.01\" gravity=\"0 0 -1\" integrator=\"RK4\" passive=\"explicit\" \
             contact=\"smooth\"/>\
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
            (a.name.as_str(), a.joint(), a.gear[0], a.ctrl_range),
            ("motor", Some(0), 50.0, Some((-2.0, 2.0)))
        );
        let o = &m.opt;
        assert_eq!(
            (
                o.timestep,
                o.gravity.z,
                o.integrator,
                o.passive,
                o.contact_model
            ),
            (
                0.01,
                -1.0,
                Integrator::Rk4,
                PassiveMode::Explicit,
                ContactModel::Smooth
            )
        );

        // MuJoCo's URDF importer's defaults.
        let d = load(&link("a")).unwrap().opt.clone();
        let defaults = (d.timestep, d.integrator, d.passive, d.contact_model);
        assert_eq!(
            defaults,
            (
                0.002,
                Integrator::Euler,
                PassiveMode::ImplicitDamping,
                ContactModel::Constraint
            )
        );
        assert!(d.contact && d.limits);
    }
}
