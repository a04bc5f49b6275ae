//! Contact rows (MuJoCo's mj_instantiateContact, efc_type mjCNSTR_CONTACT_*)
//! of the contacts at a state, in collision order, and the contacts' forces
//! from the rows'.
//!
//! - A contact's rows project J(body 2) - J(body 1) at the contact point on
//!   its frame: condim 1 one normal row; pyramidal cones 2 (condim - 1)
//!   rows, the normal plus and minus mu_k times tangent k (k = 1, 2 sliding,
//!   3 torsional, 4, 5 rolling; torsional and rolling rows use the angular
//!   Jacobian); elliptic cones condim rows (normal, tangents, then angular).
//! - A_ii from the two bodies' body_invweight0 (translation, rotation); the
//!   impedance from the distance (see [`impedance`](mod@super::impedance)).
//!   A contact's frictional rows take R_normal / impratio; a pyramid's rows
//!   all take 2 mu^2 R_normal with mu = friction_1 / sqrt(impratio); an
//!   elliptic cone's friction row k takes R_1 mu_1^2 / mu_k^2.

use super::impedance::Block;
use super::{At, ConstraintKind, Origin, RowKind, Rows};
use crate::dynamics::collision::{
    apart, collide, CollisionPair, ConstraintContact, Pre, MIN_PAIRS,
};
use crate::dynamics::{Contact, Data, Tree};
use crate::model::Cone;
use crate::spatial::{lift, Real};

/// The contacts at the current state into `out` (`data.world` filled by
/// [`world_frames`](crate::dynamics::world_frames); `pre`: the colliders' scratch).
pub fn contacts<T: Real>(
    tree: &Tree<T>,
    data: &Data<T>,
    (out, pre): (&mut Vec<ConstraintContact<T>>, &mut Vec<Pre<T>>),
) {
    out.clear();
    let consts = &tree.constraint;
    for index in within_reach(tree, data, |p| p.supported) {
        let geoms = consts.pairs[index].geoms.map(|g| &tree.geoms[g]);
        let poses = geoms.map(|g| g.pose(data));
        collide((consts, index), geoms, poses, (&mut *out, &mut *pre));
    }
}

/// The indices of the pairs that `keep` accepts and whose bounding spheres
/// are within the pair's reach (MuJoCo's broad phase: pairs farther apart
/// hold no contact, their colliders need not run), in order. Many pairs are
/// swept and pruned first ([`Sweep`](crate::dynamics::collision::Sweep)),
/// which finds the same ones.
fn within_reach<'a, T: Real>(
    tree: &'a Tree<T>,
    data: &'a Data<T>,
    keep: impl Fn(&CollisionPair<T>) -> bool + 'a,
) -> impl Iterator<Item = usize> + 'a {
    let consts = &tree.constraint;
    let pairs = &consts.pairs;
    let every = pairs.len() < MIN_PAIRS;
    let mut near = vec![];
    if !every {
        consts.sweep.near(&tree.geoms, data, &mut near);
    }
    (0..if every { pairs.len() } else { 0 })
        .chain(near)
        .filter(move |&i| {
            let p = &pairs[i];
            let [a, b] = p.geoms.map(|g| &tree.geoms[g]);
            keep(p) && !apart(a, b, data, p.params.margin + p.params.gap)
        })
}

/// Appends the rows of every contact of the state, in order.
pub(super) fn append<T: Real>(at: &At<T>, rows: &mut Rows<T>) {
    for (id, c) in at.contacts.iter().enumerate() {
        contact_rows(at.tree, at.data, (id, c), at.v, rows);
    }
}

/// Appends the rows of contact `c` (number `id` of the state's) at velocity `v`.
fn contact_rows<T: Real>(
    tree: &Tree<T>,
    data: &Data<T>,
    (id, c): (usize, &ConstraintContact<T>),
    v: &[T],
    rows: &mut Rows<T>,
) {
    let consts = &tree.constraint;
    let n = tree.nv();
    let [b1, b2] = c.bodies;
    let first = rows.len();
    if tree.body[b1].node == tree.body[b2].node {
        // Both bodies on the same dofs: the contact moves none.
        rows.contact_rows.push((first, 0));
        return;
    }
    let dim = c.params.condim;
    let elliptic = tree.opt.solver.cone == Cone::Elliptic && dim > 1;
    let mixes = mixing(dim, elliptic, &c.params.friction);
    // J(body 2) - J(body 1) at the contact point projected on the frame rows
    // (normal, tangents, then angular) per dof, and the contact's rows as
    // their combinations; a dof on both paths adds opposite terms.
    let start = rows.j.len();
    rows.j.resize(start + mixes.len() * n, T::zero());
    let j = &mut rows.j[start..];
    for (body, sign) in [(b2, T::one()), (b1, -T::one())] {
        let mut k = tree.body[body].node;
        while let Some(i) = k {
            let s = &data.world_axis[i];
            let (jp, jr) = ((s.lin + s.ang.cross(&c.pos)) * sign, s.ang * sign);
            let mut frame = [T::zero(); 6];
            for (m, f) in frame.iter_mut().enumerate().take(dim) {
                let (jac, axis) = if m < 3 { (&jp, m) } else { (&jr, m - 3) };
                *f = c.frame.row(axis).transpose().dot(jac);
            }
            for (row, mix) in j.chunks_exact_mut(n).zip(mixes.iter()) {
                row[i] += mix
                    .iter()
                    .zip(&frame)
                    .fold(T::zero(), |s, (m, f)| s + *m * *f);
            }
            k = tree.parent[i];
        }
    }
    let [w1, w2] = [b1, b2].map(|b| consts.body_invweight[b]);
    let (tran, rot) = (w1[0] + w2[0], w1[1] + w2[1]);
    let friction = clamped_friction(&c.params.friction);
    let mut kind = [RowKind::Unilateral; 10];
    let mut diag = [T::zero(); 10];
    let count = mixes.len();
    if dim == 1 {
        diag[0] = tran;
    } else if elliptic {
        for k in 0..dim {
            kind[k] = if k == 0 {
                RowKind::Cone {
                    dim,
                    cone: rows.cone.len(),
                }
            } else {
                RowKind::ConeRest
            };
            diag[k] = if k < 3 { tran } else { rot };
        }
    } else {
        for k in 1..dim {
            let mu = friction[k - 1];
            let a = if k < 3 { tran } else { rot };
            diag[2 * k - 2] = tran + mu * mu * a;
            diag[2 * k - 1] = tran + mu * mu * a;
        }
    }
    let block = Block {
        origin: Origin {
            kind: ConstraintKind::Contact,
            id,
        },
        kind: &kind[..count],
        diag: &diag[..count],
        dist: c.dist,
        pos: None,
        margin: c.params.margin,
        sol: c.params.sol,
        floss: T::zero(),
    };
    rows.contact_rows.push((first, count));
    rows.moving(count, path_dofs(tree, [b1, b2]));
    rows.push(block, v, &tree.opt, Some(c.params.solreffriction));
    if dim == 1 {
        return;
    }
    let r0 = rows.r[first];
    // Every R of the contact is proportional to the normal's.
    let dlog_r = rows.dlog_r_ddist[first];
    rows.dlog_r_ddist[first..first + count].fill(dlog_r);
    let r1 = r0 / lift(tree.opt.solver.impratio);
    let mu = friction[0] * (r1 / r0).sqrt();
    if elliptic {
        rows.cone.push((mu, friction));
        rows.r[first + 1] = r1;
        for k in 1..dim - 1 {
            rows.r[first + k + 1] = r1 * friction[0] * friction[0] / (friction[k] * friction[k]);
        }
    } else {
        let rpy = (mu * mu + mu * mu) * r0;
        for r in &mut rows.r[first..first + count] {
            *r = rpy;
        }
    }
}

/// The dofs on the paths from two bodies to the world, descending, each once.
pub(super) fn path_dofs<T: Real>(
    tree: &Tree<T>,
    bodies: [usize; 2],
) -> impl Iterator<Item = usize> + '_ {
    // Each path descends (a parent's dof comes before its children's): merge.
    let path = |b: usize| std::iter::successors(tree.body[b].node, |&i| tree.parent[i]);
    let (mut a, mut b) = (path(bodies[0]).peekable(), path(bodies[1]).peekable());
    std::iter::from_fn(move || match (a.peek(), b.peek()) {
        (Some(&x), Some(&y)) if x == y => {
            b.next();
            a.next()
        }
        (Some(&x), Some(&y)) if x < y => b.next(),
        (Some(_), _) => a.next(),
        (None, _) => b.next(),
    })
}

/// A contact's friction coefficients as its rows use them (at least 1e-5).
fn clamped_friction<T: Real>(friction: &[T; 5]) -> [T; 5] {
    friction.map(|f| f.max(lift(1e-5)))
}

/// The rows of a contact of `dim` frame rows (normal, tangents, then
/// angular) as combinations of them: row i = sum_k `mix[i][k]` frame_k. One
/// row (condim 1); an elliptic cone's frame rows; else the pyramid's edges,
/// normal + mu_k tangent_k and normal - mu_k tangent_k for k = 1..dim.
pub fn mixing<T: Real>(dim: usize, elliptic: bool, friction: &[T; 5]) -> Mixing<T> {
    let unit = |k: usize| std::array::from_fn(|j| if j == k { T::one() } else { T::zero() });
    let mut out = Mixing {
        rows: [[T::zero(); 6]; 10],
        len: 0,
    };
    let mut push = |mix: [T; 6]| {
        out.rows[out.len] = mix;
        out.len += 1;
    };
    if dim == 1 || elliptic {
        (0..dim).map(unit).for_each(push);
        return out;
    }
    let friction = clamped_friction(friction);
    for k in 1..dim {
        for sign in [T::one(), -T::one()] {
            let mut mix = unit(0);
            mix[k] = sign * friction[k - 1];
            push(mix);
        }
    }
    out
}

/// A contact's rows as [`mixing`] gives them (at most 10: a pyramid of
/// condim 6), without allocating; derefs to the rows.
#[derive(Clone, Copy, Debug)]
pub struct Mixing<T: Real> {
    rows: [[T; 6]; 10],
    len: usize,
}

impl<T: Real> std::ops::Deref for Mixing<T> {
    type Target = [[T; 6]];
    fn deref(&self) -> &Self::Target {
        &self.rows[..self.len]
    }
}

/// The force of each contact from the rows' forces, as a [`Contact`]
/// (MuJoCo's mj_contactForce, in world coordinates): in the contact frame,
/// a pyramid's normal force is the sum of its edge forces and
/// its k-th frictional component mu_k (f+ - f-) of edge pair k; an elliptic
/// cone's are its row forces. Tangential forces and torsional and rolling
/// moments go to world coordinates through the frame.
pub fn contact_forces<T: Real>(
    contacts: &[ConstraintContact<T>],
    rows: &Rows<T>,
    force: &[T],
) -> Vec<Contact<T>> {
    contacts
        .iter()
        .zip(&rows.contact_rows)
        .map(|(c, &(first, count))| {
            let local = in_frame(c, &force[first..first + count]);
            let row = |k: usize| c.frame.row(k).transpose();
            Contact {
                geoms: c.geoms,
                bodies: c.bodies,
                pos: c.pos,
                normal: row(0),
                dist: c.dist,
                normal_force: local[0],
                friction: row(1) * local[1] + row(2) * local[2],
                torque: row(0) * local[3] + row(1) * local[4] + row(2) * local[5],
                frame: c.frame,
            }
        })
        .collect()
}

/// The first geom pair without a collider that is within reach at the
/// current state (`data.world` filled by
/// [`world_frames`](crate::dynamics::world_frames)), as model geom indices.
pub fn unreachable_pair<T: Real>(tree: &Tree<T>, data: &Data<T>) -> Option<[usize; 2]> {
    within_reach(tree, data, |p| !p.supported)
        .next()
        .map(|i| tree.constraint.pairs[i].geoms.map(|g| tree.geoms[g].geom))
}

/// A contact's force in its frame from its rows' forces `f` (see [`contact_forces`]).
fn in_frame<T: Real>(c: &ConstraintContact<T>, f: &[T]) -> [T; 6] {
    let dim = c.params.condim;
    let mut local = [T::zero(); 6];
    if f.is_empty() {
        return local;
    }
    if f.len() == dim {
        local[..dim].copy_from_slice(f);
        return local;
    }
    local[0] = f.iter().fold(T::zero(), |s, x| s + *x);
    for k in 1..dim {
        local[k] = (f[2 * k - 2] - f[2 * k - 1]) * c.params.friction[k - 1];
    }
    local
}
