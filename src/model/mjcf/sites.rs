//! `<site>`: a frame on a body (see [`crate::model::Site`]). Its pose comes
//! from `pos` and an orientation, or from `fromto` as a geom's does (for
//! capsule, cylinder, box and ellipsoid sites); its type and size make the
//! zone a touch sensor reads; material, rgba, group and user data are
//! visual and not kept. Sites take `<default>`
//! classes as geoms do.

use super::frames::Member;
use super::geoms::primitive;
use super::schema::{check_attributes, SITE_ATTRS};
use super::tree::{Kind, Tree};
use super::{Reader, Result};
use crate::model::Site;

impl<'a> Reader<'a> {
    /// The sites among `members`, attached to `body`, in document order.
    pub(super) fn read_sites(
        &self,
        tree: &mut Tree<'a>,
        members: &[Member<'a>],
        body: usize,
    ) -> Result<()> {
        for m in members.iter().filter(|m| m.node.has_tag_name("site")) {
            let site = self.read_site(tree, m, body)?;
            tree.sites.push(site);
        }
        Ok(())
    }

    /// One `<site>` of `body`, its pose in the body's frame (its enclosing
    /// frames applied), its explicit name claimed.
    fn read_site(&self, tree: &mut Tree<'a>, m: &Member<'a>, body: usize) -> Result<Site> {
        let node = m.node;
        check_attributes(self.file, node, SITE_ATTRS)?;
        let a = self.attrs(node, m.class, |c| &c.site)?;
        #[rustfmt::skip]
        let types = [
            "plane", "hfield", "sphere", "capsule", "ellipsoid", "cylinder", "box", "mesh", "sdf",
        ];
        let kind = a.keyword("type", &types)?.unwrap_or("sphere");
        if ["plane", "hfield", "mesh", "sdf"].contains(&kind) {
            let msg = "meshes, height fields, SDFs and planes are not allowed in sites";
            return Err(self.error(node, msg));
        }
        let mut size = a.leading::<3>("size", [0.005; 3])?;
        let mut pos = a.vector("pos")?.unwrap_or_default();
        let rot = match a.exact::<6>("fromto")? {
            Some(ft) => self.fromto_frame(node, kind, ft, &mut pos, &mut size)?,
            None => self.orientation(&a)?,
        };
        tree.site_zones.push(primitive(kind, size));
        Ok(Site {
            name: tree.claim(self.file, node, Kind::Site, &m.suffix)?,
            body,
            pos: m.frame.point(&pos),
            rot: m.frame.rot * rot,
        })
    }
}

#[cfg(test)]
mod tests {
    use std::f64::consts::FRAC_1_SQRT_2;

    use super::super::test_util::*;

    #[test]
    fn sites_are_placed_as_in_mujoco() {
        let head = r#"<default><site size="0.01"/>
              <default class="c"><site pos="0 0 0.5" euler="0 0 90"/></default></default>"#;
        let bodies = r#"<site name="w" pos="1 2 3"/>
            <body name="b" childclass="c"><joint/><geom size="0.1"/>
              <site name="d"/><site name="f" class="main" type="capsule" fromto="0 0 0 0.3 0 0.4"/>
              <site class="main" zaxis="1 2 3"/>
            </body>"#;
        let m = load(&model(head, bodies, ""));
        let names: Vec<&str> = m.sites.iter().map(|s| s.name.as_str()).collect();
        assert_eq!(names, ["w", "d", "f", "site3"]);
        assert_eq!(
            m.sites.iter().map(|s| s.body).collect::<Vec<_>>(),
            [0, 1, 1, 1]
        );
        assert_close(m.sites[0].pos.as_slice(), &[1.0, 2.0, 3.0], 0.0);
        // MuJoCo 4.0.0's site_pos and site_quat.
        assert_close(m.sites[1].pos.as_slice(), &[0.0, 0.0, 0.5], 0.0);
        let z90 = [FRAC_1_SQRT_2, 0.0, 0.0, 0.7071067811865475];
        assert_close(&quat_of(&m.sites[1].rot), &z90, 1e-15);
        assert_close(m.sites[2].pos.as_slice(), &[0.15, 0.0, 0.2], 1e-16);
        let fromto = [0.31622776601683794, 0.0, -0.9486832980505138, 0.0];
        assert_close(&quat_of(&m.sites[2].rot), &fromto, 1e-15);
        let zaxis = [
            0.9491532346616307,
            -0.28157860306687144,
            0.14078930153343572,
            0.0,
        ];
        assert_close(&quat_of(&m.sites[3].rot), &zaxis, 1e-15);
        assert_close(m.sites[3].pos.as_slice(), &[0.0, 0.0, 0.0], 0.0);

        let bad = [
            (r#"<site type="plane"/>"#, "not allowed in sites"),
            (r#"<site name="s"/><site name="s"/>"#, "repeated name 's'"),
            (r#"<site fromto="0 0 0 0 0 1"/>"#, "fromto requires"),
            (r#"<site pos="0 0"/>"#, "needs 3 numbers"),
            (r#"<site rgb="1 0 0"/>"#, "unrecognized attribute 'rgb'"),
        ];
        for (site, expected) in bad {
            assert_rejects(&model("", &body(site), ""), expected);
        }
    }
}
