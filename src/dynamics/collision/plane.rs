//! A plane (its z axis the normal, through its centre) against a sphere, a
//! capsule, a cylinder, a box and an ellipsoid, as MuJoCo computes them. The normal of
//! every contact is the plane's.

use nalgebra::Vector3;

use super::{entry, normalize, Assets, GeomType, Placed, Pre, MINVAL};
use crate::model::Shape;
use crate::spatial::{lift, Real, Transform};

/// A plane against a sphere.
pub(super) fn sphere<T: Real>(
    _: &Assets,
    (_, plane): (&Shape, &Placed<T>),
    (s, sphere): (&Shape, &Placed<T>),
    margin: T,
    out: &mut Vec<Pre<T>>,
) {
    let [radius, ..] = s.size();
    ball(plane, sphere.pos, lift(radius), margin, out);
}

/// A plane against a sphere at `centre`: whether it touches (a contact pushed).
pub(super) fn ball<T: Real>(
    plane: &Placed<T>,
    centre: Vector3<T>,
    radius: T,
    margin: T,
    out: &mut Vec<Pre<T>>,
) -> bool {
    let normal = plane.axis(2);
    let height = (centre - plane.pos).dot(&normal);
    if height > margin + radius {
        return false;
    }
    let dist = height - radius;
    let two: T = lift(2.0);
    out.push(Pre {
        dist,
        pos: centre - normal * (dist / two + radius),
        normal,
        tangent: Vector3::zeros(),
    });
    true
}

/// Both end spheres of the capsule; their frames' tangent is the capsule axis.
pub(super) fn capsule<T: Real>(
    _: &Assets,
    (_, plane): (&Shape, &Placed<T>),
    (s, capsule): (&Shape, &Placed<T>),
    margin: T,
    out: &mut Vec<Pre<T>>,
) {
    let [radius, half, _] = s.size();
    let axis = capsule.axis(2);
    let segment = axis * lift::<T>(half);
    for end in [capsule.pos + segment, capsule.pos - segment] {
        if ball(plane, end, lift(radius), margin, out) {
            out.last_mut().expect("just pushed").tangent = axis;
        }
    }
}

/// MuJoCo's plane-cylinder: the rim point nearest the plane on the end
/// closer to it, the matching point of the other end, and two more points of
/// the closer end's rim (a triangle with the first) when it is within margin.
pub(super) fn cylinder<T: Real>(
    _: &Assets,
    (_, plane): (&Shape, &Placed<T>),
    (s, cylinder): (&Shape, &Placed<T>),
    margin: T,
    out: &mut Vec<Pre<T>>,
) {
    let [radius, half, _] = s.size();
    let normal = plane.axis(2);
    let mut axis = cylinder.axis(2);
    let mut prjaxis = normal.dot(&axis);
    if prjaxis > T::zero() {
        axis = -axis;
        prjaxis = -prjaxis;
    }
    let dist0 = (cylinder.pos - plane.pos).dot(&normal);
    let mut vec = axis * prjaxis - normal;
    let len_sqr = vec.norm_squared();
    let r: T = lift(radius);
    vec = if len_sqr >= lift(MINVAL * MINVAL) {
        vec * (r / len_sqr.sqrt())
    } else {
        cylinder.axis(0) * r
    };
    let prjvec = vec.dot(&normal);
    let axis = axis * lift::<T>(half);
    let prjaxis = prjaxis * lift::<T>(half);
    let half_t: T = lift(0.5);
    let mut add = |dist: T, at: Vector3<T>| {
        out.push(Pre {
            dist,
            pos: at - normal * (dist * half_t),
            normal,
            tangent: Vector3::zeros(),
        });
    };
    let first = dist0 + prjaxis + prjvec;
    if first > margin {
        return;
    }
    add(first, cylinder.pos + vec + axis);
    let second = dist0 - prjaxis + prjvec;
    if second <= margin {
        add(second, cylinder.pos + vec - axis);
    }
    let prjvec1 = -prjvec * half_t;
    let third = dist0 + prjaxis + prjvec1;
    if third <= margin {
        let (side, _) = normalize(vec.cross(&axis));
        let side = side * (r * lift::<T>(3f64.sqrt() / 2.0));
        for s in [side, -side] {
            add(third, cylinder.pos + s + axis - vec * half_t);
        }
    }
}

/// MuJoCo's plane-convex collider for an ellipsoid (`mjc_PlaneConvex`):
/// one contact at the ellipsoid's support point along the plane's inward
/// normal, in its libccd support arithmetic (the direction scaled by the
/// radii, normalised, scaled again).
pub(super) fn ellipsoid<T: Real>(
    _: &Assets,
    (_, plane): (&Shape, &Placed<T>),
    (s, egg): (&Shape, &Placed<T>),
    margin: T,
    out: &mut Vec<Pre<T>>,
) {
    let normal = plane.axis(2);
    let radii = s.size().map(lift::<T>);
    let m = &egg.mat;
    let d = -normal;
    let local =
        Vector3::from_fn(|i, _| (m[(0, i)] * d.x + m[(1, i)] * d.y + m[(2, i)] * d.z) * radii[i]);
    let (unit, _) = normalize(local);
    let tip = Vector3::from_fn(|i, _| unit[i] * radii[i]);
    let point = Vector3::from_fn(|i, _| {
        m[(i, 0)] * tip.x + m[(i, 1)] * tip.y + m[(i, 2)] * tip.z + egg.pos[i]
    });
    let gap = point - plane.pos;
    let dist = normal.x * gap.x + normal.y * gap.y + normal.z * gap.z;
    if dist > margin {
        return;
    }
    let half: T = lift(-0.5);
    out.push(Pre {
        dist,
        pos: point + normal * (half * dist),
        normal,
        tangent: Vector3::zeros(),
    });
}

/// The box corners below the plane's margin that point towards it, at most four.
pub(super) fn cuboid<T: Real>(
    _: &Assets,
    (_, plane): (&Shape, &Placed<T>),
    (s, cube): (&Shape, &Placed<T>),
    margin: T,
    out: &mut Vec<Pre<T>>,
) {
    let half = s.size();
    let normal = plane.axis(2);
    let dist = (cube.pos - plane.pos).dot(&normal);
    let two: T = lift(2.0);
    let mut count = 0;
    for i in 0..8 {
        let sign = |bit: usize| if i >> bit & 1 == 1 { 1.0 } else { -1.0 };
        let local = Vector3::from_fn(|r, _| lift::<T>(sign(r) * half[r]));
        let corner = cube.mat * local;
        let ldist = normal.dot(&corner);
        if dist + ldist > margin || ldist > T::zero() {
            continue;
        }
        let d = dist + ldist;
        out.push(Pre {
            dist: d,
            pos: corner + cube.pos - normal * (d / two),
            normal,
            tangent: Vector3::zeros(),
        });
        count += 1;
        if count == 4 {
            return;
        }
    }
}

/// What the table's plane collider (its plane row, [`super::Colliders::TABLE`])
/// makes of a shape at `pose`: each contact is the point nearest the plane
/// of a sphere of radius r fixed on the shape (the sphere itself, a
/// capsule's end sphere, a box's corner with r = 0), and its frame's tangent
/// hint is h (a capsule's axis; zero for none). None for a shape without a
/// plane collider, and for one whose plane contacts are no such sphere's (a
/// cylinder's rim points). The derivatives move such contacts in closed form.
pub fn fixed_sphere(shape: &Shape, pose: &Transform<f64>) -> Option<(f64, Vector3<f64>)> {
    entry::<f64>(GeomType::Plane, shape.kind())?;
    let [radius, ..] = shape.size();
    match shape.kind() {
        GeomType::Sphere => Some((radius, Vector3::zeros())),
        GeomType::Capsule => Some((radius, pose.axes().column(2).into())),
        GeomType::Box => Some((0.0, Vector3::zeros())),
        _ => None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dynamics::collision::Colliders;
    use nalgebra::Matrix3;

    fn floor() -> Placed<f64> {
        Placed {
            pos: Vector3::zeros(),
            mat: Matrix3::identity(),
        }
    }

    #[test]
    fn a_box_on_a_plane_touches_with_its_four_lowest_corners_at_most() {
        let plane = floor();
        let cube = Placed {
            pos: Vector3::new(0.0, 0.0, 0.049),
            mat: Matrix3::identity(),
        };
        let shape = Shape::Box {
            half: Vector3::new(0.2, 0.1, 0.05),
        };
        let mut out: Vec<Pre<f64>> = vec![];
        let collide = |cube: &Placed<f64>, margin: f64, out: &mut Vec<Pre<f64>>| {
            cuboid(
                &Assets::default(),
                (&Shape::Plane, &plane),
                (&shape, cube),
                margin,
                out,
            );
        };
        collide(&cube, 0.0, &mut out);
        assert_eq!(out.len(), 4);
        for c in &out {
            assert!((c.dist + 0.001).abs() < 1e-15);
            assert!((c.pos.z + 0.0005).abs() < 1e-15); // midway between the surfaces
            assert_eq!(c.normal, Vector3::z());
        }
        // Lifted beyond the margin: nothing; within it: contacts at positive distance.
        let lifted = Placed {
            pos: Vector3::new(0.0, 0.0, 0.06),
            ..cube
        };
        out.clear();
        collide(&lifted, 0.005, &mut out);
        assert!(out.is_empty());
        collide(&lifted, 0.02, &mut out);
        assert!(out.len() == 4 && out.iter().all(|c| (c.dist - 0.01).abs() < 1e-15));
    }

    #[test]
    fn plane_contacts_are_those_of_the_fixed_sphere() {
        // A tilted shape of every type with a plane collider in the table, 1
        // cm into the floor: each contact's centre pos + n (dist / 2 + r) is
        // a point of the shape's fixed sphere's centres (the centre, an end,
        // a corner); the cylinder alone has none, and a shape without a
        // plane collider has none.
        let tilt = nalgebra::Rotation3::from_euler_angles(0.3, -0.2, 0.1);
        let pose = Transform::from_pose_f64(&tilt, &Vector3::new(0.1, -0.2, 0.0));
        let shapes = [
            Shape::Sphere { radius: 0.05 },
            Shape::Capsule {
                radius: 0.05,
                half_length: 0.1,
            },
            Shape::Cylinder {
                radius: 0.05,
                half_length: 0.1,
            },
            Shape::Box {
                half: Vector3::new(0.05, 0.1, 0.02),
            },
            Shape::Ellipsoid {
                radii: Vector3::new(0.05, 0.1, 0.06),
            },
        ];
        let plane_row = Colliders::<f64>::TABLE[GeomType::Plane as usize];
        // The primitives' columns (a mesh's collider reads its assets: mesh.rs).
        let primitives = &plane_row[..GeomType::Mesh as usize];
        let with_collider = primitives.iter().filter(|c| c.is_some()).count();
        assert_eq!(
            shapes
                .iter()
                .filter(|s| entry::<f64>(GeomType::Plane, s.kind()).is_some())
                .count(),
            with_collider
        );
        for shape in shapes {
            let Some(pair) = entry::<f64>(GeomType::Plane, shape.kind()) else {
                assert_eq!(fixed_sphere(&shape, &pose), None, "{shape:?}");
                continue;
            };
            let mut placed = Placed::of(&pose);
            placed.pos.z = 0.05 - 0.01;
            let mut out = vec![];
            (pair.collide)(
                &Assets::default(),
                (&Shape::Plane, &floor()),
                (&shape, &placed),
                0.0,
                &mut out,
            );
            assert!(!out.is_empty());
            let Some((r, hint)) = fixed_sphere(&shape, &pose) else {
                assert!(matches!(
                    shape.kind(),
                    GeomType::Cylinder | GeomType::Ellipsoid
                ));
                continue;
            };
            for c in &out {
                let centre = c.pos + c.normal * (c.dist / 2.0 + r);
                let local = placed.mat.tr_mul(&(centre - placed.pos));
                let [sx, sy, sz] = shape.size();
                let on = match shape {
                    Shape::Sphere { .. } => local.norm() < 1e-15,
                    Shape::Capsule { .. } => {
                        local.xy().norm() < 1e-15 && (local.z.abs() - sy).abs() < 1e-15
                    }
                    _ => (local.abs() - Vector3::new(sx, sy, sz)).norm() < 1e-15,
                };
                assert!(on, "{shape:?}: {local}");
                assert_eq!(c.tangent, hint);
            }
        }
    }
}
