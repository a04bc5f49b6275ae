//! Primitives fitted to a mesh (MJCF `<geom type="box|..." mesh="...">`),
//! as MuJoCo's compiler fits them (mjCMesh::FitGeom).
//!
//! The fitted geom sits in the mesh frame (see [`super`]): by default the
//! primitive matches the mesh's inertia box ([`Mesh::inertia_box`]); with
//! `fitaabb` it encloses the vertices' bounding box, centred at the box's
//! centre. Sizes are MuJoCo's (radius, half-length, half-sizes), times
//! `fitscale`.

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

/// The primitive about the bounding box's centre that encloses the
/// vertices (a box or ellipsoid: the bounding box's half-sizes).
fn enclosing(mesh: &Mesh, kind: Fitted) -> ([f64; 3], Vector3<f64>) {
    let [lo, hi] = mesh.aabb;
    let centre = (lo + hi) / 2.0;
    let offsets = mesh.vertices.iter().map(|v| v - centre);
    let radial = |d: &Vector3<f64>| (d.x * d.x + d.y * d.y).sqrt();
    let max = |xs: &mut dyn Iterator<Item = f64>| xs.fold(0.0, f64::max);
    let size = match kind {
        Fitted::Sphere => [max(&mut offsets.map(|d| d.norm())), 0.0, 0.0],
        Fitted::Cylinder => {
            let radius = max(&mut offsets.clone().map(|d| radial(&d)));
            [radius, max(&mut offsets.map(|d| d.z.abs())), 0.0]
        }
        Fitted::Capsule => {
            let radius = max(&mut offsets.clone().map(|d| radial(&d)));
            // Each vertex's height above the cap's sphere at its distance
            // from the axis.
            let above = |d: Vector3<f64>| {
                let cap = radius * (radial(&d) / radius).acos().sin();
                d.z.abs() - cap
            };
            [radius, max(&mut offsets.map(above)), 0.0]
        }
        Fitted::Ellipsoid | Fitted::Box => (hi - centre).into(),
    };
    (size, centre)
}
