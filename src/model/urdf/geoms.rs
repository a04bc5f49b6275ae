//! `<collision>` elements become geoms, with the friction of the link's
//! PyBullet `<contact>`.

use nalgebra::Vector3;

use super::attributes::value;
use super::{child, children, Node, Reader, Result};
use crate::model::{Geom, Shape};

impl Reader<'_> {
    /// The geoms of `link`, attached to `body`.
    pub(super) fn geoms(&self, link: Node, body: usize) -> Result<Vec<Geom>> {
        let friction = self.friction(link)?;
        children(link, "collision")
            .filter_map(|c| self.geom(c, body, friction).transpose())
            .collect()
    }

    /// The geom of a `<collision>`; `None` for a mesh.
    fn geom(&self, collision: Node, body: usize, friction: [f64; 3]) -> Result<Option<Geom>> {
        let geometry = self.required_child(collision, "geometry")?;
        let Some(shape) = self.shape(geometry)? else {
            return Ok(None);
        };
        let (pos, rot) = self.origin(collision)?;
        Ok(Some(Geom {
            name: collision.attribute("name").unwrap_or_default().to_string(),
            body,
            shape,
            pos,
            rot,
            contype: self.bitmask(collision, "diffosi:contype")?,
            conaffinity: self.bitmask(collision, "diffosi:conaffinity")?,
            friction,
            contact: Default::default(),
        }))
    }

    /// The shape inside `<geometry>`; `None` for a mesh.
    fn shape(&self, geometry: Node) -> Result<Option<Shape>> {
        let Some(node) = geometry.children().find(|n| n.is_element()) else {
            return Err(self.error(geometry, "empty <geometry>"));
        };
        let shape = match node.tag_name().name() {
            "box" => Shape::Box {
                half: self.box_size(node)? / 2.0,
            },
            "sphere" => Shape::Sphere {
                radius: self.positive(node, "radius")?,
            },
            "cylinder" => Shape::Cylinder {
                radius: self.positive(node, "radius")?,
                half_length: self.positive(node, "length")? / 2.0,
            },
            "capsule" => Shape::Capsule {
                radius: self.positive(node, "radius")?,
                half_length: self.positive(node, "length")? / 2.0,
            },
            "mesh" => return Ok(None),
            other => return Err(self.error(node, format!("unknown geometry '{other}'"))),
        };
        Ok(Some(shape))
    }

    fn box_size(&self, node: Node) -> Result<Vector3<f64>> {
        let [x, y, z] = self.required_numbers(node, "size")?;
        if x.min(y).min(z) <= 0.0 {
            return Err(self.error(node, "box size must be positive"));
        }
        Ok(Vector3::new(x, y, z))
    }

    /// Sliding, torsional, rolling friction from PyBullet's `<contact>`.
    fn friction(&self, link: Node) -> Result<[f64; 3]> {
        let mut friction = [0.5, 0.0, 0.0];
        let Some(contact) = child(link, "contact") else {
            return Ok(friction);
        };
        let names = ["lateral_friction", "spinning_friction", "rolling_friction"];
        for (value, name) in friction.iter_mut().zip(names) {
            if let Some(node) = child(contact, name) {
                *value = self.required_number(node, "value")?;
            }
        }
        Ok(friction)
    }

    /// An MJCF collision bitmask; 1 if absent.
    fn bitmask(&self, collision: Node, name: &str) -> Result<u32> {
        let Some(text) = value(collision, name) else {
            return Ok(1);
        };
        text.trim().parse().map_err(|_| {
            self.error(
                collision,
                format!("{name} must be an unsigned integer, got '{text}'"),
            )
        })
    }
}

#[cfg(test)]
mod tests {
    use nalgebra::Vector3;

    use super::super::test_util::*;
    use crate::model::Shape;

    #[test]
    fn collisions_become_geoms_and_meshes_are_skipped() {
        let text = "<link name=\"world\">\
            <collision name=\"floor\" diffosi:conaffinity=\"0\"><origin xyz=\"0 0 -0.5\"/><geometry><box size=\"2 4 1\"/></geometry></collision>\
            <collision><geometry><cylinder radius=\"0.1\" length=\"1\"/></geometry></collision>\
            <collision><geometry><capsule radius=\"0.1\" length=\"0.4\"/></geometry></collision>\
            <collision><geometry><mesh filename=\"x.stl\"/></geometry></collision>\
            <contact><lateral_friction value=\"0.9\"/></contact></link>";
        let m = load(text).unwrap();
        let shapes: Vec<_> = m.geoms.iter().map(|g| g.shape).collect();
        assert_eq!(
            shapes,
            [
                Shape::Box {
                    half: Vector3::new(1.0, 2.0, 0.5)
                },
                Shape::Cylinder {
                    radius: 0.1,
                    half_length: 0.5
                },
                Shape::Capsule {
                    radius: 0.1,
                    half_length: 0.2
                },
            ]
        );
        let floor = &m.geoms[0];
        assert_eq!(
            (
                floor.name.as_str(),
                floor.body,
                floor.contype,
                floor.conaffinity
            ),
            ("floor", 0, 1, 0)
        );
        assert_eq!((floor.pos.z, floor.friction), (-0.5, [0.9, 0.0, 0.0]));
    }
}
