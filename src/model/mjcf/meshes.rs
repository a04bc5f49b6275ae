//! `<asset><mesh>`: mesh files (or inline `vertex`/`face` data) compiled as
//! MuJoCo does (see [`crate::model::mesh`]). A mesh file is found at
//! `meshdir` (else `assetdir`) joined with `file`, relative to the model
//! file's directory unless absolute; `strippath` keeps only its name. A
//! mesh without a name takes its file's name without directory and
//! extension. Attributes read: name, class, file, vertex, face, scale,
//! refpos, refquat, inertia, maxhullvert; the visual ones (normal,
//! texcoord, smoothnormal, material, content_type) are accepted and
//! ignored; `builtin` meshes and mesh plugins are refused.

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use super::attributes::{value, Attrs};
use super::schema::{check_attributes, MESH_ATTRS};
use super::{children, Node, Reader, Result};
use crate::model::mesh::{self, Mesh, MeshInertia, MeshSettings, RawMesh};
use crate::model::{Geom, Shape};

/// Where a mesh came from: its element, what was read, its settings.
struct Source<'a> {
    node: Node<'a>,
    raw: RawMesh,
    settings: MeshSettings,
}

/// The model's meshes, in document order, their sources and their indices
/// by name.
#[derive(Default)]
pub struct Meshes<'a> {
    pub compiled: Vec<Mesh>,
    sources: Vec<Source<'a>>,
    names: HashMap<String, usize>,
}

impl<'a> Meshes<'a> {
    /// The index of the mesh named `name`.
    pub fn find(&self, name: &str) -> Option<usize> {
        self.names.get(name).copied()
    }
}

impl<'a> Reader<'a> {
    /// Reads and compiles every `<asset><mesh>` (hulls come later, once the
    /// geoms that collide are known: [`Reader::add_hulls`]).
    pub(super) fn read_meshes(&self, root: Node<'a>) -> Result<Meshes<'a>> {
        let mut meshes = Meshes::default();
        for asset in children(root, "asset") {
            for node in children(asset, "mesh") {
                let (source, mesh) = self.read_mesh(node)?;
                let name = mesh.name.clone();
                if meshes
                    .names
                    .insert(name.clone(), meshes.compiled.len())
                    .is_some()
                {
                    return Err(self.error(node, format!("repeated name '{name}'")));
                }
                meshes.compiled.push(mesh);
                meshes.sources.push(source);
            }
        }
        Ok(meshes)
    }

    fn read_mesh(&self, node: Node<'a>) -> Result<(Source<'a>, Mesh)> {
        check_attributes(self.file, node, MESH_ATTRS)?;
        if value(node, "builtin").is_some() || !children(node, "plugin").is_empty() {
            return Err(self.error(node, "builtin and plugin meshes are not supported"));
        }
        let a = self.attrs(node, "main", |c| &c.mesh)?;
        let file = a.text("file");
        let name = match (value(node, "name"), file) {
            (Some(n), _) => n.to_string(),
            (None, Some(f)) => file_stem(f),
            (None, None) => return Err(self.error(node, "a mesh needs a name or a file")),
        };
        let settings = self.mesh_settings(&a)?;
        let mut raw = match file {
            Some(f) => {
                let path = self.mesh_path(f);
                mesh::read_file(&path, mesh::MUJOCO_FORMATS)
                    .map_err(|e| self.error(node, format!("mesh file '{}': {e}", path.display())))?
            }
            None => RawMesh::default(),
        };
        self.inline_data(&a, &mut raw)?;
        let compiled = mesh::compile(&name, &raw, &settings)
            .map_err(|e| self.error(node, format!("mesh '{name}': {e}")))?;
        let source = Source {
            node,
            raw,
            settings,
        };
        Ok((source, compiled))
    }

    fn mesh_settings(&self, a: &Attrs) -> Result<MeshSettings> {
        let d = MeshSettings::default();
        let names = MeshInertia::NAMES.map(|(n, _)| n);
        let inertia = match a.keyword("inertia", &names)? {
            Some(k) => {
                MeshInertia::NAMES
                    .iter()
                    .find(|(n, _)| *n == k)
                    .expect("listed")
                    .1
            }
            None => d.inertia,
        };
        let max = a.int("maxhullvert")?.unwrap_or(-1);
        if max != -1 && max < 4 {
            return Err(a.error(a.element, "maxhullvert must be larger than 3"));
        }
        let mut refquat = a.exact::<4>("refquat")?.unwrap_or(d.refquat);
        if refquat.iter().all(|x| *x == 0.0) {
            return Err(a.error(a.element, "refquat is a zero quaternion"));
        }
        let norm = refquat.iter().map(|x| x * x).sum::<f64>().sqrt();
        refquat.iter_mut().for_each(|x| *x /= norm);
        Ok(MeshSettings {
            scale: a.exact::<3>("scale")?.unwrap_or(d.scale),
            refpos: a.exact::<3>("refpos")?.unwrap_or(d.refpos),
            refquat,
            inertia,
            max_hull_vertices: usize::try_from(max).ok(),
            needs_hull: false,
        })
    }

    /// `vertex` and `face` given in the element (not together with a file's).
    fn inline_data(&self, a: &Attrs, raw: &mut RawMesh) -> Result<()> {
        let node = a.element;
        let numbers = |name: &str| -> Result<Option<Vec<f64>>> {
            let Some(text) = value(node, name) else {
                return Ok(None);
            };
            text.split_whitespace()
                .map(|w| w.parse::<f64>().ok().filter(|x| x.is_finite()))
                .collect::<Option<Vec<f64>>>()
                .map(Some)
                .ok_or_else(|| {
                    self.error(node, format!("attribute '{name}' must be finite numbers"))
                })
        };
        let repeated = |what: &str| self.error(node, format!("repeated {what} specification"));
        if let Some(v) = numbers("vertex")? {
            if !raw.vertices.is_empty() {
                return Err(repeated("vertex"));
            }
            if v.len() % 3 != 0 {
                return Err(self.error(node, "vertex data must be a multiple of 3"));
            }
            raw.vertices = v
                .chunks(3)
                .map(|c| [c[0] as f32, c[1] as f32, c[2] as f32])
                .collect();
        }
        if let Some(f) = numbers("face")? {
            if !raw.faces.is_empty() {
                return Err(repeated("face"));
            }
            if f.len() % 3 != 0 || f.iter().any(|x| x.fract() != 0.0 || *x < 0.0) {
                return Err(self.error(node, "face data must be a multiple of 3 vertex indices"));
            }
            raw.faces = f
                .chunks(3)
                .map(|c| [c[0] as usize, c[1] as usize, c[2] as usize])
                .collect();
        }
        Ok(())
    }

    /// Where a mesh file is: see the module documentation.
    pub(super) fn mesh_path(&self, file: &str) -> PathBuf {
        let c = &self.compiler;
        let file = match c.strippath {
            true => Path::new(file)
                .file_name()
                .map_or(file.into(), PathBuf::from),
            false => PathBuf::from(file),
        };
        let dir = Path::new(self.file).parent().unwrap_or(Path::new(""));
        dir.join(&c.meshdir).join(file)
    }

    /// Builds the hull of every mesh that a geom which may collide uses
    /// (contype or conaffinity nonzero, or in an explicit pair `paired`),
    /// as MuJoCo does; a degenerate one is refused at its `<mesh>`.
    pub(super) fn add_hulls(
        &self,
        meshes: &mut Meshes<'a>,
        geoms: &[Geom],
        paired: &[usize],
    ) -> Result<()> {
        for (g, geom) in geoms.iter().enumerate() {
            let Shape::Mesh { mesh } = geom.shape else {
                continue;
            };
            let collides = geom.contype != 0 || geom.conaffinity != 0 || paired.contains(&g);
            let (s, m) = (&mut meshes.sources[mesh], &mut meshes.compiled[mesh]);
            if collides && m.hull.is_none() {
                s.settings.needs_hull = true;
                *m = mesh::compile(&m.name, &s.raw, &s.settings)
                    .map_err(|e| self.error(s.node, format!("mesh '{}': {e}", m.name)))?;
            }
        }
        Ok(())
    }
}

/// A file's name without directory and extension.
pub(super) fn file_stem(file: &str) -> String {
    let name = file.rsplit(['/', '\\']).next().unwrap_or(file);
    match name.rfind('.') {
        Some(dot) => name[..dot].to_string(),
        None => name.to_string(),
    }
}

#[cfg(test)]
mod tests {
    use crate::model::{Inputs, State};
    use nalgebra::{Matrix3, Quaternion, UnitQuaternion, Vector3};

    use super::super::parse;
    use super::super::test_util::*;
    use crate::model::{ModelError, Shape};
    use crate::Model;

    /// An irregular hexahedron with non-planar quad faces (OBJ).
    const BLOCK: &str = "v 0 0 0\nv 1 0 0\nv 1.2 0.7 0\nv 0 0.5 0\nv 0.1 0.1 0.9\nv 0.9 0 1\n\
                         v 1 0.8 1.1\nv 0 0.6 0.8\nf 1 4 3 2\nf 5 6 7 8\nf 1 2 6 5\nf 2 3 7 6\n\
                         f 3 4 8 7\nf 4 1 5 8\n";

    /// `xml` loaded from a fresh directory `name` holding `files`.
    fn load_in(name: &str, files: &[(&str, &[u8])], xml: &str) -> Result<Model, ModelError> {
        let dir = std::env::temp_dir().join(format!("diffosi-mesh-{name}-{}", std::process::id()));
        std::fs::create_dir_all(dir.join("assets")).unwrap();
        for (file, bytes) in files {
            std::fs::write(dir.join("assets").join(file), bytes).unwrap();
        }
        let path = dir.join("model.xml");
        Model::from_spec(parse(xml, path.to_str().unwrap())?)
    }

    fn block_model(mode: &str, collide: u32) -> String {
        format!(
            r#"<mujoco><compiler meshdir="assets"/><asset><mesh name="m" file="block.obj"
            inertia="{mode}" scale="0.5 0.7 0.9" refpos="0.1 0.2 0.05" refquat="0.9 0.1 -0.2 0.3"/>
            </asset><worldbody><body name="b"><joint/><geom type="mesh" mesh="m"
            pos="0.1 -0.2 0.3" euler="10 20 30" density="800" contype="{collide}"
            conaffinity="{collide}"/></body></worldbody></mujoco>"#
        )
    }

    type Compiled = (&'static str, f64, [f64; 3], [f64; 3], [f64; 4], f64);

    /// MuJoCo 4.0.0's body_mass, body_ipos, body_inertia and body_iquat
    /// (= geom_pos, geom_quat) and geom_rbound of `block_model` per mode.
    #[rustfmt::skip]
    const MUJOCO: [Compiled; 4] = [
        ("legacy", 147.5460034196377, [0.4535410776215345, -0.1408778402129871, 0.3461761029514847],
         [12.386594207849704, 10.518476685545593, 5.93718378828174],
         [0.7491356008263073, 0.0654981273331126, 0.11344088237985187, 0.6493358245895147],
         0.8324328240265353),
        ("exact", 147.5460034196377, [0.4535410776215345, -0.1408778402129871, 0.3461761029514847],
         [12.386594207849704, 10.518476685545593, 5.93718378828174],
         [0.7491356008263073, 0.0654981273331126, 0.11344088237985187, 0.6493358245895147],
         0.8324328240265353),
        ("convex", 157.24800273308165, [0.455639463554682, -0.14528536257531635, 0.3605346743844673],
         [13.548651303035413, 11.630135403880146, 6.434946553600862],
         [0.7511216284021257, 0.06887239028317385, 0.11425079618562187, 0.6465443904127343],
         0.8453500708705419),
        ("shell", 1688.123826341382, [0.4568202888574404, -0.14104264745177808, 0.3440656907617041],
         [220.23998987765876, 191.87698729033866, 114.74888387044354],
         [0.7725866407624805, 0.06192322556481081, 0.09500015753986325, 0.6247002214809889],
         0.8547878195092414),
    ];

    #[test]
    fn mesh_inertia_and_frame_are_mujocos_in_every_mode() {
        for (mode, mass, ipos, moments, quat, rbound) in MUJOCO {
            let m = load_in(
                mode,
                &[("block.obj", BLOCK.as_bytes())],
                &block_model(mode, 0),
            )
            .unwrap_or_else(|e| panic!("{mode}: {e}"));
            let (b, g) = (&m.bodies[1], &m.geoms[0]);
            let rel = |a: f64, b: f64| (a - b).abs() / b.abs();
            assert!(
                rel(b.mass, mass) < 1e-13,
                "{mode}: mass {} vs {mass}",
                b.mass
            );
            assert_close(b.com.as_slice(), &ipos, 1e-14);
            assert_close(g.pos.as_slice(), &ipos, 1e-14);
            assert_close(&quat_of(&g.rot), &quat, 1e-9);
            let q = UnitQuaternion::from_quaternion(Quaternion::new(
                quat[0], quat[1], quat[2], quat[3],
            ));
            let r = q.to_rotation_matrix();
            let tensor = r.matrix()
                * Matrix3::from_diagonal(&Vector3::from(moments))
                * r.matrix().transpose();
            let scale = moments[0];
            assert!(
                (b.inertia - tensor).abs().max() < 1e-9 * scale,
                "{mode}: {}",
                b.inertia
            );
            assert!(rel(m.rbound(&g.shape), rbound) < 1e-6, "{mode}");
            let Shape::Mesh { mesh } = g.shape else {
                panic!("{mode}: not a mesh")
            };
            assert_eq!(m.meshes[mesh].hull.is_some(), mode == "convex");
        }
    }

    #[test]
    fn a_colliding_mesh_keeps_its_hull_and_reaching_it_with_a_capsule_is_refused() {
        // A capsule against a mesh has no collider with multiccd disabled (MuJoCo's
        // contacts are then others than ours).
        let xml = block_model("legacy", 1).replace(
            "<worldbody>",
            r#"<option><flag contact="enable" multiccd="disable"/></option><worldbody><geom type="capsule" size="1 1"/>"#,
        );
        let m = load_in("collide", &[("block.obj", BLOCK.as_bytes())], &xml).unwrap();
        let hull = m.meshes[0]
            .hull
            .as_ref()
            .expect("a colliding mesh has a hull");
        assert_eq!((hull.vertices.len(), hull.faces.len()), (8, 12));
        let q = m.reference_q();
        let err = m
            .step(
                &mut m.data(),
                &State::new(q.to_vec(), vec![0.0]),
                &Inputs::tau(&[0.0]),
            )
            .unwrap_err();
        assert!(err.to_string().contains("within reach"), "{err}");
    }

    #[test]
    fn bad_meshes_are_refused_at_their_element() {
        let flat = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nf 1 2 3\nf 2 4 3\n";
        let cases: [(&str, &[u8], &str, &str); 5] = [
            ("missing", b"", "nothing.obj", "No such file"),
            (
                "flat",
                flat.as_bytes(),
                "flat.obj",
                "mesh volume is too small",
            ),
            (
                "garbage",
                b"\x00\x01solid",
                "garbage.stl",
                "neither binary STL",
            ),
            (
                "few",
                b"v 0 0 0\nv 1 0 0\nf 1 2 2\n",
                "few.obj",
                "at least 4 vertices",
            ),
            (
                "range",
                b"v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 2 9\n",
                "range.obj",
                "does not exist",
            ),
        ];
        for (name, bytes, file, expected) in cases {
            let xml = format!(
                "<mujoco><compiler meshdir=\"assets\"/>\n<asset>\n<mesh file=\"{file}\"/></asset></mujoco>"
            );
            let stored = if name == "missing" { "other.obj" } else { file };
            match load_in(name, &[(stored, bytes)], &xml) {
                Err(ModelError::Invalid {
                    line,
                    element,
                    message,
                    ..
                }) => {
                    assert_eq!((line, element.as_str()), (3, "mesh"), "{message}");
                    assert!(message.contains(expected), "{name}: {message}");
                }
                other => panic!("{name}: {other:?}"),
            }
        }
        let flat_colliding = r#"<mujoco><asset><mesh name="f" vertex="0 0 0 1 0 0 0 1 0 1 1 0" inertia="shell"/>
            </asset><worldbody><geom type="mesh" mesh="f"/></worldbody></mujoco>"#;
        assert_rejects(flat_colliding, "coplanar vertices");
        let fitted = model(
            r#"<asset><mesh name="t" vertex="0 0 0 1 0 0 0 1 0 0 0 1"/></asset>"#,
            r#"<geom type="plane" size="1 1 1" mesh="t"/>"#,
            "",
        );
        assert_rejects(&fitted, "a plane cannot be fitted to a mesh");
    }

    #[test]
    fn inline_vertices_make_their_hull_and_visual_meshes_load() {
        // A tetrahedron given by vertices only: faces from its hull.
        let xml = model(
            r#"<asset><mesh name="t" vertex="0 0 0 1 0 0 0 1 0 0 0 1"/></asset>"#,
            r#"<body><joint/><geom type="mesh" mesh="t" contype="0" conaffinity="0"/></body>"#,
            "",
        );
        let m = load(&xml);
        assert!((m.bodies[1].mass - 1000.0 / 6.0).abs() < 1e-12);
        assert_close(m.bodies[1].com.as_slice(), &[0.25; 3], 1e-15);
        assert_eq!(m.meshes[0].faces.len(), 4);
    }
}
