//! Smooth soft contact between geoms, and soft joint limits: forces that are
//! smooth functions of (q, v) and of the contact parameters, so a step
//! through them is exactly differentiable and depends on nothing but its
//! inputs (no solver, no warm start, no contact cache).
//!
//! Conventions:
//! - A contact between geoms a and b has a world point (halfway between the
//!   two surfaces along the normal), a unit normal n in world coordinates
//!   pointing from b into a (the direction of the force on a), and a
//!   penetration depth d (> 0 overlapping, < 0 at a separation of -d). When
//!   one geom is a plane it is b. The [`Contact`] record names them in
//!   MuJoCo's convention: geom 1 is b, geom 2 is a, `dist` = -d.
//! - Normal force on a, with s(d) = w ln(1 + e^(d/w)) (softplus of width w,
//!   s' = sigmoid(d/w)) and the penetration rate d' = -n . (v_a - v_b) at the point:
//!   N = k s(d) + c s'(d) d'. It can pull (N < 0) while separating fast: the
//!   price of smoothness.
//! - Friction on a, regularised Coulomb with slip speed e: with v_t the
//!   tangential part of v_a - v_b, F_t = -mu k s(d) v_t / sqrt(|v_t|^2 + e^2);
//!   its bound uses the elastic part of N, which is never negative. The
//!   pair's coefficient is MuJoCo's rule scaled by a parameter:
//!   mu = f max(mu_a, mu_b), with mu_a, mu_b the geoms' sliding friction
//!   (MJCF `friction`, first value; URDF PyBullet `lateral_friction`) and f
//!   the dimensionless scale `contact/friction` (default 1).
//! - Force N n + F_t acts on a at the point, its opposite on b; each maps to
//!   generalized forces through the bodies' point Jacobians (J^T f).
//! - Contacts deeper out than 30 widths (s < 1e-13 w) are skipped.
//! - Joint limits (lo, hi), width w_l: below the range, with d = lo - q,
//!   tau += k_l s_l(d) - c_l s_l'(d) v; above it, with d = q - hi,
//!   tau -= k_l s_l(d) + c_l s_l'(d) v; skipped likewise beyond 30 widths
//!   inside the range.
//! - k, c, f are the named parameters `contact/stiffness`, `contact/damping`,
//!   `contact/friction`; the rest are fixed settings ([`SoftOptions`]).
//!
//! Pairs ([`crate::compile::contact_pairs`]): geoms of different bodies whose MJCF bitmasks
//! match (contype_a & conaffinity_b or contype_b & conaffinity_a), unless the
//! bodies are the same rigid body (welded together) or parent and child
//! (MuJoCo's rule; the world counts as nobody's parent). Supported shapes:
//! plane against sphere, capsule (its two end spheres) and box (its eight
//! corners); spheres and capsules against each other, as spheres at the
//! closest points of their segments (a sphere's is a point). A step refuses
//! a state at which a pair of other shapes (cylinder, ellipsoid, mesh, ...)
//! is within the cutoff ([`super::StepError::NoSmoothLaw`]), as the
//! constraint model refuses a pair without a collider, rather than miss its
//! contact: refused where it would act, not at load, so that a model whose
//! such geoms never come near each other runs.
//!
//! Non-smooth set: contact forces are smooth in (q, v) except where a contact
//! crosses the cutoff (30 widths out), where two capsules' closest points are
//! not unique or change which end clamps them (parallel axes; an end's
//! closest point on the other segment exactly at its end), and where two
//! segments touch (distance 0: no normal).

use nalgebra::Vector3;

use super::collision::{apart, make_frame, Contact, GeomFrame};

use super::{update_transforms, world_frames, Data, Tree};
#[cfg(doc)]
use crate::model::Options;
use crate::model::{Shape, SoftOptions};
use crate::spatial::{lift, Force, Motion, Real, Transform};

/// Contacts are skipped beyond this many widths of separation.
pub(crate) const CUTOFF_WIDTHS: f64 = 30.0;

/// The contact constants in the scalar of a tree (the named parameters lifted).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Soft<T: Real> {
    pub stiffness: T,
    pub damping: T,
    /// The dimensionless scale f of every pair's friction coefficient.
    pub friction: T,
    pub width: f64,
    pub slip: f64,
    pub limit_stiffness: f64,
    pub limit_damping: f64,
    pub limit_width: f64,
}

impl<T: Real> Soft<T> {
    /// The settings of `soft` with k, c and f given in T.
    pub fn new(soft: &SoftOptions, [stiffness, damping, friction]: [T; 3]) -> Self {
        Soft {
            stiffness,
            damping,
            friction,
            width: soft.width,
            slip: soft.slip,
            limit_stiffness: soft.limit_stiffness,
            limit_damping: soft.limit_damping,
            limit_width: soft.limit_width,
        }
    }
}

/// A pair of geoms that may touch: indices into the tree's geoms (b the
/// plane when there is one), and max(mu_a, mu_b), the larger of their
/// sliding friction coefficients (before the scale `contact/friction`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Pair {
    pub geoms: [usize; 2],
    pub friction: f64,
}

/// The first pair of [`Tree::lawless`] within the smooth model's reach (the
/// cutoff, 30 widths) at the current state (`data.world` filled by
/// [`world_frames`]), as model geom indices.
pub fn lawless_within_reach<T: Real>(tree: &Tree<T>, data: &Data<T>) -> Option<[usize; 2]> {
    let cutoff = CUTOFF_WIDTHS * tree.soft.width;
    tree.lawless
        .iter()
        .map(|pair| pair.map(|g| &tree.geoms[g]))
        .find(|[a, b]| !apart(a, b, data, cutoff))
        .map(|geoms| geoms.map(|g| g.geom))
}

/// softplus of width w and its derivative: (w ln(1 + e^(d/w)), sigmoid(d/w)),
/// in forms that never overflow (both branches are the same function).
pub(crate) fn softplus<T: Real>(d: T, w: f64) -> (T, T) {
    let z = d / lift::<T>(w);
    let one = T::one();
    if z > T::zero() {
        let e = (-z).exp();
        ((z + e.ln_1p()) * lift::<T>(w), one / (one + e))
    } else {
        let e = z.exp();
        (e.ln_1p() * lift::<T>(w), e / (one + e))
    }
}

/// Adds the generalized forces of the soft joint limits and contacts at
/// (q, v) to `out` (length nv) and records the contacts in `data.contacts`.
/// Leaves `data.x_up` at q.
pub fn add_soft_forces<T: Real>(
    tree: &Tree<T>,
    data: &mut Data<T>,
    (q, v): (&[T], &[T]),
    out: &mut [T],
) {
    update_transforms(tree, data, q);
    add_soft_forces_with_transforms(tree, data, (q, v), out);
}

/// [`add_soft_forces`] with `data.x_up` already at q ([`update_transforms`]).
///
/// Works in world coordinates: each node's motion axis S_i and spatial
/// velocity, each contact's spatial force about the world origin summed per
/// node, then one sweep to the root sums subtrees and projects
/// (tau_i += S_i . F_subtree(i)). A pair is skipped before any contact
/// geometry when its geoms' bounding spheres are farther apart than the cutoff.
pub fn add_soft_forces_with_transforms<T: Real>(
    tree: &Tree<T>,
    data: &mut Data<T>,
    (q, v): (&[T], &[T]),
    out: &mut [T],
) {
    add_limit_forces(tree, (q, v), out);
    data.contacts.clear();
    if tree.pairs.is_empty() {
        return;
    }
    world_frames(tree, data, v);
    data.world_force.fill(Force::zero());
    let cutoff = CUTOFF_WIDTHS * tree.soft.width;
    for pair in &tree.pairs {
        let geoms = pair.geoms.map(|g| &tree.geoms[g]);
        if apart(geoms[0], geoms[1], data, cutoff) {
            continue;
        }
        let start = data.contacts.len();
        let poses = geoms.map(|g| g.pose(data));
        let vels = geoms.map(|g| g.node.map_or(Motion::zero(), |n| data.world_vel[n]));
        pair_contacts(&tree.soft, pair, geoms, (poses, vels), &mut data.contacts);
        for c in &data.contacts[start..] {
            let f = c.force();
            let world = Force::new(c.pos.cross(&f), f);
            if let Some(n) = geoms[0].node {
                data.world_force[n] += world;
            }
            if let Some(n) = geoms[1].node {
                data.world_force[n] += -world;
            }
        }
    }
    if data.contacts.is_empty() {
        return;
    }
    for i in (0..tree.nv()).rev() {
        let f = data.world_force[i];
        out[i] += data.world_axis[i].dot(&f);
        if let Some(p) = tree.parent[i] {
            data.world_force[p] += f;
        }
    }
}

/// The contacts of one pair, with their forces, appended to `contacts`: the
/// pair's geoms at their world poses, their nodes moving with the world-frame
/// spatial velocities `vels` (zero for the world). Generic over the scalar of
/// the state (T) and of the tree the geoms come from (U).
pub fn pair_contacts<T: Real, U: Real>(
    soft: &Soft<T>,
    pair: &Pair,
    geoms: [&GeomFrame<U>; 2],
    (poses, vels): ([Transform<T>; 2], [Motion<T>; 2]),
    contacts: &mut Vec<Contact<T>>,
) {
    let [ga, gb] = geoms;
    let start = contacts.len();
    let cutoff: T = lift(-CUTOFF_WIDTHS * soft.width);
    let mut emit = |point, normal, depth: T| {
        if depth > cutoff {
            contacts.push(Contact {
                geoms: [gb.geom, ga.geom],
                bodies: [gb.body, ga.body],
                pos: point,
                normal,
                dist: -depth,
                normal_force: T::zero(),
                friction: Vector3::zeros(),
                torque: Vector3::zeros(),
                frame: make_frame(normal, Vector3::zeros()),
            });
        }
    };
    collide((&ga.shape, &poses[0]), (&gb.shape, &poses[1]), &mut emit);
    let mu = soft.friction * lift::<T>(pair.friction);
    let slip: T = lift(soft.slip);
    for c in &mut contacts[start..] {
        let at = |m: &Motion<T>| m.lin + m.ang.cross(&c.pos);
        let rel = at(&vels[0]) - at(&vels[1]);
        let normal_speed = c.normal.dot(&rel);
        let (s, ds) = softplus(-c.dist, soft.width);
        let elastic = soft.stiffness * s;
        c.normal_force = elastic - soft.damping * ds * normal_speed;
        let tangent = rel - c.normal * normal_speed;
        let norm = (tangent.norm_squared() + slip * slip).sqrt();
        c.friction = tangent * (-mu * elastic / norm);
    }
}

/// The soft joint-limit forces (see the module documentation).
fn add_limit_forces<T: Real>(tree: &Tree<T>, (q, v): (&[T], &[T]), out: &mut [T]) {
    let soft = &tree.soft;
    let (k, c, w) = (
        lift::<T>(soft.limit_stiffness),
        lift::<T>(soft.limit_damping),
        soft.limit_width,
    );
    let cutoff: T = lift(-CUTOFF_WIDTHS * w);
    for (i, range) in tree.limits.iter().enumerate() {
        let Some((lo, hi)) = *range else { continue };
        let x = q[tree.joint[i]
            .coordinate()
            .expect("limits are on hinges and slides")];
        let below = lift::<T>(lo) - x;
        if below > cutoff {
            let (s, ds) = softplus(below, w);
            out[i] += k * s - c * ds * v[i];
        }
        let above = x - lift::<T>(hi);
        if above > cutoff {
            let (s, ds) = softplus(above, w);
            out[i] -= k * s + c * ds * v[i];
        }
    }
}

/// Contact points of shape a against shape b at their world poses: calls
/// `emit(point, normal from b into a, depth)` for each (see the module
/// documentation for the supported pairs).
fn collide<T: Real>(
    (sa, xa): (&Shape, &Transform<T>),
    (sb, xb): (&Shape, &Transform<T>),
    emit: &mut impl FnMut(Vector3<T>, Vector3<T>, T),
) {
    match (sa, sb) {
        (_, Shape::Plane) => {
            let n: Vector3<T> = xb.rot.row(2).transpose();
            let mut sphere = |c: Vector3<T>, r: T| {
                let height = n.dot(&(c - xb.trans));
                let two = T::one() + T::one();
                emit(c - n * ((height + r) / two), n, r - height);
            };
            let axes = xa.axes();
            match *sa {
                Shape::Sphere { radius } => sphere(xa.trans, lift(radius)),
                Shape::Capsule {
                    radius,
                    half_length,
                } => {
                    let end = axes.column(2) * lift::<T>(half_length);
                    sphere(xa.trans + end, lift(radius));
                    sphere(xa.trans - end, lift(radius));
                }
                Shape::Box { half } => {
                    for corner in 0..8 {
                        let sign = |bit: usize| if corner >> bit & 1 == 1 { 1.0 } else { -1.0 };
                        let local = Vector3::from_fn(|r, _| lift::<T>(sign(r) * half[r]));
                        sphere(xa.trans + axes * local, T::zero());
                    }
                }
                _ => {}
            }
        }
        _ => {
            if let (Some(a), Some(b)) = (Segment::of(sa, xa), Segment::of(sb, xb)) {
                let (pa, pb) = closest_points(&a, &b);
                let gap = pa - pb;
                let distance = gap.norm();
                let n = gap / distance;
                let depth = a.radius + b.radius - distance;
                let two = T::one() + T::one();
                emit(pb + n * (b.radius - depth / two), n, depth);
            }
        }
    }
}

/// A sphere swept along a segment: a capsule, or a sphere (half length 0).
struct Segment<T: Real> {
    centre: Vector3<T>,
    /// Unit direction of the segment (the geom's z axis).
    axis: Vector3<T>,
    half_length: T,
    radius: T,
}

impl<T: Real> Segment<T> {
    /// The segment of a sphere or capsule at its world pose; None for other shapes.
    fn of(shape: &Shape, x: &Transform<T>) -> Option<Self> {
        let (radius, half_length) = match *shape {
            Shape::Sphere { radius } => (radius, 0.0),
            Shape::Capsule {
                radius,
                half_length,
            } => (radius, half_length),
            _ => return None,
        };
        Some(Segment {
            centre: x.trans,
            axis: x.rot.row(2).transpose(),
            half_length: lift(half_length),
            radius: lift(radius),
        })
    }
}

/// The closest points of two segments (a's first): the unconstrained
/// minimiser of |p_a + s u - p_b - t w|^2 for s, then t for that s clamped to
/// b, then s for that t clamped to a. Exact when the closest points are
/// unique; (nearly) parallel segments start from s = 0.
fn closest_points<T: Real>(a: &Segment<T>, b: &Segment<T>) -> (Vector3<T>, Vector3<T>) {
    let clamp = |x: T, half: T| {
        if x > half {
            half
        } else if x < -half {
            -half
        } else {
            x
        }
    };
    let r = a.centre - b.centre;
    let (cos, ur, wr) = (a.axis.dot(&b.axis), a.axis.dot(&r), b.axis.dot(&r));
    let sin2 = T::one() - cos * cos;
    let s = if sin2 > lift(1e-12) {
        clamp((cos * wr - ur) / sin2, a.half_length)
    } else {
        T::zero()
    };
    let t = clamp(cos * s + wr, b.half_length);
    let s = clamp(cos * t - ur, a.half_length);
    (a.centre + a.axis * s, b.centre + b.axis * t)
}
