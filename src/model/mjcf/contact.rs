//! `<contact>`: explicit geom pairs (`<pair>`) and excluded body pairs
//! (`<exclude>`). A pair's unset attributes take MuJoCo's pair defaults
//! (through `<default><pair>` classes), not its geoms' values: condim 3,
//! friction (1, 1, 0.005, 0.0001, 0.0001), the default solref and solimp,
//! margin and gap 0 (measured on MuJoCo 4.0.0's compiled pair_* arrays).

use super::attributes::Attrs;
use super::schema::{check_attributes, EXCLUDE_ATTRS, PAIR_ATTRS};
use super::{children, elements, tag, unrecognized, Node, Reader, Result};
use crate::model::{ContactPair, Geom, PairParams};

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
            params: PairParams {
                condim: usize::try_from(condim).unwrap_or(0),
                friction: a.leading("friction", [1.0, 1.0, 0.005, 0.0001, 0.0001])?,
                sol: a.sol_params("solref", "solimp")?,
                solreffriction: a.leading("solreffriction", [0.0; 2])?,
                margin: a.number("margin")?.unwrap_or(0.0),
                gap: a.number("gap")?.unwrap_or(0.0),
            },
        };
        pair.check(geoms.len()).map_err(|e| a.error(node, e))?;
        Ok(pair)
    }
}

#[cfg(test)]
mod tests {
    use super::super::test_util::*;
    use crate::model::constraint::{SOLIMP, SOLREF};

    const BODIES: &str = r#"<geom name="floor" type="plane" size="1 1 1"/>
        <body name="a"><joint/><geom name="ga" size="0.1" friction="2 0.1 0.01"/></body>
        <body name="b"><joint/><geom name="gb" size="0.1"/></body>"#;

    #[test]
    fn pairs_take_their_own_values_or_mujocos_defaults() {
        let contact = r#"<default><pair margin="0.01"/></default>"#;
        let tail = r#"<contact><pair name="p" geom1="ga" geom2="floor" condim="4" solref="0.05 2"/>
            <pair geom1="gb" geom2="ga" friction="0.5"/><exclude body1="a" body2="b"/></contact>"#;
        let m = load(&model(contact, BODIES, tail));
        let (pp, qp) = (&m.pairs[0], &m.pairs[1]);
        assert_eq!((pp.name.as_str(), pp.geoms), ("p", [1, 0]));
        let [p, q] = [&pp.params, &qp.params];
        assert_eq!(p.condim, 4);
        assert_eq!((p.sol.solref, p.sol.solimp), ([0.05, 2.0], SOLIMP));
        // Unset: MuJoCo's pair defaults (not the geoms' friction), the class's margin.
        assert_eq!(p.friction, [1.0, 1.0, 0.005, 0.0001, 0.0001]);
        assert_eq!((p.margin, p.gap), (0.01, 0.0));
        assert_eq!(
            (q.friction[0], q.friction[2], q.sol.solref),
            (0.5, 0.005, SOLREF)
        );
        assert_eq!(m.excludes, vec![[1, 2]]);
    }

    #[test]
    fn bad_pairs_and_excludes_name_their_line() {
        let cases = [
            (
                r#"<pair geom1="ga" geom2="nope"/>"#,
                "geom2 'nope' is not a geom",
            ),
            (r#"<pair geom1="ga" geom2="ga"/>"#, "two different geoms"),
            (
                r#"<pair geom1="ga" geom2="gb" condim="2"/>"#,
                "condim must be 1, 3, 4 or 6",
            ),
            (
                r#"<pair geom1="ga" geom2="gb" solref="0.02 -1"/>"#,
                "solref",
            ),
            (r#"<pair geom1="ga" geom2="gb" friction="-1"/>"#, "friction"),
            (
                r#"<exclude body1="a" body2="c"/>"#,
                "body2 'c' is not a body",
            ),
            (
                r#"<pair geom1="ga" geom2="gb" radius="1"/>"#,
                "unrecognized attribute 'radius'",
            ),
        ];
        for (element, expected) in cases {
            let xml = model("", BODIES, &format!("<contact>\n{element}</contact>"));
            assert_rejects(&xml, expected);
            assert_eq!(error(&xml).0, 4, "{element}: the line of the element");
        }
    }
}
