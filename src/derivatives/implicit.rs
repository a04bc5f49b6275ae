//! The constraint rows' part of the implicit derivative of the constraint
//! model's acceleration, in the state.
//!
//! The solver's acceleration a zeroes the gradient of its cost
//! ([`crate::dynamics::solver`]):
//!   g(a; q, v, tau) = ID(q, v, a) - tau - tau_passive - J^T f(J a - aref) = 0,
//! f = -D (J a - aref) on rows in their quadratic zone, the bound on dry
//! friction at its bound, 0 on free rows. With the zones fixed,
//! da = -H^-1 dg with H = M + J^T D J over the quadratic rows; this module
//! adds the rows' part of dg/dq and dg/dv (RNEA's is in [`super::rnea`]).
//!
//! Conventions: motions and forces in world coordinates about the world
//! origin; S_j the axis of dof j (`Data::world_axis`); a contact's bodies
//! b1 (sign -1) and b2 (sign +1), geom 2's side pushed along the normal.
//!
//! A contact's rows are J_i x = sum_k c_ik u_k(x), u_k(x) = W(x) . E_k, with
//! W(x) = sum_j sigma_j S_j x_j the relative motion of b2 from b1 (j over the
//! dofs on one body's path only, sigma_j that body's sign), E_k the unit
//! wrench of frame row k at the contact point p (k < 3: the force e_k at p,
//! (p x e_k, e_k); k >= 3: the moment e_{k-3}) and c the cone's mixing
//! ([`mixing`]). Its generalized force is (J^T f)_j = sigma_j S_j . F with
//! F = sum_k phi_k E_k, phi = c^T f. A change of q_m
//! - turns the axes below m: dS_j = S_m x S_j for m on j's path, so
//!   dW(x) = S_m x W_m(x), W_m(x) the part of W(x) from dofs at or below m;
//! - moves the contact's point, frame and distance with the bodies on whose
//!   path m is: the collider's derivative along the twist S_m (in closed
//!   form against a static plane, else dual numbers through the collider,
//!   one run per direction of a basis of a moving body's twists);
//! - moves aref = -B J v - K imp(x) x and R (proportional to (1 - imp) / imp)
//!   with the distance ([`Rows`] records both slopes).
//!
//! So with df_i = D_i (dlnR_i jar_i + daref_i) ddist - D_i (d(J_i a) + B_i d(J_i v)),
//! d(J^T f)_j = sigma_j [(S_m x S_j) . F + S_j . (sum_k psi_k E_k + phi_k dE_k)],
//! psi = c^T df, the first term for m at or above j on j's path. A limit row
//! (J = +-e_k, dist = +-q_k + const) has only the distance's terms; dry
//! friction depends on q not at all. In v only aref moves: d f / dv = -D B J.

use nalgebra::{Matrix3, Vector3};
use num_dual::Dual64;

use crate::dynamics::collision::{contact_geometry, ConstraintContact, Pre, MINVAL};
use crate::dynamics::constraint::{mixing, Mixing, RowKind, Rows};
use crate::dynamics::solver::Zone;
use crate::dynamics::{Constrained, Data, Tree};
use crate::model::{Cone, Shape};
use crate::spatial::{Force, Motion, Transform};

/// How a contact's point, frame (rows) and distance move along a unit twist
/// of one of its bodies.
#[derive(Clone, Copy, Debug, Default)]
struct Slope {
    dp: Vector3<f64>,
    de: Matrix3<f64>,
    ddist: f64,
}

/// How a contact moves with one of its bodies.
// Inline, not boxed: the slopes live in a buffer reused across calls.
#[allow(clippy::large_enum_variant)]
#[derive(Clone, Copy, Debug, Default)]
enum Moves {
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
type Slopes = [Moves; 2];

/// Whether the derivative of this module applies: no elliptic cone in its
/// middle zone (that zone's Hessian is not linear in the rows).
pub(super) fn differentiable(c: &Constrained<f64>) -> bool {
    !c.solution.zone.contains(&Zone::Cone)
}

/// Adds the rows' part of dg/dq to `r_q` and of dg/dv to `r_v` (n x n each,
/// column-major, column m the derivative in q_m or v_m) at the solver's
/// acceleration `a`.
/// `data` holds the world frames at the state of `c`.
pub(super) fn add_row_partials(
    tree: &Tree<f64>,
    data: &Data<f64>,
    (v, a): (&[f64], &[f64]),
    c: &Constrained<f64>,
    (r_q, r_v): (&mut [f64], &mut [f64]),
    scratch: &mut Scratch,
) {
    let rows = &c.rows;
    let zone = &c.solution.zone;
    let mut jar = std::mem::take(&mut scratch.jar);
    jar.clear();
    jar.extend((0..rows.len()).map(|i| rows.dot(i, a) - rows.aref[i]));
    let quadratic = |i: &usize| zone[*i] == Zone::Quadratic;
    for i in (0..rows.len()).filter(quadratic) {
        rows.add_outer(r_v, rows.damping[i] / rows.r[i], i);
    }
    let contacts_start = rows.contact_rows.first().map_or(rows.len(), |r| r.0);
    for i in (0..contacts_start).filter(quadratic) {
        if rows.kind[i] == RowKind::Unilateral {
            let k = rows
                .row(i)
                .iter()
                .position(|x| *x != 0.0)
                .expect("a limit row");
            r_q[k * tree.nv() + k] -=
                (rows.dlog_r_ddist[i] * jar[i] + rows.daref_ddist[i]) / rows.r[i];
        }
    }
    let mut slopes = std::mem::take(&mut scratch.slopes);
    find_slopes(tree, data, &c.contacts, (&mut slopes, &mut scratch.pre));
    let elliptic = tree.constraint.solver.cone == Cone::Elliptic;
    for ((contact, &span), slopes) in c.contacts.iter().zip(&rows.contact_rows).zip(&slopes) {
        let live = (span.0..span.0 + span.1).any(|i| zone[i] != Zone::Free);
        if live {
            let point = ContactPoint {
                contact,
                span,
                mix: mixing(contact.params.condim, elliptic, &contact.params.friction),
                slopes,
            };
            let point_rows = (rows, &zone[..], &c.solution.force[..], &jar[..]);
            point.add_partials(tree, data, (v, a), point_rows, (scratch, r_q));
        }
    }
    (scratch.jar, scratch.slopes) = (jar, slopes);
}

/// Adds the rows' part of dg/dp to `column` for a parameter that moves only
/// MuJoCo's invweight0 constants among the rows' data (a body's mass, COM or
/// inertia, a joint's armature), along `slopes`: every R is proportional to
/// its invweight0 constant (a dry friction's or a limit's dof, a contact's
/// two bodies' translational ones, R_i at its floor excepted), so with
/// f = -D jar on the quadratic rows, -J^T df = sum_i J_i^T f_i dlnR_i.
pub(super) fn add_invweight_partials(
    tree: &Tree<f64>,
    c: &Constrained<f64>,
    (d_body, d_dof): (&[[f64; 2]], &[f64]),
    column: &mut [f64],
) {
    let rows = &c.rows;
    let consts = &tree.constraint;
    let log_slope = |w: f64, dw: f64| if w > 0.0 { dw / w } else { 0.0 };
    let mut dlog_r = vec![0.0; rows.len()];
    let contacts_start = rows.contact_rows.first().map_or(rows.len(), |r| r.0);
    for (i, d) in dlog_r.iter_mut().enumerate().take(contacts_start) {
        let k = rows
            .row(i)
            .iter()
            .position(|x| *x != 0.0)
            .expect("a dof's row");
        *d = log_slope(consts.dof_invweight[k], d_dof[k]);
    }
    for (contact, &(first, count)) in c.contacts.iter().zip(&rows.contact_rows) {
        let [b1, b2] = contact.bodies;
        let tran = consts.body_invweight[b1][0] + consts.body_invweight[b2][0];
        dlog_r[first..first + count].fill(log_slope(tran, d_body[b1][0] + d_body[b2][0]));
    }
    for (i, d) in dlog_r.iter().enumerate() {
        if c.solution.zone[i] == Zone::Quadratic && rows.r[i] > MINVAL && *d != 0.0 {
            let w = c.solution.force[i] * d;
            for (x, j) in column.iter_mut().zip(rows.row(i)) {
                *x += j * w;
            }
        }
    }
}

/// One contact and what its derivative reads.
struct ContactPoint<'a> {
    contact: &'a ConstraintContact<f64>,
    /// Its first row and number of rows.
    span: (usize, usize),
    mix: Mixing<f64>,
    slopes: &'a Slopes,
}

impl ContactPoint<'_> {
    /// The unit wrench of frame row k (see the module documentation).
    fn wrench(&self, k: usize) -> Force<f64> {
        let (p, frame) = (&self.contact.pos, &self.contact.frame);
        let e = |r: usize| frame.row(r).transpose();
        if k < 3 {
            Force::new(p.cross(&e(k)), e(k))
        } else {
            Force::new(e(k - 3), Vector3::zeros())
        }
    }

    /// The terms of `slope` (see [`Along`]). With E_k = (p x e_k, e_k) for
    /// a force row and (e_{k-3}, 0) for a moment row, a motion W = (w, u)
    /// gives W . dE_k = dp . (e_k x w) + de_k . (u + w x p), resp.
    /// w . de_{k-3}; and sum_k phi_k dE_k = (dp x f + p x df + dm, df) with
    /// f = sum_{k<3} phi_k e_k, df = sum_{k<3} phi_k de_k and
    /// dm = sum_{k>=3} phi_k de_{k-3}.
    fn along(&self, slope: &Slope, at: &AtPoint) -> Along {
        let de = |r: usize| slope.de.row(r).transpose();
        let mut out = Along {
            ddist: slope.ddist,
            ..Along::default()
        };
        let (mut df, mut dm) = (Vector3::zeros(), Vector3::zeros());
        for k in 0..at.dim {
            let de_k = de(k % 3);
            if k < 3 {
                out.a_de[k] = slope.dp.dot(&at.e_cross[0][k]) + de_k.dot(&at.point[0]);
                out.v_de[k] = slope.dp.dot(&at.e_cross[1][k]) + de_k.dot(&at.point[1]);
                df += de_k * at.phi[k];
            } else {
                out.a_de[k] = at.w[0].ang.dot(&de_k);
                out.v_de[k] = at.w[1].ang.dot(&de_k);
                dm += de_k * at.phi[k];
            }
        }
        let p = &self.contact.pos;
        out.phi_de = Force::new(slope.dp.cross(&at.f) + p.cross(&df) + dm, df);
        out
    }

    /// Adds the contact's part of dg/dq to `r_q` (see the module documentation).
    /// A change of q_m moves the contact along the twist S_m: in closed form
    /// against a static plane, else as the combination c_t = u_t . S_m of
    /// the basis twists of the bodies m moves, whatever is linear in the
    /// motion formed once per basis twist.
    fn add_partials(
        &self,
        tree: &Tree<f64>,
        data: &Data<f64>,
        (v, a): (&[f64], &[f64]),
        (rows, zone, force, jar): (&Rows<f64>, &[Zone], &[f64], &[f64]),
        (scratch, r_q): (&mut Scratch, &mut [f64]),
    ) {
        let n = tree.nv();
        let dim = self.contact.params.condim;
        let (first, count) = self.span;
        let sign = [-1.0, 1.0];
        let Scratch {
            on,
            below_a,
            below_v,
            along,
            path,
            ..
        } = scratch;
        on.clear();
        on.resize(n, 0);
        below_a.clear();
        below_a.resize(n, Motion::zero());
        below_v.clear();
        below_v.resize(n, Motion::zero());
        // Which bodies' paths each dof is on (bit 0: b1, bit 1: b2); per dof m
        // W_m(a) and W_m(v); W(a) and W(v).
        let (mut w_a, mut w_v) = (Motion::zero(), Motion::zero());
        for side in 0..2 {
            let (mut run_a, mut run_v) = (Motion::zero(), Motion::zero());
            let mut k = tree.body[self.contact.bodies[side]].node;
            while let Some(j) = k {
                on[j] |= 1 << side;
                let s = data.world_axis[j];
                run_a += s * a[j];
                run_v += s * v[j];
                below_a[j] += run_a * sign[side];
                below_v[j] += run_v * sign[side];
                k = tree.parent[j];
            }
            w_a += run_a * sign[side];
            w_v += run_v * sign[side];
        }
        let mut wrenches = [Force::zero(); 6];
        for (k, e) in wrenches.iter_mut().enumerate().take(dim) {
            *e = self.wrench(k);
        }
        // phi = c^T f and F.
        let mut phi = [0.0; 6];
        for (i, mix) in self.mix.iter().enumerate() {
            for k in 0..dim {
                phi[k] += mix[k] * force[first + i];
            }
        }
        let total = (0..dim).fold(Force::zero(), |s, k| s + wrenches[k] * phi[k]);
        let (p, frame) = (&self.contact.pos, &self.contact.frame);
        let e = |k: usize| frame.row(k).transpose();
        let at = AtPoint {
            dim,
            w: [w_a, w_v],
            e_cross: [w_a, w_v].map(|w| [0, 1, 2].map(|k| e(k).cross(&w.ang))),
            point: [w_a, w_v].map(|w| w.lin + w.ang.cross(p)),
            phi,
            f: (0..dim.min(3)).fold(Vector3::zeros(), |f, k| f + e(k) * phi[k]),
        };
        // Per row i, df_i = D_i (dlnR_i jar_i + daref_i) ddist - D_i d(J_i a)
        // - D_i B_i d(J_i v) (zero off the quadratic zone), with d(J_i x) = c_i . du(x);
        // so psi = c^T df = by_dist ddist - by_a du(a) - by_v du(v), the
        // gains summed over the rows once per contact.
        let mut by_dist = [0.0; 6];
        let (mut by_a, mut by_v) = ([[0.0; 6]; 6], [[0.0; 6]; 6]);
        for (row, mix) in (first..first + count).zip(self.mix.iter()) {
            if zone[row] == Zone::Quadratic {
                let d = 1.0 / rows.r[row];
                let dist = d * (rows.dlog_r_ddist[row] * jar[row] + rows.daref_ddist[row]);
                let damped = d * rows.damping[row];
                for k in 0..dim {
                    by_dist[k] += mix[k] * dist;
                    for l in 0..dim {
                        by_a[k][l] += mix[k] * d * mix[l];
                        by_v[k][l] += mix[k] * damped * mix[l];
                    }
                }
            }
        }
        // Per basis twist (side, u) the slopes' terms, combined per dof below.
        along.clear();
        for (side, moves) in self.slopes.iter().enumerate() {
            if let Moves::Basis { len, basis, slopes } = moves {
                for (u, slope) in basis.iter().zip(slopes).take(*len) {
                    along.push((side, *u, self.along(slope, &at)));
                }
            }
        }
        // The dofs on exactly one body's path (those on both move neither
        // body relative to the other): which body's, and its sign.
        path.clear();
        path.extend(
            (0..n)
                .filter(|&j| on[j] == 1 || on[j] == 2)
                .map(|j| (j, on[j], sign[usize::from(on[j] == 2)])),
        );
        for m in (0..n).filter(|&m| on[m] != 0) {
            let s_m = data.world_axis[m];
            let twist = [
                s_m.ang.x, s_m.ang.y, s_m.ang.z, s_m.lin.x, s_m.lin.y, s_m.lin.z,
            ];
            // Against a static plane (b1) in closed form; else the basis
            // twists' terms of the bodies m moves, combined.
            let slope = match &self.slopes[1] {
                Moves::Plane(on_plane) => {
                    self.along(&on_plane.slope(&self.contact.frame, &twist), &at)
                }
                _ => {
                    let mut slope = Along::default();
                    let moved = along.iter().filter(|(side, ..)| on[m] & (1 << side) != 0);
                    for (_, u, t) in moved {
                        slope.add(t, dot(u, &twist));
                    }
                    slope
                }
            };
            let (turn_a, turn_v) = (s_m.cross_motion(&below_a[m]), s_m.cross_motion(&below_v[m]));
            let mut du_a = [0.0; 6];
            let mut du_v = [0.0; 6];
            for k in 0..dim {
                du_a[k] = slope.a_de[k] + turn_a.dot(&wrenches[k]);
                du_v[k] = slope.v_de[k] + turn_v.dot(&wrenches[k]);
            }
            let mut dtotal = slope.phi_de;
            for k in 0..dim {
                let mut psi = by_dist[k] * slope.ddist;
                for l in 0..dim {
                    psi -= by_a[k][l] * du_a[l] + by_v[k][l] * du_v[l];
                }
                dtotal += wrenches[k] * psi;
            }
            // (S_m x S_j) . F = -S_j . (S_m x* F): one force per m for every j.
            let turned = dtotal - s_m.cross_force(&total);
            let column = &mut r_q[m * n..(m + 1) * n];
            for &(j, bits, sign_j) in path.iter() {
                let below = on[m] & bits != 0 && m <= j;
                let term = data.world_axis[j].dot(if below { &turned } else { &dtotal });
                column[j] -= sign_j * term;
            }
        }
    }
}

/// What a contact's derivative forms from its slope along a twist: the
/// distance's slope, W(a) . dE_k and W(v) . dE_k, and sum_k phi_k dE_k, for
/// the change dE_k of the unit wrenches along the twist; linear in the twist.
#[derive(Clone, Copy, Debug, Default)]
struct Along {
    ddist: f64,
    a_de: [f64; 6],
    v_de: [f64; 6],
    phi_de: Force<f64>,
}

impl Along {
    /// self += c other
    fn add(&mut self, other: &Along, c: f64) {
        self.ddist += c * other.ddist;
        for k in 0..6 {
            self.a_de[k] += c * other.a_de[k];
            self.v_de[k] += c * other.v_de[k];
        }
        self.phi_de += other.phi_de * c;
    }
}

/// What [`ContactPoint::along`] reads of a contact: the motions W(a) and
/// W(v), for each the cross products e_k x w (k < 3) and the linear motion
/// at the contact's point u + w x p; the rows' multipliers phi = c^T f and
/// their force f = sum_{k<3} phi_k e_k.
struct AtPoint {
    dim: usize,
    w: [Motion<f64>; 2],
    e_cross: [[Vector3<f64>; 3]; 2],
    point: [Vector3<f64>; 2],
    phi: [f64; 6],
    f: Vector3<f64>,
}

/// The buffers of [`add_row_partials`], kept across calls: the rows'
/// residuals, every contact's slopes, and [`ContactPoint::add_partials`]'s
/// per-dof and per-basis-twist buffers, reused across contacts.
#[derive(Clone, Debug, Default)]
pub(super) struct Scratch {
    jar: Vec<f64>,
    slopes: Vec<Slopes>,
    pre: Vec<Pre<Dual64>>,
    on: Vec<u8>,
    below_a: Vec<Motion<f64>>,
    below_v: Vec<Motion<f64>>,
    along: Vec<(usize, [f64; 6], Along)>,
    path: Vec<(usize, u8, f64)>,
}

/// How every contact moves, into `out`: against a static plane in closed
/// form ([`OnPlane`]); else per pair the collider run on dual
/// numbers along each basis twist of each moving body, its contacts matched
/// to the state's in order (the same branches, so the same contacts).
fn find_slopes(
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
        let pair = &tree.constraint.pairs[index];
        let geoms = pair.geoms.map(|g| &tree.geoms[g]);
        let poses = geoms.map(|g| g.pose(&data.world));
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
                let touches = contact_geometry(shapes, dual, reach, pre)
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
struct OnPlane {
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
    fn slope(&self, frame: &Matrix3<f64>, twist: &[f64; 6]) -> Slope {
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

/// The radius r and the hint h (zero for none) of [`OnPlane`] for a sphere,
/// a capsule or a box at `pose`; None for other shapes.
fn fixed_sphere(shape: &Shape, pose: &Transform<f64>) -> Option<(f64, Vector3<f64>)> {
    match *shape {
        Shape::Sphere { radius } => Some((radius, Vector3::zeros())),
        Shape::Capsule { radius, .. } => Some((radius, pose.axes().column(2).into())),
        Shape::Box { .. } => Some((0.0, Vector3::zeros())),
        _ => None,
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

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

#[cfg(test)]
mod tests {
    use super::super::constrained::dual_columns;
    use super::super::{step_jacobians, Workspace, Wrt};
    use crate::model::{Integrator, Param};
    use crate::Model;

    /// The analytic state, control and parameter columns (every body and
    /// joint parameter) equal the dual numbers' through the whole step, along
    /// trajectories in contact (every collider, both cones, limits, dry
    /// friction; Euler and RK4).
    #[test]
    fn analytic_columns_equal_dual_numbers_through_the_step() {
        let dir = env!("CARGO_MANIFEST_DIR");
        for file in [
            "reference_models/half_cheetah.xml",
            "tests/data/contact_features_pyramidal.xml",
            "tests/data/contact_features_elliptic.xml",
        ] {
            for integrator in [Integrator::Euler, Integrator::Rk4] {
                let model = Model::load(format!("{dir}/{file}"))
                    .and_then(|m| m.edited(|s| s.opt.integrator = integrator))
                    .unwrap();
                let n = model.nv();
                let mut data = model.data();
                let mut ws = Workspace::new(&model);
                let (mut q, mut v) = (model.reference_q(), vec![0.0; n]);
                // The last body's and joint's parameters of every kind.
                let mut params: Vec<Param> = vec![];
                for p in Param::all(&model).into_iter().rev() {
                    let kind = std::mem::discriminant(&p);
                    if !p.is_constraint()
                        && !params.iter().any(|q| std::mem::discriminant(q) == kind)
                    {
                        params.push(p);
                    }
                }
                let wrt = Wrt {
                    state: true,
                    control: true,
                    params: &params,
                };
                let mut checked = 0;
                for k in 0..240 {
                    let tau: Vec<f64> = (0..n)
                        .map(|i| 0.02 * (0.3 * (k + i) as f64).sin())
                        .collect();
                    if k % 48 == 0 && !model.contacts(&mut data, &q, &v, &tau).unwrap().is_empty() {
                        let x = (&q[..], &v[..], &tau[..]);
                        let j = step_jacobians(&model, &mut ws, x, &wrt).unwrap();
                        let mut duals = Default::default();
                        let (dq, dv) = dual_columns(&model, &mut duals, x, &wrt).unwrap();
                        let analytic = [
                            (&j.dq_dq, 0, &dq),
                            (&j.dq_dv, n, &dq),
                            (&j.dq_dtau, 2 * n, &dq),
                            (&j.dq_dp, 3 * n, &dq),
                            (&j.dv_dq, 0, &dv),
                            (&j.dv_dv, n, &dv),
                            (&j.dv_dtau, 2 * n, &dv),
                            (&j.dv_dp, 3 * n, &dv),
                        ];
                        for (block, start, dual) in analytic {
                            let dual = dual.columns(start, block.ncols());
                            let scale = dual.amax().max(1.0);
                            let err = (block - dual).amax() / scale;
                            assert!(err < 1e-9, "{file} {integrator:?} step {k}: {err:e}");
                        }
                        checked += 1;
                    }
                    (q, v) = model.step(&mut data, &q, &v, &tau).unwrap();
                }
                assert!(checked >= 3, "{file}: {checked} states in contact");
            }
        }
    }
}
