//! Equality rows (MuJoCo's mj_instantiateEquality, efc_type
//! mjCNSTR_EQUALITY, efc_id the equality's index in the model), bilateral
//! (f = -D jar on both sides, [`RowKind::Equality`]), in the model's order:
//! - connect: 3 rows, J = J_p(b1, p1) - J_p(b2, p2) at the world points p1,
//!   p2 of the anchors, position error p1 - p2; A_ii the two bodies'
//!   translational invweight0.
//! - weld: those 3 rows, then 3 rotational ones: with e = conj(q2 L) (q1 R)
//!   (q1, q2 the bodies' world quaternions, R and L the frames on body 1
//!   and 2, [`Weld`]) the error is torquescale vec(e), and column k of J is
//!   torquescale 0.5 vec(conj(q2 L) (0, a1_k - a2_k) (q1 R)) with a_k the
//!   bodies' world rotational Jacobian columns; A_ii translational then
//!   rotational invweight0.
//! - joint: 1 row, error q1 - q1_0 - c0 - sum_k c_k d^k (d = q2 - q2_0),
//!   J = e_1 - (dpoly/dd) e_2; A_ii the two dofs' invweight0.
//! - tendon: the same on tendon lengths (d = L2 - L2_0, reference
//!   lengths at qpos0), J = J_1 - (dpoly/dd) J_2 (the tendons' moments);
//!   A_ii the two tendons' invweight0.
//!
//! Impedance from the norm of the equality's error (all its rows share
//! it), aref per row from its own error component; MuJoCo 4 then
//! subtracts from the aref of connect and weld rows the rate J-dot v of
//! their Jacobians along the motion (mj_Jdotv), which `jdot_v` computes:
//! for a point p fixed to a body of world velocity (w, v_O) and bias
//! acceleration A (the acceleration at qacc = 0, world coordinates about
//! the origin), J-dot v = A_lin + A_ang x p + w x p-dot, and the rotational
//! J-dot v = A_ang; the rotational rows' rate is the product rule on
//! their J v = 0.5 vec(conj(q2 L) (0, w1 - w2) (q1 R)) torquescale with
//! q-dot = 0.5 (0, w) q (w the world angular velocity).

use nalgebra::{Quaternion, Rotation3, UnitQuaternion, Vector3};

use super::contact::path_dofs;
use super::impedance::Block;
use super::{At, ConstraintKind, Origin, RowKind, Rows};
use crate::dynamics::configuration::Coordinates;
use crate::dynamics::{body_pose, Tree};
use crate::model::SolParams;
use crate::spatial::{lift, Motion, Real};

/// An active equality as its rows read it, compiled at qpos0.
#[derive(Clone, Debug, PartialEq)]
pub struct EqualityConsts<T: Real> {
    /// Its index in the model's equalities (the rows' origin id).
    pub id: usize,
    pub held: Held<T>,
    pub sol: SolParams<T>,
}

/// What an equality holds; see the module documentation.
#[derive(Clone, Debug, PartialEq)]
pub enum Held<T: Real> {
    /// Points fixed to two bodies (in body coordinates) held together: a
    /// connect, or with `weld` a weld.
    Points {
        bodies: [usize; 2],
        anchors: [Vector3<T>; 2],
        weld: Option<Weld<T>>,
    },
    /// A joint coupling of its first joint to its second (if any).
    Joints {
        first: Coupled<T>,
        second: Option<Coupled<T>>,
        polycoef: [T; 5],
    },
    /// A tendon coupling of its first tendon to its second (if any),
    /// indices into the tree's tendons.
    Tendons {
        first: usize,
        second: Option<usize>,
        polycoef: [T; 5],
    },
}

/// A joint of a coupling: its coordinate in q, its dof (node), its qpos0.
pub type Coupled<T> = (usize, usize, T);

/// A weld's frames: R on body 1, L on body 2 (a body weld: R the relative
/// pose, L the identity; a site weld: the sites' orientations).
#[derive(Clone, Debug, PartialEq)]
pub struct Weld<T: Real> {
    pub frames: [Quaternion<T>; 2],
    pub torquescale: T,
}

/// Appends the rows of every active equality, in model order.
pub(super) fn append<T: Real>(at: &At<T>, rows: &mut Rows<T>) {
    let tree = at.tree;
    for eq in &tree.constraint.equalities {
        let origin = Origin {
            kind: ConstraintKind::Equality,
            id: eq.id,
        };
        match &eq.held {
            Held::Points {
                bodies,
                anchors,
                weld,
            } => points(
                at,
                (origin, &eq.sol),
                (*bodies, anchors, weld.as_ref()),
                rows,
            ),
            Held::Joints {
                first,
                second,
                polycoef,
            } => joints(at, (origin, &eq.sol), (*first, *second, polycoef), rows),
            Held::Tendons {
                first,
                second,
                polycoef,
            } => tendons(at, (origin, &eq.sol), (*first, *second, polycoef), rows),
        }
    }
}

/// A body's world pose (rotation, origin) and its node; a mocap body's
/// from the step's mocap pose ([`crate::dynamics::mocap`]).
fn pose<T: Real>(at: &At<T>, body: usize) -> (Rotation3<T>, Vector3<T>, Option<usize>) {
    let x = body_pose(at.tree, at.data, body);
    (
        Rotation3::from_matrix_unchecked(x.axes()),
        x.trans,
        at.tree.body[body].node,
    )
}

/// (0, a) q: a pure quaternion times a quaternion.
fn axis_times<T: Real>(a: &Vector3<T>, q: &Quaternion<T>) -> Quaternion<T> {
    Quaternion::from_imag(*a) * q
}

/// q (0, a): a quaternion times a pure one.
fn times_axis<T: Real>(q: &Quaternion<T>, a: &Vector3<T>) -> Quaternion<T> {
    q * Quaternion::from_imag(*a)
}

fn connect_or_weld_rows<T: Real>(
    tree: &Tree<T>,
    at: &At<T>,
    (nodes, points): ([Option<usize>; 2], [Vector3<T>; 2]),
    dim: usize,
    j: &mut [T],
) {
    let n = tree.nv();
    for (node, p, sign) in [
        (nodes[0], points[0], T::one()),
        (nodes[1], points[1], -T::one()),
    ] {
        let mut k = node;
        while let Some(i) = k {
            let s = &at.data.world_axis[i];
            let jp = (s.lin + s.ang.cross(&p)) * sign;
            for r in 0..3 {
                j[r * n + i] += jp[r];
            }
            if dim == 6 {
                for r in 0..3 {
                    j[(3 + r) * n + i] += s.ang[r] * sign;
                }
            }
            k = tree.parent[i];
        }
    }
}

/// A connect's or weld's rows.
fn points<T: Real>(
    at: &At<T>,
    (origin, sol): (Origin, &SolParams<T>),
    (bodies, anchors, weld): ([usize; 2], &[Vector3<T>; 2], Option<&Weld<T>>),
    rows: &mut Rows<T>,
) {
    let tree = at.tree;
    let n = tree.nv();
    let [(r1, x1, n1), (r2, x2, n2)] = bodies.map(|b| pose(at, b));
    let p = [x1 + r1 * anchors[0], x2 + r2 * anchors[1]];
    let dim = if weld.is_some() { 6 } else { 3 };
    let mut error = [T::zero(); 6];
    for r in 0..3 {
        error[r] = p[0][r] - p[1][r];
    }
    let start = rows.j.len();
    rows.j.resize(start + dim * n, T::zero());
    connect_or_weld_rows(tree, at, ([n1, n2], p), dim, &mut rows.j[start..]);
    let half: T = lift(0.5);
    let quats = [r1, r2].map(|r| UnitQuaternion::from_rotation_matrix(&r).into_inner());
    if let Some(w) = weld {
        let right = quats[0] * w.frames[0];
        let left = (quats[1] * w.frames[1]).conjugate();
        let e = left * right;
        for r in 0..3 {
            error[3 + r] = e.imag()[r] * w.torquescale;
        }
        let j = &mut rows.j[start..];
        for c in 0..n {
            let axis = Vector3::from_fn(|r, _| j[(3 + r) * n + c]);
            let col = times_axis(&left, &axis) * right;
            for r in 0..3 {
                j[(3 + r) * n + c] = col.imag()[r] * half * w.torquescale;
            }
        }
    }
    rows.moving(dim, path_dofs(tree, bodies));
    let consts = &tree.constraint;
    let [w1, w2] = bodies.map(|b| consts.body_invweight[b]);
    let (tran, rot) = (w1[0] + w2[0], w1[1] + w2[1]);
    let diag = [tran, tran, tran, rot, rot, rot];
    let dist = error[..dim]
        .iter()
        .fold(T::zero(), |s, x| s + *x * *x)
        .sqrt();
    let first = rows.len();
    let block = Block {
        origin,
        kind: &[RowKind::Equality; 6][..dim],
        diag: &diag[..dim],
        dist,
        pos: Some(&error[..dim]),
        margin: 0.0,
        sol: *sol,
        floss: T::zero(),
    };
    rows.push(block, at.v, &tree.opt, None);
    let rate = jdot_v(at, ([n1, n2], p), (&quats, weld));
    for (k, r) in rate[..dim].iter().enumerate() {
        rows.aref[first + k] -= *r;
    }
}

/// J-dot v of a connect's or weld's rows (see the module documentation).
fn jdot_v<T: Real>(
    at: &At<T>,
    (nodes, p): ([Option<usize>; 2], [Vector3<T>; 2]),
    (quats, weld): (&[Quaternion<T>; 2], Option<&Weld<T>>),
) -> [T; 6] {
    let [(v1, a1), (v2, a2)] = nodes.map(|n| velocity_and_bias(at, n));
    let point = |v: &Motion<T>, a: &Motion<T>, p: &Vector3<T>| {
        let pdot = v.lin + v.ang.cross(p);
        a.lin + a.ang.cross(p) + v.ang.cross(&pdot)
    };
    let mut out = [T::zero(); 6];
    let lin = point(&v1, &a1, &p[0]) - point(&v2, &a2, &p[1]);
    out[..3].copy_from_slice(lin.as_slice());
    let Some(w) = weld else { return out };
    let half: T = lift(0.5);
    let q0r = quats[0] * w.frames[0];
    let q1l = quats[1] * w.frames[1];
    let negq1 = q1l.conjugate();
    let domega = v1.ang - v2.ang;
    let qdot0r = axis_times(&v1.ang, &q0r) * half;
    let negqdot1 = (axis_times(&v2.ang, &q1l) * half).conjugate();
    let t1 = times_axis(&negqdot1, &domega) * q0r;
    let t2 = times_axis(&negq1, &(a1.ang - a2.ang)) * q0r;
    let t3 = times_axis(&negq1, &domega) * qdot0r;
    let sum = (t1 + t2 + t3) * half;
    for r in 0..3 {
        out[3 + r] = sum.imag()[r] * w.torquescale;
    }
    out
}

/// A node's world velocity (about the world origin) and its bias
/// acceleration sum_k (dS_k/dt) v_k over its path; zero for the world.
/// A hinge's or slide's axis moves with the frame before it, dS_k/dt =
/// V_parent x S_k; a ball's three axes (the first carries the rotation)
/// are the body's, dS_k/dt = V_ball x S_k with the velocity after all three.
fn velocity_and_bias<T: Real>(at: &At<T>, node: Option<usize>) -> (Motion<T>, Motion<T>) {
    let (tree, data) = (at.tree, at.data);
    let Some(node) = node else {
        return (Motion::zero(), Motion::zero());
    };
    let mut bias = Motion::zero();
    let mut k = Some(node);
    while let Some(i) = k {
        let carrier = match tree.joint[i].coordinates {
            Coordinates::Rotation { axis, .. } => Some(i - axis + 2),
            Coordinates::Scalar { .. } => tree.parent[i],
        };
        if let Some(c) = carrier {
            bias += data.world_vel[c].cross_motion(&data.world_axis[i]) * at.v[i];
        }
        k = tree.parent[i];
    }
    (data.world_vel[node], bias)
}

/// The polynomial c1 d + c2 d^2 + c3 d^3 + c4 d^4 and its slope in d.
fn poly<T: Real>(c: &[T; 5], d: T) -> (T, T) {
    let (two, three, four): (T, T, T) = (lift(2.0), lift(3.0), lift(4.0));
    let value = c[1] * d + c[2] * d * d + c[3] * d * d * d + c[4] * d * d * d * d;
    let slope = c[1] + two * c[2] * d + three * c[3] * d * d + four * c[4] * d * d * d;
    (value, slope)
}

/// Pushes a coupling's row: J (nv), its dofs (descending), A_ii, error.
fn push_coupling<T: Real>(
    at: &At<T>,
    (origin, sol): (Origin, &SolParams<T>),
    (row, dofs, diag, error): (Vec<T>, Vec<usize>, T, T),
    rows: &mut Rows<T>,
) {
    rows.j.extend(row);
    rows.moving(1, dofs);
    let block = Block {
        origin,
        kind: &[RowKind::Equality],
        diag: &[diag],
        dist: error,
        pos: None,
        margin: 0.0,
        sol: *sol,
        floss: T::zero(),
    };
    rows.push(block, at.v, &at.tree.opt, None);
}

/// A tendon coupling's row.
fn tendons<T: Real>(
    at: &At<T>,
    (origin, sol): (Origin, &SolParams<T>),
    (first, second, c): (usize, Option<usize>, &[T; 5]),
    rows: &mut Rows<T>,
) {
    let tree = at.tree;
    let (t1, s1) = (&tree.tendons[first], &at.data.tendon[first]);
    let mut error = s1.length - t1.length0 - c[0];
    let mut row = vec![T::zero(); tree.nv()];
    s1.add_moment(T::one(), &t1.support, &mut row);
    let mut diag = t1.invweight;
    let mut dofs = t1.dofs().to_vec();
    if let Some(k) = second {
        let (t2, s2) = (&tree.tendons[k], &at.data.tendon[k]);
        let (value, slope) = poly(c, s2.length - t2.length0);
        error -= value;
        s2.add_moment(-slope, &t2.support, &mut row);
        diag += t2.invweight;
        dofs.extend_from_slice(t2.dofs());
        dofs.sort_unstable_by(|a, b| b.cmp(a));
        dofs.dedup();
    }
    push_coupling(at, (origin, sol), (row, dofs, diag, error), rows);
}

/// A joint coupling's row.
fn joints<T: Real>(
    at: &At<T>,
    (origin, sol): (Origin, &SolParams<T>),
    (first, second, c): (Coupled<T>, Option<Coupled<T>>, &[T; 5]),
    rows: &mut Rows<T>,
) {
    let tree = at.tree;
    let n = tree.nv();
    let (q1, dof1, ref1) = first;
    let mut error = at.q[q1] - ref1 - c[0];
    let mut row = vec![T::zero(); n];
    row[dof1] = T::one();
    let mut diag = tree.constraint.dof_invweight[dof1];
    let mut dofs = vec![dof1];
    if let Some((q2, dof2, ref2)) = second {
        let (value, slope) = poly(c, at.q[q2] - ref2);
        error -= value;
        row[dof2] -= slope;
        diag += tree.constraint.dof_invweight[dof2];
        if dof2 != dof1 {
            dofs.push(dof2);
        }
    }
    dofs.sort_unstable_by(|a, b| b.cmp(a));
    push_coupling(at, (origin, sol), (row, dofs, diag, error), rows);
}
