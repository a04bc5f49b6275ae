//! MuJoCo 4's multi-contact of convex pairs (`mjc_multicontact` of
//! engine_collision_gjk.c, the `multiccd` flag, on by default): when the
//! face that GJK or EPA ends on touches a face of each geom (box faces,
//! cylinder caps) or a face of one and an edge of the other (box or
//! cylinder side edges, a capsule's segment), the contact becomes the
//! polygon where the two features overlap, clipped as MuJoCo clips it, with
//! up to four points.
//!
//! Conventions: geom 1 is A and geom 2 is B of the Minkowski difference
//! A - B; `dir` = x2 - x1 runs from A's witness point to B's (from B into A
//! when they overlap). A face is the list of its corners in the world frame;
//! a feature is the set of distinct shape vertices (indices, see
//! [`Vertex`]) that the final simplex face holds on one geom: one vertex, an
//! edge or a face. Cylinder caps are MuJoCo's 16-gons. Tolerances are
//! MuJoCo's: faces are aligned within 0.0889 rad, an edge lies in a face
//! within the same angle.

use nalgebra::Vector3;

use super::convex::Body;
use super::gjk::Vertex;
use super::{normalize, GeomType};
use crate::model::{Shape, MINVAL};
use crate::spatial::{lift, Real};

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
        _ => vec![],
    }
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
            let ends = ends
                .into_iter()
                .map(|e| (normalize(e - start).0, e))
                .collect();
            Some(Edges { start, ends })
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
        Shape::Capsule { .. } => {
            let along = (w - g.pos).dot(&axis);
            let h = lift::<T>(half);
            Some(line(w - axis * (along + h), axis, h + h))
        }
        _ => None,
    }
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
