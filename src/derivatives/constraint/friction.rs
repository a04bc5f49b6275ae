//! A dry friction row's partials. Its J = e_k and its bound depend on q not
//! at all, and it has no distance: nothing in q. Its R is proportional to
//! dof_invweight0 of dof k (as a limit row's).

use super::log_slope;
use crate::dynamics::constraint::ConstraintConsts;

/// d ln R / dp of a row whose R is proportional to dof_invweight0 of `dof`,
/// along the invweight0 slopes `d_dof`.
pub(super) fn dof_log_slope(consts: &ConstraintConsts<f64>, d_dof: &[f64], dof: usize) -> f64 {
    log_slope(consts.dof_invweight[dof], d_dof[dof])
}
