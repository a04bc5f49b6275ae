//! Derivatives of the soft contact and joint-limit forces tau_soft(q, v; k, c, mu)
//! (see [`crate::dynamics::contact`]), by forward-mode dual numbers: the
//! scalar-generic force code runs once per direction (each q_j, each v_j,
//! each contact parameter) on a dual-number copy of the tree. Exact, not fast:
//! 2 nv + 3 passes of kinematics and collision at most. The other parameters
//! (inertial, joint) do not enter tau_soft.

use nalgebra::DMatrix;
use num_dual::Dual64;

use crate::dynamics::{add_soft_forces, Data, Tree};
use crate::model::{Model, Param};

/// Where the columns of a residual Jacobian live: q and v (each nv wide, at
/// 0 and `v_start`) if the state is asked for, and the first column of each
/// parameter in `params`.
pub(super) struct Columns<'a> {
    pub state: bool,
    pub v_start: usize,
    pub params: &'a [(Param, usize)],
}

/// Subtracts d tau_soft / d(column) from each column of `r` (the residual R
/// holds -tau_soft). Does nothing for a model without soft forces.
pub(super) fn subtract_soft_derivatives(
    model: &Model,
    (q, v): (&[f64], &[f64]),
    columns: &Columns,
    r: &mut DMatrix<f64>,
) {
    if !model.tree().has_soft_forces() {
        return;
    }
    let n = model.nv();
    let mut tree: Tree<Dual64> = Tree::build(model);
    let mut data = Data::new(&tree);
    let mut qd: Vec<Dual64> = q.iter().map(|&x| Dual64::from(x)).collect();
    let mut vd: Vec<Dual64> = v.iter().map(|&x| Dual64::from(x)).collect();
    let mut out = vec![Dual64::from(0.0); n];
    let mut subtract = |tree: &Tree<Dual64>, qd: &[Dual64], vd: &[Dual64], col: usize| {
        out.fill(Dual64::from(0.0));
        add_soft_forces(tree, &mut data, (qd, vd), &mut out);
        for (i, f) in out.iter().enumerate() {
            r[(i, col)] -= f.eps;
        }
    };
    if columns.state {
        for j in 0..n {
            qd[j].eps = 1.0;
            subtract(&tree, &qd, &vd, j);
            qd[j].eps = 0.0;
            vd[j].eps = 1.0;
            subtract(&tree, &qd, &vd, columns.v_start + j);
            vd[j].eps = 0.0;
        }
    }
    for &(param, col) in columns.params {
        let soft = &mut tree.soft;
        let seeded = match param {
            Param::ContactStiffness => &mut soft.stiffness,
            Param::ContactDamping => &mut soft.damping,
            Param::ContactFriction => &mut soft.friction,
            _ => continue,
        };
        seeded.eps = 1.0;
        subtract(&tree, &qd, &vd, col);
        let soft = &mut tree.soft;
        (soft.stiffness.eps, soft.damping.eps, soft.friction.eps) = (0.0, 0.0, 0.0);
    }
}
