//! Which geom pairs may touch, fixed when a model is compiled: one candidate
//! builder, whose rules both contact models share and whose differences
//! are its [`Filter`]; each model then keeps the pairs its law supports, in
//! its own order ([`collision_pairs`] for the constraint model,
//! [`contact_pairs`] for the smooth one). The broad phase at a state
//! ([`crate::dynamics::collision::apart`]) runs on these pairs.
//!
//! Candidates: geoms of different bodies, in model order (i < j), whose
//! bitmasks match (contype of one & conaffinity of the other), unless the
//! bodies are welded together or both without dofs (the world and mocap
//! bodies, each its own weld); parent and child when
//! neither is the world (MuJoCo's filterparent; the world is nobody's
//! parent), when the filter says so; bodies excluded (`<exclude>`) and
//! geoms joined by an explicit pair (`<pair>`), when the filter says so.

use super::mixing::{lifted, mixed};
use crate::dynamics::collision::supported;
use crate::model::{PairParams, Param, Shape, Spec};
use crate::spatial::Real;

#[cfg(doc)]
use crate::dynamics::collision::GeomType;

/// What a model's rules add to the common ones (see the module documentation).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Filter {
    /// Drop parent and child bodies (neither the world).
    pub parent: bool,
    /// Drop the bodies of the model's `<exclude>`s.
    pub excludes: bool,
    /// Drop the geoms of the model's explicit pairs (listed on their own).
    pub explicit: bool,
}

impl Filter {
    /// The smooth model's: parents always dropped; no excludes, no explicit pairs.
    pub const SMOOTH: Filter = Filter {
        parent: true,
        excludes: false,
        explicit: false,
    };

    /// The constraint model's: MuJoCo's, with the model's `filterparent`.
    pub fn constraint(spec: &Spec) -> Filter {
        Filter {
            parent: spec.opt.solver.filterparent,
            excludes: true,
            explicit: true,
        }
    }
}

/// The candidate pairs [i, j] (i < j, model geom indices) in model order;
/// empty when contacts are off.
pub fn candidates(spec: &Spec, filter: Filter) -> Vec<[usize; 2]> {
    if !spec.opt.contact {
        return vec![];
    }
    let bodies = &spec.bodies;
    // The rigid body each body moves with: itself (with joints, or a mocap
    // body), or its parent's if welded.
    let mut weld = vec![0; bodies.len()];
    for (b, body) in bodies.iter().enumerate().skip(1) {
        weld[b] = if body.joints.is_empty() && !body.mocap {
            weld[body.parent]
        } else {
            b
        };
    }
    // No force moves either: the world's and mocap bodies' welds.
    let dofless = |w: usize| w == 0 || bodies[w].mocap;
    let weld_parent = |b: usize| weld[bodies[weld[b]].parent];
    let explicit_pair = |i: usize, j: usize| {
        spec.pairs
            .iter()
            .any(|p| p.geoms == [i, j] || p.geoms == [j, i])
    };
    let mut pairs = vec![];
    for (i, gi) in spec.geoms.iter().enumerate() {
        for (j, gj) in spec.geoms.iter().enumerate().skip(i + 1) {
            let (bi, bj) = (gi.body, gj.body);
            let (wi, wj) = (weld[bi], weld[bj]);
            let masks = gi.contype & gj.conaffinity != 0 || gj.contype & gi.conaffinity != 0;
            let parent = filter.parent
                && wi != 0
                && wj != 0
                && (wi == weld_parent(bj) || wj == weld_parent(bi));
            let excluded = filter.excludes
                && spec
                    .excludes
                    .iter()
                    .any(|e| *e == [bi, bj] || *e == [bj, bi]);
            let explicit = filter.explicit && explicit_pair(i, j);
            let fixed = dofless(wi) && dofless(wj);
            if !masks || wi == wj || fixed || parent || excluded || explicit {
                continue;
            }
            pairs.push([i, j]);
        }
    }
    pairs
}

/// The constraint model's pairs: the explicit pairs, then the candidates,
/// each ordered by geom type ([`GeomType`]: geom 1 first), with their
/// parameters (geoms' lifted by `lift_param`, mixed; an explicit pair's own)
/// and whether the collision table holds a collider for them.
pub fn collision_pairs<T: Real>(
    spec: &Spec,
    lift_param: &impl Fn(Param, usize, f64) -> T,
) -> Vec<([usize; 2], PairParams<T>, bool)> {
    if !spec.opt.contact {
        return vec![];
    }
    let candidates = candidates(spec, Filter::constraint(spec));
    let explicit = spec.pairs.iter().map(|p| (p.geoms, lifted(&p.params)));
    let automatic = candidates
        .into_iter()
        .map(|geoms| (geoms, mixed(spec, geoms, lift_param)));
    explicit
        .chain(automatic)
        .map(|(mut geoms, params)| {
            let [a, b] = geoms.map(|g| spec.geoms[g].shape.kind());
            if a > b {
                geoms.swap(0, 1);
            }
            let margin = params.margin + params.gap;
            (geoms, params, supported(a, b, &spec.opt.solver.ccd, margin))
        })
        .collect()
}

/// The geom pairs that may touch, as model geom indices [a, b] (b the plane
/// when there is one), in model order: the candidates under the smooth
/// model's [`Filter`] whose shapes its law supports; empty when contacts
/// are off.
pub fn contact_pairs(spec: &Spec) -> Vec<[usize; 2]> {
    candidates(spec, Filter::SMOOTH)
        .into_iter()
        .filter_map(|pair| ordered(spec, pair))
        .collect()
}

/// The candidates under the smooth model's [`Filter`] whose shapes its law
/// does not cover (cylinder, ellipsoid, mesh, ...), as model geom indices:
/// a step refuses a state where one is within reach
/// ([`crate::dynamics::contact::lawless_within_reach`]) rather than miss
/// its contact.
pub fn lawless_pairs(spec: &Spec) -> Vec<[usize; 2]> {
    candidates(spec, Filter::SMOOTH)
        .into_iter()
        .filter(|&pair| ordered(spec, pair).is_none())
        .collect()
}

/// The pair ordered [a, b] as the law takes it (b the plane), or None
/// where the law has none for its shapes.
fn ordered(spec: &Spec, [i, j]: [usize; 2]) -> Option<[usize; 2]> {
    match (spec.geoms[i].shape, spec.geoms[j].shape) {
        (Shape::Sphere { .. } | Shape::Capsule { .. } | Shape::Box { .. }, Shape::Plane)
        | (
            Shape::Sphere { .. } | Shape::Capsule { .. },
            Shape::Sphere { .. } | Shape::Capsule { .. },
        ) => Some([i, j]),
        (Shape::Plane, Shape::Sphere { .. } | Shape::Capsule { .. } | Shape::Box { .. }) => {
            Some([j, i])
        }
        _ => None,
    }
}
