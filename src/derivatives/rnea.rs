//! Analytic derivatives of inverse dynamics ID(q, v, a) = M(q) a + c(q, v) with
//! respect to q and v, by forward propagation of one dof's perturbation
//! through its subtree (in the spirit of Carpentier & Mansard 2018).
//!
//! In node frames, a change of q_j moves node j's frame (and everything below
//! it) relative to its parent: a vector fixed in the parent, seen from j,
//! changes at the rate -S_j x (.) for motions and -S_j x* (.) for forces. So:
//! - d v_j / d q_j = -S_j x v_j, d a_j / d q_j = -S_j x (X_j a_parent) + (d v_j) x S_j qd_j;
//! - below j, d v_i = X_i d v_parent, d a_i = X_i d a_parent + d v_i x S_i qd_i;
//! - d f_i = I_i d a_i + d v_i x* I_i v_i + v_i x* I_i d v_i;
//! - forces pass to the parent through X_j^T, whose own change adds
//!   X_j^T (S_j x* F_j) at the joint j itself;
//! - d ID_k = S_k . d F_k for every node k on j's subtree and ancestor path.
//!
//! A change of qd_j starts with d v_j = S_j, d a_j = v_j x S_j instead.
//!
//! Where joint j and all its ancestors are slides, q_j only translates the
//! subtree under uniform gravity and every slide above reads only linear
//! forces: column j of dID/dq is zero and is not swept (a floating base's
//! slide joints, as the half cheetah's root).

use nalgebra::{DMatrixViewMut, DVectorViewMut};

#[cfg(doc)]
use crate::dynamics::rnea;
use crate::dynamics::{Data, Tree};
use crate::model::JointKind;
use crate::spatial::{Force, Motion};

/// Per-direction scratch of the sweeps.
#[derive(Clone, Debug)]
pub struct Sweep {
    dv: Vec<Motion<f64>>,
    da: Vec<Motion<f64>>,
    df: Vec<Force<f64>>,
    /// I_i v_i at the point.
    momentum: Vec<Force<f64>>,
    below: Vec<bool>,
    /// Node and all its ancestors are slides.
    translational: Vec<bool>,
    /// d ID of the current direction.
    tau: Vec<f64>,
    /// [`mass_derivative`]'s accelerations and subtree forces of M(q) y.
    acc_y: Vec<Motion<f64>>,
    force_y: Vec<Force<f64>>,
}

impl Sweep {
    /// The node accelerations and subtree forces of M(q) y (no velocity, no
    /// gravity), `data.x_up` at q; the accelerations read back by
    /// [`Sweep::mass_product_accelerations`].
    pub fn mass_product(&mut self, tree: &Tree<f64>, data: &Data<f64>, y: &[f64]) {
        let n = tree.nv();
        for i in 0..n {
            let parent = tree.parent[i].map_or(Motion::zero(), |p| {
                data.x_up[i].apply_motion(&self.acc_y[p])
            });
            self.acc_y[i] = parent + tree.joint[i].s * y[i];
            self.force_y[i] = tree.inertia[i].mul_motion(&self.acc_y[i]);
        }
        for i in (0..n).rev() {
            if let Some(p) = tree.parent[i] {
                let up = data.x_up[i].inverse_apply_force(&self.force_y[i]);
                self.force_y[p] += up;
            }
        }
    }

    /// Whether dof j and all its ancestors are slides (see the module
    /// documentation), recorded for j's children: parents come first.
    fn mark_translational(&mut self, tree: &Tree<f64>, j: usize) -> bool {
        let translational = tree.joint[j].kind == JointKind::Slide
            && tree.parent[j].is_none_or(|p| self.translational[p]);
        self.translational[j] = translational;
        translational
    }

    /// The node accelerations of the last [`Sweep::mass_product`].
    pub fn mass_product_accelerations(&self) -> &[Motion<f64>] {
        &self.acc_y
    }

    pub fn new(n: usize) -> Self {
        Sweep {
            dv: vec![Motion::zero(); n],
            da: vec![Motion::zero(); n],
            df: vec![Force::zero(); n],
            momentum: vec![Force::zero(); n],
            below: vec![false; n],
            translational: vec![false; n],
            tau: vec![0.0; n],
            acc_y: vec![Motion::zero(); n],
            force_y: vec![Force::zero(); n],
        }
    }
}

/// Fills d_dq and, if given, d_dv (n x n, column j = derivative w.r.t. q_j or v_j) of
/// ID(q, v, a); M includes the armature, which depends on neither. `data`
/// must hold [`rnea`]'s results at (q, v, a): transforms, velocities,
/// accelerations and subtree forces.
pub fn rnea_derivatives(
    tree: &Tree<f64>,
    data: &Data<f64>,
    sweep: &mut Sweep,
    v: &[f64],
    mut d_dq: DMatrixViewMut<f64>,
    mut d_dv: Option<DMatrixViewMut<f64>>,
) {
    for i in 0..tree.nv() {
        sweep.momentum[i] = tree.inertia[i].mul_motion(&data.vel[i]);
    }
    for j in 0..tree.nv() {
        let s = tree.joint[j].s;
        if sweep.mark_translational(tree, j) {
            d_dq.column_mut(j).fill(0.0);
        } else {
            position_column(tree, data, sweep, v, j, d_dq.column_mut(j));
        }
        if let Some(d_dv) = &mut d_dv {
            // Velocity of j.
            let da = data.vel[j].cross_motion(&s);
            propagate(tree, data, sweep, v, j, (s, da), Force::zero());
            d_dv.column_mut(j).copy_from_slice(&sweep.tau);
        }
    }
}

/// Fills d_dq (n x n) with d(M(q) y)/dq for a fixed y, `data.x_up` at q:
/// the position columns of [`rnea_derivatives`] for the accelerations of y
/// alone (no velocity, no gravity), one forward and one backward pass for
/// M(q) y itself, then one propagation per dof.
pub fn mass_derivative(
    tree: &Tree<f64>,
    data: &Data<f64>,
    sweep: &mut Sweep,
    y: &[f64],
    mut d_dq: DMatrixViewMut<f64>,
) {
    let n = tree.nv();
    sweep.mass_product(tree, data, y);
    for j in 0..n {
        let s = tree.joint[j].s;
        if sweep.mark_translational(tree, j) {
            d_dq.column_mut(j).fill(0.0);
            continue;
        }
        let parent_acc = tree.parent[j].map_or(Motion::zero(), |p| sweep.acc_y[p]);
        let da = -s.cross_motion(&data.x_up[j].apply_motion(&parent_acc));
        let turn = s.cross_force(&sweep.force_y[j]);
        // With no velocity perturbation the velocity terms vanish whatever v.
        propagate(tree, data, sweep, y, j, (Motion::zero(), da), turn);
        d_dq.column_mut(j).copy_from_slice(&sweep.tau);
    }
}

/// Column j of dID/dq: q_j turns node j's frame relative to its parent.
fn position_column(
    tree: &Tree<f64>,
    data: &Data<f64>,
    sweep: &mut Sweep,
    v: &[f64],
    j: usize,
    mut column: DVectorViewMut<f64>,
) {
    let s = tree.joint[j].s;
    let parent_acc = match tree.parent[j] {
        Some(p) => data.acc[p],
        None => Motion::new(nalgebra::Vector3::zeros(), -tree.gravity),
    };
    let dv = -s.cross_motion(&data.vel[j]);
    let da =
        -s.cross_motion(&data.x_up[j].apply_motion(&parent_acc)) + dv.cross_motion(&(s * v[j]));
    let turn = s.cross_force(&data.force[j]);
    propagate(tree, data, sweep, v, j, (dv, da), turn);
    column.copy_from_slice(&sweep.tau);
}

/// Pushes a perturbation (dv_j, da_j) of node j through its subtree and the
/// resulting force change up to the root; writes d ID into `sweep.tau`.
/// `turn` is the extra force change X_j^T (turn) passed to j's parent.
fn propagate(
    tree: &Tree<f64>,
    data: &Data<f64>,
    sweep: &mut Sweep,
    v: &[f64],
    j: usize,
    (dv_j, da_j): (Motion<f64>, Motion<f64>),
    turn: Force<f64>,
) {
    let n = tree.nv();
    sweep.tau.fill(0.0);
    for i in j..n {
        let below = i == j || tree.parent[i].is_some_and(|p| p > j && sweep.below[p] || p == j);
        sweep.below[i] = below;
        if !below {
            continue;
        }
        let (dv, da) = if i == j {
            (dv_j, da_j)
        } else {
            let p = tree.parent[i].expect("below j has a parent");
            let x = &data.x_up[i];
            let dv = x.apply_motion(&sweep.dv[p]);
            (
                dv,
                x.apply_motion(&sweep.da[p]) + dv.cross_motion(&(tree.joint[i].s * v[i])),
            )
        };
        let inertia = &tree.inertia[i];
        let vel = &data.vel[i];
        sweep.dv[i] = dv;
        sweep.da[i] = da;
        sweep.df[i] = inertia.mul_motion(&da)
            + dv.cross_force(&sweep.momentum[i])
            + vel.cross_force(&inertia.mul_motion(&dv));
    }
    for i in (j + 1..n).rev() {
        if sweep.below[i] {
            sweep.tau[i] = tree.joint[i].s.dot(&sweep.df[i]);
            let p = tree.parent[i].expect("below j has a parent");
            let up = data.x_up[i].inverse_apply_force(&sweep.df[i]);
            sweep.df[p] += up;
        }
    }
    sweep.tau[j] = tree.joint[j].s.dot(&sweep.df[j]);
    let mut df = data.x_up[j].inverse_apply_force(&(sweep.df[j] + turn));
    let mut k = j;
    while let Some(p) = tree.parent[k] {
        sweep.tau[p] = tree.joint[p].s.dot(&df);
        k = p;
        if tree.parent[k].is_some() {
            df = data.x_up[k].inverse_apply_force(&df);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dynamics::crba;
    use crate::Model;
    use nalgebra::DMatrix;

    /// d(M(q) y)/dq equals central differences of the mass matrix times y.
    #[test]
    fn mass_derivative_matches_finite_differences() {
        let model = Model::load(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/reference_models/half_cheetah.xml"
        ))
        .unwrap();
        let tree = model.tree();
        let n = model.nv();
        let q: Vec<f64> = (0..n).map(|i| 0.3 * (i as f64 + 1.0).sin()).collect();
        let y: Vec<f64> = (0..n).map(|i| (i as f64 + 2.0).cos()).collect();
        let mut data = model.data();
        crba(tree, &mut data, &q);
        let mut sweep = Sweep::new(n);
        let mut exact = DMatrix::zeros(n, n);
        mass_derivative(tree, &data, &mut sweep, &y, exact.columns_mut(0, n));
        let my = |q: &[f64], data: &mut Data<f64>| {
            crba(tree, data, q);
            &data.mass_matrix * nalgebra::DVector::from_column_slice(&y)
        };
        let h = 1e-6;
        for j in 0..n {
            let (mut qp, mut qm) = (q.clone(), q.clone());
            qp[j] += h;
            qm[j] -= h;
            let fd = (my(&qp, &mut data) - my(&qm, &mut data)) / (2.0 * h);
            let err = (fd - exact.column(j)).amax();
            assert!(err < 1e-7, "column {j}: {err:e}");
        }
    }
}
