//! `<geom>`: primitive shapes, where they sit in their body, and what they add
//! to its inertia (see `inertial.rs`). `size` is read as MuJoCo reads it: a
//! radius, then a half-length (capsules and cylinders), or three half-sizes
//! (boxes) or radii (ellipsoids); a plane's is only checked.

use nalgebra::{Rotation3, Vector3};

use super::attributes::Attrs;
use super::frames::Member;
use super::inertial::Principal;
use super::orientation::{unit, z_to};
use super::schema::{check_attributes, GEOM_ATTRS};
use super::tree::{Kind, Looks, Tree};
use super::{Node, Reader, Result};
use crate::model::geom_inertia::{self, MJ_EPS};
use crate::model::mesh::fit::{fit, Fitted};
use crate::model::{FluidCoefs, Geom, GeomContact, Shape};

impl<'a> Reader<'a> {
    /// The geoms among `members`, attached to `body`; returns the inertial
    /// parts of those that count for the body's inertia (when `count`).
    pub(super) fn read_geoms(
        &self,
        tree: &mut Tree<'a>,
        members: &[Member<'a>],
        body: usize,
        is_static: bool,
        count: bool,
    ) -> Result<Vec<Principal>> {
        let mut parts = vec![];
        for m in members.iter().filter(|m| m.node.has_tag_name("geom")) {
            let (geom, part) = self.read_geom(tree, m, body, is_static, count && body > 0)?;
            tree.geoms.push(geom);
            parts.extend(part);
        }
        Ok(parts)
    }

    /// A geom, and its inertial part when it `counts` for its body's inertia
    /// (and has a mass above MuJoCo's threshold).
    fn read_geom(
        &self,
        tree: &mut Tree<'a>,
        m: &Member<'a>,
        body: usize,
        is_static: bool,
        counts: bool,
    ) -> Result<(Geom, Option<Principal>)> {
        let node = m.node;
        check_attributes(self.file, node, GEOM_ATTRS)?;
        let a = self.attrs(node, m.class, |c| &c.geom)?;
        let kind = geom_type(&a)?;
        let mut size = a.leading::<3>("size", [0.0; 3])?;
        tree.geom_looks.push(Looks {
            alpha: a.leading::<4>("rgba", [0.5, 0.5, 0.5, 1.0])?[3],
            material: a.text("material"),
            plane: [size[0], size[1]],
        });
        let mut pos = a.vector("pos")?.unwrap_or_default();
        let mut rot = match a.exact::<6>("fromto")? {
            Some(ft) => self.fromto_frame(node, kind, ft, &mut pos, &mut size)?,
            None => self.orientation(&a)?,
        };
        if kind != "mesh" && a.text("mesh").is_some() {
            size = self.fitted_size(&a, kind, &mut pos, &mut rot)?;
        }
        let shape = match kind {
            "mesh" => self.mesh_shape(&a, &mut pos, &mut rot)?,
            "hfield" => self.hfield_shape(&a)?,
            _ => self.shape(node, kind, size)?,
        };
        if ["plane", "mesh", "hfield"].contains(&kind) && fluid_coefs(&a)?.is_some() {
            let msg =
                format!("the ellipsoid fluid model (fluidshape) on a {kind} is not supported");
            return Err(self.error(node, msg));
        }
        if kind == "plane" && !is_static {
            return Err(self.error(node, "planes are only allowed in static bodies"));
        }
        let geom = Geom {
            name: tree.claim(self.file, node, Kind::Geom, &m.suffix)?,
            body,
            shape,
            pos: m.frame.point(&pos),
            rot: m.frame.rot * rot,
            contype: bitmask(&a, "contype")?,
            conaffinity: bitmask(&a, "conaffinity")?,
            friction: a.leading::<3>("friction", [1.0, 0.005, 0.0001])?,
            contact: contact_settings(&a)?,
            fluid: fluid_coefs(&a)?,
        };
        let owner = format!("geom '{}'", geom.name);
        crate::model::constraint::check_friction(&geom.friction, &owner)
            .and_then(|()| geom.contact.check(&owner))
            .map_err(|e| self.error(node, e))?;
        let part = if counts {
            self.inertial_part(&a, &geom)?
        } else {
            None
        };
        Ok((geom, part))
    }

    /// The geom's mass and inertia, if its group is in `inertiagrouprange`
    /// and its mass above `mjEPS`.
    fn inertial_part(&self, a: &Attrs, geom: &Geom) -> Result<Option<Principal>> {
        let group = a.int("group")?.unwrap_or(0);
        let [lo, hi] = self.compiler.inertia_groups;
        if group < lo || group > hi {
            return Ok(None);
        }
        let density = a.number("density")?.unwrap_or(1000.0);
        let explicit = a.number("mass")?;
        let meshes = &self.meshes.compiled;
        let mass = geom_inertia::mass(&geom.shape, meshes, explicit, density);
        if mass < 0.0 || (explicit.is_none() && density < 0.0) {
            return Err(a.error(a.element, "geom mass and density cannot be negative"));
        }
        Ok((mass > MJ_EPS).then(|| Principal {
            mass,
            com: geom.pos,
            axes: *geom.rot.matrix(),
            moments: geom_inertia::principal_moments(&geom.shape, meshes, mass),
        }))
    }

    /// A mesh geom: its mesh, and its pose moved to the mesh's inertial
    /// frame (MuJoCo composes the mesh's pos/quat into geom_pos/geom_quat).
    fn mesh_shape(
        &self,
        a: &Attrs,
        pos: &mut Vector3<f64>,
        rot: &mut Rotation3<f64>,
    ) -> Result<Shape> {
        let node = a.element;
        if a.text("fromto").is_some() {
            return Err(self.error(node, "fromto cannot be used with mesh geom"));
        }
        let name = a
            .text("mesh")
            .ok_or_else(|| self.error(node, "a mesh geom needs a mesh"))?;
        let mesh = self
            .meshes
            .find(name)
            .ok_or_else(|| self.error(node, format!("unknown mesh '{name}'")))?;
        let m = &self.meshes.compiled[mesh];
        *pos += *rot * m.pos;
        *rot *= crate::model::mesh::rotation(&m.quat);
        Ok(Shape::Mesh { mesh })
    }

    /// A primitive fitted to its mesh (see [`crate::model::mesh::fit`]):
    /// its size, its pose moved to the fitted primitive's frame (the mesh
    /// frame, shifted to the bounding box's centre under `fitaabb`).
    fn fitted_size(
        &self,
        a: &Attrs,
        kind: &str,
        pos: &mut Vector3<f64>,
        rot: &mut Rotation3<f64>,
    ) -> Result<[f64; 3]> {
        let node = a.element;
        if a.text("fromto").is_some() {
            return Err(self.error(node, "fromto cannot be used with mesh geom"));
        }
        let name = a.text("mesh").unwrap_or_default();
        let mesh = self
            .meshes
            .find(name)
            .ok_or_else(|| self.error(node, format!("unknown mesh '{name}'")))?;
        let m = &self.meshes.compiled[mesh];
        let fitted = match kind {
            "sphere" => Fitted::Sphere,
            "capsule" => Fitted::Capsule,
            "cylinder" => Fitted::Cylinder,
            "ellipsoid" => Fitted::Ellipsoid,
            _ => Fitted::Box,
        };
        let scale = a.number("fitscale")?.unwrap_or(1.0);
        let (size, centre) = fit(m, fitted, self.compiler.fit_aabb, scale);
        let mesh_rot = crate::model::mesh::rotation(&m.quat);
        *pos += *rot * (m.pos + mesh_rot * centre);
        *rot *= mesh_rot;
        Ok(size)
    }

    /// A height-field geom: its field (its size is the field's, MuJoCo's
    /// geom_size).
    fn hfield_shape(&self, a: &Attrs) -> Result<Shape> {
        let node = a.element;
        let name = a
            .text("hfield")
            .ok_or_else(|| self.error(node, "an hfield geom needs an hfield"))?;
        let hfield = self
            .hfields
            .find(name)
            .ok_or_else(|| self.error(node, format!("unknown hfield '{name}'")))?;
        let size = self.hfields.compiled[hfield].size;
        Ok(Shape::HField { hfield, size })
    }

    /// MuJoCo's `fromto`: the geom sits midway, its z axis along from - to, its
    /// half-length half the distance (`size[1]` for capsules and cylinders,
    /// `size[2]` with `size[1] = size[0]` for boxes and ellipsoids).
    pub(super) fn fromto_frame(
        &self,
        node: Node<'a>,
        kind: &str,
        ft: [f64; 6],
        pos: &mut Vector3<f64>,
        size: &mut [f64; 3],
    ) -> Result<Rotation3<f64>> {
        if !["capsule", "cylinder", "ellipsoid", "box"].contains(&kind) {
            return Err(self.error(
                node,
                "fromto requires a capsule, cylinder, box or ellipsoid",
            ));
        }
        if *pos != Vector3::zeros() {
            return Err(self.error(node, "pos and fromto cannot both be given"));
        }
        let (from, to) = (
            Vector3::new(ft[0], ft[1], ft[2]),
            Vector3::new(ft[3], ft[4], ft[5]),
        );
        let dir = unit(from - to).ok_or_else(|| self.error(node, "fromto points are too close"))?;
        size[1] = (from - to).norm() / 2.0;
        if kind == "box" || kind == "ellipsoid" {
            size[2] = size[1];
            size[1] = size[0];
        }
        *pos = (from + to) / 2.0;
        Ok(z_to(&dir))
    }

    fn shape(&self, node: Node<'a>, kind: &str, s: [f64; 3]) -> Result<Shape> {
        let needed = match kind {
            "plane" => {
                if s[2] <= 0.0 {
                    return Err(self.error(node, "plane size[2] must be positive"));
                }
                return Ok(Shape::Plane);
            }
            "sphere" => 1,
            "capsule" | "cylinder" => 2,
            _ => 3,
        };
        if let Some(i) = s[..needed].iter().position(|x| *x <= 0.0) {
            let msg = format!(
                "a {kind} needs {needed} positive size values; size[{i}] = {}",
                s[i]
            );
            return Err(self.error(node, msg));
        }
        Ok(primitive(kind, s))
    }
}

/// The primitive solid of MJCF type `kind` (sphere, capsule, cylinder,
/// box; else ellipsoid) and `size`, as MuJoCo reads the size.
pub(super) fn primitive(kind: &str, s: [f64; 3]) -> Shape {
    match kind {
        "sphere" => Shape::Sphere { radius: s[0] },
        "capsule" => Shape::Capsule {
            radius: s[0],
            half_length: s[1],
        },
        "cylinder" => Shape::Cylinder {
            radius: s[0],
            half_length: s[1],
        },
        "box" => Shape::Box {
            half: Vector3::from(s),
        },
        _ => Shape::Ellipsoid {
            radii: Vector3::from(s),
        },
    }
}

/// The geom type (sphere by default); rejects what is not a primitive solid
/// or a mesh, a plane or height field fitted to a mesh, and fluid forces.
fn geom_type(a: &Attrs) -> Result<&'static str> {
    #[rustfmt::skip]
    let types = [
        "plane", "sphere", "capsule", "ellipsoid", "cylinder", "box", "mesh", "hfield", "sdf",
    ];
    let kind = a.keyword("type", &types)?.unwrap_or("sphere");
    if kind == "sdf" {
        return Err(a.error(a.element, "SDF geoms are not supported"));
    }
    if kind != "hfield" && a.text("hfield").is_some() {
        let msg = format!("a {kind} geom cannot name a height field (hfield=)");
        return Err(a.error(a.element, msg));
    }
    if ["plane", "hfield"].contains(&kind) && a.text("mesh").is_some() {
        let msg = format!("a {kind} cannot be fitted to a mesh (mesh=)");
        return Err(a.error(a.element, msg));
    }
    if a.flag("shellinertia")? == Some(true) {
        return Err(a.error(a.element, "shellinertia is not supported"));
    }
    Ok(kind)
}

/// The geom's ellipsoid fluid model (`fluidshape`, `fluidcoef`), if any.
fn fluid_coefs(a: &Attrs) -> Result<Option<FluidCoefs>> {
    if a.keyword("fluidshape", &["none", "ellipsoid"])? != Some("ellipsoid") {
        return Ok(None);
    }
    let coefs = a.leading::<5>("fluidcoef", FluidCoefs::default().to_array())?;
    Ok(Some(FluidCoefs::from_array(coefs)))
}

/// The constraint model's settings of a geom (MuJoCo's defaults where unset).
fn contact_settings(a: &Attrs) -> Result<GeomContact> {
    let d = GeomContact::default();
    let condim = a.int("condim")?.unwrap_or(d.condim as i64);
    let priority = a.int("priority")?.unwrap_or(0);
    Ok(GeomContact {
        condim: usize::try_from(condim).unwrap_or(0),
        priority: i32::try_from(priority)
            .map_err(|_| a.error(a.element, format!("priority {priority} is out of range")))?,
        solmix: a.number("solmix")?.unwrap_or(d.solmix),
        sol: a.sol_params("solref", "solimp")?,
        margin: a.number("margin")?.unwrap_or(d.margin),
        gap: a.number("gap")?.unwrap_or(d.gap),
    })
}

/// A contact bitmask (`contype`, `conaffinity`), 1 by default.
fn bitmask(a: &Attrs, name: &str) -> Result<u32> {
    let v = a.int(name)?.unwrap_or(1);
    u32::try_from(v)
        .map_err(|_| a.error(a.element, format!("{name} must be a 32-bit mask, got {v}")))
}

#[cfg(test)]
mod tests {
    use std::f64::consts::PI;

    use nalgebra::Vector3;

    use super::super::test_util::*;
    use crate::model::{geom_inertia, Shape};

    #[test]
    fn fromto_capsule_is_placed_and_weighed_as_in_mujoco() {
        let capsule = r#"<geom type="capsule" fromto="0 0 0 0.3 0 0.4" size="0.05 9"/>"#;
        let m = load(&model("", &format!("<body><joint/>{capsule}</body>"), ""));
        let g = &m.geoms[0];
        assert_eq!(
            g.shape,
            Shape::Capsule {
                radius: 0.05,
                half_length: 0.25
            }
        );
        assert_close(g.pos.as_slice(), &[0.15, 0.0, 0.2], 1e-16);
        // MuJoCo's geom_quat: the z axis points from `to` towards `from`.
        let expected = [0.31622776601683794, 0.0, -0.9486832980505138, 0.0];
        assert_close(&quat_of(&g.rot), &expected, 1e-15);
        let (r, h): (f64, f64) = (0.05, 0.5);
        let mass = 1000.0 * PI * (r * r * h + 4.0 * r * r * r / 3.0);
        let b = &m.bodies[1];
        assert!((b.mass - mass).abs() < 1e-14 * mass);
        assert_close(b.com.as_slice(), g.pos.as_slice(), 1e-16);
        let axis = g.rot * Vector3::z();
        let axial = (b.inertia * axis).dot(&axis);
        assert!((axial - geom_inertia::principal_moments(&g.shape, &[], mass).z).abs() < 1e-15);

        let sphere = r#"<geom fromto="0 0 0 0 0 1" size="0.1"/>"#;
        assert_rejects(&model("", &body(sphere), ""), "fromto requires");
        let both = r#"<geom type="capsule" pos="1 0 0" fromto="0 0 0 0 0 1" size="0.1"/>"#;
        assert_rejects(&model("", &body(both), ""), "pos and fromto");
    }
}
