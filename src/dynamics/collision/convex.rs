//! MuJoCo's general convex collider (`mjc_Convex` with its native CCD:
//! engine_collision_convex.c and `mjc_ccd` of engine_collision_gjk.c, as
//! MuJoCo 4.0.0 runs them), for the pairs MuJoCo routes to it among the
//! primitives and meshes: an ellipsoid against a sphere, a capsule, an
//! ellipsoid, a cylinder, a box or a mesh, and a sphere against a mesh (one
//! contact; a mesh is its hull, [`Mesh::support`]), and a cylinder against
//! a capsule, a cylinder or a box and a capsule, cylinder, box or mesh
//! against a mesh, where touching faces or edges add MuJoCo's multiccd
//! contacts (up to four, [`super::multiccd`]; all share the first one's
//! frame). Between boxes and meshes without margin (MuJoCo's discrete
//! pairs, [`Body::discrete`]) GJK runs without tolerance and EPA until a
//! support vertex repeats.
//!
//! Each geom is a [`Body`]: its shape at its world pose, grown by half the
//! pair margin (so the bodies overlap exactly when the geoms are within the
//! margin). As MuJoCo 4.0.0 does (measured against its binary: 38 of 40
//! sphere-ellipsoid states to 1e-9 this way, 24 with the margin inside the
//! support), a body is first shrunk to its core (a sphere to its centre, a
//! capsule to its segment, every body by its half margin) and GJK measures
//! the distance of the cores when a core radius is left: a shallow contact
//! is that distance less the radii. Otherwise GJK finds a simplex holding the
//! origin and EPA the penetration ([`super::epa`]). The contact lies midway
//! between the witness points x1 (on geom 1) and x2 (on geom 2); its normal
//! is x1 - x2 normalised (from geom 1 into geom 2 when they overlap), its
//! distance the margin plus the signed distance of the witness points.
//!
//! Accuracy: GJK stops within ccd_tolerance (1e-6) of the distance and EPA
//! after at most ccd_iterations (35) expansions, which on smooth shapes
//! often ends before the tolerance (a deep contact's normal may then be off
//! by a few 1e-2 rad, as MuJoCo's is). Contacts equal those of MuJoCo
//! 4.0.0's mj_forward to 1e-9 in most states (harness/tests/test_convex.py:
//! 23 to 38 of 40 per pair); in the others the iterations take another path
//! (GJK's stopping test is decided at the level of rounding, and EPA's
//! budget then ends elsewhere) and agree only to the iterations' accuracy. Derivatives are those of the iterations (dual
//! numbers), not yet the implicit ones of the converged geometry. Settings
//! are MuJoCo's defaults (ccd_iterations 35, ccd_tolerance 1e-6, native
//! CCD).

use nalgebra::{Matrix3, Vector3};

use super::epa::penetration;
use super::gjk::{gjk, Vertex};
use super::multiccd;
use super::{normalize, Assets, Placed, Pre};
use crate::model::mesh::Mesh;
use crate::model::{Shape, CCD_ITERATIONS, CCD_TOLERANCE};
use crate::spatial::{lift, lift_vector, Real};

/// How GJK sees a geom: whole, or a sphere as its centre and a capsule as
/// its segment (their radii added back to the distance).
#[derive(Clone, Copy, PartialEq)]
enum Core {
    Whole,
    Point,
    Segment,
}

/// A convex geom for GJK and EPA (MuJoCo's mjCCDObj): shape, world pose,
/// and the margin that grows it by half along every direction.
#[derive(Clone, Copy)]
pub(super) struct Body<'a, T: Real> {
    pub shape: &'a Shape,
    pub pos: Vector3<T>,
    pub mat: Matrix3<T>,
    pub margin: T,
    core: Core,
    /// A height field's prism instead of the shape (hfield.rs): its six
    /// vertices in the working frame (pos and mat unused).
    prism: Option<&'a [Vector3<T>; 6]>,
    /// A mesh shape's mesh, whose hull is the body.
    pub mesh: Option<&'a Mesh>,
}

impl<'a, T: Real> Body<'a, T> {
    /// The geom `shape` at `pos`, `mat`, grown by half of `margin`.
    pub fn placed(shape: &'a Shape, (pos, mat): (Vector3<T>, Matrix3<T>), margin: T) -> Self {
        Body {
            shape,
            pos,
            mat,
            margin,
            core: Core::Whole,
            prism: None,
            mesh: None,
        }
    }

    /// The body with its mesh from `assets`, when its shape is a mesh.
    pub fn with_assets(self, assets: &'a Assets) -> Self {
        let mesh = match *self.shape {
            Shape::Mesh { mesh } => Some(&assets.meshes[mesh]),
            _ => None,
        };
        Body { mesh, ..self }
    }

    /// A height field's prism (`shape` the field's), as hfield.rs makes it.
    pub fn prism(shape: &'a Shape, vertices: &'a [Vector3<T>; 6]) -> Self {
        Body {
            prism: Some(vertices),
            ..Body::placed(shape, (Vector3::zeros(), Matrix3::identity()), T::zero())
        }
    }

    /// The geom's centre, where GJK starts (a prism's centroid).
    pub fn centre(&self) -> Vector3<T> {
        match self.prism {
            Some(p) => super::hfield::centroid(p),
            None => self.pos,
        }
    }

    /// The point farthest along the unit world direction `dir`, and
    /// MuJoCo's index of the shape vertex there (see
    /// [`Vertex`](super::gjk::Vertex)): a box corner's sign bits (x 1, y 2,
    /// z 4, set on the + side), a cylinder's cap (0 top, 1 bottom), a mesh
    /// vertex's index; -1 for other shapes, cores and prisms.
    pub fn support(&self, dir: &Vector3<T>) -> (Vector3<T>, i32) {
        if let Some(p) = self.prism {
            return (super::hfield::prism_support(p, dir), -1);
        }
        let [_, half_length, _] = self.shape.size();
        match self.core {
            Core::Point => (self.pos, -1),
            Core::Segment => {
                let axis = self.mat.column(2).into_owned();
                let h = if axis.dot(dir) >= T::zero() {
                    half_length
                } else {
                    -half_length
                };
                (self.pos + axis * lift::<T>(h), -1)
            }
            Core::Whole => {
                let (mut p, index) = if let Shape::Sphere { radius } = self.shape {
                    (dir * lift::<T>(*radius) + self.pos, -1)
                } else {
                    let local = self.mat.tr_mul(dir);
                    let (s, index) = self.local_support(&local);
                    (self.mat * s + self.pos, index)
                };
                if self.margin > T::zero() {
                    p += dir * (lift::<T>(0.5) * self.margin);
                }
                (p, index)
            }
        }
    }

    /// The whole shape's support point and vertex index along the geom-frame
    /// direction `local`.
    fn local_support(&self, local: &Vector3<T>) -> (Vector3<T>, i32) {
        if let Some(mesh) = self.mesh {
            return match mesh.support_vertex(local) {
                Some(i) => (lift_vector(&mesh.vertices[i]), i as i32),
                None => (Vector3::zeros(), -1),
            };
        }
        let s = self.shape.support(local).unwrap_or_else(Vector3::zeros);
        let plus = |x: T| x >= T::zero();
        let index = match self.shape {
            Shape::Box { .. } => (0..3).filter(|&k| plus(local[k])).map(|k| 1 << k).sum(),
            Shape::Cylinder { .. } => i32::from(!plus(local.z)),
            _ => -1,
        };
        (s, index)
    }

    /// Whether MuJoCo counts the body discrete (`discreteGeoms`): a box, a
    /// mesh or a height-field prism without margin, whose GJK and EPA run
    /// to exact convergence.
    pub fn discrete(&self) -> bool {
        self.margin == T::zero()
            && (self.prism.is_some()
                || matches!(self.shape, Shape::Box { .. } | Shape::Mesh { .. }))
    }

    /// The radius GJK's core leaves out: a sphere's or capsule's radius,
    /// and half the margin of every body.
    fn core_radius(&self) -> T {
        let [radius, _, _] = self.shape.size();
        let half_margin = lift::<T>(0.5) * self.margin;
        match self.shape {
            Shape::Sphere { .. } | Shape::Capsule { .. } => lift::<T>(radius) + half_margin,
            _ => half_margin,
        }
    }

    /// The body without its core radius: a sphere's centre, a capsule's
    /// segment, any other shape bare (no margin).
    fn shrunk(&self) -> Body<'_, T> {
        let core = match self.shape {
            Shape::Sphere { .. } => Core::Point,
            Shape::Capsule { .. } => Core::Segment,
            _ => Core::Whole,
        };
        Body {
            core,
            margin: T::zero(),
            ..*self
        }
    }
}

/// The collider of the table: see the module documentation.
pub(super) fn convex<T: Real>(
    assets: &Assets,
    (s1, p1): (&Shape, &Placed<T>),
    (s2, p2): (&Shape, &Placed<T>),
    margin: T,
    out: &mut Vec<Pre<T>>,
) {
    let body =
        |shape, p: &Placed<T>| Body::placed(shape, (p.pos, p.mat), margin).with_assets(assets);
    let (a, b) = (body(s1, p1), body(s2, p2));
    let Some(found) = witnesses(&a, &b) else {
        return;
    };
    if found.dist >= T::zero() {
        return;
    }
    let clipped = match found.face {
        Some(face) if multiccd::pairs(s1.kind(), s2.kind()) => {
            multiccd::contacts((&a, &b), &face, (found.x1, found.x2))
        }
        _ => vec![],
    };
    let Some(first) = clipped.first() else {
        out.push(single(found.x1, found.x2, found.dist, margin));
        return;
    };
    // MuJoCo's frame is the first clipped pair's; a lone clipped pair keeps
    // the distance GJK or EPA found.
    let normal = normalize(first.x1 - first.x2).0;
    let alone = clipped.len() == 1;
    out.extend(clipped.iter().map(|w| Pre {
        dist: margin + if alone { found.dist } else { w.dist },
        pos: (w.x1 + w.x2) * lift::<T>(0.5),
        normal,
        tangent: Vector3::zeros(),
    }));
}

/// The contact of witness points x1, x2 at signed distance `dist`: midway,
/// normal x1 - x2.
fn single<T: Real>(x1: Vector3<T>, x2: Vector3<T>, dist: T, margin: T) -> Pre<T> {
    Pre {
        dist: margin + dist,
        pos: (x1 + x2) * lift::<T>(0.5),
        normal: normalize(x1 - x2).0,
        tangent: Vector3::zeros(),
    }
}

/// One contact of the bodies (MuJoCo's `mjc_penetration` over `mjc_ccd`),
/// if they overlap.
pub(super) fn contact<T: Real>(a: &Body<T>, b: &Body<T>, margin: T) -> Option<Pre<T>> {
    let Witnesses { x1, x2, dist, .. } = witnesses(a, b)?;
    (dist < T::zero()).then(|| single(x1, x2, dist, margin))
}

/// What `mjc_ccd` recovers: the witness points on the bodies, their signed
/// distance, and the simplex face they lie on (EPA's nearest face, or GJK's
/// simplex of the cores when it measured the distance) for multiccd.
struct Witnesses<T: Real> {
    x1: Vector3<T>,
    x2: Vector3<T>,
    dist: T,
    face: Option<[Vertex<T>; 3]>,
}

/// The witness points on the bodies and their signed distance, when GJK
/// or EPA recover them (MuJoCo's `mjc_ccd` with no distance cutoff).
fn witnesses<T: Real>(a: &Body<T>, b: &Body<T>) -> Option<Witnesses<T>> {
    let (r1, r2) = (a.core_radius(), b.core_radius());
    if r1 > T::zero() || r2 > T::zero() {
        let shallow = gjk(
            (&a.shrunk(), &b.shrunk()),
            r1 + r2,
            CCD_TOLERANCE,
            CCD_ITERATIONS,
        );
        if shallow.dist > lift(CCD_TOLERANCE) {
            let n = normalize(shallow.x2 - shallow.x1).0;
            let dist = shallow.dist - (r1 + r2);
            return (dist <= T::zero()).then(|| Witnesses {
                x1: shallow.x1 + n * r1,
                x2: shallow.x2 - n * r2,
                dist,
                face: simplex_face(&shallow.simplex),
            });
        }
    }
    let found = gjk((a, b), T::zero(), CCD_TOLERANCE, CCD_ITERATIONS);
    if found.dist > lift(CCD_TOLERANCE) || found.simplex.len() < 2 || found.separated {
        return None;
    }
    let p = penetration(&found.simplex, (a, b), CCD_TOLERANCE, CCD_ITERATIONS)?;
    Some(Witnesses {
        x1: p.x1,
        x2: p.x2,
        dist: p.dist,
        face: Some(p.face),
    })
}

/// GJK's simplex as a face (MuJoCo's `gjk_simplex_to_epa`): its first
/// three vertices, the first repeated where there are fewer.
fn simplex_face<T: Real>(s: &[Vertex<T>]) -> Option<[Vertex<T>; 3]> {
    let at = |k: usize| s[if s.len() > k { k } else { 0 }];
    (!s.is_empty()).then(|| [s[0], at(1), at(2)])
}

#[cfg(test)]
mod tests {
    use super::*;

    fn contacts(
        s1: Shape,
        pos1: Vector3<f64>,
        s2: Shape,
        pos2: Vector3<f64>,
        margin: f64,
    ) -> Vec<Pre<f64>> {
        let place = |pos| Placed {
            pos,
            mat: Matrix3::identity(),
        };
        let mut out = vec![];
        convex(
            &Assets::default(),
            (&s1, &place(pos1)),
            (&s2, &place(pos2)),
            margin,
            &mut out,
        );
        out
    }

    #[test]
    fn a_sphere_on_a_round_ellipsoid_is_gjks_distance_less_the_radius() {
        // Centres 0.49 apart, radii 0.2 and 0.3: 0.01 deep along the centre line,
        // the normal from the sphere (geom 1) to the ellipsoid.
        let ball = Shape::Ellipsoid {
            radii: Vector3::new(0.3, 0.3, 0.3),
        };
        let dir = Vector3::new(2.0, -3.0, 6.0) / 7.0;
        let c = contacts(
            Shape::Sphere { radius: 0.2 },
            dir * 0.49,
            ball,
            Vector3::zeros(),
            0.0,
        );
        assert_eq!(c.len(), 1);
        assert!((c[0].dist + 0.01).abs() < 1e-6, "{}", c[0].dist);
        assert!((c[0].normal + dir).norm() < 1e-5, "{}", c[0].normal);
        assert!((c[0].pos - dir * 0.295).norm() < 1e-5, "{}", c[0].pos);
        // Apart by 0.01: none, unless the margin reaches.
        let far = |margin| {
            contacts(
                Shape::Sphere { radius: 0.2 },
                dir * 0.51,
                ball,
                Vector3::zeros(),
                margin,
            )
        };
        assert!(far(0.0).is_empty());
        let c = far(0.02);
        assert_eq!(c.len(), 1);
        assert!((c[0].dist - 0.01).abs() < 1e-6, "{}", c[0].dist);
    }

    #[test]
    fn an_ellipsoid_on_a_box_face_takes_the_face_normal() {
        // The ellipsoid's lowest point 0.01 below the box's top face (z = 0.1).
        let slab = Shape::Box {
            half: Vector3::new(1.0, 1.0, 0.1),
        };
        let egg = Shape::Ellipsoid {
            radii: Vector3::new(0.1, 0.2, 0.3),
        };
        let c = contacts(
            egg,
            Vector3::new(0.1, 0.2, 0.39),
            slab,
            Vector3::zeros(),
            0.0,
        );
        assert_eq!(c.len(), 1);
        assert!((c[0].dist + 0.01).abs() < 1e-6, "{}", c[0].dist);
        assert!(
            (c[0].normal + Vector3::z()).norm() < 1e-6,
            "{}",
            c[0].normal
        );
        assert!(
            (c[0].pos - Vector3::new(0.1, 0.2, 0.095)).norm() < 1e-3,
            "{}",
            c[0].pos
        );
        let apart = contacts(
            egg,
            Vector3::new(0.1, 0.2, 0.41),
            slab,
            Vector3::zeros(),
            0.0,
        );
        assert!(apart.is_empty());
    }

    #[test]
    fn deep_round_ellipsoids_stay_near_the_exact_contact() {
        // Two balls 0.07 deep: EPA ends at its iteration budget near the exact
        // depth and normal (the centre line).
        let ball = |r| Shape::Ellipsoid {
            radii: Vector3::new(r, r, r),
        };
        let centre = Vector3::new(0.1, 0.05, 0.2);
        let c = contacts(ball(0.2), Vector3::zeros(), ball(0.1), centre, 0.0);
        assert_eq!(c.len(), 1);
        let exact = centre.norm() - 0.3;
        assert!((c[0].dist - exact).abs() < 1e-4, "{} {exact}", c[0].dist);
        assert!(
            (c[0].normal - centre.normalize()).norm() < 0.05,
            "{}",
            c[0].normal
        );
    }
}
