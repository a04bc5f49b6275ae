//! What the colliders and the broad phase need of a shape, in its geom
//! frame (centre at the origin, capsules and cylinders along z, a plane the
//! z = 0 plane with its normal +z): its type, MuJoCo's size triple, its
//! bounding radius and its support function.

use nalgebra::Vector3;

use super::GeomType;
use crate::model::hfield::HField;
use crate::model::Shape;
use crate::model::MINVAL;
use crate::spatial::{lift, Real};

impl Shape {
    /// The geom type of the collision table.
    pub fn kind(&self) -> GeomType {
        match self {
            Shape::Plane => GeomType::Plane,
            Shape::Sphere { .. } => GeomType::Sphere,
            Shape::Capsule { .. } => GeomType::Capsule,
            Shape::Ellipsoid { .. } => GeomType::Ellipsoid,
            Shape::Cylinder { .. } => GeomType::Cylinder,
            Shape::Box { .. } => GeomType::Box,
            Shape::Mesh { .. } => GeomType::Mesh,
            Shape::HField { .. } => GeomType::Hfield,
        }
    }

    /// MuJoCo's geom_size: a sphere's [radius, 0, 0], a capsule's or
    /// cylinder's [radius, half length, 0], a box's half-sizes, an
    /// ellipsoid's radii; zero for a plane (infinite here) and for a mesh
    /// (whose extent is its [`Mesh::aabb`](crate::model::mesh::Mesh)).
    pub fn size(&self) -> [f64; 3] {
        match *self {
            Shape::Plane | Shape::Mesh { .. } => [0.0; 3],
            Shape::Sphere { radius } => [radius, 0.0, 0.0],
            Shape::Capsule {
                radius,
                half_length,
            }
            | Shape::Cylinder {
                radius,
                half_length,
            } => [radius, half_length, 0.0],
            Shape::Box { half } => half.into(),
            Shape::Ellipsoid { radii } => radii.into(),
            Shape::HField { size, .. } => HField::geom_size(&size),
        }
    }

    /// The radius of a sphere about the centre that holds the shape
    /// (MuJoCo's geom_rbound; infinite for a plane). A cylinder's is
    /// radius + half length, a looser bound than MuJoCo's hypotenuse. A
    /// mesh's needs its mesh ([`Spec::rbound`](crate::model::Spec::rbound));
    /// without it, infinite.
    pub fn rbound(&self) -> f64 {
        match *self {
            Shape::Plane | Shape::Mesh { .. } => f64::INFINITY,
            Shape::Sphere { radius } => radius,
            Shape::Capsule {
                radius,
                half_length,
            }
            | Shape::Cylinder {
                radius,
                half_length,
            } => radius + half_length,
            Shape::Box { half } => half.norm(),
            Shape::Ellipsoid { radii } => radii.max(),
            Shape::HField { size, .. } => HField::rbound(&size),
        }
    }

    /// The support function: a point of the shape farthest along the unit
    /// direction `dir` (geom frame), as MuJoCo's convex collider computes
    /// it (mjc_*Support, in its arithmetic so that GJK and EPA take its
    /// branches): ties between faces go to the + side, a cylinder's axial
    /// direction to its cap's centre, an ellipsoid's vanishing one to +x.
    /// None for a plane, which has none, and for a mesh, whose support is
    /// its mesh's ([`Mesh::support`](crate::model::mesh::Mesh::support)).
    pub fn support<T: Real>(&self, dir: &Vector3<T>) -> Option<Vector3<T>> {
        let side = |x: T, h: f64| if x >= T::zero() { lift(h) } else { lift(-h) };
        Some(match *self {
            Shape::Plane | Shape::Mesh { .. } | Shape::HField { .. } => return None,
            Shape::Sphere { radius } => dir * lift::<T>(radius),
            Shape::Capsule {
                radius,
                half_length,
            } => {
                let mut s = dir * lift::<T>(radius);
                s.z += side(dir.z, half_length);
                s
            }
            Shape::Cylinder {
                radius,
                half_length,
            } => {
                let n2 = dir.x * dir.x + dir.y * dir.y;
                let scale = if n2 >= lift(MINVAL * MINVAL) {
                    lift::<T>(radius) / n2.sqrt()
                } else {
                    T::zero()
                };
                Vector3::new(dir.x * scale, dir.y * scale, side(dir.z, half_length))
            }
            Shape::Box { half } => Vector3::from_fn(|i, _| side(dir[i], half[i])),
            Shape::Ellipsoid { radii } => {
                // The point x = R^2 d / |R d| of the ellipsoid with radii R.
                let r: Vector3<T> = radii.map(lift);
                let scaled = dir.component_mul(&r);
                let n2 = scaled.norm_squared();
                if n2 < lift(MINVAL * MINVAL) {
                    return Some(Vector3::new(r.x, T::zero(), T::zero()));
                }
                let inv = T::one() / n2.sqrt();
                Vector3::from_fn(|i, _| scaled[i] * (inv * r[i]))
            }
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every shape but the plane, and points on its surface.
    fn shapes() -> [Shape; 5] {
        [
            Shape::Sphere { radius: 0.3 },
            Shape::Capsule {
                radius: 0.1,
                half_length: 0.4,
            },
            Shape::Cylinder {
                radius: 0.2,
                half_length: 0.5,
            },
            Shape::Box {
                half: Vector3::new(0.1, 0.2, 0.3),
            },
            Shape::Ellipsoid {
                radii: Vector3::new(0.1, 0.2, 0.3),
            },
        ]
    }

    /// The distance of `p` from the shape's surface (negative inside).
    fn surface_distance(shape: &Shape, p: &Vector3<f64>) -> f64 {
        match *shape {
            Shape::Sphere { radius } => p.norm() - radius,
            Shape::Capsule {
                radius,
                half_length,
            } => {
                let z = p.z.clamp(-half_length, half_length);
                (p - Vector3::new(0.0, 0.0, z)).norm() - radius
            }
            Shape::Cylinder {
                radius,
                half_length,
            } => (p.xy().norm() - radius).max(p.z.abs() - half_length),
            Shape::Box { half } => (p.abs() - half).max(),
            Shape::Ellipsoid { radii } => p.component_div(&radii).norm() - 1.0,
            Shape::Plane => p.z,
            Shape::Mesh { .. } | Shape::HField { .. } => {
                unreachable!("the test shapes are primitives")
            }
        }
    }

    #[test]
    fn the_support_point_lies_on_the_surface_and_farthest_along_the_direction() {
        let dirs = [
            Vector3::new(1.0, 0.0, 0.0),
            Vector3::new(0.0, -2.0, 0.0),
            Vector3::new(0.0, 0.0, 0.5),
            Vector3::new(0.3, -0.4, 0.8),
            Vector3::new(-1.0, 1.0, -1.0),
        ];
        // Sampled surface points: none may reach farther along a direction.
        let samples: Vec<Vector3<f64>> = (0..400)
            .map(|k| {
                let (a, b) = (k as f64 * 0.37, k as f64 * 0.11);
                Vector3::new(a.cos() * b.sin(), a.sin() * b.sin(), b.cos())
            })
            .collect();
        for shape in shapes() {
            for d in &dirs {
                let d = &d.normalize();
                let s = shape.support(d).expect("bounded");
                let reach = d.dot(&s);
                assert!(surface_distance(&shape, &s).abs() < 1e-15, "{shape:?} {d}");
                for u in &samples {
                    let far = shape.support(&u.normalize()).expect("bounded");
                    assert!(d.dot(&far) <= reach + 1e-15, "{shape:?} {d} {u}");
                }
                // Within the bounding sphere.
                assert!(s.norm() <= shape.rbound() + 1e-15);
            }
        }
        assert_eq!(Shape::Plane.support(&Vector3::<f64>::z()), None);
    }

    #[test]
    fn supports_are_those_of_the_shapes() {
        let d = Vector3::new(0.0, 0.6, 0.8);
        let at = |s: Shape| s.support(&d).expect("bounded");
        assert!((at(Shape::Sphere { radius: 0.5 }) - Vector3::new(0.0, 0.3, 0.4)).norm() < 1e-15);
        let capsule = Shape::Capsule {
            radius: 0.5,
            half_length: 1.0,
        };
        assert!((at(capsule) - Vector3::new(0.0, 0.3, 1.4)).norm() < 1e-15);
        let cylinder = Shape::Cylinder {
            radius: 0.5,
            half_length: 1.0,
        };
        assert_eq!(at(cylinder), Vector3::new(0.0, 0.5, 1.0));
        let cube = Shape::Box {
            half: Vector3::new(0.1, 0.2, 0.3),
        };
        assert_eq!(at(cube), Vector3::new(0.1, 0.2, 0.3));
        let ball = Shape::Ellipsoid {
            radii: Vector3::new(0.5, 0.5, 0.5),
        };
        assert!((at(ball) - Vector3::new(0.0, 0.3, 0.4)).norm() < 1e-15);
        // A vanishing direction gives a point all the same: an ellipsoid's +x,
        // a cylinder's cap centre along the axis.
        let zero = Vector3::<f64>::zeros();
        assert_eq!(ball.support(&zero), Some(Vector3::new(0.5, 0.0, 0.0)));
        assert_eq!(
            cylinder.support(&Vector3::z()),
            Some(Vector3::new(0.0, 0.0, 1.0))
        );
    }

    #[test]
    fn bounding_radii_are_mujocos() {
        assert_eq!(Shape::Plane.rbound(), f64::INFINITY);
        assert_eq!(Shape::Sphere { radius: 0.3 }.rbound(), 0.3);
        let capsule = Shape::Capsule {
            radius: 0.1,
            half_length: 0.4,
        };
        assert_eq!(capsule.rbound(), 0.5);
        let cube = Shape::Box {
            half: Vector3::new(0.3, 0.4, 1.2),
        };
        assert!((cube.rbound() - 1.3).abs() < 1e-15);
        let e = Shape::Ellipsoid {
            radii: Vector3::new(0.1, 0.5, 0.3),
        };
        assert_eq!(e.rbound(), 0.5);
    }
}
