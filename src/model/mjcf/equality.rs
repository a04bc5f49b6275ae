//! `<equality>`: connect, weld and joint constraints, read with MuJoCo 4's
//! meaning (see [`crate::model::equality`]): common attributes `name`,
//! `active`, `solref`, `solimp` (through `<default><equality>` classes);
//! a connect is by body when it names body1 and an anchor, else by sites;
//! a weld is by body when it names body1, else by sites; body2 defaults to
//! the world; `polycoef` defaults to (0, 1, 0, 0, 0) and `torquescale` to 1.
//! A tendon equality names tendon1 (and tendon2) as a joint one its
//! joints. The flex ones are refused with the line.

use nalgebra::{Quaternion, Vector3};

use super::attributes::Attrs;
use super::schema::{check_attributes, EQUALITY_ATTRS};
use super::{children, elements, tag, unrecognized, unsupported, Node, Reader, Result};
use crate::model::{Body, Equality, EqualityKind, Joint, Objects, Site, Tendon};

/// The objects an equality may name.
pub(super) struct Named<'s> {
    pub bodies: &'s [Body],
    pub joints: &'s [Joint],
    pub sites: &'s [Site],
    pub tendons: &'s [Tendon],
}

impl<'a> Reader<'a> {
    /// The equalities of every `<equality>` section, in document order.
    pub(super) fn read_equalities(&self, root: Node<'a>, named: &Named) -> Result<Vec<Equality>> {
        let mut out = vec![];
        for section in children(root, "equality") {
            for node in elements(section) {
                let kind = tag(node);
                let own: &[&str] = match kind {
                    "connect" => &["body1", "body2", "site1", "site2", "anchor"],
                    "weld" => &[
                        "body1",
                        "body2",
                        "site1",
                        "site2",
                        "anchor",
                        "relpose",
                        "torquescale",
                    ],
                    "joint" => &["joint1", "joint2", "polycoef"],
                    "tendon" => &["tendon1", "tendon2", "polycoef"],
                    "flex" | "flexvert" | "flexstrain" => {
                        return Err(unsupported(self.file, node, "flexes change the dynamics"));
                    }
                    _ => return Err(unrecognized(self.file, node)),
                };
                check_attributes(self.file, node, &[EQUALITY_ATTRS, own].concat())?;
                out.push(self.read_equality(node, named)?);
            }
        }
        Ok(out)
    }

    fn read_equality(&self, node: Node<'a>, named: &Named) -> Result<Equality> {
        let a = self.attrs(node, "main", |c| &c.equality)?;
        let kind = match tag(node) {
            "connect" => {
                let anchor = a.vector("anchor")?;
                let by_body = a.text("body1").is_some() && anchor.is_some();
                EqualityKind::Connect {
                    objects: objects(&a, named, by_body)?,
                    anchor: anchor.filter(|_| by_body).unwrap_or_else(Vector3::zeros),
                }
            }
            "weld" => {
                let by_body = a.text("body1").is_some();
                let relpose = a.exact::<7>("relpose")?.and_then(|r| {
                    let q = Quaternion::new(r[3], r[4], r[5], r[6]);
                    (q.norm() > 0.0).then(|| (Vector3::new(r[0], r[1], r[2]), q))
                });
                EqualityKind::Weld {
                    objects: objects(&a, named, by_body)?,
                    anchor: a
                        .vector("anchor")?
                        .filter(|_| by_body)
                        .unwrap_or_else(Vector3::zeros),
                    relpose: relpose.filter(|_| by_body),
                    torquescale: a.number("torquescale")?.unwrap_or(1.0),
                }
            }
            kind => {
                let (what, names): (&str, Vec<&str>) = match kind {
                    "joint" => (
                        "joint",
                        named.joints.iter().map(|j| j.name.as_str()).collect(),
                    ),
                    _ => (
                        "tendon",
                        named.tendons.iter().map(|t| t.name.as_str()).collect(),
                    ),
                };
                let find = |key: &str| -> Result<Option<usize>> {
                    let Some(name) = a.text(key) else {
                        return Ok(None);
                    };
                    let k = names.iter().position(|n| *n == name);
                    k.map(Some)
                        .ok_or_else(|| a.error(node, format!("{key} '{name}' is not a {what}")))
                };
                let Some(first) = find(&format!("{what}1"))? else {
                    return Err(a.error(node, format!("a {what} equality needs {what}1")));
                };
                let pair = [Some(first), find(&format!("{what}2"))?];
                let polycoef = a.leading("polycoef", [0.0, 1.0, 0.0, 0.0, 0.0])?;
                match what {
                    "joint" => EqualityKind::Joint {
                        joints: pair,
                        polycoef,
                    },
                    _ => EqualityKind::Tendon {
                        tendons: pair,
                        polycoef,
                    },
                }
            }
        };
        let eq = Equality {
            name: a.text("name").unwrap_or_default().to_string(),
            kind,
            active: a.flag("active")?.unwrap_or(true),
            sol: a.sol_params("solref", "solimp")?,
        };
        let counts = [named.bodies.len(), named.sites.len(), named.tendons.len()];
        eq.check_parts(counts, named.joints)
            .map_err(|e| a.error(node, e))?;
        Ok(eq)
    }
}

/// A connect's or weld's two bodies (body2 the world when absent) or two sites.
fn objects(a: &Attrs, named: &Named, by_body: bool) -> Result<Objects> {
    let node = a.element;
    let find = |key: &str, names: Vec<&str>| {
        let name = a.text(key).unwrap_or_default();
        names.iter().position(|n| *n == name).ok_or_else(|| {
            a.error(
                node,
                format!("{key} '{name}' is not a {}", &key[..key.len() - 1]),
            )
        })
    };
    let bodies = || named.bodies.iter().map(|b| b.name.as_str()).collect();
    let sites = || named.sites.iter().map(|s| s.name.as_str()).collect();
    if by_body {
        if a.text("site1").is_some() || a.text("site2").is_some() {
            return Err(a.error(node, "name either bodies or sites, not both"));
        }
        let second = match a.text("body2") {
            Some(_) => find("body2", bodies())?,
            None => 0,
        };
        return Ok(Objects::Bodies([find("body1", bodies())?, second]));
    }
    if a.text("site1").is_none() || a.text("site2").is_none() {
        let why = match tag(node) {
            "connect" => "a connect needs body1 and anchor, or site1 and site2",
            _ => "a weld needs body1, or site1 and site2",
        };
        return Err(a.error(node, why));
    }
    Ok(Objects::Sites([
        find("site1", sites())?,
        find("site2", sites())?,
    ]))
}

#[cfg(test)]
mod tests {
    use super::super::test_util::*;
    use crate::model::{EqualityKind, Objects};

    const BODIES: &str = r#"<body name="a"><joint name="h" type="hinge"/><geom size="0.1"/>
          <site name="s1" pos="0.1 0 0"/>
          <body name="b" pos="0 0 -0.5"><joint name="s" type="slide"/><geom size="0.1"/>
            <site name="s2"/></body></body>
        <body name="f"><freejoint name="free"/><geom size="0.1"/></body>"#;

    #[test]
    fn equalities_read_with_mujocos_defaults_and_classes() {
        let tail = r#"<equality>
            <connect body1="a" anchor="0 0 -0.5" class="soft"/>
            <connect site1="s1" site2="s2" active="false"/>
            <weld body1="f" relpose="1 2 3 0 0 0 0"/>
            <weld body1="f" body2="a" relpose="0 0 0 2 0 0 0" torquescale="3"/>
            <joint joint1="s" joint2="h" polycoef="0.1"/>
          </equality>"#;
        let head =
            r#"<default><default class="soft"><equality solref="0.05 0.5"/></default></default>"#;
        let m = load(&model(head, BODIES, tail));
        let e = &m.equalities;
        assert_eq!(e.len(), 5);
        assert_eq!(e[0].sol.solref, [0.05, 0.5]);
        assert!(matches!(
            e[0].kind,
            EqualityKind::Connect {
                objects: Objects::Bodies([1, 0]),
                ..
            }
        ));
        assert!(!e[1].active);
        assert!(matches!(
            e[1].kind,
            EqualityKind::Connect {
                objects: Objects::Sites([0, 1]),
                ..
            }
        ));
        // A zero quaternion in relpose: the pose at qpos0 (relpose ignored).
        let EqualityKind::Weld {
            relpose,
            torquescale,
            ..
        } = &e[2].kind
        else {
            panic!()
        };
        assert_eq!((relpose.is_none(), *torquescale), (true, 1.0));
        let EqualityKind::Weld {
            relpose,
            torquescale,
            ..
        } = &e[3].kind
        else {
            panic!()
        };
        assert_eq!(relpose.unwrap().1.w, 2.0);
        assert_eq!(*torquescale, 3.0);
        let EqualityKind::Joint { joints, polycoef } = &e[4].kind else {
            panic!()
        };
        assert_eq!(
            (*joints, *polycoef),
            ([Some(1), Some(0)], [0.1, 1.0, 0.0, 0.0, 0.0])
        );
    }

    #[test]
    fn bad_equalities_are_refused_with_the_line() {
        let cases = [
            (
                r#"<connect body1="a"/>"#,
                "a connect needs body1 and anchor, or site1 and site2",
            ),
            (
                r#"<connect body1="x" anchor="0 0 0"/>"#,
                "body1 'x' is not a body",
            ),
            (
                r#"<weld site1="s1" site2="nowhere"/>"#,
                "site2 'nowhere' is not a site",
            ),
            (r#"<weld body1="a" site1="s1"/>"#, "either bodies or sites"),
            (r#"<joint joint1="free"/>"#, "must be a hinge or a slide"),
            (r#"<joint joint2="h"/>"#, "needs joint1"),
            (r#"<joint joint1="h" joint2="h"/>"#, "two different objects"),
            (r#"<weld body1="a" solref="0.02 -1"/>"#, "solref"),
            (r#"<weld body1="a" torquescale="nan"/>"#, "torquescale"),
            (r#"<flex flex="f"/>"#, "flexes"),
            (r#"<pulley/>"#, "unrecognized element"),
        ];
        for (element, expected) in cases {
            let tail = format!("<equality>{element}</equality>");
            assert_rejects(&model("", BODIES, &tail), expected);
        }
    }
}
