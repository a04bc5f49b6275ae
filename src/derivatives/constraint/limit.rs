//! A joint limit row's partials. Its J = +-e_k does not depend on q, its
//! distance is +-q_k + const: only the distance's terms move, aref and R
//! (df = D (dlnR jar + daref) ddist), and (J^T f)_k's derivative in q_k is
//! (+-1)^2 D (dlnR jar + daref) whichever the side. Its R is proportional to
//! dof_invweight0 of dof k, as dry friction's ([`super::friction`]).

use std::ops::Range;

use crate::dynamics::constraint::solver::Zone;
use crate::dynamics::Constrained;

/// Adds the part of dg/dq of the limit rows `range` of dof `dof` to `r_q`
/// (n x n, column-major); `jar`: J a - aref per row.
pub(super) fn add_state_partials(
    n: usize,
    (c, dof, range): (&Constrained<f64>, usize, Range<usize>),
    jar: &[f64],
    r_q: &mut [f64],
) {
    let rows = &c.rows;
    for i in range.filter(|&i| c.solution.zone[i] == Zone::Quadratic) {
        r_q[dof * n + dof] -= (rows.dlog_r_ddist[i] * jar[i] + rows.daref_ddist[i]) / rows.r[i];
    }
}
