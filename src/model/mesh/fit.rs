//! Primitives fitted to a mesh (MJCF `<geom type="box|..." mesh="...">`),
//! as MuJoCo's compiler fits them (mjCMesh::FitGeom).
//!
//! The fitted geom sits in the mesh frame (see [`super`]): by default the
//! primitive matches the mesh's inertia box ([`Mesh::inertia_box`]); with
//! `fitaabb` it is the smallest whose bounding box contains the vertices'
//! ([`Mesh::aabb`]), centred at that box's centre. Sizes are MuJoCo's
//! (radius, half-length, half-sizes), times `fitscale`.

use nalgebra::Vector3;

use super::Mesh;

/// The primitives a mesh can be fitted with.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Fitted {
    Sphere,
    Capsule,
    Cylinder,
    Ellipsoid,
    Box,
}

/// The fitted primitive's size and its centre in the mesh frame (the
/// origin unless `aabb`).
pub fn fit(mesh: &Mesh, kind: Fitted, aabb: bool, scale: f64) -> ([f64; 3], Vector3<f64>) {
    let (size, centre) = if aabb {
        enclosing(mesh, kind)
    } else {
        (inertia_fit(&mesh.inertia_box, kind), Vector3::zeros())
    };
    (size.map(|s| s * scale), centre)
}

/// The primitive of the inertia box's size.
fn inertia_fit(b: &Vector3<f64>, kind: Fitted) -> [f64; 3] {
    match kind {
        Fitted::Sphere => [(b.x + b.y + b.z) / 3.0, 0.0, 0.0],
        Fitted::Capsule => {
            let radius = (b.x + b.y) / 2.0;
            [radius, (b.z - radius / 2.0).max(0.0), 0.0]
        }
        Fitted::Cylinder => [(b.x + b.y) / 2.0, b.z, 0.0],
        Fitted::Ellipsoid | Fitted::Box => [b.x, b.y, b.z],
    }
}

/// The smallest primitive about the bounding box's centre whose own
/// bounding box contains it (a capsule's half-length its box's less the
/// radius).
fn enclosing(mesh: &Mesh, kind: Fitted) -> ([f64; 3], Vector3<f64>) {
    let [lo, hi] = mesh.aabb;
    let centre = (lo + hi) / 2.0;
    let h = hi - centre;
    let size = match kind {
        Fitted::Sphere => [h.max(), 0.0, 0.0],
        Fitted::Cylinder => [h.x.max(h.y), h.z, 0.0],
        Fitted::Capsule => [h.x.max(h.y), h.z - h.x.max(h.y), 0.0],
        Fitted::Ellipsoid | Fitted::Box => h.into(),
    };
    (size, centre)
}
