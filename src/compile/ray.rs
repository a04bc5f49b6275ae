//! Rays against the surfaces of primitive shapes, as MuJoCo's mj_rayGeom
//! casts them (the touch sensor's zone test, the rangefinder).
//!
//! A ray is p + x d, x >= 0, in world coordinates (d need not be unit: x is
//! in units of |d|). A shape sits at `pos` with axes `rot` (columns); its
//! sizes are MuJoCo's (radius, half-length along z, half-sizes, radii). A
//! hit is the smallest x >= 0 on the surface, with the outward unit normal
//! there (world coordinates); a ray starting inside a solid hits it from
//! within. A plane is hit only on its front (+z) face, within its rendered
//! half-extents (0: unbounded). A mesh is hit on any of its triangles
//! (not its hull), from either side, the normal that of the triangle's
//! winding.

use nalgebra::{Matrix3, Vector3};

use crate::model::mesh::Mesh;
use crate::model::{Shape, MINVAL};

/// Where the ray (p, d) first meets `shape` placed at (pos, rot): the
/// distance and the normal; None for a miss (and for meshes, see
/// [`ray_mesh`], and height fields, which no caller casts at).
pub fn ray_shape(
    shape: &Shape,
    plane: [f64; 2],
    (pos, rot): (&Vector3<f64>, &Matrix3<f64>),
    (p, d): (&Vector3<f64>, &Vector3<f64>),
) -> Option<(f64, Vector3<f64>)> {
    let (lp, ld) = (rot.tr_mul(&(p - pos)), rot.tr_mul(d));
    let local = match *shape {
        Shape::Sphere { radius } => return sphere(pos, radius * radius, p, d),
        Shape::Plane => plane_hit(plane, &lp, &ld),
        Shape::Capsule {
            radius,
            half_length,
        } => {
            let bound = radius + half_length;
            sphere(pos, bound * bound, p, d)?;
            capsule(radius, half_length, &lp, &ld)
        }
        Shape::Cylinder {
            radius,
            half_length,
        } => {
            sphere(pos, radius * radius + half_length * half_length, p, d)?;
            cylinder(radius, half_length, &lp, &ld)
        }
        Shape::Box { half } => {
            sphere(pos, half.norm_squared(), p, d)?;
            cuboid(&half, &lp, &ld)
        }
        Shape::Ellipsoid { radii } => ellipsoid(&radii, &lp, &ld),
        Shape::Mesh { .. } | Shape::HField { .. } => None,
    };
    local.map(|(x, n)| (x, rot * n))
}

/// Where the ray (p, d) first meets a triangle of `mesh` placed at (pos,
/// rot) (its mesh frame): the distance and the triangle's unit normal.
pub fn ray_mesh(
    mesh: &Mesh,
    (pos, rot): (&Vector3<f64>, &Matrix3<f64>),
    (p, d): (&Vector3<f64>, &Vector3<f64>),
) -> Option<(f64, Vector3<f64>)> {
    let (lp, ld) = (rot.tr_mul(&(p - pos)), rot.tr_mul(d));
    let basis = across(&ld);
    let mut best: Option<(f64, Vector3<f64>)> = None;
    for face in &mesh.faces {
        let v = face.map(|i| mesh.vertices[i]);
        if let Some((x, n)) = triangle(&v, &lp, &ld, &basis) {
            best = nearer(best, x, n);
        }
    }
    best.map(|(x, n)| (x, rot * n))
}

/// Two unit vectors spanning the plane across direction d.
fn across(d: &Vector3<f64>) -> [Vector3<f64>; 2] {
    let k = d.iamin();
    let mut e = Vector3::repeat(1.0);
    e[k] = 0.0;
    let b1 = (e - d * (d.dot(&e) / d.dot(d))).normalize();
    [b1.cross(d).normalize(), b1]
}

/// The ray against one triangle: whether the ray's line passes through
/// it (the triangle projected across the ray contains the origin), then
/// the distance to its plane.
fn triangle(
    v: &[Vector3<f64>; 3],
    lp: &Vector3<f64>,
    ld: &Vector3<f64>,
    [b0, b1]: &[Vector3<f64>; 2],
) -> Option<(f64, Vector3<f64>)> {
    let planar = v.map(|v| {
        let r = v - lp;
        (r.dot(b0), r.dot(b1))
    });
    let (p0, p1, p2) = (planar[0], planar[1], planar[2]);
    // The origin as p2 + t0 (p0 - p2) + t1 (p1 - p2).
    let (a00, a01, a10, a11) = (p0.0 - p2.0, p1.0 - p2.0, p0.1 - p2.1, p1.1 - p2.1);
    let det = a00 * a11 - a01 * a10;
    if det.abs() < MINVAL {
        return None;
    }
    let t0 = (-p2.0 * a11 + p2.1 * a01) / det;
    let t1 = (-p2.1 * a00 + p2.0 * a10) / det;
    if t0 < 0.0 || t1 < 0.0 || t0 + t1 > 1.0 {
        return None;
    }
    let normal = (v[0] - v[2]).cross(&(v[1] - v[2]));
    let denom = ld.dot(&normal);
    if denom.abs() < MINVAL {
        return None;
    }
    let x = -(lp - v[2]).dot(&normal) / denom;
    (x >= 0.0).then(|| (x, normal.normalize()))
}

/// The roots of a x^2 + 2 b x + c = 0, ascending, when its discriminant
/// is at least MINVAL (MuJoCo's ray_quad).
fn roots(a: f64, b: f64, c: f64) -> Option<[f64; 2]> {
    let det = b * b - a * c;
    if det < MINVAL {
        return None;
    }
    let det = det.sqrt();
    Some([(-b - det) / a, (-b + det) / a])
}

/// The first non-negative root.
fn first(r: Option<[f64; 2]>) -> Option<f64> {
    r.and_then(|[x0, x1]| [x0, x1].into_iter().find(|x| *x >= 0.0))
}

/// Keeps the nearer of two candidate hits.
fn nearer<P>(best: Option<(f64, P)>, x: f64, part: P) -> Option<(f64, P)> {
    match best {
        Some((y, _)) if y <= x => best,
        _ => Some((x, part)),
    }
}

/// A sphere of squared radius r2 about `centre` (world coordinates).
fn sphere(
    centre: &Vector3<f64>,
    r2: f64,
    p: &Vector3<f64>,
    d: &Vector3<f64>,
) -> Option<(f64, Vector3<f64>)> {
    let dif = p - centre;
    let x = first(roots(d.dot(d), d.dot(&dif), dif.dot(&dif) - r2))?;
    Some((x, (p + d * x - centre).normalize()))
}

fn plane_hit(half: [f64; 2], lp: &Vector3<f64>, ld: &Vector3<f64>) -> Option<(f64, Vector3<f64>)> {
    if ld.z > -MINVAL {
        return None;
    }
    let x = -lp.z / ld.z;
    if x < 0.0 {
        return None;
    }
    let inside = |k: usize| half[k] <= 0.0 || (lp[k] + x * ld[k]).abs() <= half[k];
    (inside(0) && inside(1)).then(|| (x, Vector3::z()))
}

/// The round side of a radius-r cylinder about z, between z = -h and h:
/// the first root, if it lies between the flat sides.
fn round_side(r: f64, h: f64, lp: &Vector3<f64>, ld: &Vector3<f64>) -> Option<f64> {
    let a = ld.x * ld.x + ld.y * ld.y;
    let b = ld.x * lp.x + ld.y * lp.y;
    let c = lp.x * lp.x + lp.y * lp.y - r * r;
    first(roots(a, b, c)).filter(|x| (lp.z + x * ld.z).abs() <= h)
}

fn capsule(r: f64, h: f64, lp: &Vector3<f64>, ld: &Vector3<f64>) -> Option<(f64, Vector3<f64>)> {
    let mut best = round_side(r, h, lp, ld).map(|x| (x, 0.0));
    // The caps: spheres about z = +-h, the outer half of each.
    for side in [1.0, -1.0] {
        let dif = Vector3::new(lp.x, lp.y, lp.z - side * h);
        for x in roots(ld.dot(ld), ld.dot(&dif), dif.dot(&dif) - r * r).unwrap_or([-1.0; 2]) {
            if x >= 0.0 && side * (lp.z + x * ld.z) >= h {
                best = nearer(best, x, side);
            }
        }
    }
    // The normal: radial on the side, from the cap's centre on a cap.
    best.map(|(x, side)| {
        let at = lp + ld * x;
        let z = if side == 0.0 { 0.0 } else { at.z - side * h };
        (x, Vector3::new(at.x, at.y, z).normalize())
    })
}

fn cylinder(r: f64, h: f64, lp: &Vector3<f64>, ld: &Vector3<f64>) -> Option<(f64, Vector3<f64>)> {
    let mut best = None;
    if ld.z.abs() > MINVAL {
        for side in [-1.0, 1.0] {
            let x = (side * h - lp.z) / ld.z;
            let (px, py) = (lp.x + x * ld.x, lp.y + x * ld.y);
            if x >= 0.0 && px * px + py * py <= r * r {
                best = nearer(best, x, side);
            }
        }
    }
    if let Some(x) = round_side(r, h, lp, ld) {
        best = nearer(best, x, 0.0);
    }
    best.map(|(x, side)| {
        let normal = if side == 0.0 {
            let at = lp + ld * x;
            Vector3::new(at.x, at.y, 0.0).normalize()
        } else {
            Vector3::new(0.0, 0.0, side)
        };
        (x, normal)
    })
}

fn cuboid(
    half: &Vector3<f64>,
    lp: &Vector3<f64>,
    ld: &Vector3<f64>,
) -> Option<(f64, Vector3<f64>)> {
    let mut best = None;
    for i in (0..3).filter(|i| ld[*i].abs() > MINVAL) {
        let (j, k) = ((i + 1) % 3, (i + 2) % 3);
        for side in [-1.0, 1.0] {
            let x = (side * half[i] - lp[i]) / ld[i];
            let on_face =
                (lp[j] + x * ld[j]).abs() <= half[j] && (lp[k] + x * ld[k]).abs() <= half[k];
            if x >= 0.0 && on_face {
                best = nearer(best, x, (i, side));
            }
        }
    }
    best.map(|(x, (i, side))| {
        let mut normal = Vector3::zeros();
        normal[i] = side;
        (x, normal)
    })
}

fn ellipsoid(
    radii: &Vector3<f64>,
    lp: &Vector3<f64>,
    ld: &Vector3<f64>,
) -> Option<(f64, Vector3<f64>)> {
    let s = radii.map(|r| 1.0 / (r * r));
    let sd = s.component_mul(ld);
    let x = first(roots(
        sd.dot(ld),
        sd.dot(lp),
        s.component_mul(lp).dot(lp) - 1.0,
    ))?;
    Some((x, s.component_mul(&(lp + ld * x)).normalize()))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cast(shape: Shape, p: [f64; 3], d: [f64; 3]) -> Option<(f64, Vector3<f64>)> {
        let (pos, rot) = (Vector3::new(0.0, 0.0, 0.0), Matrix3::identity());
        let ray = (&Vector3::from(p), &Vector3::from(d));
        ray_shape(&shape, [0.0; 2], (&pos, &rot), ray)
    }

    #[test]
    fn rays_hit_each_primitive_where_its_surface_is() {
        let down = [0.0, 0.0, -1.0];
        let (radius, half_length) = (0.5, 1.0);
        let cases = [
            (Shape::Sphere { radius }, 1.5),
            (
                Shape::Capsule {
                    radius,
                    half_length,
                },
                0.5,
            ),
            (
                Shape::Cylinder {
                    radius,
                    half_length,
                },
                1.0,
            ),
            (
                Shape::Box {
                    half: Vector3::new(1.0, 1.0, 0.25),
                },
                1.75,
            ),
            (
                Shape::Ellipsoid {
                    radii: Vector3::new(1.0, 1.0, 0.5),
                },
                1.5,
            ),
            (Shape::Plane, 2.0),
        ];
        for (shape, x) in cases {
            let (hit, normal) = cast(shape, [0.0, 0.0, 2.0], down).expect("a hit");
            assert!((hit - x).abs() < 1e-15, "{shape:?}: {hit}");
            assert!(
                (normal - Vector3::z()).norm() < 1e-15,
                "{shape:?}: {normal}"
            );
            // Away from the shape, or at a plane's back face: a miss.
            assert_eq!(cast(shape, [0.0, 0.0, 2.0], [0.0, 0.0, 1.0]), None);
        }
        // A capsule's side: the normal is radial.
        let capsule = Shape::Capsule {
            radius,
            half_length,
        };
        let (x, n) = cast(capsule, [2.0, 0.0, 0.5], [-1.0, 0.0, -0.1]).unwrap();
        assert!(
            (x - 1.5).abs() < 1e-15 && (n - Vector3::x()).norm() < 1e-15,
            "{x} {n}"
        );
        // From inside, a ray leaves through the far side.
        let (x, n) = cast(Shape::Sphere { radius }, [0.0; 3], [1.0, 0.0, 0.0]).unwrap();
        assert_eq!((x, n), (0.5, Vector3::x()));
    }
}
