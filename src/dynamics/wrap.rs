//! A spatial tendon's segment wrapped around a sphere or a cylinder
//! (MuJoCo 4's mju_wrap, mju_wrapCircle, mju_wrapInside).
//!
//! Conventions: the segment runs from x0 to x1 (world coordinates, metres)
//! past a geom at `pos` with axes `mat` (columns, world coordinates) and
//! radius r. The problem is solved in a plane through the geom's centre: a
//! sphere's plane holds x0 and x1, a cylinder's is its x-y plane (the
//! height then interpolated along the path). In that plane the path runs
//! along a tangent from each end to the circle and along the arc between
//! the tangent points; of the two such paths it takes the shorter one, or
//! with a sidesite the one on the sidesite's side (winding around the
//! centre as the polyline x0 -> side -> x1 does). A segment that clears
//! the circle (on the side's side) does not wrap. A sidesite inside the
//! geom makes the path pass through the circle at one point where it
//! touches it from inside (mju_wrapInside, Newton's method).
//!
//! Smoothness: within each case (no wrap, either way round, the inside
//! point) the result is smooth in x0, x1, pos and mat. Where a segment
//! starts to touch the geom the length and its gradient are continuous
//! (the tangent points meet at the touching point); where the way round
//! switches (the two ways equal without a sidesite, the sidesite's side
//! changing with one) the length can jump. The inside wrap's point comes
//! from at most 20 Newton steps to a tolerance 1e-6 (as MuJoCo's), so its
//! derivatives are those of the iterate, not of the exact root.

use nalgebra::{Matrix3, Vector2, Vector3};

use crate::spatial::{lift, Real};

/// MuJoCo's mjMINVAL.
pub const MINVAL: f64 = 1e-15;

/// A geom the path may wrap around, at its world pose.
pub struct Obstacle<T: Real> {
    pub pos: Vector3<T>,
    pub mat: Matrix3<T>,
    pub radius: T,
    pub cylinder: bool,
}

/// The wrapped path x0 -> p0 ~ p1 -> x1 past `geom`: the length of the
/// part on the geom and the tangent points p0, p1 (world); None where the
/// straight segment stands.
pub fn wrap<T: Real>(
    (x0, x1): (&Vector3<T>, &Vector3<T>),
    geom: &Obstacle<T>,
    side: Option<&Vector3<T>>,
) -> Option<(T, Vector3<T>, Vector3<T>)> {
    let minval: T = lift(MINVAL);
    let p0 = geom.mat.tr_mul(&(x0 - geom.pos));
    let p1 = geom.mat.tr_mul(&(x1 - geom.pos));
    if p0.norm() < minval || p1.norm() < minval {
        return None;
    }
    let (axis0, axis1) = if geom.cylinder {
        (Vector3::x(), Vector3::y())
    } else {
        sphere_plane(&p0, &p1)
    };
    let project = |p: &Vector3<T>| Vector2::new(p.dot(&axis0), p.dot(&axis1));
    let end = [project(&p0), project(&p1)];
    let r = geom.radius;
    let (wlen, pnt0, pnt1) = match side.map(|s| geom.mat.tr_mul(&(s - geom.pos))) {
        Some(s) if s.norm() < r => inside(end, r)?,
        Some(s) => {
            let proj = project(&s);
            let n = proj.norm();
            let dir = if n < minval { Vector2::x() } else { proj / n };
            circle(end, Some(dir * r), r)?
        }
        None => circle(end, None, r)?,
    };
    let mut res0 = axis0 * pnt0.x + axis1 * pnt0.y;
    let mut res1 = axis0 * pnt1.x + axis1 * pnt1.y;
    let mut wlen = wlen;
    if geom.cylinder {
        let l0 = (p0.xy() - res0.xy()).norm();
        let l1 = (p1.xy() - res1.xy()).norm();
        let total = safe(l0 + wlen + l1);
        res0.z = p0.z + (p1.z - p0.z) * l0 / total;
        res1.z = p0.z + (p1.z - p0.z) * (l0 + wlen) / total;
        let height = (res1.z - res0.z).abs();
        wlen = (wlen * wlen + height * height).sqrt();
    }
    Some((wlen, geom.mat * res0 + geom.pos, geom.mat * res1 + geom.pos))
}

/// A divisor kept away from zero (MuJoCo's mju_safeDiv: mjMINVAL for 0).
fn safe<T: Real>(x: T) -> T {
    if x == T::zero() {
        lift(MINVAL)
    } else {
        x
    }
}

/// A sphere's plane: the first axis along p0, the second in the plane of
/// p0 and p1 (any plane through p0 where they are parallel).
fn sphere_plane<T: Real>(p0: &Vector3<T>, p1: &Vector3<T>) -> (Vector3<T>, Vector3<T>) {
    let axis0 = p0.normalize();
    let normal = p0.cross(p1);
    let nrm = normal.norm();
    let normal = if nrm < lift(MINVAL) {
        let a = axis0.map(|x| x.abs());
        let i = if a.y > a.x && a.y > a.z {
            1
        } else if a.z > a.x && a.z > a.y {
            2
        } else {
            0
        };
        let mut other = Vector3::repeat(T::one());
        other[i] = T::zero();
        axis0.cross(&other).normalize()
    } else {
        normal / nrm
    };
    (axis0, normal.cross(&axis0).normalize())
}

/// A 2-D wrap: the length on the circle and the two tangent points.
type Planar<T> = (T, Vector2<T>, Vector2<T>);

/// The signed angle from p to q about the origin, in (-pi, pi].
fn winding<T: Real>(p: &Vector2<T>, q: &Vector2<T>) -> T {
    (p.x * q.y - p.y * q.x).atan2(p.dot(q))
}

/// Whether segments p1-p2 and p3-p4 cross (MuJoCo's is_intersect).
fn crossing<T: Real>(p1: &Vector2<T>, p2: &Vector2<T>, p3: &Vector2<T>, p4: &Vector2<T>) -> bool {
    let (u, v) = (p2 - p1, p4 - p3);
    let det = v.y * u.x - v.x * u.y;
    if det.abs() < lift(MINVAL) {
        return false;
    }
    let s = if det > T::zero() { T::one() } else { -T::one() };
    let (w, d) = (p1 - p3, p2 - p4);
    let a0 = (v.x * w.y - v.y * w.x) * s;
    let a1 = (v.x * d.y - v.y * d.x) * s;
    let b0 = (u.x * w.y - u.y * w.x) * s;
    let b1 = (u.x * d.y - u.y * d.x) * s;
    a0 >= T::zero() && a1 < T::zero() && b0 >= T::zero() && b1 < T::zero()
}

/// The 2-D wrap of end[0] -> end[1] around the circle of radius r at the
/// origin, `side` the sidesite's direction scaled to r: arc length and
/// tangent points.
fn circle<T: Real>(end: [Vector2<T>; 2], side: Option<Vector2<T>>, r: T) -> Option<Planar<T>> {
    let [e0, e1] = end;
    let (sq0, sq1, sqr) = (e0.norm_squared(), e1.norm_squared(), r * r);
    if sq0 < sqr || sq1 < sqr || r < lift(MINVAL) {
        return None;
    }
    let dif = e1 - e0;
    let dd = dif.norm_squared();
    if dd < lift(MINVAL) {
        return None;
    }
    let a = (-dif.dot(&e0) / dd).clamp(T::zero(), T::one());
    let clear = (dif * a + e0).norm_squared() > sqr;
    let wside = side.map(|s| winding(&e0, &s) + winding(&s, &e1));
    match wside {
        Some(w) if clear && (w - winding(&e0, &e1)).abs() < T::pi() => return None,
        None if clear => return None,
        _ => {}
    }
    let (s0, s1) = ((sq0 - sqr).sqrt(), (sq1 - sqr).sqrt());
    let tangent = |e: &Vector2<T>, sq: T, root: T, sign: T| {
        Vector2::new(
            (e.x * sqr + sign * r * e.y * root) / safe(sq),
            (e.y * sqr - sign * r * e.x * root) / safe(sq),
        )
    };
    let one = T::one();
    let sol = [
        (tangent(&e0, sq0, s0, one), tangent(&e1, sq1, s1, -one)),
        (tangent(&e0, sq0, s0, -one), tangent(&e1, sq1, s1, one)),
    ];
    let crosses = sol.map(|(a, b)| crossing(&e0, &a, &e1, &b));
    let good = [0, 1].map(|k| {
        if crosses[k] {
            lift(-10000.0)
        } else {
            -(sol[k].0 - sol[k].1).norm_squared()
        }
    });
    let ind = match wside {
        Some(w) => usize::from(w > T::zero()),
        None => usize::from(good[0] <= good[1]),
    };
    if crosses[ind] {
        return None;
    }
    let (pnt0, pnt1) = sol[ind];
    let length = match wside {
        Some(w) => r * (w - winding(&e0, &pnt0) - winding(&pnt1, &e1)).abs(),
        None => arc(&pnt0, &pnt1, ind, r),
    };
    Some((length, pnt0, pnt1))
}

/// The arc from p0 to p1 on the circle of radius r, the long way where the
/// orientation `ind` asks for it (MuJoCo's length_circle).
fn arc<T: Real>(p0: &Vector2<T>, p1: &Vector2<T>, ind: usize, r: T) -> T {
    let cross = p0.y * p1.x - p0.x * p1.y;
    let mut angle = cross.abs().atan2(p0.dot(p1));
    let flip = (cross > T::zero() && ind != 0) || (cross < T::zero() && ind == 0);
    if angle > lift(1e-6) && flip {
        angle = T::two_pi() - angle;
    }
    r * angle
}

/// The 2-D wrap with the sidesite inside the circle: the point where the
/// path end[0] -> p -> end[1] touches the circle from inside; length 0.
fn inside<T: Real>(end: [Vector2<T>; 2], r: T) -> Option<Planar<T>> {
    let minval: T = lift(MINVAL);
    let [e0, e1] = end;
    let (len0, len1) = (e0.norm(), e1.norm());
    let dif = e1 - e0;
    let dd = dif.norm_squared();
    if len0 <= r || len1 <= r || r < minval || len0 < minval || len1 < minval {
        return None;
    }
    if dd > minval {
        let a = -dif.dot(&e0) / dd;
        if a > T::zero() && a < T::one() && (e0 + dif * a).norm() <= r {
            return None;
        }
    }
    let mid = (e0 + e1) * lift::<T>(0.5);
    let n = mid.norm();
    let fallback = if n < minval { mid } else { mid / n } * r;
    let done = |p: Vector2<T>| Some((T::zero(), p, p));
    let (a, b) = (r / len0, r / len1);
    let cos_g = (len0 * len0 + len1 * len1 - dd) / safe(lift::<T>(2.0) * len0 * len1);
    if cos_g < minval - T::one() {
        return None;
    }
    if cos_g > T::one() - minval {
        return done(fallback);
    }
    let g = cos_g.acos();
    let mut phi = T::frac_pi_2();
    let mut z = T::one();
    let (mut asin_a, mut asin_b) = (a.asin(), b.asin());
    let mut f = asin_a + asin_b - T::pi() + g;
    if f > T::zero() {
        return done(fallback);
    }
    let tolerance: T = lift(1e-6);
    let mut iter = 0;
    while iter < 20 && f.abs() > tolerance {
        let sq_z = z * z;
        let slope = |c: T| c / (T::one() - sq_z * c * c).sqrt().max(minval);
        let df = phi.cos() * (slope(a) + slope(b)) - lift(2.0);
        if df > -minval {
            return done(fallback);
        }
        let next = phi - f / df;
        if next > phi {
            return done(fallback);
        }
        phi = next;
        z = phi.sin();
        asin_a = (a * z).asin();
        asin_b = (b * z).asin();
        f = asin_a + asin_b - lift::<T>(2.0) * phi + g;
        if f > tolerance {
            return done(fallback);
        }
        iter += 1;
    }
    if iter >= 20 {
        return done(fallback);
    }
    let (from, ang) = if e0.x * e1.y - e0.y * e1.x > T::zero() {
        (e0, phi - asin_a)
    } else {
        (e1, phi - asin_b)
    };
    let u = from.normalize();
    let (c, s) = (ang.cos(), ang.sin());
    done(Vector2::new(u.x * c - u.y * s, u.x * s + u.y * c) * r)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A unit sphere between (-2, 0, 0) and (2, 0, 0.1): each tangent
    /// touches where cos(angle) = 1/|x|, and the path's length is the sum
    /// of the tangents' lengths sqrt(|x|^2 - 1) and the arc between the
    /// tangent points, all in the plane of the two ends and the centre.
    #[test]
    fn a_sphere_wrap_is_two_tangents_and_an_arc() {
        let (x0, x1) = (Vector3::new(-2.0, 0.0, 0.0), Vector3::new(2.0, 0.0, 0.1));
        let geom = Obstacle {
            pos: Vector3::zeros(),
            mat: Matrix3::identity(),
            radius: 1.0,
            cylinder: false,
        };
        let (arc, p0, p1) = wrap((&x0, &x1), &geom, None).unwrap();
        let angle = |a: &Vector3<f64>, b: &Vector3<f64>| (a.dot(b) / (a.norm() * b.norm())).acos();
        let expected = angle(&x0, &x1) - (1.0 / 2.0f64).acos() - (1.0 / x1.norm()).acos();
        assert!((arc - expected).abs() < 1e-14, "{arc} vs {expected}");
        for (p, x) in [(p0, x0), (p1, x1)] {
            assert!((p.norm() - 1.0).abs() < 1e-14);
            assert!(p.dot(&(x - p)).abs() < 1e-14, "tangent at {p}");
        }
        // Far above the sphere the segment stands straight.
        let high = Vector3::new(0.0, 0.0, 3.0);
        assert!(wrap((&(x0 + high), &(x1 + high)), &geom, None).is_none());
    }
}
