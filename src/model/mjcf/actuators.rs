//! `<actuator>`: motors on joints. A `<general>` with gain `gainprm[0]` and
//! gear `g` is stored with `gear = g * gainprm[0]`, the torque per unit
//! control; actuator elements take defaults from class `main` only unless they
//! name a `class`.

use std::collections::HashSet;

use super::attributes::{value, Attrs};
use super::schema::{check_attributes, ACTUATOR_KINDS, GENERAL_ONLY_ATTRS, MOTOR_ATTRS};
use super::tree::Tree;
use super::{children, elements, tag, unrecognized, unsupported, Node, Reader, Result};
use crate::model::Actuator;

impl<'a> Reader<'a> {
    /// Every actuator in document order; explicit names must differ.
    pub(super) fn read_actuators(&self, tree: &Tree<'a>, root: Node<'a>) -> Result<Vec<Actuator>> {
        let mut names = HashSet::new();
        let mut actuators = vec![];
        for node in children(root, "actuator").into_iter().flat_map(elements) {
            let actuator = self.read_actuator(tree, node)?;
            if !actuator.name.is_empty() && !names.insert(actuator.name.clone()) {
                return Err(self.error(node, format!("repeated name '{}'", actuator.name)));
            }
            actuators.push(actuator);
        }
        Ok(actuators)
    }

    fn read_actuator(&self, tree: &Tree<'a>, node: Node<'a>) -> Result<Actuator> {
        self.check_actuator_kind(node)?;
        let a = self.attrs(node, "main", |c| &c.actuator)?;
        let joint = self.target_joint(tree, node)?;
        let autolimits = self.compiler.autolimits;
        check_unsupported(&a, autolimits)?;
        let gear = a.leading::<6>("gear", [1.0, 0.0, 0.0, 0.0, 0.0, 0.0])?[0];
        Ok(Actuator {
            name: value(node, "name").unwrap_or("").to_string(),
            joint,
            gear: gear * self.motor_gain(&a)?,
            ctrl_range: a
                .limits("ctrllimited", "ctrlrange", autolimits)?
                .map(|[lo, hi]| (lo, hi)),
        })
    }

    /// Only `<motor>` and `<general>` are read.
    fn check_actuator_kind(&self, node: Node<'a>) -> Result<()> {
        match tag(node) {
            "motor" => check_attributes(self.file, node, MOTOR_ATTRS),
            "general" => {
                check_attributes(self.file, node, &[MOTOR_ATTRS, GENERAL_ONLY_ATTRS].concat())
            }
            kind if ACTUATOR_KINDS.contains(&kind) || kind == "plugin" => Err(unsupported(
                self.file,
                node,
                "only motor and motor-like general actuators",
            )),
            _ => Err(unrecognized(self.file, node)),
        }
    }

    /// The index of the joint the actuator drives.
    fn target_joint(&self, tree: &Tree<'a>, node: Node<'a>) -> Result<usize> {
        for target in ["tendon", "site", "body", "jointinparent", "cranksite"] {
            if value(node, target).is_some() {
                let msg = format!("actuators on a {target} are not supported: only on joints");
                return Err(self.error(node, msg));
            }
        }
        let joint_name = value(node, "joint")
            .ok_or_else(|| self.error(node, "an actuator needs a joint to act on"))?;
        let joint = tree
            .joints
            .iter()
            .position(|j| j.name == joint_name)
            .ok_or_else(|| self.error(node, format!("unknown joint '{joint_name}'")))?;
        if tree.joints[joint].kind.nv() != 1 {
            let msg = format!(
                "'{joint_name}' is a ball or free joint; actuators drive hinges and slides"
            );
            return Err(self.error(node, msg));
        }
        Ok(joint)
    }

    /// The force per unit control of a motor-like actuator (gaintype fixed,
    /// biastype none, dyntype none): 1 for `<motor>`, `gainprm[0]` for
    /// `<general>`. A `<motor>` default resets a class to motor settings; other
    /// shortcut defaults (position, ...) make a `<general>` unsupported.
    fn motor_gain(&self, a: &Attrs<'a, '_>) -> Result<f64> {
        let motor: (f64, [&'a str; 3]) = (1.0, ["fixed", "none", "none"]);
        let (mut gain, mut types) = motor;
        let mut shortcut = None;
        for node in a.nodes() {
            match tag(node) {
                "motor" => ((gain, types), shortcut) = (motor, None),
                "general" => {
                    let prm = Attrs::of(self.file, node).leading::<10>("gainprm", [gain; 10])?;
                    gain = prm[0];
                    for (t, key) in types.iter_mut().zip(["gaintype", "biastype", "dyntype"]) {
                        *t = value(node, key).unwrap_or(t);
                    }
                }
                _ => shortcut = Some(node),
            }
        }
        if let Some(s) = shortcut {
            let msg = format!(
                "this general actuator inherits <{}> defaults (line {}); only motor-like \
                 actuators are supported",
                tag(s),
                s.document().text_pos_at(s.range().start).row
            );
            return Err(self.error(a.element, msg));
        }
        if types != motor.1 {
            let [g, b, d] = types;
            let msg = format!(
                "gaintype \"{g}\", biastype \"{b}\", dyntype \"{d}\": only fixed gain, no bias \
                 and no activation dynamics are supported"
            );
            return Err(self.error(a.element, msg));
        }
        Ok(gain)
    }
}

/// Force limits, actuator damping, armature and delay.
fn check_unsupported(a: &Attrs, autolimits: bool) -> Result<()> {
    let force_limits = a.limits("forcelimited", "forcerange", autolimits)?;
    if force_limits.is_some() {
        return Err(a.error(a.element, "force-limited actuators are not supported"));
    }
    let damping = a.leading::<3>("damping", [0.0; 3])?;
    let armature = a.number("armature")?.unwrap_or(0.0);
    let delay = a.number("delay")?.unwrap_or(0.0);
    if damping != [0.0; 3] || armature != 0.0 || delay != 0.0 {
        let msg = "actuator damping, armature and delay are not supported";
        return Err(a.error(a.element, msg));
    }
    Ok(())
}
