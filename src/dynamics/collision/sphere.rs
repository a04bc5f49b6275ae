//! A sphere against a sphere, a capsule, a cylinder and a box, as MuJoCo
//! computes them; the normal points from the sphere (geom 1) to the other.

use nalgebra::{Matrix3, Vector3};

use super::{clip, normalize, plane, Assets, Placed, Pre, MINVAL};
use crate::model::Shape;
use crate::spatial::{lift, Real};

/// Two spheres.
pub(super) fn sphere<T: Real>(
    _: &Assets,
    (s1, p1): (&Shape, &Placed<T>),
    (s2, p2): (&Shape, &Placed<T>),
    margin: T,
    out: &mut Vec<Pre<T>>,
) {
    let ([r1, ..], [r2, ..]) = (s1.size(), s2.size());
    balls(p1, lift(r1), p2, lift(r2), margin, out);
}

/// Two spheres of radii r1 and r2 at the centres of `p1` and `p2`;
/// coincident centres take the normal from the cross product of the
/// frames' z axes (MuJoCo's rule).
pub(super) fn balls<T: Real>(
    p1: &Placed<T>,
    r1: T,
    p2: &Placed<T>,
    r2: T,
    margin: T,
    out: &mut Vec<Pre<T>>,
) {
    let gap = p1.pos - p2.pos;
    let reach = margin + r1 + r2;
    let cdist_sqr = gap.norm_squared();
    if cdist_sqr > reach * reach {
        return;
    }
    let dist = cdist_sqr.sqrt() - r1 - r2;
    let (mut normal, len) = normalize(p2.pos - p1.pos);
    if len < lift(MINVAL) {
        normal = normalize(p1.axis(2).cross(&p2.axis(2))).0;
    }
    let two: T = lift(2.0);
    out.push(Pre {
        dist,
        pos: p1.pos + normal * (r1 + dist / two),
        normal,
        tangent: Vector3::zeros(),
    });
}

/// A sphere against the capsule's sphere at the point of its segment
/// nearest the sphere's centre.
pub(super) fn capsule<T: Real>(
    _: &Assets,
    (s1, p1): (&Shape, &Placed<T>),
    (s2, p2): (&Shape, &Placed<T>),
    margin: T,
    out: &mut Vec<Pre<T>>,
) {
    let ([radius, ..], [r2, half_length, _]) = (s1.size(), s2.size());
    let x = clip(
        p2.axis(2).dot(&(p1.pos - p2.pos)),
        lift(-half_length),
        lift(half_length),
    );
    let nearest = Placed {
        pos: p2.pos + p2.axis(2) * x,
        mat: p2.mat,
    };
    balls(p1, lift(radius), &nearest, lift(r2), margin, out);
}

/// MuJoCo's sphere-cylinder: against the side (a sphere on the axis), a cap
/// (a plane) or the rim (a point), whichever the sphere's centre faces.
pub(super) fn cylinder<T: Real>(
    _: &Assets,
    (s1, sphere): (&Shape, &Placed<T>),
    (s2, cylinder): (&Shape, &Placed<T>),
    margin: T,
    out: &mut Vec<Pre<T>>,
) {
    let ([radius, ..], [r2, half, _]) = (s1.size(), s2.size());
    let radius: T = lift(radius);
    let (rc, hc): (T, T) = (lift(r2), lift(half));
    let axis = cylinder.axis(2);
    let vec = sphere.pos - cylinder.pos;
    let x = axis.dot(&vec);
    let a_proj = axis * x;
    let p_proj = vec - a_proj;
    let p_sqr = p_proj.norm_squared();
    let mut side = x.abs() < hc;
    let mut cap = p_sqr < rc * rc;
    if side && cap {
        if hc - x.abs() < rc - p_sqr.sqrt() {
            side = false;
        } else {
            cap = false;
        }
    }
    if side {
        let on_axis = Placed {
            pos: cylinder.pos + a_proj,
            mat: cylinder.mat,
        };
        return balls(sphere, radius, &on_axis, rc, margin, out);
    }
    if cap {
        let top = x > T::zero();
        let flip = Matrix3::from_columns(&[-cylinder.axis(0), cylinder.axis(1), -axis]);
        let plane = Placed {
            pos: cylinder.pos + axis * if top { hc } else { -hc },
            mat: if top { cylinder.mat } else { flip },
        };
        if plane::ball(&plane, sphere.pos, radius, margin, out) {
            let c = out.last_mut().expect("just pushed");
            c.normal = -c.normal;
        }
        return;
    }
    let rim = Placed {
        pos: cylinder.pos
            + p_proj * (rc / p_sqr.sqrt())
            + axis * if x > T::zero() { hc } else { -hc },
        mat: cylinder.mat,
    };
    balls(sphere, radius, &rim, T::zero(), margin, out);
}

/// A sphere against a box.
pub(super) fn cuboid<T: Real>(
    _: &Assets,
    (s1, sphere): (&Shape, &Placed<T>),
    (s2, cube): (&Shape, &Placed<T>),
    margin: T,
    out: &mut Vec<Pre<T>>,
) {
    let [radius, ..] = s1.size();
    ball_box(
        sphere,
        lift(radius),
        cube,
        &Vector3::from(s2.size()),
        margin,
        out,
    );
}

/// MuJoCo's sphere-box for a sphere of radius `radius` at the centre of
/// `sphere`: from the point of the box nearest the sphere's centre, or, with
/// the centre inside, from the nearest face.
pub(super) fn ball_box<T: Real>(
    sphere: &Placed<T>,
    radius: T,
    cube: &Placed<T>,
    half: &Vector3<f64>,
    margin: T,
    out: &mut Vec<Pre<T>>,
) {
    let size: Vector3<T> = half.map(lift);
    let centre = cube.mat.tr_mul(&(sphere.pos - cube.pos));
    let clamped = Vector3::from_fn(|i, _| clip(centre[i], -size[i], size[i]));
    let (dir, dist) = normalize(clamped - centre);
    if dist - radius > margin {
        return;
    }
    let half_t: T = lift(0.5);
    let (local_pos, local_normal, dist) = if dist <= lift(MINVAL) {
        let mut best = (size.x + size.y + size.z) * lift::<T>(2.0);
        let mut k = 0;
        for i in 0..6 {
            let face = if i % 2 == 1 {
                size[i / 2]
            } else {
                -size[i / 2]
            };
            let d = (face - centre[i / 2]).abs();
            if best > d {
                best = d;
                k = i;
            }
        }
        let mut nearest = Vector3::zeros();
        nearest[k / 2] = if k % 2 == 1 { -T::one() } else { T::one() };
        let pos = centre + nearest * ((radius - best) * half_t);
        (pos, nearest, -best)
    } else {
        let deepest = centre + dir * radius;
        ((clamped + deepest) * half_t, dir, dist)
    };
    out.push(Pre {
        dist: dist - radius,
        pos: cube.mat * local_pos + cube.pos,
        normal: cube.mat * local_normal,
        tangent: Vector3::zeros(),
    });
}
