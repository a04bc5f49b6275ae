//! `<tendon>`: fixed tendons that only measure. A fixed tendon is a linear
//! combination of joint positions; it changes the dynamics only through a
//! limit, a spring, damping, dry friction, armature or an actuator on it.
//! One without any of these (gymnasium's humanoid has two) is checked and
//! left out of the model; one with them, and every spatial tendon, is
//! refused.

use super::schema::{check_attributes, FIXED_TENDON_ATTRS, TENDON_JOINT_ATTRS};
use super::tree::Tree;
use super::{elements, tag, unsupported, Node, Reader, Result};

impl<'a> Reader<'a> {
    /// Checks every `<tendon>` section of `root`.
    pub(super) fn check_tendons(&self, tree: &Tree<'a>, root: Node<'a>) -> Result<()> {
        let sections = elements(root).filter(|s| tag(*s) == "tendon");
        for tendon in sections.flat_map(elements) {
            match tag(tendon) {
                "fixed" => self.check_fixed(tree, tendon)?,
                _ => {
                    let why = "spatial tendons change the dynamics";
                    return Err(unsupported(self.file, tendon, why));
                }
            }
        }
        Ok(())
    }

    /// A fixed tendon: known joints, and nothing that acts.
    fn check_fixed(&self, tree: &Tree<'a>, tendon: Node<'a>) -> Result<()> {
        check_attributes(self.file, tendon, FIXED_TENDON_ATTRS)?;
        let a = self.attrs(tendon, "main", |c| &c.tendon)?;
        let limited = a.limits("limited", "range", self.compiler.autolimits)?;
        let acting = ["stiffness", "damping", "frictionloss", "armature"]
            .into_iter()
            .map(|name| Ok((name, a.number(name)?.unwrap_or(0.0))))
            .collect::<Result<Vec<_>>>()?;
        if let Some((name, _)) = acting.iter().find(|(_, x)| *x != 0.0) {
            let why = format!("a fixed tendon with {name} changes the dynamics");
            return Err(unsupported(self.file, tendon, &why));
        }
        if limited.is_some() {
            let why = "a limited fixed tendon changes the dynamics";
            return Err(unsupported(self.file, tendon, why));
        }
        for joint in elements(tendon) {
            if tag(joint) != "joint" {
                return Err(self.error(joint, "a fixed tendon holds <joint> elements"));
            }
            check_attributes(self.file, joint, TENDON_JOINT_ATTRS)?;
            let name = joint.attribute("joint").unwrap_or("");
            if !tree.joints.iter().any(|j| j.name == name) {
                return Err(self.error(joint, format!("unknown joint '{name}'")));
            }
        }
        Ok(())
    }
}
