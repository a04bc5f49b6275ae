//! Joint limit rows (MuJoCo's mj_instantiateLimit, efc_type
//! mjCNSTR_LIMIT_JOINT) of hinges and slides: per limited dof i, one row
//! per side within the margin: J = +e_i below the range (dist = q - lo) and
//! -e_i above it (dist = hi - q), while dist < margin; A_ii =
//! dof_invweight0 of dof i (see [`impedance`](mod@super::impedance)).

use super::impedance::Block;
use super::{At, ConstraintKind, Origin, RowKind, Rows};
use crate::model::SolParams;
use crate::spatial::{lift, Real};

/// A joint limit: the range, the margin within which its rows exist, and
/// its solver parameters.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Limit<T: Real> {
    pub range: (f64, f64),
    pub margin: f64,
    pub sol: SolParams<T>,
}

/// Appends the limit rows, dof by dof, the lower side first.
pub(super) fn append<T: Real>(at: &At<T>, rows: &mut Rows<T>) {
    let (tree, consts) = (at.tree, &at.tree.constraint);
    for i in 0..tree.nv() {
        let Some(Limit {
            range: (lo, hi),
            margin,
            sol,
        }) = consts.limits[i]
        else {
            continue;
        };
        let x = at.q[tree.joint[i]
            .coordinate()
            .expect("limits are on hinges and slides")];
        for (dist, sign) in [(x - lift(lo), T::one()), (lift::<T>(hi) - x, -T::one())] {
            if dist < lift(margin) {
                rows.unit(i, sign);
                let origin = Origin {
                    kind: ConstraintKind::JointLimit,
                    id: i,
                };
                push_side(
                    at,
                    (origin, consts.dof_invweight[i]),
                    (dist, margin, sol),
                    rows,
                );
            }
        }
    }
}

/// Pushes the limit row (one side) just appended to J: its origin and
/// A_ii, its distance, margin and solver parameters.
pub(super) fn push_side<T: Real>(
    at: &At<T>,
    (origin, diag): (Origin, T),
    (dist, margin, sol): (T, f64, SolParams<T>),
    rows: &mut Rows<T>,
) {
    let block = Block {
        origin,
        kind: &[RowKind::Unilateral],
        diag: &[diag],
        dist,
        pos: None,
        margin,
        sol,
        floss: T::zero(),
    };
    rows.push(block, at.v, &at.tree.opt, None);
}
