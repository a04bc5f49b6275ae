//! A plane against a mesh, as MuJoCo 4.0.0 computes it (its plane-convex
//! collider for meshes): up to four contacts, the normal the plane's.
//!
//! In the mesh frame (the geom's, see [`Mesh`]):
//! - the first contact is the mesh's support vertex along minus the plane
//!   normal (the first of equals in vertex order); none when it is farther
//!   than the margin;
//! - of the hull's flat sides ([`Mesh::polygons`]) through that vertex, the
//!   one whose normal points most against the plane's is the incident side;
//!   it is pruned to at most four vertices, the support vertex kept
//!   (MuJoCo's hull4: starting from the next three vertices along the
//!   cycle, each of the last, third and second moves on while the
//!   quadrilateral's area grows);
//! - each other vertex kept gives a contact when it lies no higher than the
//!   mesh's centre along the plane normal and within the margin.
//!
//! A contact at vertex v with signed height d above the plane lies at
//! v - d/2 n. With ten vertices or more MuJoCo finds the support vertex by
//! climbing qhull's vertex graph, whose order is not ours: the contacts
//! are the same, but among vertices exactly level with each other
//! (a side resting flat) the first contact may be another of them.

use nalgebra::Vector3;

use super::{Assets, Placed, Pre};
use crate::model::mesh::{Mesh, Polygon};
use crate::model::Shape;
use crate::spatial::{lift, lift_vector, Real};

/// MuJoCo scans every vertex for the support below this many vertices.
const SCAN_BELOW: usize = 10;

/// A plane against a mesh; see the module documentation.
pub(super) fn plane<T: Real>(
    assets: &Assets,
    (_, plane): (&Shape, &Placed<T>),
    (s, placed): (&Shape, &Placed<T>),
    margin: T,
    out: &mut Vec<Pre<T>>,
) {
    let Shape::Mesh { mesh } = *s else {
        return;
    };
    let mesh = &assets.meshes[mesh];
    let normal = plane.axis(2);
    let local = placed.mat.tr_mul(&normal);
    let Some(first) = lowest(mesh, &-local) else {
        return;
    };
    let two: T = lift(2.0);
    let world = |v: usize| placed.mat * lift_vector::<T>(&mesh.vertices[v]) + placed.pos;
    let contact = |p: Vector3<T>, dist: T| Pre {
        dist,
        pos: p - normal * (dist / two),
        normal,
        tangent: Vector3::zeros(),
    };
    let p0 = world(first);
    let dist0 = normal.dot(&(p0 - plane.pos));
    if dist0 > margin {
        return;
    }
    out.push(contact(p0, dist0));
    let Some(side) = incident(&mesh.polygons, first, &local) else {
        return;
    };
    let at = side.vertices.iter().position(|&v| v == first).unwrap_or(0);
    for k in quad(mesh, &side.vertices, at).into_iter().skip(1) {
        let p = world(side.vertices[k]);
        if normal.dot(&(p - placed.pos)) > T::zero() {
            continue;
        }
        let dist = normal.dot(&(p - plane.pos));
        if dist < margin {
            out.push(contact(p, dist));
        }
    }
}

/// The vertex farthest along `dir` (mesh frame), the first of equals: over
/// every vertex for small meshes, over the hull's otherwise.
fn lowest<T: Real>(mesh: &Mesh, dir: &Vector3<T>) -> Option<usize> {
    let all = mesh.vertices.len();
    let candidates: Vec<usize> = match &mesh.hull {
        Some(h) if all >= SCAN_BELOW => h.vertices.clone(),
        _ => (0..all).collect(),
    };
    let mut best: Option<(usize, T)> = None;
    for i in candidates {
        let reach = dir.dot(&lift_vector(&mesh.vertices[i]));
        if best.as_ref().is_none_or(|(_, r)| reach > *r) {
            best = Some((i, reach));
        }
    }
    best.map(|(i, _)| i)
}

/// The side through `vertex` whose normal points most against `normal`
/// (mesh frame), the first of equals; None when no side passes through it.
fn incident<'a, T: Real>(
    sides: &'a [Polygon],
    vertex: usize,
    normal: &Vector3<T>,
) -> Option<&'a Polygon> {
    let mut best: Option<(&Polygon, T)> = None;
    for side in sides.iter().filter(|s| s.vertices.contains(&vertex)) {
        let along = normal.dot(&lift_vector(&side.normal));
        let limit = best.as_ref().map_or(T::one(), |(_, b)| *b);
        if along < limit {
            best = Some((side, along));
        }
    }
    best.map(|(s, _)| s)
}

/// Positions in the cycle `cycle` of at most four of its vertices, the
/// first at position `a`: MuJoCo's hull4 (module documentation).
fn quad(mesh: &Mesh, cycle: &[usize], a: usize) -> Vec<usize> {
    let n = cycle.len();
    let at = |k: usize| mesh.vertices[cycle[k % n]];
    let area = |[a, b, c, d]: [usize; 4]| 0.5 * (at(a) - at(c)).cross(&(at(b) - at(d))).norm();
    let mut q = [a, (a + 1) % n, (a + 2) % n, (a + 3) % n];
    if n <= 4 {
        return q[..n].to_vec();
    }
    let mut m = area(q);
    let mut step = |q: &mut [usize; 4], k: usize| {
        let mut next = *q;
        next[k] = (q[k] + 1) % n;
        let grown = area(next);
        (grown > m).then(|| {
            *q = next;
            m = grown;
        })
    };
    while step(&mut q, 3).is_some() {
        while step(&mut q, 2).is_some() {}
        while step(&mut q, 1).is_some() {}
    }
    q.to_vec()
}
