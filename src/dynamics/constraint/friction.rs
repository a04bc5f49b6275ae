//! Dry friction rows (MuJoCo's mj_instantiateFriction, efc_type
//! mjCNSTR_FRICTION_DOF): one row J = e_i per dof i with `frictionloss` > 0,
//! its force bounded by the frictionloss; A_ii = dof_invweight0 of dof i;
//! no distance (dist = margin = 0), and K = 0 (see
//! [`impedance`](mod@super::impedance)).

use super::impedance::Block;
use super::{At, ConstraintKind, Origin, RowKind, Rows};
use crate::model::SolParams;
use crate::spatial::Real;

/// Appends the dry friction rows, dof by dof.
pub(super) fn append<T: Real>(at: &At<T>, rows: &mut Rows<T>) {
    let consts = &at.tree.constraint;
    for i in 0..at.tree.nv() {
        let (floss, sol) = consts.frictionloss[i];
        if floss > T::zero() {
            rows.unit(i, T::one());
            let origin = Origin {
                kind: ConstraintKind::DofFriction,
                id: i,
            };
            push(at, (origin, consts.dof_invweight[i]), (floss, sol), rows);
        }
    }
}

/// Pushes the dry friction row just appended to J: its origin and A_ii,
/// its bound and solver parameters.
pub(super) fn push<T: Real>(
    at: &At<T>,
    (origin, diag): (Origin, T),
    (floss, sol): (T, SolParams<T>),
    rows: &mut Rows<T>,
) {
    let block = Block {
        origin,
        kind: &[RowKind::Friction],
        diag: &[diag],
        dist: T::zero(),
        pos: None,
        margin: 0.0,
        sol,
        floss,
    };
    rows.push(block, at.v, &at.tree.opt, None);
}
