//! Collision detection of the constraint model, as MuJoCo computes it: which
//! geom pairs may touch (fixed when the model is built), and the contacts of
//! a pair at a state (the primitive colliders, by shape).
//!
//! Conventions (MuJoCo's):
//! - A pair's geoms are ordered by shape (plane, sphere, capsule, ellipsoid,
//!   cylinder, box); geom 1 is the first. A contact's `frame` has the normal
//!   as its first row, pointing from geom 1 to geom 2, and two tangents as
//!   its other rows (a right-handed frame); `dist` is the signed distance
//!   between the surfaces along the normal (negative: penetration); `pos`
//!   lies midway between them.
//! - A contact exists while dist < margin + gap; it takes part in the
//!   solver while dist < margin. A pair's margin and gap are the sums of its
//!   geoms' (an explicit pair's own).
//! - Pair parameters at equal priority: condim and friction the larger,
//!   solimp mixed by solmix, solref mixed by solmix when both are time
//!   constants and the smaller of each entry otherwise; else those of the
//!   geom with higher priority. Friction has five components (sliding
//!   twice, torsional, rolling twice).
//!
//! Pairs: explicit pairs (MJCF `<pair>`) always; other geoms of different
//! bodies when their bitmasks match (contype of one & conaffinity of the
//! other), unless the bodies are welded together, both static, excluded
//! (`<exclude>`), or parent and child when neither is the world
//! (`filterparent`), or when an explicit pair joins them.
//!
//! Supported shapes: plane against sphere, capsule, cylinder and box; sphere
//! against sphere, capsule, cylinder and box; capsule against capsule and box
//! ([`super::capsule_box`]); box against box ([`super::box_box`]). A model
//! may hold other pairs (ellipsoids, cylinders with capsules, cylinders or
//! boxes): a step refuses to run while one of them is
//! within reach ([`super::StepError::NoCollider`]).

use nalgebra::{Matrix3, Vector3};

use super::contact::GeomFrame;
use crate::model::constraint::solmix;
use crate::model::{PairParams, Param, Shape, SolParams, Spec};
use crate::spatial::{lift, Real, Transform};

/// MuJoCo's mjMINVAL: lengths below it count as zero.
pub const MINVAL: f64 = 1e-15;

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

/// Shape order of MuJoCo's collision table; None for shapes without one.
fn rank(shape: &Shape) -> usize {
    match shape {
        Shape::Plane => 0,
        Shape::Sphere { .. } => 2,
        Shape::Capsule { .. } => 3,
        Shape::Ellipsoid { .. } => 4,
        Shape::Cylinder { .. } => 5,
        Shape::Box { .. } => 6,
    }
}

/// Whether a primitive collider exists for shapes of these ranks (a <= b).
fn supported(a: usize, b: usize) -> bool {
    matches!(
        (a, b),
        (0, 2 | 3 | 5 | 6) | (2, 2 | 3 | 5 | 6) | (3, 3 | 6) | (6, 6)
    )
}

/// A geom's friction, solref and solimp in scalar T, lifted as its named
/// parameters (see [`Tree::build_with`](super::Tree::build_with)).
fn geom_params<T: Real>(
    spec: &Spec,
    g: usize,
    lift_param: &impl Fn(Param, usize, f64) -> T,
) -> ([T; 3], SolParams<T>) {
    let geom = &spec.geoms[g];
    let friction = std::array::from_fn(|k| lift_param(Param::GeomFriction(g), k, geom.friction[k]));
    let sol = geom.contact.sol.lift(
        |k, x| lift_param(Param::GeomSolref(g), k, x),
        |k, x| lift_param(Param::GeomSolimp(g), k, x),
    );
    (friction, sol)
}

/// The parameters of a pair from its geoms' (see the module documentation).
fn mixed<T: Real>(
    spec: &Spec,
    [a, b]: [usize; 2],
    lift_param: &impl Fn(Param, usize, f64) -> T,
) -> PairParams<T> {
    let (ca, cb) = (&spec.geoms[a].contact, &spec.geoms[b].contact);
    let ((fa, sa), (fb, sb)) = (
        geom_params(spec, a, lift_param),
        geom_params(spec, b, lift_param),
    );
    let (condim, friction, sol) = match ca.priority.cmp(&cb.priority) {
        std::cmp::Ordering::Greater => (ca.condim, fa, sa),
        std::cmp::Ordering::Less => (cb.condim, fb, sb),
        std::cmp::Ordering::Equal => {
            let mix: T = lift(solmix(ca.solmix, cb.solmix));
            let weigh = |x: T, y: T| mix * x + (T::one() - mix) * y;
            // At a tie the value is either's; its derivative the mean of
            // the one-sided ones (what central differences give).
            let tie = |x: T, y: T| (x + y) * lift(0.5);
            let smaller = |x: T, y: T| if x == y { tie(x, y) } else { x.min(y) };
            let larger = |x: T, y: T| if x == y { tie(x, y) } else { x.max(y) };
            let (ra, rb) = (sa.solref, sb.solref);
            let solref = if ra[0] > T::zero() && rb[0] > T::zero() {
                std::array::from_fn(|i| weigh(ra[i], rb[i]))
            } else {
                std::array::from_fn(|i| smaller(ra[i], rb[i]))
            };
            let solimp = std::array::from_fn(|i| weigh(sa.solimp[i], sb.solimp[i]));
            (
                ca.condim.max(cb.condim),
                std::array::from_fn(|i| larger(fa[i], fb[i])),
                SolParams { solref, solimp },
            )
        }
    };
    let [slide, spin, roll] = friction;
    PairParams {
        condim,
        friction: [slide, slide, spin, roll, roll],
        sol,
        solreffriction: [T::zero(); 2],
        margin: ca.margin + cb.margin,
        gap: ca.gap + cb.gap,
    }
}

/// An explicit pair's parameters in scalar T (they are no named parameter).
fn lifted<T: Real>(p: &PairParams) -> PairParams<T> {
    PairParams {
        condim: p.condim,
        friction: p.friction.map(lift),
        sol: p.sol.lift(|_, x| lift(x), |_, x| lift(x)),
        solreffriction: p.solreffriction.map(lift),
        margin: p.margin,
        gap: p.gap,
    }
}

/// The model's geom pairs that may touch, as model geom indices in MuJoCo's
/// order, with their parameters (geoms' lifted by `lift_param`) and whether
/// a collider exists for them; empty when contacts are off.
pub fn collision_pairs<T: Real>(
    spec: &Spec,
    lift_param: &impl Fn(Param, usize, f64) -> T,
) -> Vec<([usize; 2], PairParams<T>, bool)> {
    if !spec.opt.contact {
        return vec![];
    }
    let bodies = &spec.bodies;
    // The rigid body each body moves with: itself, or its parent's if welded.
    let mut weld = vec![0; bodies.len()];
    for (b, body) in bodies.iter().enumerate().skip(1) {
        weld[b] = if body.joints.is_empty() {
            weld[body.parent]
        } else {
            b
        };
    }
    let weld_parent = |b: usize| weld[bodies[weld[b]].parent];
    let filterparent = spec.opt.solver.filterparent;
    let explicit_pair = |i: usize, j: usize| {
        spec.pairs
            .iter()
            .any(|p| p.geoms == [i, j] || p.geoms == [j, i])
    };
    let mut pairs: Vec<([usize; 2], PairParams<T>)> = spec
        .pairs
        .iter()
        .map(|p| (p.geoms, lifted(&p.params)))
        .collect();
    for (i, gi) in spec.geoms.iter().enumerate() {
        for (j, gj) in spec.geoms.iter().enumerate().skip(i + 1) {
            let (bi, bj) = (gi.body, gj.body);
            let (wi, wj) = (weld[bi], weld[bj]);
            let masks = gi.contype & gj.conaffinity != 0 || gj.contype & gi.conaffinity != 0;
            let parent = filterparent
                && wi != 0
                && wj != 0
                && (wi == weld_parent(bj) || wj == weld_parent(bi));
            let excluded = spec
                .excludes
                .iter()
                .any(|e| *e == [bi, bj] || *e == [bj, bi]);
            if !masks || wi == wj || parent || excluded || explicit_pair(i, j) {
                continue;
            }
            pairs.push(([i, j], mixed(spec, [i, j], lift_param)));
        }
    }
    pairs
        .into_iter()
        .map(|(mut geoms, params)| {
            let [a, b] = geoms.map(|g| rank(&spec.geoms[g].shape));
            if a > b {
                geoms.swap(0, 1);
            }
            (geoms, params, supported(a.min(b), a.max(b)))
        })
        .collect()
}

/// A geom at its world pose: centre and axes (columns), MuJoCo's geom_xpos
/// and geom_xmat.
pub(super) struct Placed<T: Real> {
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

/// Whether the geoms of a pair without a collider are out of reach: their
/// bounding spheres (a plane's half-space) apart by more than margin + gap.
pub fn out_of_reach<T: Real>(
    pair: &CollisionPair<T>,
    geoms: [&GeomFrame<T>; 2],
    world: &[Transform<T>],
) -> bool {
    let reach = pair.params.margin + pair.params.gap;
    let [g1, g2] = geoms;
    if g1.shape == Shape::Plane {
        super::contact::apart(g2, g1, world, reach)
    } else {
        super::contact::apart(g1, g2, world, reach)
    }
}

/// Appends the contacts of pair `index` of `pairs` at the geoms' world poses
/// to `out` (`pre`: [`contact_geometry`]'s scratch).
pub fn collide<T: Real>(
    (pairs, index): (&[CollisionPair<T>], usize),
    geoms: [&GeomFrame<T>; 2],
    poses: [Transform<T>; 2],
    (out, pre): (&mut Vec<ConstraintContact<T>>, &mut Vec<Pre<T>>),
) {
    let pair = &pairs[index];
    let [g1, g2] = geoms;
    let reach = pair.params.margin + pair.params.gap;
    for (pos, frame, dist) in contact_geometry([&g1.shape, &g2.shape], poses, reach, pre) {
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
/// of two rank-ordered shapes at their world poses, within `reach`; `pre` is
/// scratch, kept by the caller so that repeated calls do not allocate.
pub fn contact_geometry<'a, T: Real>(
    shapes: [&Shape; 2],
    poses: [Transform<T>; 2],
    reach: f64,
    pre: &'a mut Vec<Pre<T>>,
) -> impl Iterator<Item = (Vector3<T>, Matrix3<T>, T)> + 'a {
    let (p1, p2) = (Placed::of(&poses[0]), Placed::of(&poses[1]));
    pre.clear();
    narrow((shapes[0], &p1), (shapes[1], &p2), lift(reach), pre);
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
pub(super) fn normalize<T: Real>(v: Vector3<T>) -> (Vector3<T>, T) {
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

/// Dispatches to the collider of the two (rank-ordered) shapes.
fn narrow<T: Real>(
    (s1, p1): (&Shape, &Placed<T>),
    (s2, p2): (&Shape, &Placed<T>),
    margin: T,
    out: &mut Vec<Pre<T>>,
) {
    match (*s1, *s2) {
        (Shape::Plane, Shape::Sphere { radius }) => {
            plane_sphere(p1, p2.pos, lift(radius), margin, out);
        }
        (
            Shape::Plane,
            Shape::Capsule {
                radius,
                half_length,
            },
        ) => plane_capsule(p1, p2, [radius, half_length], margin, out),
        (
            Shape::Plane,
            Shape::Cylinder {
                radius,
                half_length,
            },
        ) => plane_cylinder(p1, p2, [radius, half_length], margin, out),
        (Shape::Plane, Shape::Box { half }) => plane_box(p1, p2, &half, margin, out),
        (Shape::Sphere { radius: r1 }, Shape::Sphere { radius: r2 }) => {
            sphere_sphere(p1, lift(r1), p2, lift(r2), margin, out);
        }
        (
            Shape::Sphere { radius },
            Shape::Capsule {
                radius: r2,
                half_length,
            },
        ) => {
            let x = clip(
                p2.axis(2).dot(&(p1.pos - p2.pos)),
                lift(-half_length),
                lift(half_length),
            );
            let nearest = Placed {
                pos: p2.pos + p2.axis(2) * x,
                mat: p2.mat,
            };
            sphere_sphere(p1, lift(radius), &nearest, lift(r2), margin, out);
        }
        (
            Shape::Sphere { radius },
            Shape::Cylinder {
                radius: r2,
                half_length,
            },
        ) => sphere_cylinder(p1, lift(radius), p2, [r2, half_length], margin, out),
        (Shape::Sphere { radius }, Shape::Box { half }) => {
            sphere_box(p1, lift(radius), p2, &half, margin, out);
        }
        (
            Shape::Capsule {
                radius: r1,
                half_length: h1,
            },
            Shape::Capsule {
                radius: r2,
                half_length: h2,
            },
        ) => capsule_capsule((p1, [r1, h1]), (p2, [r2, h2]), margin, out),
        (
            Shape::Capsule {
                radius,
                half_length,
            },
            Shape::Box { half },
        ) => super::capsule_box::collide((p1, [radius, half_length]), (p2, &half), margin, out),
        (Shape::Box { half: h1 }, Shape::Box { half: h2 }) => {
            super::box_box::collide((p1.pos, p1.mat, &h1), (p2.pos, p2.mat, &h2), margin, out);
        }
        _ => {}
    }
}

/// A plane (its z axis the normal) against a sphere at `centre`.
fn plane_sphere<T: Real>(
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
fn plane_capsule<T: Real>(
    plane: &Placed<T>,
    capsule: &Placed<T>,
    [radius, half]: [f64; 2],
    margin: T,
    out: &mut Vec<Pre<T>>,
) {
    let axis = capsule.axis(2);
    let segment = axis * lift::<T>(half);
    for end in [capsule.pos + segment, capsule.pos - segment] {
        if plane_sphere(plane, end, lift(radius), margin, out) {
            out.last_mut().expect("just pushed").tangent = axis;
        }
    }
}

/// MuJoCo's plane-cylinder: the rim point nearest the plane on the end
/// closer to it, the matching point of the other end, and two more points of
/// the closer end's rim (a triangle with the first) when it is within margin.
fn plane_cylinder<T: Real>(
    plane: &Placed<T>,
    cylinder: &Placed<T>,
    [radius, half]: [f64; 2],
    margin: T,
    out: &mut Vec<Pre<T>>,
) {
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

/// The box corners below the plane's margin that point towards it, at most four.
fn plane_box<T: Real>(
    plane: &Placed<T>,
    cube: &Placed<T>,
    half: &Vector3<f64>,
    margin: T,
    out: &mut Vec<Pre<T>>,
) {
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

/// Two spheres; coincident centres take the normal from the cross product
/// of the geoms' z axes (MuJoCo's rule).
fn sphere_sphere<T: Real>(
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

/// MuJoCo's sphere-cylinder: against the side (a sphere on the axis), a cap
/// (a plane) or the rim (a point), whichever the sphere's centre faces.
fn sphere_cylinder<T: Real>(
    sphere: &Placed<T>,
    radius: T,
    cylinder: &Placed<T>,
    [r2, half]: [f64; 2],
    margin: T,
    out: &mut Vec<Pre<T>>,
) {
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
        return sphere_sphere(sphere, radius, &on_axis, rc, margin, out);
    }
    if cap {
        let top = x > T::zero();
        let flip = Matrix3::from_columns(&[-cylinder.axis(0), cylinder.axis(1), -axis]);
        let plane = Placed {
            pos: cylinder.pos + axis * if top { hc } else { -hc },
            mat: if top { cylinder.mat } else { flip },
        };
        if plane_sphere(&plane, sphere.pos, radius, margin, out) {
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
    sphere_sphere(sphere, radius, &rim, T::zero(), margin, out);
}

/// MuJoCo's sphere-box: from the point of the box nearest the sphere's
/// centre, or, with the centre inside, from the nearest face.
pub(super) fn sphere_box<T: Real>(
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

/// MuJoCo's capsule-capsule: the closest points of the segments (clamped as
/// MuJoCo clamps them) as two spheres; (nearly) parallel axes give up to two
/// contacts from the segments' ends.
fn capsule_capsule<T: Real>(
    (p1, [r1, h1]): (&Placed<T>, [f64; 2]),
    (p2, [r2, h2]): (&Placed<T>, [f64; 2]),
    margin: T,
    out: &mut Vec<Pre<T>>,
) {
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
        return sphere_sphere(&s1, r1, &s2, r2, margin, out);
    }
    let start = out.len();
    for end in [one, -one] {
        let x2 = clip((v - mb * end) / mc, -one, one);
        let (s1, s2) = (at(p1, &axis1, end), at(p2, &axis2, x2));
        sphere_sphere(&s1, r1, &s2, r2, margin, out);
    }
    for end in [one, -one] {
        if out.len() - start >= 2 {
            return;
        }
        let x1 = clip((u - mb * end) / ma, -one, one);
        let (s1, s2) = (at(p1, &axis1, x1), at(p2, &axis2, end));
        sphere_sphere(&s1, r1, &s2, r2, margin, out);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

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
    fn a_box_on_a_plane_touches_with_its_four_lowest_corners_at_most() {
        let plane = Placed {
            pos: Vector3::zeros(),
            mat: Matrix3::identity(),
        };
        let cube = Placed {
            pos: Vector3::new(0.0, 0.0, 0.049),
            mat: Matrix3::identity(),
        };
        let mut out: Vec<Pre<f64>> = vec![];
        plane_box(&plane, &cube, &Vector3::new(0.2, 0.1, 0.05), 0.0, &mut out);
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
        plane_box(
            &plane,
            &lifted,
            &Vector3::new(0.2, 0.1, 0.05),
            0.005,
            &mut out,
        );
        assert!(out.is_empty());
        plane_box(
            &plane,
            &lifted,
            &Vector3::new(0.2, 0.1, 0.05),
            0.02,
            &mut out,
        );
        assert!(out.len() == 4 && out.iter().all(|c| (c.dist - 0.01).abs() < 1e-15));
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
        let mut out: Vec<Pre<f64>> = vec![];
        capsule_capsule((&a, [0.05, 0.2]), (&b, [0.05, 0.2]), 0.0, &mut out);
        assert_eq!(out.len(), 2);
        for c in &out {
            assert!((c.dist + 0.01).abs() < 1e-15 && (c.normal - Vector3::z()).norm() < 1e-15);
        }
    }
}
