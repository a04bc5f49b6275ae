//! `<tendon>`: fixed tendons, read with MuJoCo 4's meaning (see
//! [`crate::model::tendon`]) through `<default><tendon>` classes:
//! `stiffness`, `damping`, `springlength` (one value: both ends; -1 -1,
//! the default: the length at qpos0), `frictionloss`, `limited`/`range`,
//! `margin`, solreflimit/solimplimit, solreffriction/solimpfriction; each
//! `<joint joint= coef=>` a term (both required, as MuJoCo requires them). Spatial tendons and
//! tendon armature are refused with the line.

use super::schema::{check_attributes, FIXED_TENDON_ATTRS, TENDON_JOINT_ATTRS};
use super::tree::Tree;
use super::{elements, tag, unsupported, Node, Reader, Result};
use crate::model::Tendon;

impl<'a> Reader<'a> {
    /// The tendons of every `<tendon>` section of `root`, in document order.
    pub(super) fn read_tendons(&self, tree: &Tree<'a>, root: Node<'a>) -> Result<Vec<Tendon>> {
        let sections = elements(root).filter(|s| tag(*s) == "tendon");
        let mut out = vec![];
        for tendon in sections.flat_map(elements) {
            match tag(tendon) {
                "fixed" => out.push(self.read_fixed(tree, tendon)?),
                _ => {
                    let why = "spatial tendons change the dynamics";
                    return Err(unsupported(self.file, tendon, why));
                }
            }
        }
        Ok(out)
    }

    /// A fixed tendon and its joints.
    fn read_fixed(&self, tree: &Tree<'a>, tendon: Node<'a>) -> Result<Tendon> {
        check_attributes(self.file, tendon, FIXED_TENDON_ATTRS)?;
        let a = self.attrs(tendon, "main", |c| &c.tendon)?;
        if a.number("armature")?.unwrap_or(0.0) != 0.0 {
            let why = "tendon armature changes the dynamics";
            return Err(unsupported(self.file, tendon, why));
        }
        let springlength = match a.list("springlength")?.as_deref() {
            None | Some([-1.0, -1.0]) => None,
            Some(&[x]) => Some([x, x]),
            Some(&[lo, hi]) => Some([lo, hi]),
            Some(_) => return Err(self.error(tendon, "springlength takes one or two numbers")),
        };
        let mut joints = vec![];
        for joint in elements(tendon) {
            if tag(joint) != "joint" {
                return Err(self.error(joint, "a fixed tendon holds <joint> elements"));
            }
            check_attributes(self.file, joint, TENDON_JOINT_ATTRS)?;
            let name = joint.attribute("joint").unwrap_or("");
            let Some(j) = tree.joints.iter().position(|j| j.name == name) else {
                return Err(self.error(joint, format!("unknown joint '{name}'")));
            };
            let Some(coef) = super::attributes::Attrs::of(self.file, joint).number("coef")? else {
                return Err(self.error(joint, "a tendon's <joint> needs coef"));
            };
            joints.push((j, coef));
        }
        let t = Tendon {
            name: a.text("name").unwrap_or_default().to_string(),
            joints,
            stiffness: a.number("stiffness")?.unwrap_or(0.0),
            damping: a.number("damping")?.unwrap_or(0.0),
            springlength,
            frictionloss: a.number("frictionloss")?.unwrap_or(0.0),
            range: a.limits("limited", "range", self.compiler.autolimits)?,
            margin: a.number("margin")?.unwrap_or(0.0),
            limit_sol: a.sol_params("solreflimit", "solimplimit")?,
            friction_sol: a.sol_params("solreffriction", "solimpfriction")?,
        };
        t.check(&tree.joints).map_err(|e| self.error(tendon, e))?;
        Ok(t)
    }
}
