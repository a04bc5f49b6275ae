//! Collision detection of the constraint model, as MuJoCo computes it: which
//! geom pairs may touch (fixed when the model is compiled,
//! [`crate::compile::collision_pairs`]), the broad phase ([`Sweep`], then
//! [`apart`]), and the contacts of a pair at a state: one table of
//! colliders indexed by the two geoms' types, one file per collider family
//! (plane.rs, sphere.rs, capsule.rs, box_box.rs, mesh.rs). The smooth model
//! ([`super::contact`]) shares the placed geoms, the broad phase and the
//! candidate pairs; its contact geometry is part of its force law.
//!
//! Conventions (MuJoCo's):
//! - A pair's geoms are ordered by geom type ([`GeomType`]: plane, hfield,
//!   sphere, capsule, ellipsoid, cylinder, box, mesh); geom 1 is the first.
//!   A contact's `frame` has the normal as its first row, pointing from geom
//!   1 to geom 2, and two tangents as its other rows (a right-handed frame);
//!   `dist` is the signed distance between the surfaces along the normal
//!   (negative: penetration); `pos` lies midway between them.
//! - A contact exists while dist < margin + gap; it takes part in the
//!   solver while dist < margin. A pair's margin and gap are the sums of its
//!   geoms' (an explicit pair's own).
//! - Pair parameters at equal priority: condim and friction the larger,
//!   solimp mixed by solmix, solref mixed by solmix when both are time
//!   constants and the smaller of each entry otherwise; else those of the
//!   geom with higher priority. Friction has five components (sliding
//!   twice, torsional, rolling twice).
//! - Colliders work in world coordinates on [`Placed`] geoms (centre and
//!   axes) and push [`Pre`] contacts: normal from geom 1 to geom 2, with an
//!   optional tangent hint for the frame (`make_frame`).
//!
//! Pairs: explicit pairs (MJCF `<pair>`) always; other geoms of different
//! bodies when their bitmasks match (contype of one & conaffinity of the
//! other), unless the bodies are welded together, both static, excluded
//! (`<exclude>`), or parent and child when neither is the world
//! (`filterparent`), or when an explicit pair joins them
//! ([`crate::compile::candidates`]).
//!
//! Supported pairs are those with an entry in [`Colliders::TABLE`]: plane
//! against sphere, capsule, ellipsoid, cylinder, box and mesh (mesh.rs); sphere against sphere,
//! capsule, cylinder and box; capsule against capsule and box; box against
//! box; an ellipsoid against the other primitives, and a cylinder against a
//! capsule, a cylinder or a box (GJK and EPA, convex.rs, with MuJoCo's
//! multi-contact for the pairs with faces or edges, multiccd.rs; the
//! plane-ellipsoid pair by its support point, plane.rs); a sphere, capsule,
//! ellipsoid, cylinder, box or mesh against a mesh (convex.rs on the mesh's
//! hull, multiccd on its sides); a height field against a sphere, capsule,
//! ellipsoid or cylinder (hfield.rs). A model may hold other pairs (a
//! height field against a box or mesh): a step refuses to run while one is
//! within reach ([`super::StepError::NoCollider`]). Each [`Entry`] states
//! what it takes: the general convex collider runs MuJoCo's default
//! settings only (under other `ccd_iterations`, `ccd_tolerance`, with
//! `nativeccd` disabled, or, for the pairs it applies to, with `multiccd`
//! disabled, its pairs count as having no collider), and a height field's
//! pairs only without margin ([`supported`]).
//!
//! # Adding a collider
//!
//! A collider is a function of the [`Collider`] signature in the file of its
//! family: the model's [`Assets`] (meshes and height fields), geoms 1 and 2
//! (shape and world pose, geom 1's type first in [`GeomType`] order), the
//! margin, and the contacts to push to. Write it, then add its [`Entry`]
//! to [`Colliders::TABLE`] at row type 1, column type 2 (the upper
//! triangle): `exact(f)` for an analytic collider, `ccd(f)` for one through
//! GJK and EPA. Nothing else: [`supported`] reads the table, so the
//! pair builder marks the pair supported and the step runs it (and its
//! derivatives, through dual numbers). For example, MuJoCo's
//! cylinder-cylinder would be, in a new `cylinder.rs`:
//!
//! ```ignore
//! pub(super) fn cylinder<T: Real>(
//!     _: &Assets,
//!     (s1, p1): (&Shape, &Placed<T>),
//!     (s2, p2): (&Shape, &Placed<T>),
//!     margin: T,
//!     out: &mut Vec<Pre<T>>,
//! ) {
//!     let ([r1, h1, _], [r2, h2, _]) = (s1.size(), s2.size());
//!     // ... push a Pre { dist, pos, normal (from 1 to 2), tangent } per contact
//! }
//! ```
//!
//! and, in the table's cylinder row, the cylinder column becomes
//! `exact(cylinder::cylinder)`. The general convex collider (convex.rs,
//! GJK in gjk.rs and EPA in epa.rs) reads the shapes through
//! [`Shape::support`]; an entry becomes `ccd(convex::convex)` once its
//! pair's contacts are MuJoCo's.

use nalgebra::{Matrix3, Vector3};

use super::constraint::ConstraintConsts;
use crate::model::hfield::HField;
use crate::model::mesh::Mesh;
use crate::model::{Ccd, PairParams, Shape};
use crate::spatial::{lift, Real, Transform};

mod box_box;
mod capsule;
mod convex;
mod epa;
mod geom;
mod gjk;
mod hfield;
mod mesh;
mod multiccd;
mod plane;
mod record;
mod shape;
mod sphere;
mod sweep;

pub use geom::{apart, GeomFrame};
pub use plane::fixed_sphere;
pub use record::{body_contact_forces, Contact};
pub use sweep::{Sweep, MIN_PAIRS};

pub use crate::model::MINVAL;

/// A geom pair that may touch: indices into the tree's geom frames, in
/// MuJoCo's order (see the module documentation), and whether a collider
/// exists for its shapes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CollisionPair<T: Real> {
    pub geoms: [usize; 2],
    pub params: PairParams<T>,
    pub supported: bool,
}

/// One contact at a state.
#[derive(Clone, Debug, PartialEq)]
pub struct ConstraintContact<T: Real> {
    /// Model indices of geoms 1 and 2, and of their bodies; the index of
    /// their pair in the tree's pairs.
    pub geoms: [usize; 2],
    pub bodies: [usize; 2],
    pub pair: usize,
    pub pos: Vector3<T>,
    /// Rows: normal (from geom 1 to geom 2), first and second tangent.
    pub frame: Matrix3<T>,
    pub dist: T,
    pub params: PairParams<T>,
}

/// MuJoCo's geom types (mjtGeom), in its order: a pair's geom 1 is the one
/// of lower type.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum GeomType {
    Plane,
    Hfield,
    Sphere,
    Capsule,
    Ellipsoid,
    Cylinder,
    Box,
    Mesh,
}

/// The number of geom types.
pub const NTYPES: usize = 8;

/// The model's asset tables that colliders read: its meshes (with their
/// convex hulls) and height fields, indexed by [`Shape::Mesh`] and
/// [`Shape::HField`]. One per model, shared by its trees.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Assets {
    pub meshes: Vec<Mesh>,
    pub hfields: Vec<HField>,
}

/// A collider: the contacts of geom 1 against geom 2 (shape and world
/// pose; geom 1's type first) within `margin`, pushed to the last argument;
/// a mesh's or height field's shape is read from the assets.
pub type Collider<T> = fn(&Assets, (&Shape, &Placed<T>), (&Shape, &Placed<T>), T, &mut Vec<Pre<T>>);

/// An entry of the collision table: the collider and the pairs it takes.
#[derive(Clone, Copy)]
pub struct Entry<T: Real> {
    pub collide: Collider<T>,
    /// Whether it runs MuJoCo's convex collision (GJK and EPA), which
    /// ours runs under MuJoCo's default settings only ([`Ccd::is_default`]).
    pub ccd: bool,
    /// Whether it takes a pair with a margin or gap (else only margin +
    /// gap = 0: see `hfield::hfield`).
    pub margin: bool,
}

/// An analytic collider, for any margin and convex-collision settings.
const fn exact<T: Real>(collide: Collider<T>) -> Option<Entry<T>> {
    Some(Entry {
        collide,
        ccd: false,
        margin: true,
    })
}

/// A collider through the convex collision, for any margin.
const fn ccd<T: Real>(collide: Collider<T>) -> Option<Entry<T>> {
    Some(Entry {
        collide,
        ccd: true,
        margin: true,
    })
}

/// A collider through the convex collision, only without margin or gap.
const fn ccd_bare<T: Real>(collide: Collider<T>) -> Option<Entry<T>> {
    Some(Entry {
        collide,
        ccd: true,
        margin: false,
    })
}

/// MuJoCo's collision function table (mjCOLLISIONFUNC), in the scalar T.
pub struct Colliders<T>(std::marker::PhantomData<T>);

impl<T: Real> Colliders<T> {
    /// Row: geom 1's type; column: geom 2's (the upper triangle, as
    /// [`GeomType`] orders them); None where no collider exists.
    #[rustfmt::skip]
    pub const TABLE: [[Option<Entry<T>>; NTYPES]; NTYPES] = [
        // plane, hfield, sphere, capsule, ellipsoid, cylinder, box, mesh
        [None, None, exact(plane::sphere), exact(plane::capsule), exact(plane::ellipsoid), exact(plane::cylinder), exact(plane::cuboid), exact(mesh::plane)],
        [None, None, ccd_bare(hfield::hfield), ccd_bare(hfield::hfield), ccd_bare(hfield::hfield), ccd_bare(hfield::hfield), None, None],
        [None, None, exact(sphere::sphere), exact(sphere::capsule), ccd(convex::convex), exact(sphere::cylinder), exact(sphere::cuboid), ccd(convex::convex)],
        [None, None, None, exact(capsule::capsule), ccd(convex::convex), ccd(convex::convex), exact(capsule::cuboid), ccd(convex::convex)],
        [None, None, None, None, ccd(convex::convex), ccd(convex::convex), ccd(convex::convex), ccd(convex::convex)],
        [None, None, None, None, None, ccd(convex::convex), ccd(convex::convex), ccd(convex::convex)], // cylinder
        [None, None, None, None, None, None, exact(box_box::cuboid), ccd(convex::convex)],
        [None, None, None, None, None, None, None, ccd(convex::convex)], // mesh
    ];
}

/// The table's entry for geoms of types a <= b, if any.
pub fn entry<T: Real>(a: GeomType, b: GeomType) -> Option<Entry<T>> {
    Colliders::<T>::TABLE[a as usize][b as usize]
}

/// Whether a collider exists for geoms of types a and b (either order)
/// under the convex-collision settings `ccd` and within `margin` (margin
/// plus gap): an entry of the convex collision only under the settings it
/// runs (MuJoCo's defaults, `multiccd` only for the pairs it applies to;
/// others would give other contacts), and one without margin only for a
/// pair without one.
pub fn supported(a: GeomType, b: GeomType, ccd: &Ccd, margin: f64) -> bool {
    let runs = |e: &Entry<f64>| {
        let settings = Ccd {
            multi: true,
            ..*ccd
        }
        .is_default();
        !e.ccd || (settings && (ccd.multi || !multiccd::pairs(a, b)))
    };
    entry::<f64>(a.min(b), a.max(b)).is_some_and(|e| runs(&e) && (margin == 0.0 || e.margin))
}

/// A geom at its world pose: centre and axes (columns), MuJoCo's geom_xpos
/// and geom_xmat.
pub struct Placed<T: Real> {
    pub pos: Vector3<T>,
    pub mat: Matrix3<T>,
}

impl<T: Real> Placed<T> {
    fn of(x: &Transform<T>) -> Self {
        Placed {
            pos: x.trans,
            mat: x.axes(),
        }
    }

    pub(super) fn axis(&self, k: usize) -> Vector3<T> {
        self.mat.column(k).into_owned()
    }
}

/// A contact before its frame is complete: the tangent is a hint (zero for none).
#[derive(Clone, Debug)]
pub struct Pre<T: Real> {
    pub dist: T,
    pub pos: Vector3<T>,
    pub normal: Vector3<T>,
    pub tangent: Vector3<T>,
}

/// Appends the contacts of pair `index` of the constraint model's at the
/// geoms' world poses to `out` (`pre`: [`contact_geometry`]'s scratch).
pub fn collide<T: Real>(
    (consts, index): (&ConstraintConsts<T>, usize),
    geoms: [&GeomFrame<T>; 2],
    poses: [Transform<T>; 2],
    (out, pre): (&mut Vec<ConstraintContact<T>>, &mut Vec<Pre<T>>),
) {
    let pair = &consts.pairs[index];
    let [g1, g2] = geoms;
    let reach = pair.params.margin + pair.params.gap;
    let shapes = (&*consts.assets, [&g1.shape, &g2.shape]);
    for (pos, frame, dist) in contact_geometry(shapes, poses, reach, pre) {
        out.push(ConstraintContact {
            geoms: [g1.geom, g2.geom],
            bodies: [g1.body, g2.body],
            pair: index,
            pos,
            frame,
            dist,
            params: pair.params,
        });
    }
}

/// The point, frame and distance (see [`ConstraintContact`]) of each contact
/// of two rank-ordered shapes (meshes and height fields in `assets`) at
/// their world poses, within `reach`; `pre` is scratch, kept by the caller
/// so that repeated calls do not allocate.
pub fn contact_geometry<'a, T: Real>(
    (assets, shapes): (&Assets, [&Shape; 2]),
    poses: [Transform<T>; 2],
    reach: f64,
    pre: &'a mut Vec<Pre<T>>,
) -> impl Iterator<Item = (Vector3<T>, Matrix3<T>, T)> + 'a {
    let (p1, p2) = (Placed::of(&poses[0]), Placed::of(&poses[1]));
    pre.clear();
    if let Some(e) = entry(shapes[0].kind(), shapes[1].kind()) {
        (e.collide)(assets, (shapes[0], &p1), (shapes[1], &p2), lift(reach), pre);
    }
    pre.drain(..)
        .map(|c| (c.pos, make_frame(c.normal, c.tangent), c.dist))
}

/// MuJoCo's contact frame from a normal and an optional tangent hint: the
/// hint (else world y, or world z when the normal is close to y) made
/// orthogonal to the normal, and their cross product.
pub(crate) fn make_frame<T: Real>(normal: Vector3<T>, hint: Vector3<T>) -> Matrix3<T> {
    let (n, _) = normalize(normal);
    let half: T = lift(0.5);
    let mut y = hint;
    if y.norm_squared() < lift(0.25) {
        y = if n.y < half && n.y > -half {
            Vector3::y()
        } else {
            Vector3::z()
        };
    }
    let (y, _) = normalize(y - n * n.dot(&y));
    let z = n.cross(&y);
    Matrix3::from_rows(&[n.transpose(), y.transpose(), z.transpose()])
}

/// MuJoCo's mju_normalize3: the unit vector and the length; (1, 0, 0) for a
/// vector shorter than mjMINVAL.
pub(crate) fn normalize<T: Real>(v: Vector3<T>) -> (Vector3<T>, T) {
    let len = (v.x * v.x + v.y * v.y + v.z * v.z).sqrt();
    if len < lift(MINVAL) {
        (Vector3::x(), len)
    } else {
        (v * (T::one() / len), len)
    }
}

pub(super) fn clip<T: Real>(x: T, lo: T, hi: T) -> T {
    if x < lo {
        lo
    } else if x > hi {
        hi
    } else {
        x
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_table_is_upper_triangular_and_supported_reads_it() {
        let types = [
            GeomType::Plane,
            GeomType::Hfield,
            GeomType::Sphere,
            GeomType::Capsule,
            GeomType::Ellipsoid,
            GeomType::Cylinder,
            GeomType::Box,
            GeomType::Mesh,
        ];
        for (i, &a) in types.iter().enumerate() {
            assert_eq!(a as usize, i);
            for &b in &types[..i] {
                assert!(entry::<f64>(a, b).is_none(), "{a:?} {b:?}");
                assert_eq!(
                    supported(a, b, &Ccd::default(), 0.0),
                    supported(b, a, &Ccd::default(), 0.0)
                );
            }
        }
        let count = types
            .iter()
            .flat_map(|&a| types.iter().map(move |&b| (a, b)))
            .filter(|&(a, b)| a <= b && supported(a, b, &Ccd::default(), 0.0))
            .count();
        assert_eq!(count, 31);
        let (h, ccd) = (GeomType::Hfield, Ccd::default());
        assert!(supported(GeomType::Capsule, h, &ccd, 0.0));
        assert!(!supported(h, GeomType::Capsule, &ccd, 0.01));
        assert!(!supported(h, GeomType::Box, &ccd, 0.0));
        assert!(!supported(h, GeomType::Plane, &ccd, 0.0));
        assert!(supported(
            GeomType::Box,
            GeomType::Capsule,
            &Ccd::default(),
            0.0
        ));
        assert!(supported(
            GeomType::Ellipsoid,
            GeomType::Capsule,
            &Ccd::default(),
            0.0
        ));
        assert!(supported(
            GeomType::Cylinder,
            GeomType::Capsule,
            &Ccd::default(),
            0.0
        ));
        assert!(supported(
            GeomType::Plane,
            GeomType::Ellipsoid,
            &Ccd::default(),
            0.0
        ));
        assert!(supported(
            GeomType::Plane,
            GeomType::Mesh,
            &Ccd::default(),
            0.0
        ));
    }

    #[test]
    fn frames_are_mujocos() {
        // No hint: the tangent is world y made orthogonal to the normal, or world z
        // when the normal is close to y; rows orthonormal and right-handed.
        let n = Vector3::new(0.0, 0.0, 2.0);
        let f: Matrix3<f64> = make_frame(n, Vector3::zeros());
        assert_eq!(
            f,
            Matrix3::new(0.0, 0.0, 1.0, 0.0, 1.0, 0.0, -1.0, 0.0, 0.0)
        );
        let f: Matrix3<f64> = make_frame(Vector3::new(0.1, 0.9, 0.0), Vector3::zeros());
        let n = Vector3::new(0.1, 0.9, 0.0).normalize();
        assert!((f.row(1).transpose() - (Vector3::z())).norm() < 1e-15);
        assert!((f.row(0).transpose() - n).norm() < 1e-15);
        // A hint (a capsule's axis) is made orthogonal to the normal.
        let f: Matrix3<f64> = make_frame(Vector3::z(), Vector3::new(1.0, 0.0, 1.0));
        assert!((f.row(1).transpose() - Vector3::x()).norm() < 1e-15);
        assert!((f * f.transpose() - Matrix3::identity()).norm() < 1e-15);
        assert!((f.determinant() - 1.0).abs() < 1e-15);
    }

    #[test]
    fn convex_pairs_collide_only_under_the_default_ccd_settings() {
        let (e, c, b) = (GeomType::Ellipsoid, GeomType::Capsule, GeomType::Box);
        for other in [
            Ccd {
                native: false,
                ..Ccd::default()
            },
            Ccd {
                iterations: 50,
                ..Ccd::default()
            },
            Ccd {
                tolerance: 1e-8,
                ..Ccd::default()
            },
        ] {
            assert!(!supported(e, c, &other, 0.0), "{other:?}");
            assert!(supported(b, c, &other, 0.0), "{other:?}");
        }
        // multiccd matters to the pairs with faces or edges only.
        let single = Ccd {
            multi: false,
            ..Ccd::default()
        };
        assert!(supported(e, c, &single, 0.0));
        assert!(!supported(GeomType::Cylinder, b, &single, 0.0));
        assert!(!supported(GeomType::Cylinder, c, &single, 0.0));
    }
}
