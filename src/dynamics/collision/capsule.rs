//! Capsule against capsule and against box, as MuJoCo computes them.
//!
//! Capsule-capsule: the closest points of the segments (clamped as MuJoCo
//! clamps them) as two spheres; (nearly) parallel axes give up to two
//! contacts from the segments' ends.
//!
//! Capsule-box: the point of the capsule's segment closest to the box (from
//! the segment's ends against the box's faces, and the segment against each
//! of the box's 12 edges), a second point along the segment where the
//! capsule lies along a face or across an edge, and a sphere of the capsule's
//! radius against the box at each. Work happens in the box's frame. The
//! closest-feature code (`kind`) is MuJoCo's: -3 or -1, an end of the segment
//! (-1 or +1) nearest a face; 0-8, an edge, with kind / 3 telling where on
//! the box's edge (0 its lower corner, 1 inside, 2 its upper corner) and
//! kind % 3 where on the segment.

use nalgebra::Vector3;

use super::sphere::{ball_box, balls};
use super::{clip, Assets, Placed, Pre, MINVAL};
use crate::model::Shape;
use crate::spatial::{lift, Real};

/// MuJoCo's capsule-capsule (see the module documentation).
pub(super) fn capsule<T: Real>(
    _: &Assets,
    (s1, p1): (&Shape, &Placed<T>),
    (s2, p2): (&Shape, &Placed<T>),
    margin: T,
    out: &mut Vec<Pre<T>>,
) {
    let ([r1, h1, _], [r2, h2, _]) = (s1.size(), s2.size());
    let (r1, r2): (T, T) = (lift(r1), lift(r2));
    let axis1 = p1.axis(2) * lift::<T>(h1);
    let axis2 = p2.axis(2) * lift::<T>(h2);
    let dif = p1.pos - p2.pos;
    let ma = axis1.dot(&axis1);
    let mb = -axis1.dot(&axis2);
    let mc = axis2.dot(&axis2);
    let u = -axis1.dot(&dif);
    let v = axis2.dot(&dif);
    let det = ma * mc - mb * mb;
    let one = T::one();
    let at = |p: &Placed<T>, axis: &Vector3<T>, x: T| Placed {
        pos: p.pos + axis * x,
        mat: p.mat,
    };
    if det.abs() >= lift(MINVAL) {
        let mut x1 = (mc * u - mb * v) / det;
        let mut x2 = (ma * v - mb * u) / det;
        if x1 > one {
            x1 = one;
            x2 = (v - mb) / mc;
        } else if x1 < -one {
            x1 = -one;
            x2 = (v + mb) / mc;
        }
        if x2 > one {
            x2 = one;
            x1 = clip((u - mb) / ma, -one, one);
        } else if x2 < -one {
            x2 = -one;
            x1 = clip((u + mb) / ma, -one, one);
        }
        let (s1, s2) = (at(p1, &axis1, x1), at(p2, &axis2, x2));
        return balls(&s1, r1, &s2, r2, margin, out);
    }
    let start = out.len();
    for end in [one, -one] {
        let x2 = clip((v - mb * end) / mc, -one, one);
        let (s1, s2) = (at(p1, &axis1, end), at(p2, &axis2, x2));
        balls(&s1, r1, &s2, r2, margin, out);
    }
    for end in [one, -one] {
        if out.len() - start >= 2 {
            return;
        }
        let x1 = clip((u - mb * end) / ma, -one, one);
        let (s1, s2) = (at(p1, &axis1, x1), at(p2, &axis2, end));
        balls(&s1, r1, &s2, r2, margin, out);
    }
}

/// The closest feature found so far.
struct Closest<T: Real> {
    /// Squared distance, and where on the segment (-1..1) and on the box's edge.
    dist2: T,
    segment: T,
    edge_pos: T,
    kind: i32,
    face: i32,
    corner: usize,
    edge: usize,
}

/// MuJoCo's capsule-box (see the module documentation).
pub(super) fn cuboid<T: Real>(
    _: &Assets,
    (s1, capsule): (&Shape, &Placed<T>),
    (s2, cube): (&Shape, &Placed<T>),
    margin: T,
    out: &mut Vec<Pre<T>>,
) {
    let ([radius, half_length, _], half) = (s1.size(), Vector3::from(s2.size()));
    let half = &half;
    let size: Vector3<T> = half.map(lift);
    let (r, len): (T, T) = (lift(radius), lift(half_length));
    let pos = cube.mat.tr_mul(&(capsule.pos - cube.pos));
    let axis = cube.mat.tr_mul(&capsule.axis(2));
    let halfaxis = axis * len;
    let axisdir = (0..3).fold(0, |d, k| {
        d + usize::from(halfaxis[k] > T::zero()) * (1 << k)
    });
    let two: T = lift(2.0);
    let bound = margin + two * (r + len + size.x + size.y + size.z);
    let mut best = Closest {
        dist2: bound,
        segment: T::zero(),
        edge_pos: T::zero(),
        kind: -4,
        face: -1,
        corner: 0,
        edge: 0,
    };
    ends_against_faces(pos, halfaxis, &size, &mut best);
    segment_against_edges(pos, halfaxis, (&size, len), &mut best);
    if best.kind == -4 {
        return;
    }
    let second = second_point(&best, axisdir, (pos, axis, halfaxis), &size);
    let sphere_at = |s: T| Placed {
        pos: cube.mat * (pos + halfaxis * s) + cube.pos,
        mat: capsule.mat,
    };
    ball_box(&sphere_at(best.segment), r, cube, half, margin, out);
    if let Some(second) = second {
        ball_box(
            &sphere_at(second + best.segment),
            r,
            cube,
            half,
            margin,
            out,
        );
    }
}

/// Each end of the segment clamped into the box: an end outside at most one
/// face's slab is a face candidate.
fn ends_against_faces<T: Real>(
    pos: Vector3<T>,
    halfaxis: Vector3<T>,
    size: &Vector3<T>,
    best: &mut Closest<T>,
) {
    for end in [-1, 1] {
        let point = pos + halfaxis * lift::<T>(end as f64);
        let mut clamped = point;
        let (mut outside, mut face) = (0, -1);
        for j in 0..3 {
            if clamped[j] < -size[j] {
                (outside, face) = (outside + 1, j as i32);
                clamped[j] = -size[j];
            } else if clamped[j] > size[j] {
                (outside, face) = (outside + 1, j as i32);
                clamped[j] = size[j];
            }
        }
        if outside > 1 {
            continue;
        }
        let gap = clamped - point;
        let dist2 = gap.dot(&gap);
        if dist2 < best.dist2 {
            best.dist2 = dist2;
            best.segment = lift(end as f64);
            best.kind = -2 + end;
            best.face = face;
        }
    }
}

/// The segment against each edge of the box (closest points of two segments,
/// clamped as MuJoCo clamps them).
fn segment_against_edges<T: Real>(
    pos: Vector3<T>,
    halfaxis: Vector3<T>,
    (size, len): (&Vector3<T>, T),
    best: &mut Closest<T>,
) {
    let one = T::one();
    for j in 0..3 {
        for i in 0..8usize {
            if i & (1 << j) != 0 {
                continue;
            }
            let sign = |bit: usize, s: T| if i & (1 << bit) != 0 { s } else { -s };
            let mut start = Vector3::new(sign(0, size[0]), sign(1, size[1]), sign(2, size[2]));
            start[j] = T::zero();
            let dif = start - pos;
            let ma = size[j] * size[j];
            let mb = -size[j] * halfaxis[j];
            let mc = len * len;
            let u = -size[j] * dif[j];
            let v = halfaxis.dot(&dif);
            let det = ma * mc - mb * mb;
            if det.abs() < lift(MINVAL) {
                continue;
            }
            let idet = one / det;
            let mut x1 = (mc * u - mb * v) * idet;
            let mut x2 = (ma * v - mb * u) * idet;
            let (mut s1, mut s2) = (1, 1);
            if x1 > one {
                (x1, s1) = (one, 2);
                x2 = (v - mb) * (one / mc);
            } else if x1 < -one {
                (x1, s1) = (-one, 0);
                x2 = (v + mb) * (one / mc);
            }
            let clamp_box = |x1: &mut T, s1: &mut i32| {
                if *x1 > one {
                    (*x1, *s1) = (one, 2);
                } else if *x1 < -one {
                    (*x1, *s1) = (-one, 0);
                }
            };
            if x2 > one {
                (x2, s2) = (one, 2);
                x1 = (u - mb) * (one / ma);
                clamp_box(&mut x1, &mut s1);
            } else if x2 < -one {
                (x2, s2) = (-one, 0);
                x1 = (u + mb) * (one / ma);
                clamp_box(&mut x1, &mut s1);
            }
            let mut gap = dif - halfaxis * x2;
            gap[j] += size[j] * x1;
            let dist2 = gap.dot(&gap);
            if dist2 < best.dist2 - lift(MINVAL) {
                let kind = s1 * 3 + s2;
                best.dist2 = dist2;
                best.segment = x2;
                best.edge_pos = x1;
                best.corner = i + (1 << j) * (kind / 6) as usize;
                best.edge = j;
                best.kind = kind;
            }
        }
    }
}

/// Where along the segment (relative to the first point) a second contact
/// goes, if the capsule lies along a face or across an edge; MuJoCo's case
/// analysis of the capsule's direction against the closest corner or edge.
fn second_point<T: Real>(
    best: &Closest<T>,
    axisdir: usize,
    (pos, axis, halfaxis): (Vector3<T>, Vector3<T>, Vector3<T>),
    size: &Vector3<T>,
) -> Option<T> {
    let (one, two): (T, T) = (T::one(), lift(2.0));
    let (kind, seg) = (best.kind, best.segment);
    if kind >= 0 && kind / 3 != 1 {
        // Closest to a corner of the box.
        let mut c1 = axisdir ^ best.corner;
        if c1 == 0 || c1 == 7 {
            return None;
        }
        let (mul, de, dp) = if [1, 2, 4].contains(&c1) {
            (one, one - seg, one + seg)
        } else {
            c1 = 7 - c1;
            (-one, one + seg, one - seg)
        };
        let (ax, ax1, ax2) = match c1 {
            1 => (0, 1, 2),
            2 => (1, 2, 0),
            _ => (2, 0, 1),
        };
        if axis[ax] * axis[ax] > lift(0.5) {
            let reach = two * size[ax] / halfaxis[ax].abs();
            return Some(if reach < de { reach } else { de } * mul);
        }
        let mut second = dp;
        for a in [ax1, ax2] {
            let reach = two * size[a] / halfaxis[a].abs();
            if reach < second {
                second = reach;
            }
        }
        return Some(second * -mul);
    }
    if kind >= 0 {
        // On an edge of the box: a cross configuration gets a second point.
        let mut c1 = axisdir ^ best.corner;
        c1 &= 7 - (1 << best.edge);
        if c1 != 1 && c1 != 2 && c1 != 4 {
            return None;
        }
        let ax = best.edge;
        let (mut ax1, ax2) = match ax {
            0 => (1, 2),
            1 => (2, 0),
            _ => (0, 1),
        };
        if axis[ax1].abs() > axis[ax2].abs() {
            ax1 = ax2;
        }
        let ax2 = 3 - ax - ax1;
        let (mul, mut second) = if c1 & (1 << ax2) != 0 {
            (one, one - seg)
        } else {
            (-one, one + seg)
        };
        let reach = two * size[ax2] / halfaxis[ax2].abs();
        if reach < second {
            second = reach;
        }
        let along = ((axisdir & (1 << ax)) != 0) == ((c1 & (1 << ax2)) != 0);
        let e2 = if along {
            one - best.edge_pos
        } else {
            one + best.edge_pos
        };
        let reach = size[ax] * e2 / halfaxis[ax].abs();
        if reach < second {
            second = reach;
        }
        return Some(second * mul);
    }
    // An end nearest a face: the other end, clamped to the farthest point above the box.
    if best.face == -1 {
        return None;
    }
    let mul = if kind == -3 { one } else { -one };
    let mut second = two;
    let other = pos - halfaxis * mul;
    for i in 0..3 {
        if i as i32 == best.face {
            continue;
        }
        for bound in [size[i], -size[i]] {
            let e = (bound - other[i]) / halfaxis[i] * mul;
            if e > T::zero() && e < second {
                second = e;
            }
        }
    }
    Some(second * mul)
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Matrix3;

    #[test]
    fn a_capsule_lying_on_a_box_touches_at_two_points() {
        let cube = Placed {
            pos: Vector3::zeros(),
            mat: Matrix3::identity(),
        };
        // Lying along x, 1 mm into the top face.
        let lying = Matrix3::new(0.0, 0.0, 1.0, 0.0, 1.0, 0.0, -1.0, 0.0, 0.0);
        let capsule = Placed {
            pos: Vector3::new(0.0, 0.0, 0.149),
            mat: lying,
        };
        let mut out: Vec<Pre<f64>> = vec![];
        let shapes = (
            Shape::Capsule {
                radius: 0.05,
                half_length: 0.2,
            },
            Shape::Box {
                half: Vector3::new(0.3, 0.3, 0.1),
            },
        );
        cuboid(
            &Assets::default(),
            (&shapes.0, &capsule),
            (&shapes.1, &cube),
            0.0,
            &mut out,
        );
        assert_eq!(out.len(), 2);
        for c in &out {
            assert!((c.dist + 0.001).abs() < 1e-15, "{}", c.dist);
            assert!((c.normal + Vector3::z()).norm() < 1e-15); // from the capsule into the box
        }
    }

    #[test]
    fn parallel_capsules_touch_at_two_points() {
        let lying = Matrix3::new(0.0, 0.0, 1.0, 0.0, 1.0, 0.0, -1.0, 0.0, 0.0);
        let a = Placed {
            pos: Vector3::zeros(),
            mat: lying,
        };
        let b = Placed {
            pos: Vector3::new(0.1, 0.0, 0.09),
            mat: lying,
        };
        let shape = Shape::Capsule {
            radius: 0.05,
            half_length: 0.2,
        };
        let mut out: Vec<Pre<f64>> = vec![];
        capsule(
            &Assets::default(),
            (&shape, &a),
            (&shape, &b),
            0.0,
            &mut out,
        );
        assert_eq!(out.len(), 2);
        for c in &out {
            assert!((c.dist + 0.01).abs() < 1e-15 && (c.normal - Vector3::z()).norm() < 1e-15);
        }
    }
}
