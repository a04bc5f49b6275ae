//! Box against box, as MuJoCo 4 computes it: a separating-axis test over the
//! 15 candidate axes (the boxes' face normals and the cross products of their
//! edges), then either one edge-edge contact at the midpoint of the edges'
//! closest points, or the incident face clipped against the reference face
//! (up to 8 contacts, one per vertex of the clipped polygon within the margin,
//! each midway between the reference face and the incident surface).
//!
//! Conventions: box 1 is geom 1; "frame 1" is box 1's axes; `rot` holds box
//! 2's axes in frame 1 as columns; the normal points from box 1 to box 2. The
//! rounding tolerances are MuJoCo's (double precision).

use nalgebra::{Matrix3, Vector3};

use super::{clip, normalize, Assets, Placed, Pre, MINVAL};
use crate::model::Shape;
use crate::spatial::{lift, Real};

/// Slack of the separation tests, times the summed half-sizes.
const SEP_EPS: f64 = 1e-13;
/// sin^2 of the angle below which an edge-cross axis is noise.
const PAR_EPS: f64 = 1e-16;
/// Axis component below which a support corner is ambiguous.
const SGN_EPS: f64 = 1e-9;
/// Squared relative radius under which clipped vertices are duplicates.
const DUP_EPS: f64 = 1e-14;
/// Relative penalty of an edge axis against the best face axis on near-ties.
const EDGE_BIAS: f64 = 1e-6;
/// Vertex capacity of the clipped polygon.
const MAX_VERT: usize = 12;

/// The contacts of box 1 against box 2 within `margin`, appended to `out`.
pub(super) fn cuboid<T: Real>(
    _: &Assets,
    (b1, p1): (&Shape, &Placed<T>),
    (b2, p2): (&Shape, &Placed<T>),
    margin: T,
    out: &mut Vec<Pre<T>>,
) {
    let (pos1, mat1, pos2, mat2) = (p1.pos, p1.mat, p2.pos, p2.mat);
    let (s1, s2): (Vector3<T>, Vector3<T>) =
        (b1.size().map(lift).into(), b2.size().map(lift).into());
    let pos21 = mat1.tr_mul(&(pos2 - pos1));
    let pos12 = mat2.tr_mul(&(pos1 - pos2));
    let rot = mat1.tr_mul(&mat2);
    let rotabs = rot.map(|x| x.abs());
    let septol = margin + lift::<T>(SEP_EPS) * (s1.x + s1.y + s1.z + s2.x + s2.y + s2.z);

    // Stage 1: the separating axis with the largest separation (code 0-2: a face
    // of box 1, 3-5: of box 2, 6 + 3 i + j: edge i of box 1 crossed with edge j of box 2).
    let mut best = lift::<T>(-f64::MAX);
    let mut code = 0;
    for i in 0..3 {
        let radius2 = rotabs[(i, 0)] * s2[0] + rotabs[(i, 1)] * s2[1] + rotabs[(i, 2)] * s2[2];
        let sep = pos21[i].abs() - s1[i] - radius2;
        if sep > septol {
            return;
        }
        if sep > best {
            (best, code) = (sep, i);
        }
    }
    for j in 0..3 {
        let radius1 = rotabs[(0, j)] * s1[0] + rotabs[(1, j)] * s1[1] + rotabs[(2, j)] * s1[2];
        let sep = pos12[j].abs() - s2[j] - radius1;
        if sep > septol {
            return;
        }
        if sep > best {
            (best, code) = (sep, 3 + j);
        }
    }
    let (face_sep, face_code) = (best, code);
    for i in 0..3 {
        for j in 0..3 {
            let (i1, i2) = ((i + 1) % 3, (i + 2) % 3);
            let (mut ax1, mut ax2) = (-rot[(i2, j)], rot[(i1, j)]);
            let norm2 = ax1 * ax1 + ax2 * ax2;
            if norm2 < lift(PAR_EPS) {
                continue;
            }
            let inv = T::one() / norm2.sqrt();
            ax1 *= inv;
            ax2 *= inv;
            let radius1 = s1[i1] * ax1.abs() + s1[i2] * ax2.abs();
            let (j1, j2) = ((j + 1) % 3, (j + 2) % 3);
            let a2_1 = ax1 * rot[(i1, j1)] + ax2 * rot[(i2, j1)];
            let a2_2 = ax1 * rot[(i1, j2)] + ax2 * rot[(i2, j2)];
            let radius2 = s2[j1] * a2_1.abs() + s2[j2] * a2_2.abs();
            let sep = (ax1 * pos21[i1] + ax2 * pos21[i2]).abs() - radius1 - radius2;
            if sep > septol {
                return;
            }
            if sep - lift::<T>(EDGE_BIAS) * sep.abs() > best && sep > face_sep {
                (best, code) = (sep, 6 + 3 * i + j);
            }
        }
    }
    // An edge axis within ~8 degrees of the best face axis and not clearly better
    // duplicates it: the face gives the contact (several points).
    if code >= 6 {
        let axis = edge_axis(&rot, code);
        let face_dot = if face_code < 3 {
            axis[face_code].abs()
        } else {
            axis.dot(&rot.column(face_code - 3)).abs()
        };
        let tie = face_sep + lift::<T>(0.05) * face_sep.abs() + lift(MINVAL);
        if face_dot > lift(0.99) && best < tie {
            code = face_code;
        }
    }
    if code >= 6 {
        edge_edge((pos1, mat1, s1), (s2, &rot, pos21), code, septol, out);
    } else {
        let geometry = Faces {
            boxes: [(pos1, mat1, s1), (pos2, mat2, s2)],
            rot,
            centres: [pos21, pos12],
        };
        face(&geometry, code, margin, out);
    }
}

/// The unit edge-cross axis of `code` in frame 1.
fn edge_axis<T: Real>(rot: &Matrix3<T>, code: usize) -> Vector3<T> {
    let (i, j) = ((code - 6) / 3, (code - 6) % 3);
    let (i1, i2) = ((i + 1) % 3, (i + 2) % 3);
    let mut axis = Vector3::zeros();
    axis[i1] = -rot[(i2, j)];
    axis[i2] = rot[(i1, j)];
    normalize(axis).0
}

/// One contact at the midpoint of the closest points of the two supporting
/// edges; where an axis component is too small to pick an edge's corner, both
/// corners are tried and the closer witness pair kept.
fn edge_edge<T: Real>(
    (pos1, mat1, s1): (Vector3<T>, Matrix3<T>, Vector3<T>),
    (s2, rot, pos21): (Vector3<T>, &Matrix3<T>, Vector3<T>),
    code: usize,
    septol: T,
    out: &mut Vec<Pre<T>>,
) {
    let (i, j) = ((code - 6) / 3, (code - 6) % 3);
    let (i1, i2) = ((i + 1) % 3, (i + 2) % 3);
    let (j1, j2) = ((j + 1) % 3, (j + 2) % 3);
    let mut axis = edge_axis(rot, code);
    if axis.dot(&pos21) < T::zero() {
        axis = -axis;
    }
    let a2 = rot.tr_mul(&axis);
    let ambiguous = |x: T| x.abs() < lift(SGN_EPS);
    let amb1 = [i1, i2].into_iter().find(|&k| ambiguous(axis[k]));
    let amb2 = [j1, j2].into_iter().find(|&k| ambiguous(a2[k]));
    let d2: Vector3<T> = rot.column(j).into_owned();
    let b = d2[i];
    let denom = T::one() - b * b;
    let signed = |positive: bool, size: T| if positive { size } else { -size };
    let mut witness = (Vector3::zeros(), Vector3::zeros());
    let mut best = lift::<T>(f64::MAX);
    for flip1 in 0..if amb1.is_some() { 2 } else { 1 } {
        for flip2 in 0..if amb2.is_some() { 2 } else { 1 } {
            let mut c1 = Vector3::zeros();
            c1[i1] = signed(axis[i1] >= T::zero(), s1[i1]);
            c1[i2] = signed(axis[i2] >= T::zero(), s1[i2]);
            if let (Some(k), 1) = (amb1, flip1) {
                c1[k] = -c1[k];
            }
            let mut cc = Vector3::zeros();
            cc[j1] = signed(a2[j1] < T::zero(), s2[j1]);
            cc[j2] = signed(a2[j2] < T::zero(), s2[j2]);
            if let (Some(k), 1) = (amb2, flip2) {
                cc[k] = -cc[k];
            }
            let c2 = rot * cc + pos21;
            let e = c2 - c1;
            let (d1e, d2e) = (e[i], d2.dot(&e));
            let s = if denom < lift(MINVAL) {
                T::zero()
            } else {
                (d1e - b * d2e) / denom
            };
            let s = clip(s, -s1[i], s1[i]);
            let t = clip(b * s - d2e, -s2[j], s2[j]);
            let s = clip(d1e + b * t, -s1[i], s1[i]);
            let mut p1 = c1;
            p1[i] += s;
            let p2 = c2 + d2 * t;
            let gap2 = (p2 - p1).norm_squared();
            if gap2 < best {
                best = gap2;
                witness = (p1, p2);
            }
        }
    }
    let (w1, w2) = witness;
    let dist = (w2 - w1).dot(&axis);
    if dist > septol {
        return;
    }
    let half: T = lift(0.5);
    out.push(Pre {
        dist,
        pos: mat1 * ((w1 + w2) * half) + pos1,
        normal: mat1 * axis,
        tangent: Vector3::zeros(),
    });
}

/// What the face stage needs of the two boxes: each one's centre, axes and
/// half-sizes; box 2's axes in frame 1 (`rot`); each centre in the other's frame.
struct Faces<T: Real> {
    boxes: [(Vector3<T>, Matrix3<T>, Vector3<T>); 2],
    rot: Matrix3<T>,
    centres: [Vector3<T>; 2],
}

/// The incident face (of the box not owning the winning face, the one most
/// opposed to the winning normal) clipped against the reference face's four
/// side planes; every vertex within `margin` of the reference face is a
/// contact (near-duplicates dropped).
fn face<T: Real>(g: &Faces<T>, code: usize, margin: T, out: &mut Vec<Pre<T>>) {
    let ref1 = code < 3;
    let a = if ref1 { code } else { code - 3 };
    let ((pos_ref, mat_ref, size_ref), (_, _, size_inc)) = if ref1 {
        (g.boxes[0], g.boxes[1])
    } else {
        (g.boxes[1], g.boxes[0])
    };
    let centre = g.centres[usize::from(!ref1)];
    let rinc = if ref1 { g.rot } else { g.rot.transpose() };
    let sgn = if centre[a] >= T::zero() {
        T::one()
    } else {
        -T::one()
    };
    let mut binc = 0;
    for k in 1..3 {
        if rinc[(a, k)].abs() > rinc[(a, binc)].abs() {
            binc = k;
        }
    }
    let tinc = if sgn * rinc[(a, binc)] > T::zero() {
        -T::one()
    } else {
        T::one()
    };
    let (ax, ay) = ((a + 1) % 3, (a + 2) % 3);
    let (bu, bv) = ((binc + 1) % 3, (binc + 2) % 3);
    // The incident face's centre and half-edges in (x, y, height above the reference face).
    let (mut cx, mut du, mut dv) = (Vector3::zeros(), Vector3::zeros(), Vector3::zeros());
    for (r, c) in [ax, ay, a].into_iter().enumerate() {
        cx[r] = centre[c] + tinc * size_inc[binc] * rinc[(c, binc)];
        du[r] = size_inc[bu] * rinc[(c, bu)];
        dv[r] = size_inc[bv] * rinc[(c, bv)];
    }
    cx[2] = sgn * cx[2] - size_ref[a];
    du[2] *= sgn;
    dv[2] *= sgn;
    let mut poly = Polygon::empty();
    for (su, sv) in [(1.0, 1.0), (-1.0, 1.0), (-1.0, -1.0), (1.0, -1.0)] {
        poly.push(cx + du * lift::<T>(su) + dv * lift::<T>(sv));
    }
    for (coord, sign, limit) in [
        (0, 1.0, size_ref[ax]),
        (0, -1.0, size_ref[ax]),
        (1, 1.0, size_ref[ay]),
        (1, -1.0, size_ref[ay]),
    ] {
        poly = clip_half_plane(&poly, coord, lift(sign), limit);
    }
    let dupe2 = lift::<T>(DUP_EPS) * (size_ref[ax] * size_ref[ax] + size_ref[ay] * size_ref[ay]);
    let mut accepted = Polygon::empty();
    for &v in poly.vertices() {
        let near = |q: &Vector3<T>| {
            let (dx, dy) = (q.x - v.x, q.y - v.y);
            dx * dx + dy * dy < dupe2
        };
        if v.z <= margin && !accepted.vertices().iter().any(near) {
            accepted.push(v);
        }
    }
    let nsign = if ref1 { sgn } else { -sgn };
    let normal = mat_ref.column(a) * nsign;
    let half: T = lift(0.5);
    for &v in accepted.vertices() {
        let mut local = Vector3::zeros();
        local[ax] = v.x;
        local[ay] = v.y;
        local[a] = sgn * (size_ref[a] + half * v.z);
        out.push(Pre {
            dist: v.z,
            pos: mat_ref * local + pos_ref,
            normal,
            tangent: Vector3::zeros(),
        });
    }
}

/// A polygon of at most [`MAX_VERT`] vertices (x, y, height), on the stack.
#[derive(Clone, Copy)]
struct Polygon<T: Real> {
    vertices: [Vector3<T>; MAX_VERT],
    len: usize,
}

impl<T: Real> Polygon<T> {
    fn empty() -> Self {
        Polygon {
            vertices: [Vector3::zeros(); MAX_VERT],
            len: 0,
        }
    }

    fn vertices(&self) -> &[Vector3<T>] {
        &self.vertices[..self.len]
    }

    /// Appends `v`; a full polygon keeps its vertices.
    fn push(&mut self, v: Vector3<T>) {
        if self.len < MAX_VERT {
            self.vertices[self.len] = v;
            self.len += 1;
        }
    }
}

/// The polygon clipped to sign * v[coord] <= limit (vertices' heights
/// interpolated along the cut edges); unchanged when wholly inside.
fn clip_half_plane<T: Real>(poly: &Polygon<T>, coord: usize, sign: T, limit: T) -> Polygon<T> {
    let beyond = |p: &Vector3<T>| sign * p[coord] - limit;
    if poly.vertices().iter().all(|p| beyond(p) <= T::zero()) {
        return *poly;
    }
    let n = poly.len;
    let mut out = Polygon::empty();
    for k in 0..n {
        let k1 = (k + 1) % n;
        let (p, q) = (poly.vertices[k], poly.vertices[k1]);
        let (dp, dq) = (beyond(&p), beyond(&q));
        if dp <= T::zero() {
            out.push(p);
        }
        let crosses = (dp < T::zero() && dq > T::zero()) || (dp > T::zero() && dq < T::zero());
        if crosses {
            let t = dp / (dp - dq);
            out.push(p + (q - p) * t);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Rotation3;

    fn boxes(pos2: [f64; 3], rot1: Rotation3<f64>, rot2: Rotation3<f64>) -> Vec<Pre<f64>> {
        let cube = Shape::Box {
            half: Vector3::new(0.1, 0.1, 0.1),
        };
        let mut out = vec![];
        let (b1, b2) = (
            Placed {
                pos: Vector3::zeros(),
                mat: *rot1.matrix(),
            },
            Placed {
                pos: Vector3::from(pos2),
                mat: *rot2.matrix(),
            },
        );
        cuboid(
            &Assets::default(),
            (&cube, &b1),
            (&cube, &b2),
            0.0,
            &mut out,
        );
        out
    }

    #[test]
    fn a_turned_box_on_a_box_touches_at_the_octagon_of_their_faces() {
        // MuJoCo 4.0.0: 8 contacts, 1 mm deep, at the clipped polygon's vertices.
        let turned = Rotation3::from_euler_angles(0.0, 0.0, std::f64::consts::FRAC_PI_4);
        let out = boxes([0.01, 0.02, 0.199], Rotation3::identity(), turned);
        assert_eq!(out.len(), 8);
        for c in &out {
            assert!((c.dist + 0.001).abs() < 1e-15 && c.normal == Vector3::z());
            assert!((c.pos.z - 0.0995).abs() < 1e-15);
            assert!(c.pos.x.abs().max(c.pos.y.abs()) > 0.1 - 1e-15); // on the lower face's rim
        }
    }

    #[test]
    fn crossed_edges_touch_once_as_mujoco_says() {
        // MuJoCo 4.0.0 on the same boxes (euler 45 0 0 and 0 45 3, degrees):
        // one contact, its dist, point and normal below.
        let deg = std::f64::consts::PI / 180.0;
        let rot1 = Rotation3::from_axis_angle(&Vector3::x_axis(), 45.0 * deg);
        // MuJoCo's euler sequence xyz is intrinsic: R = Ry(45) Rz(3).
        let rot2 = Rotation3::from_axis_angle(&Vector3::y_axis(), 45.0 * deg)
            * Rotation3::from_axis_angle(&Vector3::z_axis(), 3.0 * deg);
        let out = boxes([0.003, 0.002, 0.2825], rot1, rot2);
        assert_eq!(out.len(), 1);
        assert!((out[0].dist + 0.0005135153018395284).abs() < 1e-15);
        let pos = Vector3::new(
            0.0031704505878586546,
            9.50837173042951e-06,
            0.14116477470607067,
        );
        let normal = Vector3::new(0.0, -0.03703247672027199, 0.9993140625789085);
        assert!((out[0].pos - pos).norm() < 1e-15, "{}", out[0].pos - pos);
        assert!((out[0].normal - normal).norm() < 1e-15);
    }
}
