//! A mesh's volume, centre of mass and inertia as MuJoCo's compiler
//! computes them (`mjCMesh::ComputeFaceCentroid`, `ComputeVolume`,
//! `ComputeSurfaceArea`, `ComputeInertia`): each triangle with the faces'
//! area-weighted centroid spans a pyramid (signed by its orientation), or
//! is a sheet of its area (shell). All in the mesh file's frame after
//! refpos, refquat and scale; inertia per unit density.

use nalgebra::Vector3;

use super::MeshInertia;

use crate::model::MINVAL;

/// Area (0 below mjMINVAL), unit normal and centre of a triangle.
fn triangle(
    a: &Vector3<f64>,
    b: &Vector3<f64>,
    c: &Vector3<f64>,
) -> (f64, Vector3<f64>, Vector3<f64>) {
    let center = Vector3::new(
        (a[0] + b[0] + c[0]) / 3.0,
        (a[1] + b[1] + c[1]) / 3.0,
        (a[2] + b[2] + c[2]) / 3.0,
    );
    let n = (b - a).cross(&(c - a));
    let len = n.dot(&n).sqrt();
    if len < MINVAL {
        return (0.0, Vector3::zeros(), center);
    }
    (0.5 * len, n / len, center)
}

/// The area of a triangle of `p` (MuJoCo's, 0 below mjMINVAL).
pub fn area(p: &[Vector3<f64>], f: &[usize; 3]) -> f64 {
    triangle(&p[f[0]], &p[f[1]], &p[f[2]]).0
}

/// The faces' area-weighted centroid and their total area.
pub fn face_centroid(p: &[Vector3<f64>], faces: &[[usize; 3]]) -> (Vector3<f64>, f64) {
    let (mut sum, mut total) = (Vector3::zeros(), 0.0);
    for f in faces {
        let (area, _, center) = triangle(&p[f[0]], &p[f[1]], &p[f[2]]);
        sum += area * center;
        total += area;
    }
    if total >= MINVAL {
        sum /= total;
    }
    (sum, total)
}

/// Volume (or area, for a shell) and centre of mass, from `faces` and the
/// face centroid `cen`.
pub fn volume_and_com(
    p: &[Vector3<f64>],
    faces: &[[usize; 3]],
    cen: &Vector3<f64>,
    mode: MeshInertia,
) -> (f64, Vector3<f64>) {
    let (mut total, mut com) = (0.0, Vector3::zeros());
    for f in faces {
        let (area, normal, center) = triangle(&p[f[0]], &p[f[1]], &p[f[2]]);
        let weight = match mode {
            MeshInertia::Shell => area,
            MeshInertia::Legacy => ((center - cen).dot(&normal) * area / 3.0).abs(),
            _ => (center - cen).dot(&normal) * area / 3.0,
        };
        total += weight;
        for k in 0..3 {
            com[k] += weight * (center[k] * 3.0 / 4.0 + cen[k] / 4.0);
        }
    }
    if total >= MINVAL {
        com /= total;
    }
    (total, com)
}

/// The inertia tensor per unit density about `com` (xx, yy, zz, xy, xz,
/// yz) and the recomputed volume (or area).
pub fn inertia(
    p: &[Vector3<f64>],
    faces: &[[usize; 3]],
    com: &Vector3<f64>,
    mode: MeshInertia,
) -> ([f64; 6], f64) {
    const K: [(usize, usize); 6] = [(0, 0), (1, 1), (2, 2), (0, 1), (0, 2), (1, 2)];
    let centred: Vec<Vector3<f64>> = p.iter().map(|x| x - com).collect();
    let (mut prod, mut total) = ([0.0; 6], 0.0);
    let c = if mode == MeshInertia::Shell {
        12.0
    } else {
        20.0
    };
    for f in faces {
        let [d, e, g] = f.map(|i| &centred[i]);
        let (area, normal, center) = triangle(d, e, g);
        let mut weight = match mode {
            MeshInertia::Shell => area,
            _ => center.dot(&normal) * area / 3.0,
        };
        if mode == MeshInertia::Legacy {
            weight = weight.abs();
        }
        total += weight;
        for (j, &(a, b)) in K.iter().enumerate() {
            prod[j] += weight / c
                * (2.0 * (d[a] * d[b] + e[a] * e[b] + g[a] * g[b])
                    + d[a] * e[b]
                    + d[b] * e[a]
                    + d[a] * g[b]
                    + d[b] * g[a]
                    + e[a] * g[b]
                    + e[b] * g[a]);
        }
    }
    let i = [
        prod[1] + prod[2],
        prod[0] + prod[2],
        prod[0] + prod[1],
        -prod[3],
        -prod[4],
        -prod[5],
    ];
    (i, total)
}
