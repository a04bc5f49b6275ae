//! `<contact>`: explicit geom pairs (`<pair>`) and excluded body pairs
//! (`<exclude>`). A pair's unset attributes come from its geoms as MuJoCo's
//! compiler sets them: margin and gap the larger of the geoms'; condim,
//! friction, solref and solimp from the geom of higher priority, or at equal
//! priority the larger condim and friction, solimp mixed by solmix and
//! solref the smaller of each entry (MuJoCo's compiler takes that branch for
//! an unset solref).

use super::attributes::Attrs;
use super::schema::{check_attributes, EXCLUDE_ATTRS, PAIR_ATTRS};
use super::{children, elements, tag, unrecognized, Node, Reader, Result};
use crate::model::constraint::solmix;
use crate::model::{ContactPair, Geom, SolParams};

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
        let ids = [find("geom1")?, find("geom2")?];
        let [g1, g2] = ids.map(|g| &geoms[g]);
        let (c1, c2) = (&g1.contact, &g2.contact);
        let leader = match c1.priority.cmp(&c2.priority) {
            std::cmp::Ordering::Greater => Some(g1),
            std::cmp::Ordering::Less => Some(g2),
            std::cmp::Ordering::Equal => None,
        };
        let (condim, friction, sol) = match leader {
            Some(g) => (g.contact.condim, g.friction, g.contact.sol),
            None => {
                let mix = solmix(c1.solmix, c2.solmix);
                let sol = SolParams {
                    solref: std::array::from_fn(|i| c1.sol.solref[i].min(c2.sol.solref[i])),
                    solimp: std::array::from_fn(|i| {
                        mix * c1.sol.solimp[i] + (1.0 - mix) * c2.sol.solimp[i]
                    }),
                };
                let friction = std::array::from_fn(|i| g1.friction[i].max(g2.friction[i]));
                (c1.condim.max(c2.condim), friction, sol)
            }
        };
        let [slide, spin, roll] = friction;
        let condim = a
            .int("condim")?
            .map_or(condim, |c| usize::try_from(c).unwrap_or(0));
        let pair = ContactPair {
            name: a.text("name").unwrap_or_default().to_string(),
            geoms: ids,
            condim,
            friction: a.leading("friction", [slide, slide, spin, roll, roll])?,
            sol: SolParams {
                solref: a.leading("solref", sol.solref)?,
                solimp: a.leading("solimp", sol.solimp)?,
            },
            solreffriction: a.leading("solreffriction", [0.0; 2])?,
            margin: a.number("margin")?.unwrap_or(c1.margin.max(c2.margin)),
            gap: a.number("gap")?.unwrap_or(c1.gap.max(c2.gap)),
        };
        pair.check(geoms.len()).map_err(|e| a.error(node, e))?;
        Ok(pair)
    }
}
