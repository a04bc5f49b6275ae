//! How a contact's point, frame and distance move with its bodies: along
//! any twist in closed form against a static plane ([`OnPlane`]); else by
//! dual numbers through the collider along each twist of an orthonormal
//! basis of a moving body's twists ([`twist_basis`]). Conventions as in
//! [`super`]: twists (angular, then linear) in world coordinates about the
//! world origin.

use nalgebra::{Matrix3, Vector3};
use num_dual::Dual64;

use crate::dynamics::collision::{contact_geometry, fixed_sphere, ConstraintContact, Pre, MINVAL};
use crate::dynamics::{Data, Tree};
use crate::model::Shape;
use crate::spatial::Transform;

/// How a contact's point, frame (rows) and distance move along a unit twist
/// of one of its bodies.
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct Slope {
    pub dp: Vector3<f64>,
    pub de: Matrix3<f64>,
    pub ddist: f64,
}

/// How a contact moves with one of its bodies.
// Inline, not boxed: the slopes live in a buffer reused across calls.
#[allow(clippy::large_enum_variant)]
#[derive(Clone, Copy, Debug, Default)]
pub(super) enum Moves {
    /// The body does not move.
    #[default]
    Still,
    /// The slopes along an orthonormal basis of the twists the body's dofs
    /// give it (the first `len` 6-vectors, angular then linear), one dual
    /// run of the collider per basis twist: a planar chain spans three
    /// twists, a spatial one six.
    Basis {
        len: usize,
        basis: [[f64; 6]; 6],
        slopes: [Slope; 6],
    },
    /// In closed form along any twist: the other body (b2) against a
    /// static plane (b1, never moving).
    Plane(OnPlane),
}

/// Per body of a contact (b1, b2): how the contact moves with it.
pub(super) type Slopes = [Moves; 2];

/// How every contact moves, into `out`: against a static plane in closed
/// form ([`OnPlane`]); else per pair the collider run on dual
/// numbers along each basis twist of each moving body, its contacts matched
/// to the state's in order (the same branches, so the same contacts).
pub(super) fn find_slopes(
    tree: &Tree<f64>,
    data: &Data<f64>,
    contacts: &[ConstraintContact<f64>],
    (out, pre): (&mut Vec<Slopes>, &mut Vec<Pre<Dual64>>),
) {
    // Resized, not cleared and refilled: an entry is large, and most
    // contacts use little of it; what they use is written below.
    out.resize(contacts.len(), Slopes::default());
    for moves in out.iter_mut() {
        moves[0] = Moves::Still;
        moves[1] = Moves::Still;
    }
    let mut start = 0;
    while start < contacts.len() {
        let index = contacts[start].pair;
        let end = start
            + contacts[start..]
                .iter()
                .take_while(|c| c.pair == index)
                .count();
        let (pair, assets) = (&tree.constraint.pairs[index], &*tree.constraint.assets);
        let geoms = pair.geoms.map(|g| &tree.geoms[g]);
        let poses = geoms.map(|g| g.pose(data));
        let shapes = geoms.map(|g| &g.shape);
        let reach = pair.params.margin + pair.params.gap;
        let static_plane = geoms[0].node.is_none() && *shapes[0] == Shape::Plane;
        if let Some(sphere) = static_plane
            .then(|| fixed_sphere(shapes[1], &poses[1]))
            .flatten()
        {
            for (moves, c) in out[start..end].iter_mut().zip(&contacts[start..end]) {
                moves[1] = Moves::Plane(OnPlane::new(c, sphere));
            }
            start = end;
            continue;
        }
        for side in (0..2).filter(|&s| geoms[s].node.is_some()) {
            let (len, basis) = twist_basis(tree, data, geoms[side].node);
            let slopes = [Slope::default(); 6];
            for moves in &mut out[start..end] {
                moves[side] = Moves::Basis { len, basis, slopes };
            }
            for (t, u) in basis[..len].iter().enumerate() {
                let dual = std::array::from_fn(|s| perturbed(&poses[s], (s == side).then_some(u)));
                let touches = contact_geometry((assets, shapes), dual, reach, pre)
                    .filter(|(_, _, dist)| dist.re < pair.params.margin);
                for (moves, (p, e, dist)) in out[start..end].iter_mut().zip(touches) {
                    if let Moves::Basis { slopes, .. } = &mut moves[side] {
                        slopes[t] = Slope {
                            dp: p.map(|x| x.eps),
                            de: e.map(|x| x.eps),
                            ddist: dist.eps,
                        };
                    }
                }
            }
        }
        start = end;
    }
}

/// A contact of a static plane (normal n, the frame's first row) with a
/// sphere, a capsule or a box: the point nearest the plane of a sphere of
/// radius r fixed on the moving body (the sphere itself, a capsule's end
/// sphere, a box's corner with r = 0), whose centre is c = pos + n (dist / 2 + r).
/// The frame is the plane's but for a capsule, whose tangent hint h is
/// its axis: the frame's second row is y = P h / |P h|, P = I - n n^T.
#[derive(Clone, Copy, Debug)]
pub(super) struct OnPlane {
    centre: Vector3<f64>,
    /// h and 1 / |P h| (zero without a hint, or with h along n).
    hint: Vector3<f64>,
    scale: f64,
}

impl OnPlane {
    /// The contact `c` with the sphere of radius r and hint h of [`fixed_sphere`].
    fn new(c: &ConstraintContact<f64>, (radius, hint): (f64, Vector3<f64>)) -> Self {
        let n: Vector3<f64> = c.frame.row(0).transpose();
        let length = (hint - n * n.dot(&hint)).norm();
        OnPlane {
            centre: c.pos + n * (c.dist / 2.0 + radius),
            hint,
            scale: if length >= MINVAL { 1.0 / length } else { 0.0 },
        }
    }

    /// The slope along the twist (w, u): dc = u + w x c, ddist = n . dc,
    /// dp = dc - n ddist / 2; with dh = w x h, dy = (I - y y^T) P dh / |P h|
    /// and d(n x y) = n x dy.
    pub(super) fn slope(&self, frame: &Matrix3<f64>, twist: &[f64; 6]) -> Slope {
        let w = Vector3::new(twist[0], twist[1], twist[2]);
        let u = Vector3::new(twist[3], twist[4], twist[5]);
        let (n, y): (Vector3<f64>, Vector3<f64>) =
            (frame.row(0).transpose(), frame.row(1).transpose());
        let dc = u + w.cross(&self.centre);
        let ddist = n.dot(&dc);
        let mut de = Matrix3::zeros();
        if self.scale != 0.0 {
            let dh = w.cross(&self.hint);
            let flat = dh - n * n.dot(&dh);
            let dy = (flat - y * y.dot(&flat)) * self.scale;
            de.set_row(1, &dy.transpose());
            de.set_row(2, &n.cross(&dy).transpose());
        }
        Slope {
            dp: dc - n * (ddist / 2.0),
            de,
            ddist,
        }
    }
}

/// An orthonormal basis (Gram-Schmidt) of the twists of the dofs on the
/// path from `node` to the root, world coordinates: its size and vectors.
fn twist_basis(tree: &Tree<f64>, data: &Data<f64>, node: Option<usize>) -> (usize, [[f64; 6]; 6]) {
    let (mut len, mut basis) = (0, [[0.0; 6]; 6]);
    let mut k = node;
    while let Some(j) = k {
        let s = data.world_axis[j];
        let mut u = [s.ang.x, s.ang.y, s.ang.z, s.lin.x, s.lin.y, s.lin.z];
        let scale = dot(&u, &u);
        for b in &basis[..len] {
            let along = dot(b, &u);
            u.iter_mut().zip(b).for_each(|(x, y)| *x -= along * y);
        }
        // Kept when longer than 1e-9 of its length before the projection.
        let norm = dot(&u, &u);
        if len < 6 && norm > 1e-18 * scale {
            let inverse = norm.sqrt().recip();
            basis[len] = u.map(|x| x * inverse);
            len += 1;
        }
        k = tree.parent[j];
    }
    (len, basis)
}

/// A pose on dual numbers, moved along `twist` (angular, then linear;
/// world coordinates about the origin) when given.
fn perturbed(x: &Transform<f64>, twist: Option<&[f64; 6]>) -> Transform<Dual64> {
    let twist = twist.copied().unwrap_or([0.0; 6]);
    let (w, u) = (
        Vector3::new(twist[0], twist[1], twist[2]),
        Vector3::new(twist[3], twist[4], twist[5]),
    );
    let axes = x.axes();
    let daxes = w.cross_matrix() * axes;
    let dorigin = u + w.cross(&x.trans);
    Transform::from_pose(
        &Matrix3::from_fn(|r, c| Dual64::new(axes[(r, c)], daxes[(r, c)])),
        &Vector3::from_fn(|r, _| Dual64::new(x.trans[r], dorigin[r])),
    )
}

pub(super) fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}
