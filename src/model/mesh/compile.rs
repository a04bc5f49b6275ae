//! From a read mesh to a compiled [`Mesh`], step by step as MuJoCo's
//! `mjCMesh::Process`: checks, hull, refpos/refquat/scale, inertia, then
//! the move to the inertial frame. Errors carry MuJoCo's messages.

use nalgebra::Vector3;

use super::eig3::{eig3, mul_mat_t_vec, mul_mat_vec, normalize, quat_to_mat};
use super::hull::{check_spread, hull};
use super::inertia;
use super::polygon::{self, Polygon};
use super::{Mesh, MeshInertia, MeshSettings, RawMesh};
use crate::model::MINVAL;

/// Compiles mesh `name` read as `raw` with `settings`.
pub fn compile(name: &str, raw: &RawMesh, settings: &MeshSettings) -> Result<Mesh, String> {
    let mut p = check(raw)?;
    let mut faces = raw.faces.clone();
    let mode = settings.inertia;
    if mode == MeshInertia::Exact {
        check_orientation(&p, &faces, name)?;
    }
    let hull = if settings.needs_hull || mode == MeshInertia::Convex || faces.is_empty() {
        check_spread(&p, name)?;
        Some(hull(&p, settings.max_hull_vertices)?)
    } else {
        None
    };
    if faces.is_empty() {
        faces.clone_from(&hull.as_ref().expect("built without faces").faces);
    }
    let sides = hull
        .as_ref()
        .map_or_else(Vec::new, |h| polygon::sides(&p, &h.faces));
    let s = settings.scale;
    if s[0] * s[1] * s[2] <= 0.0 {
        faces.iter_mut().for_each(|f| f.swap(1, 2));
    }
    transform(&mut p, settings);
    let (cen, area) = inertia::face_centroid(&p, &faces);
    if area < MINVAL {
        return Err(format!("mesh surface area is too small: {name}"));
    }
    let weighed: &[[usize; 3]] = match (&hull, mode) {
        (Some(h), MeshInertia::Convex) => &h.faces,
        _ => &faces,
    };
    let (volume, com) = inertia::volume_and_com(&p, weighed, &cen, mode);
    if volume < MINVAL {
        return Err(match mode {
            MeshInertia::Shell => format!("mesh surface area is too small: {name}"),
            _ if volume < 0.0 => {
                format!("mesh volume is negative (misoriented triangles): {name}")
            }
            _ => format!("mesh volume is too small: {name} . Try setting inertia to shell"),
        });
    }
    let (i, volume) = inertia::inertia(&p, weighed, &com, mode);
    if !(volume.is_finite() && com.iter().chain(&i).all(|x| x.is_finite())) {
        return Err(format!(
            "mesh volume or inertia overflows (coordinates too large): {name}"
        ));
    }
    let full = [i[0], i[3], i[4], i[3], i[1], i[5], i[4], i[5], i[2]];
    let (e, quat) = eig3(&full);
    check_moments(&e, name)?;
    let half = |a: f64, b: f64, c: f64| 0.5 * (6.0 * (a + b - c) / volume).sqrt();
    let inertia_box = Vector3::new(
        half(e[1], e[2], e[0]),
        half(e[0], e[2], e[1]),
        half(e[0], e[1], e[2]),
    );
    let inverse = quat_to_mat(&[quat[0], -quat[1], -quat[2], -quat[3]]);
    let exact: Vec<Vector3<f64>> = p
        .iter()
        .map(|x| Vector3::from(mul_mat_vec(&inverse, &(x - com).into())))
        .collect();
    let polygons = sides
        .into_iter()
        .map(|vertices| Polygon {
            normal: polygon::normal(&exact, &vertices),
            vertices,
        })
        .collect();
    let vertices: Vec<Vector3<f64>> = exact
        .iter()
        .map(|v| v.map(|c| f64::from(c as f32)))
        .collect();
    let aabb = aabb(&p, &com, &inverse);
    Ok(Mesh {
        name: name.to_string(),
        vertices,
        faces,
        hull,
        polygons,
        inertia: mode,
        volume,
        pos: com,
        quat,
        inertia_box,
        aabb,
    })
}

/// The vertices as doubles, after MuJoCo's checks of the raw data.
fn check(raw: &RawMesh) -> Result<Vec<Vector3<f64>>, String> {
    if raw.vertices.len() < 4 {
        return Err("at least 4 vertices required".into());
    }
    if let Some(i) = raw
        .vertices
        .iter()
        .position(|v| !v.iter().all(|x| x.is_finite()))
    {
        return Err(format!("vertex coordinate {i} is not finite"));
    }
    let nv = raw.vertices.len();
    if let Some((i, f)) = raw
        .faces
        .iter()
        .enumerate()
        .find(|(_, f)| f.iter().any(|&v| v >= nv))
    {
        return Err(format!(
            "in face {i}, a vertex index of {f:?} does not exist"
        ));
    }
    Ok(raw
        .vertices
        .iter()
        .map(|v| Vector3::from(v.map(f64::from)))
        .collect())
}

/// `exact` inertia needs consistently oriented faces: no directed edge may
/// appear twice among the faces of area above sqrt(mjMINVAL).
fn check_orientation(p: &[Vector3<f64>], faces: &[[usize; 3]], name: &str) -> Result<(), String> {
    let mut half_edges: Vec<(usize, usize)> = faces
        .iter()
        .filter(|f| inertia::area(p, f) > MINVAL.sqrt())
        .flat_map(|f| [(f[0], f[1]), (f[1], f[2]), (f[2], f[0])])
        .collect();
    half_edges.sort_unstable();
    match half_edges.windows(2).find(|w| w[0] == w[1]) {
        Some(w) => Err(format!(
            "faces of mesh '{name}' have inconsistent orientation. Please check the faces \
             containing the vertices {} and {}.",
            w[0].0 + 1,
            w[0].1 + 1
        )),
        None => Ok(()),
    }
}

/// refpos, then refquat (vertices rotated by its inverse), then scale.
fn transform(p: &mut [Vector3<f64>], s: &MeshSettings) {
    let mut q = s.refquat;
    let rotate = q != [1.0, 0.0, 0.0, 0.0];
    normalize(&mut q);
    let mat = quat_to_mat(&q);
    for x in p.iter_mut() {
        *x -= Vector3::from(s.refpos);
        if rotate {
            *x = Vector3::from(mul_mat_t_vec(&mat, &(*x).into()));
        }
        for k in 0..3 {
            x[k] *= s.scale[k];
        }
    }
}

/// MuJoCo's checks of the principal moments (per unit density).
fn check_moments(e: &[f64; 3], name: &str) -> Result<(), String> {
    if e[2] <= 0.0 {
        return Err(format!(
            "eigenvalue of mesh inertia must be positive: {name}"
        ));
    }
    let violates = |a: f64, b: f64, c: f64| a + b < c * (1.0 - 1e-6) - 1e-9;
    if violates(e[0], e[1], e[2]) || violates(e[0], e[2], e[1]) || violates(e[1], e[2], e[0]) {
        return Err(format!(
            "eigenvalues of mesh inertia violate A + B >= C: {name}"
        ));
    }
    Ok(())
}

/// The bounding box, in the mesh frame, of the vertices (in double
/// precision, before MuJoCo narrows them).
fn aabb(p: &[Vector3<f64>], com: &Vector3<f64>, inverse: &[f64; 9]) -> [Vector3<f64>; 2] {
    let mut lo = Vector3::repeat(1e10);
    let mut hi = Vector3::repeat(-1e10);
    for x in p {
        let v = Vector3::from(mul_mat_vec(inverse, &(x - com).into()));
        lo = lo.inf(&v);
        hi = hi.sup(&v);
    }
    [lo, hi]
}
