//! `<contact>`: explicit geom pairs (`<pair>`) and excluded body pairs
//! (`<exclude>`). A pair's unset attributes take MuJoCo's pair defaults
//! (through `<default><pair>` classes), not its geoms' values: condim 3,
//! friction (1, 1, 0.005, 0.0001, 0.0001), the default solref and solimp,
//! margin and gap 0 (measured on MuJoCo 4.0.0's compiled pair_* arrays).

use super::attributes::Attrs;
use super::schema::{check_attributes, EXCLUDE_ATTRS, PAIR_ATTRS};
use super::{children, elements, tag, unrecognized, Node, Reader, Result};
use crate::model::{ContactPair, Geom};

impl<'a> Reader<'a> {
    /// The explicit pairs and excluded body pairs of every `<contact>`;
    /// `geoms` and `bodies` name the objects they refer to.
    pub(super) fn read_contact(
        &self,
        root: Node<'a>,
        geoms: &[Geom],
        bodies: &[&str],
    ) -> Result<(Vec<ContactPair>, Vec<[usize; 2]>)> {
        let (mut pairs, mut excludes) = (vec![], vec![]);
        for section in children(root, "contact") {
            for node in elements(section) {
                match tag(node) {
                    "pair" => pairs.push(self.read_pair(node, geoms)?),
                    "exclude" => {
                        check_attributes(self.file, node, EXCLUDE_ATTRS)?;
                        let a = Attrs::of(self.file, node);
                        let find = |key: &str| {
                            let name = a.text(key).unwrap_or_default();
                            bodies.iter().position(|b| *b == name).ok_or_else(|| {
                                a.error(node, format!("{key} '{name}' is not a body"))
                            })
                        };
                        excludes.push([find("body1")?, find("body2")?]);
                    }
                    _ => return Err(unrecognized(self.file, node)),
                }
            }
        }
        Ok((pairs, excludes))
    }

    fn read_pair(&self, node: Node<'a>, geoms: &[Geom]) -> Result<ContactPair> {
        check_attributes(self.file, node, PAIR_ATTRS)?;
        let a = self.attrs(node, "main", |c| &c.pair)?;
        let find = |key: &str| {
            let name = a.text(key).unwrap_or_default();
            geoms
                .iter()
                .position(|g| g.name == name)
                .ok_or_else(|| a.error(node, format!("{key} '{name}' is not a geom")))
        };
        let condim = a.int("condim")?.unwrap_or(3);
        let pair = ContactPair {
            name: a.text("name").unwrap_or_default().to_string(),
            geoms: [find("geom1")?, find("geom2")?],
            condim: usize::try_from(condim).unwrap_or(0),
            friction: a.leading("friction", [1.0, 1.0, 0.005, 0.0001, 0.0001])?,
            sol: a.sol_params("solref", "solimp")?,
            solreffriction: a.leading("solreffriction", [0.0; 2])?,
            margin: a.number("margin")?.unwrap_or(0.0),
            gap: a.number("gap")?.unwrap_or(0.0),
        };
        pair.check(geoms.len()).map_err(|e| a.error(node, e))?;
        Ok(pair)
    }
}
