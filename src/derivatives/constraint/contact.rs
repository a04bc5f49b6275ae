//! A contact's rows' partials in q and in the invweight0 constants.
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
//!   one run per direction of a basis of a moving body's twists: module
//!   `slopes`);
//! - moves aref = -B J v - K imp(x) x and R (proportional to (1 - imp) / imp)
//!   with the distance ([`Rows`] records both slopes).
//!
//! So with df_i = D_i (dlnR_i jar_i + daref_i) ddist - D_i (d(J_i a) + B_i d(J_i v)),
//! d(J^T f)_j = sigma_j [(S_m x S_j) . F + S_j . (sum_k psi_k E_k + phi_k dE_k)],
//! psi = c^T df, the first term for m at or above j on j's path.
//!
//! Every R of a contact is proportional to the sum of its two bodies'
//! translational body_invweight0.

use std::ops::Range;

use nalgebra::Vector3;

use super::slopes::{dot, Moves, Slope, Slopes};
use super::{log_slope, Scratch};
use crate::dynamics::collision::ConstraintContact;
use crate::dynamics::constraint::solver::Zone;
use crate::dynamics::constraint::{mixing, ConstraintConsts, Mixing, Rows};
use crate::dynamics::{Constrained, Data, Tree};
use crate::model::Cone;
use crate::spatial::{Force, Motion};

/// Adds the part of dg/dq of contact `id` of `c`, whose rows are `range`,
/// to `r_q` (see the module documentation); nothing while all its rows are
/// free. `slopes`: how it moves with its bodies; `jar`: J a - aref per row.
pub(super) fn add_state_partials(
    tree: &Tree<f64>,
    data: &Data<f64>,
    (v, a): (&[f64], &[f64]),
    (c, id, range): (&Constrained<f64>, usize, Range<usize>),
    (slopes, jar): (&Slopes, &[f64]),
    (scratch, r_q): (&mut Scratch, &mut [f64]),
) {
    let zone = &c.solution.zone;
    if range.clone().all(|i| zone[i] == Zone::Free) {
        return;
    }
    let contact = &c.contacts[id];
    let elliptic = tree.opt.solver.cone == Cone::Elliptic;
    let point = ContactPoint {
        contact,
        span: (range.start, range.len()),
        mix: mixing(contact.params.condim, elliptic, &contact.params.friction),
        slopes,
    };
    let point_rows = (&c.rows, &zone[..], &c.solution.force[..], jar);
    point.add_partials(tree, data, (v, a), point_rows, (scratch, r_q));
}

/// d ln R / dp of a contact's rows along the invweight0 slopes `d_body`.
pub(super) fn invweight_log_slope(
    consts: &ConstraintConsts<f64>,
    contact: &ConstraintContact<f64>,
    d_body: &[[f64; 2]],
) -> f64 {
    let [b1, b2] = contact.bodies;
    let tran = consts.body_invweight[b1][0] + consts.body_invweight[b2][0];
    log_slope(tran, d_body[b1][0] + d_body[b2][0])
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
pub(super) struct Along {
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
