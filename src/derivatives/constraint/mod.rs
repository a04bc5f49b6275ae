//! The constraint rows' part of the implicit derivative of the constraint
//! model's acceleration, in the state and in the invweight0 constants.
//!
//! The solver's acceleration a zeroes the gradient of its cost
//! ([`crate::dynamics::constraint::solver`]):
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
//! Rows are differentiated by their origin ([`Origin`]), never by their
//! position: each kind's partials are in its file (`friction`, `limit`,
//! `contact` with `slopes`), dispatched here. A kind without analytic
//! partials is refused by [`differentiable`] (the step's Jacobians then come
//! from dual numbers, exact). Common to every row: in v only aref moves,
//! d f / dv = -D B J; and R is proportional to an invweight0 constant of its
//! kind's (see [`add_invweight_partials`]).

mod contact;
mod friction;
mod limit;
mod slopes;

use num_dual::Dual64;

use crate::dynamics::collision::{Pre, MINVAL};
use crate::dynamics::constraint::solver::Zone;
use crate::dynamics::constraint::{ConstraintKind, Origin};
use crate::dynamics::{Constrained, Data, Tree};
use crate::spatial::Motion;
use slopes::{find_slopes, Slopes};

/// Whether the derivative of this module applies: every row of a kind with
/// analytic partials ([`analytic`]), no elliptic cone in its middle zone
/// (that zone's Hessian is not linear in the rows), no noslip sweep after
/// the solver (its forces are not the optimum's; dual numbers carry the
/// derivative through the sweeps).
pub(super) fn differentiable(c: &Constrained<f64>) -> bool {
    let s = &c.solution;
    !s.noslip && !s.zone.contains(&Zone::Cone) && c.rows.origin.iter().all(|o| analytic(o.kind))
}

/// Whether rows of `kind` have their partials here (in q and in the
/// invweight0 constants); a new kind is false until they are written.
fn analytic(kind: ConstraintKind) -> bool {
    match kind {
        ConstraintKind::DofFriction | ConstraintKind::JointLimit | ConstraintKind::Contact => true,
        ConstraintKind::Equality | ConstraintKind::TendonFriction | ConstraintKind::TendonLimit => {
            false
        }
    }
}

/// Adds the rows' part of dg/dq to `r_q` and of dg/dv to `r_v` (n x n each,
/// column-major, column m the derivative in q_m or v_m) at the solver's
/// acceleration `a`, for `c` [`differentiable`].
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
    let mut slopes = std::mem::take(&mut scratch.slopes);
    find_slopes(tree, data, &c.contacts, (&mut slopes, &mut scratch.pre));
    for (Origin { kind, id }, range) in rows.by_origin() {
        match kind {
            ConstraintKind::Equality
            | ConstraintKind::TendonFriction
            | ConstraintKind::TendonLimit => {
                unreachable!("equality and tendon rows take the dual path")
            }
            ConstraintKind::DofFriction => {}
            ConstraintKind::JointLimit => {
                limit::add_state_partials(tree.nv(), (c, id, range), &jar, r_q);
            }
            ConstraintKind::Contact => {
                let (at, moves) = ((c, id, range), (&slopes[id], &jar[..]));
                contact::add_state_partials(tree, data, (v, a), at, moves, (scratch, r_q));
            }
        }
    }
    (scratch.jar, scratch.slopes) = (jar, slopes);
}

/// Adds the rows' part of dg/dp to `column` for a parameter that moves only
/// MuJoCo's invweight0 constants among the rows' data (a body's mass, COM or
/// inertia, a joint's armature), along `slopes`, for `c` [`differentiable`]:
/// every R is proportional to its invweight0 constant (a dry friction's or
/// a limit's dof, a contact's two bodies' translational ones, R_i at its
/// floor excepted), so with f = -D jar on the quadratic rows,
/// -J^T df = sum_i J_i^T f_i dlnR_i.
pub(super) fn add_invweight_partials(
    tree: &Tree<f64>,
    c: &Constrained<f64>,
    (d_body, d_dof): (&[[f64; 2]], &[f64]),
    column: &mut [f64],
) {
    let rows = &c.rows;
    let consts = &tree.constraint;
    let mut dlog_r = vec![0.0; rows.len()];
    for (Origin { kind, id }, range) in rows.by_origin() {
        dlog_r[range].fill(match kind {
            ConstraintKind::Equality
            | ConstraintKind::TendonFriction
            | ConstraintKind::TendonLimit => {
                unreachable!("equality and tendon rows take the dual path")
            }
            ConstraintKind::DofFriction | ConstraintKind::JointLimit => {
                friction::dof_log_slope(consts, d_dof, id)
            }
            ConstraintKind::Contact => {
                contact::invweight_log_slope(consts, &c.contacts[id], d_body)
            }
        });
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

/// d ln w / dp = dw / w of a positive constant w (0 for w = 0).
fn log_slope(w: f64, dw: f64) -> f64 {
    if w > 0.0 {
        dw / w
    } else {
        0.0
    }
}

/// The buffers of [`add_row_partials`], kept across calls: the rows'
/// residuals, every contact's slopes, and the contacts' per-dof and
/// per-basis-twist buffers (module `contact`), reused across contacts.
#[derive(Clone, Debug, Default)]
pub(super) struct Scratch {
    jar: Vec<f64>,
    slopes: Vec<Slopes>,
    pre: Vec<Pre<Dual64>>,
    on: Vec<u8>,
    below_a: Vec<Motion<f64>>,
    below_v: Vec<Motion<f64>>,
    along: Vec<(usize, [f64; 6], contact::Along)>,
    path: Vec<(usize, u8, f64)>,
}

#[cfg(test)]
mod tests {
    use super::super::constrained::dual_columns;
    use super::super::{step_jacobians, Workspace, Wrt};
    use super::*;
    use crate::dynamics::acceleration;
    use crate::model::{Inputs, State};
    use crate::model::{Integrator, Param};
    use crate::Model;

    /// `c` with its rows in another order: the kinds of
    /// [`ConstraintKind::ORDER`] reversed (contacts first), each
    /// constraint's rows kept together.
    fn reversed_kinds(c: &Constrained<f64>) -> Constrained<f64> {
        let mut blocks: Vec<_> = c.rows.by_origin().collect();
        blocks.sort_by_key(|(o, _)| std::cmp::Reverse(rank_of(o.kind)));
        let order: Vec<usize> = blocks.into_iter().flat_map(|(_, r)| r).collect();
        fn permuted<X: Copy>(x: &[X], order: &[usize]) -> Vec<X> {
            order.iter().map(|&i| x[i]).collect()
        }
        let (rows, mut out) = (&c.rows, c.clone());
        out.rows.j = order.iter().flat_map(|&i| rows.row(i).to_vec()).collect();
        out.rows.span = permuted(&rows.span, &order);
        out.rows.kind = permuted(&rows.kind, &order);
        out.rows.origin = permuted(&rows.origin, &order);
        out.rows.aref = permuted(&rows.aref, &order);
        out.rows.r = permuted(&rows.r, &order);
        out.rows.floss = permuted(&rows.floss, &order);
        out.rows.damping = permuted(&rows.damping, &order);
        out.rows.daref_ddist = permuted(&rows.daref_ddist, &order);
        out.rows.dlog_r_ddist = permuted(&rows.dlog_r_ddist, &order);
        out.solution.force = permuted(&c.solution.force, &order);
        out.solution.zone = permuted(&c.solution.zone, &order);
        for (first, count) in &mut out.rows.contact_rows {
            if *count > 0 {
                *first = order.iter().position(|i| i == first).unwrap();
            }
        }
        out
    }

    /// The rows' partials in the state and the invweight0 constants do not
    /// depend on the rows' order: they follow each row's origin. States of
    /// a model with dry friction, a limit (started within its margin) and
    /// contacts of both cones, their rows reordered contacts first.
    #[test]
    fn rows_are_differentiated_by_origin_not_position() {
        let dir = env!("CARGO_MANIFEST_DIR");
        for file in ["pyramidal", "elliptic"] {
            let path = format!("{dir}/tests/data/contact_features_{file}.xml");
            let model = Model::load(path).unwrap();
            let (tree, n) = (model.tree(), model.nv());
            let mode = (model.opt.passive, model.opt.timestep);
            let limited = model.joints.iter().position(|j| j.range.is_some()).unwrap();
            let mut data = model.data();
            let (mut q, mut v) = (model.reference_q(), vec![0.0; n]);
            q[limited] = model.joints[limited].range.unwrap().1 - 0.005;
            let tau = vec![0.0; n];
            // Invweight0 slopes with no symmetry.
            let d_body: Vec<[f64; 2]> = (0..model.bodies.len())
                .map(|b| [0.3 + 0.1 * b as f64, 0.2])
                .collect();
            let d_dof: Vec<f64> = (0..n).map(|i| 0.5 - 0.05 * i as f64).collect();
            let mut kinds_seen = [false; ConstraintKind::ORDER.len()];
            for _ in 0..120 {
                let mut qdd = vec![0.0; n];
                acceleration(tree, &mut data, mode, (&q, &v, &tau), &mut qdd);
                let c = data.constrained.clone();
                if let Some(c) = c.filter(differentiable) {
                    let partials = |c: &Constrained<f64>| {
                        let mut r = vec![0.0; 3 * n * n];
                        let (r_q, rest) = r.split_at_mut(n * n);
                        let (r_v, column) = rest.split_at_mut(n * n);
                        let at = (&v[..], &c.solution.qacc[..]);
                        let mut scratch = Scratch::default();
                        add_row_partials(tree, &data, at, c, (r_q, r_v), &mut scratch);
                        add_invweight_partials(tree, c, (&d_body, &d_dof), &mut column[..n]);
                        r
                    };
                    let (plain, reordered) = (partials(&c), partials(&reversed_kinds(&c)));
                    let scale = plain.iter().fold(1.0f64, |m, x| m.max(x.abs()));
                    for (a, b) in plain.iter().zip(&reordered) {
                        assert!((a - b).abs() <= 1e-12 * scale, "{file}: {a} vs {b}");
                    }
                    for (i, o) in c.rows.origin.iter().enumerate() {
                        if c.solution.zone[i] == Zone::Quadratic {
                            kinds_seen[rank_of(o.kind)] = true;
                        }
                    }
                }
                State { q, v, .. } = model
                    .step(&mut data, &State::new(q, v), &Inputs::tau(&tau))
                    .unwrap();
            }
            // Every analytic kind's rows active (equality and tendon rows take dual numbers).
            let expected = ConstraintKind::ORDER.map(analytic);
            assert_eq!(kinds_seen, expected, "{file}: every kind's rows active");
        }
    }

    /// The place of `kind` in the row order.
    fn rank_of(kind: ConstraintKind) -> usize {
        ConstraintKind::ORDER
            .iter()
            .position(|k| *k == kind)
            .unwrap()
    }

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
                    if k % 48 == 0
                        && !model
                            .contacts(
                                &mut data,
                                &State::new(q.to_vec(), v.to_vec()),
                                &Inputs::tau(&tau),
                            )
                            .unwrap()
                            .is_empty()
                    {
                        let x = (&q[..], &v[..], &tau[..]);
                        let j = step_jacobians(&model, &mut ws, x, &wrt).unwrap();
                        let mut duals = Default::default();
                        let (dq, dv) = dual_columns(&model, &mut duals, x, &wrt).unwrap();
                        let analytic = [
                            (j.dq_dq(), 0, &dq),
                            (j.dq_dv(), n, &dq),
                            (j.dq_dtau(), 2 * n, &dq),
                            (j.dq_dp(), 3 * n, &dq),
                            (j.dv_dq(), 0, &dv),
                            (j.dv_dv(), n, &dv),
                            (j.dv_dtau(), 2 * n, &dv),
                            (j.dv_dp(), 3 * n, &dv),
                        ];
                        for (block, start, dual) in analytic {
                            let dual = dual.columns(start, block.ncols());
                            let scale = dual.amax().max(1.0);
                            let err = (block - dual).amax() / scale;
                            assert!(err < 1e-9, "{file} {integrator:?} step {k}: {err:e}");
                        }
                        checked += 1;
                    }
                    State { q, v, .. } = model
                        .step(&mut data, &State::new(q, v), &Inputs::tau(&tau))
                        .unwrap();
                }
                assert!(checked >= 3, "{file}: {checked} states in contact");
            }
        }
    }
}
