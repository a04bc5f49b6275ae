//! Triangle meshes as MuJoCo 4's compiler makes them (`mjCMesh`): read from
//! STL, OBJ or MSH files, moved by `refpos`, `refquat` and `scale`, weighed
//! by one of MuJoCo's inertia modes, and re-centred at their inertial frame.
//!
//! Frames: a mesh file's vertices are in the *file frame*. The compiled
//! mesh lives in its *mesh frame*: origin at the centre of mass, axes the
//! principal axes of inertia (moments decreasing, MuJoCo's order). The mesh
//! frame sits in the file frame (after refpos/refquat/scale) at [`Mesh::pos`]
//! rotated by [`Mesh::quat`]; a mesh geom's compiled pose is its written pose
//! composed with that one (MuJoCo's geom_pos/geom_quat). Units: the file's
//! lengths times `scale`; volume in length^3 (area for a shell).
//!
//! The convex hull (qhull in MuJoCo, here [`hull`]) is built when a geom of
//! the mesh may collide or the inertia mode is `convex`, on the vertices as
//! read, before refpos/refquat/scale (as MuJoCo does), and kept in
//! [`Mesh::hull`] for the colliders.

mod collada;
mod compile;
mod eig3;
pub mod fit;
pub mod hull;
mod inertia;
mod msh;
mod obj;
pub mod polygon;
mod stl;

use std::path::Path;

use nalgebra::{Matrix3, Rotation3, Vector3};

use crate::spatial::{lift_vector, Real};

pub use compile::compile;
pub use hull::Hull;
pub use polygon::Polygon;

/// The largest mesh file read (bytes): larger ones are refused before
/// reading, so no file can exhaust memory.
pub const MAX_FILE_BYTES: u64 = 256 << 20;

/// A mesh as read from a file: single-precision vertices and triangles
/// (indices into `vertices`, not yet checked).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct RawMesh {
    pub vertices: Vec<[f32; 3]>,
    pub faces: Vec<[usize; 3]>,
}

/// MuJoCo's mesh `inertia` modes: how volume and inertia come from the
/// triangles. `Legacy` (MuJoCo's default) sums unsigned pyramid volumes,
/// `Exact` signed ones (faces must be consistently oriented), `Convex` uses
/// the convex hull, `Shell` spreads the mass over the surface.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MeshInertia {
    Convex,
    Exact,
    Legacy,
    Shell,
}

impl MeshInertia {
    /// The spellings of MJCF's `inertia` attribute.
    pub const NAMES: [(&'static str, MeshInertia); 4] = [
        ("convex", MeshInertia::Convex),
        ("exact", MeshInertia::Exact),
        ("legacy", MeshInertia::Legacy),
        ("shell", MeshInertia::Shell),
    ];
}

/// The `<mesh>` attributes that shape the compiled mesh.
#[derive(Clone, Debug, PartialEq)]
pub struct MeshSettings {
    pub scale: [f64; 3],
    pub refpos: [f64; 3],
    /// (w, x, y, z), normalised by the compiler.
    pub refquat: [f64; 4],
    pub inertia: MeshInertia,
    /// The hull's vertex budget (MJCF `maxhullvert`; None: unbounded).
    pub max_hull_vertices: Option<usize>,
    /// Whether the hull is built (a geom of the mesh may collide).
    pub needs_hull: bool,
}

impl Default for MeshSettings {
    fn default() -> Self {
        MeshSettings {
            scale: [1.0; 3],
            refpos: [0.0; 3],
            refquat: [1.0, 0.0, 0.0, 0.0],
            inertia: MeshInertia::Legacy,
            max_hull_vertices: None,
            needs_hull: false,
        }
    }
}

/// A compiled mesh (see the module documentation for its frame).
#[derive(Clone, Debug, PartialEq)]
pub struct Mesh {
    pub name: String,
    /// Vertices in the mesh frame, at single precision as MuJoCo keeps them.
    pub vertices: Vec<Vector3<f64>>,
    pub faces: Vec<[usize; 3]>,
    /// The convex hull, when one was needed, and its flat sides (empty
    /// without a hull).
    pub hull: Option<Hull>,
    pub polygons: Vec<Polygon>,
    pub inertia: MeshInertia,
    /// Volume (area for a shell).
    pub volume: f64,
    /// The mesh frame in the file frame: position and quaternion (w, x, y, z).
    pub pos: Vector3<f64>,
    pub quat: [f64; 4],
    /// Half-sizes of the box of equal volume and principal moments, along
    /// the mesh axes (MuJoCo's mesh inertia box).
    pub inertia_box: Vector3<f64>,
    /// The vertices' bounding box in the mesh frame: [min, max].
    pub aabb: [Vector3<f64>; 2],
}

impl Mesh {
    /// MuJoCo's mesh geom_rbound: the norm of the bounding box's largest
    /// half-extents about the mesh origin.
    pub fn rbound(&self) -> f64 {
        let [lo, hi] = &self.aabb;
        lo.abs().sup(&hi.abs()).norm()
    }

    /// The support function of the shape colliders see, the convex hull (all
    /// vertices when no hull was built): a hull vertex farthest along `dir`
    /// (mesh frame; ties to the lowest index).
    pub fn support<T: Real>(&self, dir: &Vector3<T>) -> Vector3<T> {
        self.support_vertex(dir)
            .map_or_else(Vector3::zeros, |i| lift_vector(&self.vertices[i]))
    }

    /// The index of [`Mesh::support`]'s vertex (None for a mesh without
    /// vertices).
    pub fn support_vertex<T: Real>(&self, dir: &Vector3<T>) -> Option<usize> {
        match &self.hull {
            Some(h) => self.farthest(h.vertices.iter().copied(), dir),
            None => self.farthest(0..self.vertices.len(), dir),
        }
    }

    /// The first of the vertices `indices` farthest along `dir`.
    fn farthest<T: Real>(
        &self,
        indices: impl Iterator<Item = usize>,
        dir: &Vector3<T>,
    ) -> Option<usize> {
        let mut best: Option<(T, usize)> = None;
        for i in indices {
            let reach = dir.dot(&lift_vector::<T>(&self.vertices[i]));
            if best.as_ref().is_none_or(|(r, _)| reach > *r) {
                best = Some((reach, i));
            }
        }
        best.map(|(_, i)| i)
    }

    /// Principal moments of inertia of the mesh with mass `mass`, along the
    /// mesh axes (MuJoCo's, from the inertia box).
    pub fn principal_moments(&self, mass: f64) -> Vector3<f64> {
        let b = self.inertia_box;
        Vector3::new(
            mass * (b[1] * b[1] + b[2] * b[2]) / 3.0,
            mass * (b[0] * b[0] + b[2] * b[2]) / 3.0,
            mass * (b[0] * b[0] + b[1] * b[1]) / 3.0,
        )
    }
}

/// The rotation of a unit quaternion (w, x, y, z) as MuJoCo's compiler
/// computes its matrix (`mjuu_quat2mat`).
pub fn rotation(q: &[f64; 4]) -> Rotation3<f64> {
    let m = eig3::quat_to_mat(q);
    Rotation3::from_matrix_unchecked(Matrix3::from_row_slice(&m))
}

/// The mesh file types MuJoCo reads (MJCF).
pub const MUJOCO_FORMATS: &[&str] = &["stl", "obj", "msh"];
/// The mesh file types a URDF may name: MuJoCo's, and COLLADA as PyBullet
/// and Pinocchio read it.
pub const URDF_FORMATS: &[&str] = &["stl", "obj", "msh", "dae"];

/// Reads a mesh file by its extension (any case), one of `formats`.
pub fn read_file(path: &Path, formats: &[&str]) -> Result<RawMesh, String> {
    let ext = path
        .extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase())
        .unwrap_or_default();
    if !formats.contains(&ext.as_str()) {
        let (last, rest) = formats.split_last().unwrap_or((&"", &[]));
        return Err(format!(
            "unknown mesh file type: expected .{} or .{last}",
            rest.join(", .")
        ));
    }
    let size = std::fs::metadata(path).map_err(|e| e.to_string())?.len();
    if size > MAX_FILE_BYTES {
        return Err(format!(
            "mesh file of {size} bytes; at most {MAX_FILE_BYTES} are read"
        ));
    }
    let bytes = std::fs::read(path).map_err(|e| e.to_string())?;
    read_bytes(&ext, &bytes)
}

/// Reads mesh file contents of type `ext` (`stl`, `obj`, `msh` or `dae`).
pub fn read_bytes(ext: &str, bytes: &[u8]) -> Result<RawMesh, String> {
    match ext {
        "dae" => collada::read(bytes),
        "stl" => stl::read(bytes),
        "obj" => obj::read(bytes),
        "msh" => msh::read(bytes),
        _ => Err(format!("unknown mesh file type '{ext}'")),
    }
}

#[cfg(test)]
mod tests {
    use nalgebra::Vector3;

    use super::*;

    #[test]
    fn a_tetrahedron_compiles_with_its_hull_support_and_bound() {
        let raw = RawMesh {
            vertices: vec![
                [0.0, 0.0, 0.0],
                [1.0, 0.0, 0.0],
                [0.0, 1.0, 0.0],
                [0.0, 0.0, 1.0],
            ],
            faces: vec![],
        };
        let settings = MeshSettings {
            needs_hull: true,
            ..Default::default()
        };
        let m = compile("t", &raw, &settings).unwrap();
        assert!((m.volume - 1.0 / 6.0).abs() < 1e-16);
        assert!((m.pos - Vector3::repeat(0.25)).amax() < 1e-16);
        // The support along each hull vertex's own direction is that vertex.
        for v in &m.vertices {
            assert_eq!(&m.support(v), v);
        }
        let far = m.vertices.iter().map(|v| v.norm()).fold(0.0, f64::max);
        assert!(m.rbound() >= far - 1e-7 && m.rbound() <= 3f64.sqrt() * far);
    }

    #[test]
    fn collada_is_a_urdf_format_only() {
        let path = Path::new("/nonexistent/arm.DAE");
        let err = read_file(path, MUJOCO_FORMATS).unwrap_err();
        assert_eq!(err, "unknown mesh file type: expected .stl, .obj or .msh");
        let err = read_file(path, URDF_FORMATS).unwrap_err();
        assert!(!err.contains("unknown mesh file type"), "{err}");
    }
}
