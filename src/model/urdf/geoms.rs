//! `<collision>` elements become geoms, with the friction of the link's
//! PyBullet `<contact>`.
//!
//! A `<mesh filename scale>` becomes a mesh geom as MuJoCo's URDF importer
//! makes it: the mesh compiled with MuJoCo's defaults (legacy inertia) and
//! `scale`, its convex hull built (the geom collides), the geom's pose
//! moved to the mesh's inertial frame. One mesh per file and scale. A mesh
//! whose volume MuJoCo finds too small (an open surface), which its importer
//! refuses and PyBullet loads, is compiled with its hull's inertia instead,
//! with a warning: the mesh only places the geom's frame.
//! Where the file is: [`mesh_path`].

use std::path::{Path, PathBuf};

use nalgebra::Vector3;

use super::attributes::value;
use super::{child, children, resolve, Node, Reader, Result};
use crate::model::mesh::{self, Mesh, MeshInertia, MeshSettings};
use crate::model::{Geom, Shape};

/// A mesh of a collision geom: its file and scale, and the compiled mesh.
pub struct UrdfMesh {
    path: PathBuf,
    scale: [f64; 3],
    pub mesh: Mesh,
}

impl Reader<'_> {
    /// The geoms of `link`, attached to `body`.
    pub(super) fn geoms(&self, link: Node, body: usize) -> Result<Vec<Geom>> {
        let friction = self.friction(link)?;
        children(link, "collision")
            .filter_map(|c| self.geom(c, body, friction).transpose())
            .collect()
    }

    /// The geom of a `<collision>`.
    fn geom(&self, collision: Node, body: usize, friction: [f64; 3]) -> Result<Option<Geom>> {
        let geometry = self.required_child(collision, "geometry")?;
        let shape = self.shape(geometry)?;
        let (mut pos, mut rot) = self.origin(collision)?;
        if let Shape::Mesh { mesh } = shape {
            let m = &self.meshes.borrow()[mesh].mesh;
            pos += rot * m.pos;
            rot *= mesh::rotation(&m.quat);
        }
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
            fluid: None,
        }))
    }

    /// The shape inside `<geometry>`.
    fn shape(&self, geometry: Node) -> Result<Shape> {
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
            "mesh" => self.mesh(node)?,
            other => return Err(self.error(node, format!("unknown geometry '{other}'"))),
        };
        Ok(shape)
    }

    /// A `<mesh>`: its file read and compiled once per scale.
    fn mesh(&self, node: Node) -> Result<Shape> {
        let filename = value(node, "filename")
            .ok_or_else(|| self.error(node, "required attribute missing: 'filename'"))?;
        let scale = match value(node, "scale") {
            Some(_) => self.required_numbers::<3>(node, "scale")?,
            None => [1.0; 3],
        };
        let path = resolve(filename, Path::new(self.file), &self.options.package_dirs)
            .map_err(|e| self.error(node, format!("mesh '{filename}': {e}")))?;
        let mut meshes = self.meshes.borrow_mut();
        if let Some(i) = meshes
            .iter()
            .position(|m| m.path == path && m.scale == scale)
        {
            return Ok(Shape::Mesh { mesh: i });
        }
        let settings = MeshSettings {
            scale,
            needs_hull: true,
            ..Default::default()
        };
        let name = path
            .file_stem()
            .map_or(String::new(), |s| s.to_string_lossy().into_owned());
        let error = |e| self.error(node, format!("mesh file '{}': {e}", path.display()));
        let raw = mesh::read_file(&path, mesh::URDF_FORMATS).map_err(error)?;
        let compiled = match mesh::compile(&name, &raw, &settings) {
            Err(e) if e.starts_with("mesh volume is too small") => {
                let convex = MeshSettings {
                    inertia: MeshInertia::Convex,
                    ..settings
                };
                let compiled = mesh::compile(&name, &raw, &convex).map_err(error)?;
                self.warn(
                    node,
                    format!(
                        "mesh file '{}': {e} (MuJoCo's importer refuses it); compiled with \
                         inertia=\"convex\", its hull's, as PyBullet loads it: the mesh \
                         gives the geom its frame, never the link its inertia",
                        path.display()
                    ),
                );
                compiled
            }
            compiled => compiled.map_err(error)?,
        };
        meshes.push(UrdfMesh {
            path,
            scale,
            mesh: compiled,
        });
        Ok(Shape::Mesh {
            mesh: meshes.len() - 1,
        })
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
    use crate::model::urdf::LoadOptions;
    use crate::model::Shape;

    #[test]
    fn collisions_become_geoms() {
        let text = "<link name=\"world\">\
            <collision name=\"floor\" diffosi:conaffinity=\"0\"><origin xyz=\"0 0 -0.5\"/><geometry><box size=\"2 4 1\"/></geometry></collision>\
            <collision><geometry><cylinder radius=\"0.1\" length=\"1\"/></geometry></collision>\
            <collision><geometry><capsule radius=\"0.1\" length=\"0.4\"/></geometry></collision>\
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

    /// `block.obj`: an irregular hexahedron with non-planar quad faces.
    const BLOCK: &str = "v 0 0 0\nv 1 0 0\nv 1.2 0.7 0\nv 0 0.5 0\nv 0.1 0.1 0.9\nv 0.9 0 1\n\
                         v 1 0.8 1.1\nv 0 0.6 0.8\nf 1 4 3 2\nf 5 6 7 8\nf 1 2 6 5\nf 2 3 7 6\n\
                         f 3 4 8 7\nf 4 1 5 8\n";

    #[test]
    fn mesh_collisions_become_mujocos_hull_geoms() {
        let dir = std::env::temp_dir().join(format!("diffosi-urdf-{}", std::process::id()));
        let urdf_dir = dir.join("mypkg").join("urdf");
        std::fs::create_dir_all(&urdf_dir).unwrap();
        std::fs::write(urdf_dir.join("block.obj"), BLOCK).unwrap();
        let path = urdf_dir.join("r.urdf");
        let collision = |file: &str| {
            format!(
                "<link name=\"base\"><inertial><mass value=\"1\"/><inertia ixx=\"1\" iyy=\"1\" \
                 izz=\"1\" ixy=\"0\" ixz=\"0\" iyz=\"0\"/></inertial><collision><origin \
                 xyz=\"0.1 -0.2 0.3\" rpy=\"0.1 0.2 0.3\"/><geometry><mesh filename=\"{file}\" \
                 scale=\"0.5 0.7 0.9\"/></geometry></collision></link>"
            )
        };
        let load_file = |file: &str| {
            let text = urdf(&collision(file));
            let options = LoadOptions::default();
            super::super::parse(&text, path.to_str().unwrap(), &options).map(|l| l.spec)
        };
        for file in ["block.obj", "package://mypkg/urdf/block.obj"] {
            let spec = load_file(file).unwrap();
            let g = &spec.geoms[0];
            assert_eq!(
                (g.shape, g.contype, g.conaffinity),
                (Shape::Mesh { mesh: 0 }, 1, 1)
            );
            assert!(spec.meshes[0].hull.is_some());
            // MuJoCo 4.0.0's geom_pos and geom_quat of this URDF.
            let pos = [0.3978574735501256, 0.10826382722212369, 0.6771872690057856];
            assert!((g.pos - Vector3::from(pos)).amax() < 1e-14, "{}", g.pos);
            let quat = [
                0.3761892927377824,
                0.09838674678388007,
                0.08622423290853162,
                0.917260620405165,
            ];
            let q = nalgebra::UnitQuaternion::from_rotation_matrix(&g.rot);
            let ours = [q.w, q.i, q.j, q.k].map(|x| x * q.w.signum());
            assert!(
                ours.iter().zip(quat).all(|(a, b)| (a - b).abs() < 1e-9),
                "{ours:?}"
            );
        }
        let err = load_file("package://nowhere/block.obj")
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("<mesh>") && err.contains("package 'nowhere'"),
            "{err}"
        );
        let err = load_file("missing.stl").unwrap_err().to_string();
        assert!(
            err.contains("<mesh>") && err.contains("missing.stl"),
            "{err}"
        );
    }

    /// Three crossed squares: every face's plane holds the surface's
    /// centroid, so MuJoCo 4.0.0 refuses the mesh as legacy ("mesh volume is
    /// too small") and compiles it as convex: a cuboctahedron of volume 20/3.
    const CROSS: &str = "v 1 1 0\nv -1 1 0\nv -1 -1 0\nv 1 -1 0\nv 1 0 1\nv -1 0 1\n\
        v -1 0 -1\nv 1 0 -1\nv 0 1 1\nv 0 -1 1\nv 0 -1 -1\nv 0 1 -1\n\
        f 1 2 3\nf 1 3 4\nf 5 6 7\nf 5 7 8\nf 9 10 11\nf 9 11 12\n";

    #[test]
    fn a_mesh_without_volume_gets_its_hulls_inertia_with_a_warning() {
        let dir = std::env::temp_dir().join(format!("diffosi-urdf-cross-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        std::fs::write(dir.join("cross.obj"), CROSS).unwrap();
        let text = urdf(
            "<link name=\"base\"><collision><geometry>\n\
             <mesh filename=\"cross.obj\"/></geometry></collision></link>",
        );
        let path = dir.join("r.urdf");
        let loaded = super::super::parse(&text, path.to_str().unwrap(), &Default::default());
        let loaded = loaded.unwrap();
        assert!((loaded.spec.meshes[0].volume - 20.0 / 3.0).abs() < 1e-12);
        assert!(
            loaded.spec.geoms[0].pos.norm() < 1e-15,
            "{}",
            loaded.spec.geoms[0].pos
        );
        let warnings: Vec<_> = loaded
            .warnings
            .iter()
            .filter(|w| w.contains("<mesh>"))
            .collect();
        let [warning] = warnings[..] else {
            panic!("one warning on the mesh expected: {:?}", loaded.warnings)
        };
        assert!(warning.contains(":3: <mesh>: mesh file"), "{warning}");
        assert!(warning.contains("volume is too small"), "{warning}");
        assert!(warning.contains("inertia=\"convex\""), "{warning}");
    }
}
