//! Tendon rows (MuJoCo's mj_instantiateFriction and mj_instantiateLimit
//! for tendons), each with J the tendon's moment (J_t, nv) and A_ii its
//! tendon_invweight0 ([`crate::dynamics::tendon`]):
//! The tendons' lengths and moments are their states at the rows' state
//! (`Data::tendon`).
//! - dry friction (efc_type mjCNSTR_FRICTION_TENDON): one row J_t per
//!   tendon with `frictionloss` > 0, its force bounded by it; no distance;
//! - limits (mjCNSTR_LIMIT_TENDON): per limited tendon of length L, one row
//!   per side within the margin: J = +J_t below the range (dist = L - lo),
//!   -J_t above it (dist = hi - L).
//!
//! The origin's id is the tendon's index in the model.

use super::limit::{self, Limit};
use super::{friction, At, ConstraintKind, Origin, Rows};
use crate::dynamics::{TendonConsts, TendonState};
use crate::spatial::{lift, Real};

/// Appends J = sign J_t for tendon `t` at its state `s`.
fn push_moment<T: Real>(rows: &mut Rows<T>, (t, s): (&TendonConsts<T>, &TendonState<T>), sign: T) {
    let start = rows.j.len();
    rows.j.resize(start + rows.nv, T::zero());
    s.add_moment(sign, &t.support, &mut rows.j[start..]);
    rows.moving(1, t.dofs().iter().copied());
}

/// Appends the tendons' dry friction rows, tendon by tendon.
pub(super) fn append_friction<T: Real>(at: &At<T>, rows: &mut Rows<T>) {
    for (id, (t, s)) in at.tree.tendons.iter().zip(&at.data.tendon).enumerate() {
        let (floss, sol) = t.frictionloss;
        if floss > T::zero() {
            push_moment(rows, (t, s), T::one());
            let origin = Origin {
                kind: ConstraintKind::TendonFriction,
                id,
            };
            friction::push(at, (origin, t.invweight), (floss, sol), rows);
        }
    }
}

/// Appends the tendons' limit rows, tendon by tendon, the lower side first.
pub(super) fn append_limits<T: Real>(at: &At<T>, rows: &mut Rows<T>) {
    for (id, (t, s)) in at.tree.tendons.iter().zip(&at.data.tendon).enumerate() {
        let Some(Limit {
            range: (lo, hi),
            margin,
            sol,
        }) = t.limit
        else {
            continue;
        };
        let l = s.length;
        for (dist, sign) in [(l - lift(lo), T::one()), (lift::<T>(hi) - l, -T::one())] {
            if dist < lift(margin) {
                push_moment(rows, (t, s), sign);
                let origin = Origin {
                    kind: ConstraintKind::TendonLimit,
                    id,
                };
                limit::push_side(at, (origin, t.invweight), (dist, margin, sol), rows);
            }
        }
    }
}
