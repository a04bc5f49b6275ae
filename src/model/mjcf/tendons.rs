//! `<tendon>`: fixed and spatial tendons, read with MuJoCo 4's meaning (see
//! [`crate::model::tendon`]) through `<default><tendon>` classes:
//! `stiffness`, `damping`, `springlength` (one value: both ends; -1 -1,
//! the default: the length at qpos0), `frictionloss`, `limited`/`range`,
//! `margin`, solreflimit/solimplimit, solreffriction/solimpfriction; each
//! `<joint joint= coef=>` a term (both required, as MuJoCo requires them).
//! A `<spatial>` path holds `<site site=>`, `<geom geom= sidesite=>` (a
//! sphere or cylinder) and `<pulley divisor=>`. Tendon armature is refused
//! with the line.

use super::attributes::Attrs;
use super::schema::{check_attributes, FIXED_TENDON_ATTRS, SPATIAL_TENDON_ATTRS};
use super::tree::Tree;
use super::{elements, tag, unsupported, Node, Reader, Result};
use crate::model::{Shape, Tendon, Wrap};

impl<'a> Reader<'a> {
    /// The tendons of every `<tendon>` section of `root`, in document order.
    pub(super) fn read_tendons(&self, tree: &Tree<'a>, root: Node<'a>) -> Result<Vec<Tendon>> {
        let sections = elements(root).filter(|s| tag(*s) == "tendon");
        let mut out = vec![];
        for tendon in sections.flat_map(elements) {
            match tag(tendon) {
                "fixed" => out.push(self.read_tendon(tree, tendon, false)?),
                "spatial" => out.push(self.read_tendon(tree, tendon, true)?),
                _ => return Err(self.error(tendon, "a <tendon> holds <fixed> and <spatial>")),
            }
        }
        Ok(out)
    }

    /// A fixed tendon and its joints, or a spatial one and its path.
    fn read_tendon(&self, tree: &Tree<'a>, tendon: Node<'a>, spatial: bool) -> Result<Tendon> {
        let allowed = if spatial {
            SPATIAL_TENDON_ATTRS
        } else {
            FIXED_TENDON_ATTRS
        };
        check_attributes(self.file, tendon, allowed)?;
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
        let (mut joints, mut path) = (vec![], vec![]);
        for element in elements(tendon) {
            match (spatial, tag(element)) {
                (false, "joint") => joints.push(self.tendon_joint(tree, element)?),
                (true, "site" | "geom" | "pulley") => path.push(self.wrap(tree, element)?),
                (false, _) => {
                    return Err(self.error(element, "a fixed tendon holds <joint> elements"))
                }
                (true, _) => {
                    let why = "a spatial tendon holds <site>, <geom> and <pulley> elements";
                    return Err(self.error(element, why));
                }
            }
        }
        if spatial && path.is_empty() {
            return Err(self.error(tendon, "a spatial tendon needs a path of sites"));
        }
        let t = Tendon {
            name: a.text("name").unwrap_or_default().to_string(),
            joints,
            spatial: path,
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

    /// A fixed tendon's `<joint joint= coef=>`.
    fn tendon_joint(&self, tree: &Tree<'a>, joint: Node<'a>) -> Result<(usize, f64)> {
        check_attributes(self.file, joint, &["joint", "coef"])?;
        let name = joint.attribute("joint").unwrap_or("");
        let Some(j) = tree.joints.iter().position(|j| j.name == name) else {
            return Err(self.error(joint, format!("unknown joint '{name}'")));
        };
        let Some(coef) = Attrs::of(self.file, joint).number("coef")? else {
            return Err(self.error(joint, "a tendon's <joint> needs coef"));
        };
        Ok((j, coef))
    }

    /// One element of a spatial path: the site or geom it names must
    /// exist, a wrap geom be a sphere or a cylinder.
    fn wrap(&self, tree: &Tree<'a>, element: Node<'a>) -> Result<Wrap> {
        let site = |key: &str| -> Result<Option<usize>> {
            let Some(name) = element.attribute(key) else {
                return Ok(None);
            };
            match tree.sites.iter().position(|s| s.name == name) {
                Some(k) => Ok(Some(k)),
                None => Err(self.error(element, format!("unknown site '{name}'"))),
            }
        };
        match tag(element) {
            "site" => {
                check_attributes(self.file, element, &["site"])?;
                let k = site("site")?;
                k.map(Wrap::Site)
                    .ok_or_else(|| self.error(element, "a tendon's <site> needs site"))
            }
            "geom" => {
                check_attributes(self.file, element, &["geom", "sidesite"])?;
                let name = element.attribute("geom").unwrap_or("");
                let Some(geom) = tree.geoms.iter().position(|g| g.name == name) else {
                    return Err(self.error(element, format!("unknown geom '{name}'")));
                };
                if !matches!(
                    tree.geoms[geom].shape,
                    Shape::Sphere { .. } | Shape::Cylinder { .. }
                ) {
                    let why = format!("wrap geom '{name}' must be a sphere or a cylinder");
                    return Err(self.error(element, why));
                }
                let sidesite = site("sidesite")?;
                Ok(Wrap::Geom { geom, sidesite })
            }
            _ => {
                check_attributes(self.file, element, &["divisor"])?;
                let divisor = Attrs::of(self.file, element).number("divisor")?;
                let divisor =
                    divisor.ok_or_else(|| self.error(element, "a <pulley> needs divisor"))?;
                Ok(Wrap::Pulley { divisor })
            }
        }
    }
}
