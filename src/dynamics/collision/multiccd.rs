//! MuJoCo 4's multi-contact of convex pairs (`mjc_multicontact` of
//! engine_collision_gjk.c, the `multiccd` flag, on by default): when the
//! face that GJK or EPA ends on touches a face of each geom (box faces,
//! cylinder caps, the flat sides of a mesh's hull) or a face of one and an
//! edge of the other (box, mesh or cylinder side edges, a capsule's
//! segment), the contact becomes the
//! polygon where the two features overlap, clipped as MuJoCo clips it, with
//! up to four points.
//!
//! Conventions: geom 1 is A and geom 2 is B of the Minkowski difference
//! A - B; `dir` = x2 - x1 runs from A's witness point to B's (from B into A
//! when they overlap). A face is the list of its corners in the world frame;
//! a feature is the set of distinct shape vertices (indices, see
//! [`Vertex`]) that the final simplex face holds on one geom: one vertex, an
//! edge or a face. A mesh's faces are its hull's sides
//! ([`Mesh::polygons`]), walked in reverse as MuJoCo's `mesh_face` does; a
//! side's cycle may start at another vertex than qhull's, so a polygon
//! reduced to four corners may keep others than MuJoCo. Cylinder caps are
//! MuJoCo's 16-gons. Tolerances are MuJoCo's: faces are aligned within
//! 0.0889 rad, an edge lies in a face
//! within the same angle.

use nalgebra::Vector3;

use super::convex::Body;
use super::gjk::Vertex;
use super::{normalize, GeomType};
use crate::model::mesh::Mesh;
use crate::model::{Shape, MINVAL};
use crate::spatial::{lift, lift_vector, Real};

/// The angle within which faces count as aligned (MuJoCo's FACE_TOL is its
/// cosine, EDGE_TOL its sine).
const ALIGNED: f64 = 0.0889;

/// How far past an edge a clipping intersection still counts.
const INTERSECT_TOL: f64 = 3e-7;

/// A pair of witness points (on geom 1 and geom 2) and their signed distance.
pub(super) struct Witness<T: Real> {
    pub x1: Vector3<T>,
    pub x2: Vector3<T>,
    pub dist: T,
}

fn has_face(g: GeomType) -> bool {
    matches!(g, GeomType::Box | GeomType::Cylinder | GeomType::Mesh)
}

/// Whether MuJoCo looks for the extra contacts of geom types a and b:
/// faces on both, or a face on one and a capsule's edge on the other.
pub(super) fn pairs(a: GeomType, b: GeomType) -> bool {
    let edge = |g: GeomType| g == GeomType::Capsule;
    (has_face(a) || edge(a)) && (has_face(b) || edge(b)) && (has_face(a) || has_face(b))
}

/// The distinct vertices of one geom on the simplex face: how many (1 to
/// 3), their indices and points.
struct Feature<T: Real> {
    dim: usize,
    index: [i32; 3],
    vert: [Vector3<T>; 3],
}

impl<T: Real> Feature<T> {
    /// Geom 1's (`first`) or geom 2's feature of the face.
    fn of(face: &[Vertex<T>; 3], first: bool) -> Self {
        let index = face.map(|v| if first { v.i1 } else { v.i2 });
        let vert = face.map(|v| if first { v.p1 } else { v.p2 });
        if index[0] != index[1] {
            let dim = if index[2] == index[0] || index[2] == index[1] {
                2
            } else {
                3
            };
            return Feature { dim, index, vert };
        }
        let dim = if index[0] != index[2] { 2 } else { 1 };
        Feature {
            dim,
            index: [index[0], index[2], index[2]],
            vert: [vert[0], vert[2], vert[2]],
        }
    }
}

/// A face normal of a geom (world frame) and the index of that face.
type Normal<T> = (Vector3<T>, usize);

/// An edge from a common start: directions (unit) and end points.
struct Edges<T: Real> {
    start: Vector3<T>,
    ends: Vec<(Vector3<T>, Vector3<T>)>,
}

impl<T: Real> Edges<T> {
    /// The edges from `start` to each of `ends`, with their unit directions.
    fn from_ends(start: Vector3<T>, ends: Vec<Vector3<T>>) -> Self {
        let ends = ends
            .into_iter()
            .map(|e| (normalize(e - start).0, e))
            .collect();
        Edges { start, ends }
    }
}

/// The extra contacts of the pair (see the module documentation) from the
/// simplex face and the witness points x1, x2; empty when the features are
/// not aligned or the clipping leaves nothing (one contact stays).
pub(super) fn contacts<T: Real>(
    (a, b): (&Body<T>, &Body<T>),
    face: &[Vertex<T>; 3],
    (x1, x2): (Vector3<T>, Vector3<T>),
) -> Vec<Witness<T>> {
    let (f1, f2) = (Feature::of(face, true), Feature::of(face, false));
    let dir = x2 - x1;
    let n1 = face_normals(a, &f1, &-dir);
    let n2 = face_normals(b, &f2, &dir);
    if let Some((i, j)) = aligned_faces(&n1, &n2, &dir) {
        // Face against face.
        let (face1, face2) = (face_of(a, n1[i].1), face_of(b, n2[j].1));
        let wit = n2[j].0;
        let c = polygon_clip(&face1, &face2, &n1[i].0, &wit, half_margins(a, b));
        with_margins(c, (a, b), -wit)
    } else if f1.dim < 3 && !n2.is_empty() && (f1.dim <= f2.dim || n1.is_empty()) {
        // An edge of geom 1 in a face of geom 2.
        let Some(e) = edges(a, &f1, x1) else {
            return vec![];
        };
        let Some((i, j)) = face_edge(&e, &n2, &dir) else {
            return vec![];
        };
        let edge = [e.start, e.ends[i].1];
        let face2 = face_of(b, n2[j].1);
        let wit = -n2[j].0;
        let c = polygon_clip(&face2, &edge, &n2[j].0, &wit, half_margins(a, b));
        let swapped = c
            .into_iter()
            .map(|w| Witness {
                x1: w.x2,
                x2: w.x1,
                dist: w.dist,
            })
            .collect();
        with_margins(swapped, (a, b), wit)
    } else if f2.dim < 3 {
        // An edge of geom 2 in a face of geom 1.
        let Some(e) = edges(b, &f2, x2) else {
            return vec![];
        };
        let Some((i, j)) = face_edge(&e, &n1, &-dir) else {
            return vec![];
        };
        let edge = [e.start, e.ends[i].1];
        let face1 = face_of(a, n1[j].1);
        let wit = -n1[j].0;
        let c = polygon_clip(&face1, &edge, &n1[j].0, &wit, half_margins(a, b));
        with_margins(c, (a, b), n1[j].0)
    } else {
        vec![]
    }
}

/// Half of the pair margin on each geom that is not a capsule (a capsule's
/// edge already lies on its grown surface).
fn half_margin<T: Real>(g: &Body<T>) -> T {
    match g.shape {
        Shape::Capsule { .. } => T::zero(),
        _ => lift::<T>(0.5) * g.margin,
    }
}

fn half_margins<T: Real>(a: &Body<T>, b: &Body<T>) -> T {
    half_margin(a) + half_margin(b)
}

/// Moves the clipped witness points out to the geoms grown by their half
/// margins along `normal` (out of geom 1) and shortens their distances.
fn with_margins<T: Real>(
    clipped: Vec<Witness<T>>,
    (a, b): (&Body<T>, &Body<T>),
    normal: Vector3<T>,
) -> Vec<Witness<T>> {
    let (m1, m2) = (half_margin(a), half_margin(b));
    clipped
        .into_iter()
        .map(|w| Witness {
            x1: w.x1 + normal * m1,
            x2: w.x2 - normal * m2,
            dist: w.dist - (m1 + m2),
        })
        .collect()
}

/// MuJoCo's `aligned_faces`: the pair of normals of geom 1 (against `dir`)
/// and geom 2 (along `dir`) most opposed, within the alignment tolerance.
fn aligned_faces<T: Real>(
    n1: &[Normal<T>],
    n2: &[Normal<T>],
    dir: &Vector3<T>,
) -> Option<(usize, usize)> {
    let dir_tol = lift::<T>(ALIGNED.sin()) * dir.norm();
    let mut best = lift::<T>(-ALIGNED.cos());
    let mut found = None;
    for (i, (a, _)) in n1.iter().enumerate() {
        if a.dot(dir) >= -dir_tol {
            continue;
        }
        for (j, (b, _)) in n2.iter().enumerate() {
            if b.dot(dir) <= dir_tol {
                continue;
            }
            let d = a.dot(b);
            if d < best {
                best = d;
                found = Some((i, j));
            }
        }
    }
    found
}

/// MuJoCo's `aligned_face_edge`: the first edge (index) perpendicular to a
/// face normal (index) that faces along `dir`.
fn face_edge<T: Real>(
    e: &Edges<T>,
    faces: &[Normal<T>],
    dir: &Vector3<T>,
) -> Option<(usize, usize)> {
    let tol = lift::<T>(ALIGNED.sin());
    for (i, (f, _)) in faces.iter().enumerate() {
        if f.dot(dir) <= lift(MINVAL) {
            continue;
        }
        for (j, (d, _)) in e.ends.iter().enumerate() {
            if d.dot(f).abs() < tol {
                return Some((j, i));
            }
        }
    }
    None
}

/// The candidate face normals of a geom at its feature; `dir` points out
/// of the geom towards the other (a box falls back to its face nearest it).
fn face_normals<T: Real>(g: &Body<T>, f: &Feature<T>, dir: &Vector3<T>) -> Vec<Normal<T>> {
    match g.shape {
        Shape::Box { .. } => box_normals(g, f, dir),
        Shape::Cylinder { .. } if f.dim == 1 => {
            let top = f.index[0] == 0;
            let axis = g.mat.column(2).into_owned();
            vec![(if top { axis } else { -axis }, f.index[0] as usize)]
        }
        Shape::Mesh { .. } => mesh_normals(g, f),
        _ => vec![],
    }
}

/// The sides of a mesh that hold vertex v, in side order (MuJoCo's
/// `mesh_polymap`).
fn sides_at(mesh: &Mesh, v: i32) -> impl Iterator<Item = usize> + '_ {
    let v = usize::try_from(v).ok();
    mesh.polygons
        .iter()
        .enumerate()
        .filter(move |(_, p)| v.is_some_and(|v| p.vertices.contains(&v)))
        .map(|(k, _)| k)
}

/// MuJoCo's `mesh_normals`: the sides that hold every vertex of the
/// feature (the first two sides an edge's ends share, the first side of a
/// face's three vertices, every side at a single vertex).
fn mesh_normals<T: Real>(g: &Body<T>, f: &Feature<T>) -> Vec<Normal<T>> {
    let Some(mesh) = g.mesh else {
        return vec![];
    };
    let corners = &f.index[..f.dim];
    let common = sides_at(mesh, corners[0])
        .filter(|&k| {
            corners[1..]
                .iter()
                .all(|&c| usize::try_from(c).is_ok_and(|c| mesh.polygons[k].vertices.contains(&c)))
        })
        .take(match f.dim {
            1 => usize::MAX,
            2 => 2,
            _ => 1,
        });
    common
        .map(|k| (g.mat * lift_vector::<T>(&mesh.polygons[k].normal), k))
        .collect()
}

/// The normal of box face k (0 +x, 1 -x, 2 +y, 3 -y, 4 +z, 5 -z) in the world.
fn box_normal<T: Real>(g: &Body<T>, k: usize) -> Vector3<T> {
    let axis = g.mat.column(k / 2).into_owned();
    if k.is_multiple_of(2) {
        axis
    } else {
        -axis
    }
}

/// MuJoCo's `box_normals`: the faces that hold every corner of the feature
/// (a corner's three faces, an edge's two, a face), else the face within
/// the alignment tolerance of `dir`.
fn box_normals<T: Real>(g: &Body<T>, f: &Feature<T>, dir: &Vector3<T>) -> Vec<Normal<T>> {
    let corners = &f.index[..f.dim];
    let faces: Vec<usize> = (0..3)
        .filter_map(|k| {
            let bit = 1 << k;
            if corners.iter().all(|c| c & bit != 0) {
                Some(2 * k)
            } else if corners.iter().all(|c| c & bit == 0) {
                Some(2 * k + 1)
            } else {
                None
            }
        })
        .collect();
    let direct = match f.dim {
        1 => true,
        2 => faces.len() == 1 || faces.len() == 2,
        _ => faces.len() == 1,
    };
    if direct {
        return faces.into_iter().map(|k| (box_normal(g, k), k)).collect();
    }
    let (local, _) = normalize(g.mat.tr_mul(dir));
    let cos = lift::<T>(ALIGNED.cos());
    (0..6)
        .find(|&k| {
            let v = local[k / 2];
            (if k.is_multiple_of(2) { v } else { -v }) > cos
        })
        .map(|k| vec![(box_normal(g, k), k)])
        .unwrap_or_default()
}

/// A box corner (sign bits as in [`Vertex`]) in the world, unless `flip`
/// mirrors it along one axis.
fn box_corner<T: Real>(g: &Body<T>, index: i32, flip: Option<usize>) -> Vector3<T> {
    let [hx, hy, hz] = g.shape.size();
    let local = Vector3::from_fn(|k, _| {
        let h = [hx, hy, hz][k];
        let mut s = if index & (1 << k) != 0 { h } else { -h };
        if flip == Some(k) {
            s = -s;
        }
        lift::<T>(s)
    });
    g.mat * local + g.pos
}

/// The edges of a geom at its feature (MuJoCo's `*_edge_normals`): a box's
/// edge, or the three at a corner; a cylinder's side line through its
/// rim point; a capsule's side line through the witness point `w`.
fn edges<T: Real>(g: &Body<T>, f: &Feature<T>, w: Vector3<T>) -> Option<Edges<T>> {
    let [radius, half, _] = g.shape.size();
    let axis = g.mat.column(2).into_owned();
    let line = |start: Vector3<T>, d: Vector3<T>, length: T| Edges {
        start,
        ends: vec![(d, start + d * length)],
    };
    match g.shape {
        Shape::Box { .. } => {
            let start = box_corner(g, f.index[0], None);
            let ends: Vec<Vector3<T>> = match f.dim {
                2 => vec![box_corner(g, f.index[1], None)],
                1 => (0..3).map(|k| box_corner(g, f.index[0], Some(k))).collect(),
                _ => return None,
            };
            Some(Edges::from_ends(start, ends))
        }
        Shape::Cylinder { .. } if f.dim < 3 => {
            let bottom = f.index[0] != 0;
            let sign = lift::<T>(if bottom { 1.0 } else { -1.0 });
            let mut v = f.vert[0];
            if g.margin > T::zero() {
                // The grown vertex back on the rim of its cap.
                let d = v - g.pos;
                let (l0, l1) = (g.mat.column(0).dot(&d), g.mat.column(1).dot(&d));
                let n2 = l0 * l0 + l1 * l1;
                let scale = if n2 >= lift(MINVAL * MINVAL) {
                    lift::<T>(radius) / n2.sqrt()
                } else {
                    T::zero()
                };
                v = g.mat * Vector3::new(scale * l0, scale * l1, -sign * lift::<T>(half)) + g.pos;
            }
            Some(line(v, axis * sign, lift(2.0 * half)))
        }
        Shape::Mesh { .. } => mesh_edges(g, f),
        Shape::Capsule { .. } => {
            let along = (w - g.pos).dot(&axis);
            let h = lift::<T>(half);
            Some(line(w - axis * (along + h), axis, h + h))
        }
        _ => None,
    }
}

/// MuJoCo's `mesh_edge_normals`: a mesh's edge between the feature's two
/// vertices, or at a single vertex the edge to its predecessor on each side
/// that holds it.
fn mesh_edges<T: Real>(g: &Body<T>, f: &Feature<T>) -> Option<Edges<T>> {
    let mesh = g.mesh?;
    let vertex = |i: usize| g.mat * lift_vector::<T>(&mesh.vertices[i]) + g.pos;
    let first = usize::try_from(f.index[0]).ok()?;
    let start = vertex(first);
    let ends: Vec<Vector3<T>> = match f.dim {
        2 => vec![vertex(usize::try_from(f.index[1]).ok()?)],
        1 => sides_at(mesh, f.index[0])
            .filter_map(|k| {
                let cycle = &mesh.polygons[k].vertices;
                let j = cycle.iter().position(|&v| v == first)?;
                Some(vertex(cycle[(j + cycle.len() - 1) % cycle.len()]))
            })
            .collect(),
        _ => return None,
    };
    Some(Edges::from_ends(start, ends))
}

/// The corners of face k of a geom (MuJoCo's `box_face`, `cylinder_face`).
fn face_of<T: Real>(g: &Body<T>, k: usize) -> Vec<Vector3<T>> {
    match g.shape {
        Shape::Box { .. } => {
            // Each face's corners as sign triples, in MuJoCo's order.
            const SIGNS: [[[i8; 3]; 4]; 6] = [
                [[1, 1, 1], [1, 1, -1], [1, -1, -1], [1, -1, 1]],
                [[-1, 1, -1], [-1, 1, 1], [-1, -1, 1], [-1, -1, -1]],
                [[-1, 1, -1], [1, 1, -1], [1, 1, 1], [-1, 1, 1]],
                [[-1, -1, 1], [1, -1, 1], [1, -1, -1], [-1, -1, -1]],
                [[-1, 1, 1], [1, 1, 1], [1, -1, 1], [-1, -1, 1]],
                [[1, 1, -1], [-1, 1, -1], [-1, -1, -1], [1, -1, -1]],
            ];
            let half = g.shape.size();
            SIGNS[k]
                .iter()
                .map(|s| {
                    let local = Vector3::from_fn(|i, _| lift::<T>(f64::from(s[i]) * half[i]));
                    g.mat * local + g.pos
                })
                .collect()
        }
        Shape::Cylinder { .. } => {
            let [radius, half, _] = g.shape.size();
            let sign = if k != 0 { -1.0 } else { 1.0 };
            let centre = g.mat.column(2) * lift::<T>(sign * half) + g.pos;
            let c0 = g.mat.column(0) * lift::<T>(radius);
            let c1 = g.mat.column(1) * lift::<T>(radius * sign);
            (0..16)
                .map(|i| {
                    let t = f64::from(i) * std::f64::consts::PI / 8.0;
                    c0 * lift::<T>(t.cos()) - c1 * lift::<T>(t.sin()) + centre
                })
                .collect()
        }
        // A mesh side's vertices in reverse order (MuJoCo's `mesh_face`).
        Shape::Mesh { .. } => g.mesh.map_or_else(Vec::new, |mesh| {
            mesh.polygons[k]
                .vertices
                .iter()
                .rev()
                .map(|&v| g.mat * lift_vector::<T>(&mesh.vertices[v]) + g.pos)
                .collect()
        }),
        _ => vec![],
    }
}

/// MuJoCo's `polygon_clip`: the polygon `face2` (or an edge) clipped by the
/// side planes of `face1` (normal `n`), its corners within `margin` of
/// face1's plane projected on it (x1) and moved along `dir` to their depth
/// (x2); more than four reduced to the quadrilateral of largest area, an
/// edge to its two farthest points.
fn polygon_clip<T: Real>(
    face1: &[Vector3<T>],
    face2: &[Vector3<T>],
    n: &Vector3<T>,
    dir: &Vector3<T>,
    margin: T,
) -> Vec<Witness<T>> {
    if face1.len() < 3 {
        return vec![];
    }
    let m = face1.len();
    // The side planes: normal and offset.
    let planes: Vec<(Vector3<T>, T)> = (0..m)
        .map(|i| {
            let (v1, v2) = (face1[i], face1[(i + 1) % m]);
            let pn = (v2 - v1).cross(&(v1 + n - v1));
            (pn, pn.dot(&v1))
        })
        .collect();
    let inside = |a: &Vector3<T>, pn: &Vector3<T>, p: &Vector3<T>| (p - a).dot(pn) > lift(-1e-10);
    let mut polygon: Vec<Vector3<T>> = face2.to_vec();
    for (e, (pn, pd)) in planes.iter().enumerate() {
        let mut clipped = Vec::with_capacity(2 * polygon.len());
        let k = polygon.len();
        for i in 0..k {
            let (p, q) = (polygon[i], polygon[(i + 1) % k]);
            let (in1, in2) = (inside(&face1[e], pn, &p), inside(&face1[e], pn, &q));
            if !in1 && !in2 {
                continue;
            }
            if in1 && in2 {
                clipped.push(q);
                continue;
            }
            let t = plane_intersect(pn, *pd, &p, &q);
            if t > lift(-INTERSECT_TOL) && t < lift(1.0 + INTERSECT_TOL) {
                let t = super::clip(t, T::zero(), T::one());
                clipped.push(p + (q - p) * t);
            }
            if in2 {
                clipped.push(q);
            }
        }
        polygon = clipped;
    }
    polygon.retain(|p| (p - face1[0]).dot(n) <= margin);
    if polygon.is_empty() {
        return vec![];
    }
    let witness = |v: &Vector3<T>| {
        let w1 = v - n * (v - face1[0]).dot(n);
        let dist = (w1 - v).dot(dir);
        Witness {
            x1: w1,
            x2: w1 - dir * dist,
            dist,
        }
    };
    let picked: Vec<usize> = if face2.len() == 2 && polygon.len() > 2 {
        farthest_pair(&polygon).to_vec()
    } else if polygon.len() > 4 {
        largest_quad(&polygon).to_vec()
    } else {
        (0..polygon.len()).collect()
    };
    picked.iter().map(|&i| witness(&polygon[i])).collect()
}

/// Where the line a + t (b - a) meets the plane pn . x = pd (MuJoCo's
/// `plane_intersect`; a huge t when parallel).
fn plane_intersect<T: Real>(pn: &Vector3<T>, pd: T, a: &Vector3<T>, b: &Vector3<T>) -> T {
    let dot = pn.dot(&(b - a));
    if dot.abs() < lift(1e-10) {
        return lift(1e30);
    }
    (pd - pn.dot(a)) / dot
}

/// The two points farthest apart, the first pair on ties.
fn farthest_pair<T: Real>(p: &[Vector3<T>]) -> [usize; 2] {
    let mut best = [0, 1];
    let mut max = T::zero();
    for i in 0..p.len() {
        for j in i + 1..p.len() {
            let d2 = (p[j] - p[i]).norm_squared();
            if d2 > max {
                max = d2;
                best = [i, j];
            }
        }
    }
    best
}

/// The area of the quadrilateral a b c d.
fn area4<T: Real>(a: &Vector3<T>, b: &Vector3<T>, c: &Vector3<T>, d: &Vector3<T>) -> T {
    lift::<T>(0.5) * (a - c).cross(&(b - d)).norm()
}

/// MuJoCo's `polygon_quad`: a quadrilateral of maximal area among the
/// corners of a convex polygon (more than four), by rotating calipers.
fn largest_quad<T: Real>(p: &[Vector3<T>]) -> [usize; 4] {
    let n = p.len();
    let (mut b, mut c, mut d) = (1, 2, 3);
    let mut res = [0, b, c, d];
    let mut m = area4(&p[0], &p[b], &p[c], &p[d]);
    for a in 0..n {
        loop {
            let next = area4(&p[a], &p[b], &p[c], &p[(d + 1) % n]);
            if next <= m {
                break;
            }
            m = next;
            d = (d + 1) % n;
            res = [a, b, c, d];
            loop {
                let next = area4(&p[a], &p[b], &p[(c + 1) % n], &p[d]);
                if next <= m {
                    break;
                }
                m = next;
                c = (c + 1) % n;
                res = [a, b, c, d];
            }
            loop {
                let next = area4(&p[a], &p[(b + 1) % n], &p[c], &p[d]);
                if next <= m {
                    break;
                }
                m = next;
                b = (b + 1) % n;
                res = [a, b, c, d];
            }
        }
        if b == a {
            b = (b + 1) % n;
            if c == b {
                c = (c + 1) % n;
                if d == c {
                    d = (d + 1) % n;
                }
            }
        }
    }
    res
}

#[cfg(test)]
mod tests {
    use nalgebra::Matrix3;

    use super::super::{convex::convex, Assets, Placed, Pre};
    use super::*;

    fn collide(s1: Shape, pos1: Vector3<f64>, s2: Shape, pos2: Vector3<f64>) -> Vec<Pre<f64>> {
        let place = |pos| Placed {
            pos,
            mat: Matrix3::identity(),
        };
        let mut out = vec![];
        convex(
            &Assets::default(),
            (&s1, &place(pos1)),
            (&s2, &place(pos2)),
            0.0,
            &mut out,
        );
        out
    }

    /// A mesh box of half-sizes 0.1, 0.2, 0.3 (its mesh frame the geom's, as
    /// MuJoCo compiles it) and a geom of `other` at `pos`, rotated by `quat`
    /// (w, x, y, z), against it.
    fn on_mesh_box(other: Shape, pos: Vector3<f64>, quat: [f64; 4]) -> Vec<Pre<f64>> {
        use crate::model::mesh::{compile, MeshSettings, RawMesh};
        // Corner i: bit k of i sets the + side along axis k.
        let vertices = (0..8)
            .map(|i: usize| {
                let side = |k: usize| if i >> k & 1 == 1 { 1.0f32 } else { -1.0 };
                [0.1 * side(0), 0.2 * side(1), 0.3 * side(2)]
            })
            .collect();
        let raw = RawMesh {
            vertices,
            faces: vec![],
        };
        let settings = MeshSettings {
            needs_hull: true,
            ..Default::default()
        };
        let assets = Assets {
            meshes: vec![compile("box", &raw, &settings).unwrap()],
            hfields: vec![],
        };
        let [w, x, y, z] = quat;
        let rotation =
            nalgebra::UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(w, x, y, z));
        let (a, b) = (
            Placed {
                pos,
                mat: rotation.to_rotation_matrix().into_inner(),
            },
            Placed {
                pos: Vector3::zeros(),
                mat: Matrix3::identity(),
            },
        );
        let mut out = vec![];
        convex(
            &assets,
            (&other, &a),
            (&Shape::Mesh { mesh: 0 }, &b),
            0.0,
            &mut out,
        );
        out
    }

    /// Each contact equals one of MuJoCo's points (x, y; z = 0.2975, midway
    /// into the mesh top, a single-precision vertex at 0.3), all at depth
    /// `depth` with the normal -z.
    fn assert_mujocos(c: &[Pre<f64>], mujoco: &[[f64; 2]], (z, depth): (f64, f64)) {
        assert_eq!(c.len(), mujoco.len());
        for c in c {
            let near = mujoco
                .iter()
                .map(|[x, y]| (c.pos - Vector3::new(*x, *y, z)).norm())
                .fold(f64::INFINITY, f64::min);
            assert!(near < 1e-12, "{}", c.pos);
            assert!((c.dist + depth).abs() < 1e-12, "{}", c.dist);
            assert!((c.normal + Vector3::z()).norm() < 1e-12, "{}", c.normal);
        }
    }

    #[test]
    fn geoms_resting_on_a_mesh_face_take_mujocos_clipped_contacts() {
        // mj_forward (MuJoCo 4.0.0) on each geom 5 mm into the mesh box's top face:
        // a box turned 0.2 rad about z (four corners), a capsule along x and a
        // cylinder along y (their side lines' ends).
        let cube = Shape::Box {
            half: Vector3::new(0.05, 0.05, 0.05),
        };
        let turned = [0.9950041652780258, 0.0, 0.0, 0.09983341664682815];
        let c = on_mesh_box(cube, Vector3::new(0.02, 0.01, 0.345), turned);
        let level = (0.29750000596046444, 0.005000011920928971);
        assert_mujocos(
            &c,
            &[
                [-0.03893679543181514, 0.049069862352309],
                [0.05906986235230904, 0.06893679543181513],
                [0.07893679543181514, -0.02906986235230902],
                [-0.01906986235230903, -0.04893679543181512],
            ],
            level,
        );
        let capsule = Shape::Capsule {
            radius: 0.05,
            half_length: 0.08,
        };
        let h = std::f64::consts::FRAC_1_SQRT_2;
        let along_x = [h, 0.0, h, 0.0];
        let c = on_mesh_box(capsule, Vector3::new(0.0, 0.05, 0.345), along_x);
        assert_mujocos(&c, &[[-0.08, 0.05], [0.08, 0.05]], level);
        let cylinder = Shape::Cylinder {
            radius: 0.05,
            half_length: 0.08,
        };
        let along_y = [h, h, 0.0, 0.0];
        let c = on_mesh_box(cylinder, Vector3::new(0.01, -0.02, 0.345), along_y);
        let x = 0.00999479005396101;
        assert_mujocos(
            &c,
            &[[x, 0.06], [x, -0.1]],
            (0.29750000609618216, 0.0050000116494935964),
        );
    }

    #[test]
    fn a_cylinder_cap_on_a_box_face_takes_four_contacts_of_its_16_gon() {
        // A cylinder (radius 0.1, half length 0.2) standing 5 mm into a box's bottom
        // face: mj_forward (MuJoCo 4.0.0) gives four contacts at corners of the cap's
        // 16-gon, 0.005 deep, midway between the cap and the face, normal +z.
        let cylinder = Shape::Cylinder {
            radius: 0.1,
            half_length: 0.2,
        };
        let slab = Shape::Box {
            half: Vector3::new(0.3, 0.3, 0.1),
        };
        let c = collide(
            cylinder,
            Vector3::zeros(),
            slab,
            Vector3::new(0.0, 0.0, 0.295),
        );
        let mujoco = [
            [0.09238795, -0.03826834],
            [0.03826834, 0.09238795],
            [-0.09238795, 0.03826834],
            [-0.03826834, -0.09238795],
        ];
        assert_eq!(c.len(), 4);
        for (c, [x, y]) in c.iter().zip(mujoco) {
            assert!(
                (c.pos - Vector3::new(x, y, 0.1975)).norm() < 1e-8,
                "{}",
                c.pos
            );
            assert!((c.dist + 0.005).abs() < 1e-12, "{}", c.dist);
            assert!((c.normal - Vector3::z()).norm() < 1e-12, "{}", c.normal);
        }
    }
}
