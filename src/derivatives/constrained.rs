//! Step Jacobians through the constraint model: forward-mode dual numbers
//! through the whole step (collision, rows, impedance, invweight0, the
//! solver, the integrator), one column per input direction.
//!
//! Exact for the solver's converged zones: the solver's last iterate is a
//! full Newton step on fixed zones from a point whose gradient is at rounding
//! level, so its dual part is the derivative of that zone set's minimiser
//! (the implicit derivative of the optimality conditions); with an elliptic
//! cone in its middle zone, Newton's iteration carries the derivative to
//! convergence with the value. Where a step of the input would change the
//! zones (a contact appearing, a row switching between free and active, dry
//! friction between stick and slip) the derivative is the one-sided
//! derivative on the side of the zones at the point itself. Cost: one dual
//! step per column. It gives the contact parameters' columns, and every
//! column where the analytic derivative ([`super::constraint`]) does not
//! apply; that one is tested against it.
//!
//! Positions are differentiated in the tangent space (mjd_transitionFD's
//! layout, nv rows and columns for q): a column of q seeds q (+) eps e_k
//! (for a ball's axis: the body turned by eps about its own axis k), and a
//! row of q' reads the tangent of q' (+) d at d = 0 (a quaternion's
//! 2 vec(conj(q') dq'/deps)). For hinges and slides both are the plain
//! coordinate.

use nalgebra::{DMatrix, DVector};
use num_dual::Dual64;

use super::step::Wrt;
use crate::dynamics::configuration::{integrate, multiply, Coordinates};
use crate::dynamics::mocap::set_mocap;
use crate::dynamics::{step_applied, Data, StepError, Tree};
use crate::model::Param;
use crate::Model;

/// The scalar a dual tree is seeded along: a parameter's component, or none.
type Seed = Option<(Param, usize)>;

/// Trees on dual numbers for one model (by its [`Model::stamp`]), each
/// seeded along one scalar of a parameter or along none, and a workspace
/// for them: built once per model, not per call.
#[derive(Clone, Debug, Default)]
pub(super) struct DualTrees {
    stamp: u64,
    trees: Vec<(Seed, Tree<Dual64>)>,
    data: Option<Data<Dual64>>,
    invweights: Vec<(Seed, InvweightSlopes)>,
    /// The mocap poses the data holds for the model of a stamp (checked by
    /// [`super::Workspace::set_mocap`]); for another model the compiled ones.
    pub(super) mocap: (u64, Vec<f64>, Vec<f64>),
}

/// How MuJoCo's invweight0 constants move with one scalar of a parameter:
/// per body (translation, rotation), per dof.
pub(super) type InvweightSlopes = (Vec<[f64; 2]>, Vec<f64>);

impl DualTrees {
    /// The tree seeded along `seed` and the workspace.
    pub(super) fn get(
        &mut self,
        model: &Model,
        seed: Option<(Param, usize)>,
    ) -> (&Tree<Dual64>, &mut Data<Dual64>) {
        if self.stamp != model.stamp() {
            *self = DualTrees {
                stamp: model.stamp(),
                mocap: std::mem::take(&mut self.mocap),
                ..DualTrees::default()
            };
        }
        let index = match self.trees.iter().position(|(s, _)| *s == seed) {
            Some(i) => i,
            None => {
                let tree = Tree::build_with(model, |p, c, x| {
                    Dual64::new(x, if Some((p, c)) == seed { 1.0 } else { 0.0 })
                });
                self.trees.push((seed, tree));
                self.trees.len() - 1
            }
        };
        let tree = &self.trees[index].1;
        let data = self.data.get_or_insert_with(|| Data::new(tree));
        let (stamp, pos, quat) = &self.mocap;
        let given = (*stamp == model.stamp()).then_some((&pos[..], &quat[..]));
        set_mocap(tree, data, given.unwrap_or_default()).expect("checked when set");
        (tree, data)
    }

    /// The slopes of invweight0 along one scalar of a parameter (the dual
    /// parts of the seeded tree's constants).
    pub(super) fn invweight_slopes(
        &mut self,
        model: &Model,
        seed: (Param, usize),
    ) -> &InvweightSlopes {
        let seed = Some(seed);
        if self.stamp != model.stamp() || !self.invweights.iter().any(|(s, _)| *s == seed) {
            let (tree, _) = self.get(model, seed);
            let c = &tree.constraint;
            let slopes = (
                c.body_invweight.iter().map(|w| w.map(|x| x.eps)).collect(),
                c.dof_invweight.iter().map(|x| x.eps).collect(),
            );
            self.invweights.push((seed, slopes));
        }
        let index = self.invweights.iter().position(|(s, _)| *s == seed);
        &self.invweights[index.expect("just added")].1
    }
}

/// d q' and d v' (n rows each) with respect to the columns of `wrt`: [q, v] if the state was asked for, then tau, then the
/// flattened parameters.
pub(super) fn dual_columns(
    model: &Model,
    duals: &mut DualTrees,
    (q, v, tau): (&[f64], &[f64], &[f64]),
    wrt: &Wrt,
) -> Result<(DMatrix<f64>, DMatrix<f64>), StepError> {
    let n = model.nv();
    let inputs = [wrt.state, wrt.state, wrt.control]
        .iter()
        .filter(|x| **x)
        .count()
        * n;
    let params: Vec<(Param, usize)> = wrt
        .params
        .iter()
        .flat_map(|p| (0..p.size()).map(move |k| (*p, k)))
        .collect();
    let columns = inputs + params.len();
    let (mut dq, mut dv) = (DMatrix::zeros(n, columns), DMatrix::zeros(n, columns));
    // The input a column seeds: (q, v, tau) index in 0..3n.
    let seeded: Vec<usize> = [(wrt.state, 0), (wrt.state, n), (wrt.control, 2 * n)]
        .into_iter()
        .filter(|(on, _)| *on)
        .flat_map(|(_, start)| start..start + n)
        .collect();
    for (col, &input) in seeded.iter().enumerate() {
        let (tree, data) = duals.get(model, None);
        let (q1, v1) = dual_step(tree, model, data, (q, v, tau), Some(input))?;
        dq.set_column(col, &q1);
        dv.set_column(col, &v1);
    }
    for (k, seed) in params.into_iter().enumerate() {
        let (tree, data) = duals.get(model, Some(seed));
        let (q1, v1) = dual_step(tree, model, data, (q, v, tau), None)?;
        dq.set_column(inputs + k, &q1);
        dv.set_column(inputs + k, &v1);
    }
    Ok((dq, dv))
}

/// The derivative parts of one dual step, the input `seed` (an
/// index into (q, v, tau)) seeded with 1.
fn dual_step(
    tree: &Tree<Dual64>,
    model: &Model,
    data: &mut Data<Dual64>,
    (q, v, tau): (&[f64], &[f64], &[f64]),
    seed: Option<usize>,
) -> Result<(DVector<f64>, DVector<f64>), StepError> {
    let n = model.nv();
    let lift = |x: &[f64], offset: usize| -> Vec<Dual64> {
        x.iter()
            .enumerate()
            .map(|(i, &xi)| Dual64::new(xi, if seed == Some(offset + i) { 1.0 } else { 0.0 }))
            .collect()
    };
    let qd = tangent_point(tree, q, seed);
    let (vd, td) = (lift(v, n), lift(tau, 2 * n));
    let (mut q1, mut v1) = (vec![Dual64::from(0.0); q.len()], vec![Dual64::from(0.0); n]);
    step_applied(tree, data, (&qd, &vd, &td), (&mut q1, &mut v1))?;
    let eps = |x: &[Dual64]| DVector::from_iterator(n, x.iter().map(|d| d.eps));
    Ok((tangent_slope(tree, &q1), eps(&v1)))
}

/// Dual positions q (+) eps e_k for a `seed` k < nv in q's tangent space,
/// else q with no slope (the inverse of [`tangent_slope`]).
pub(super) fn tangent_point(tree: &Tree<Dual64>, q: &[f64], seed: Option<usize>) -> Vec<Dual64> {
    let plain: Vec<Dual64> = q.iter().map(|&x| Dual64::from(x)).collect();
    let n = tree.nv();
    let Some(k) = seed.filter(|&k| k < n) else {
        return plain;
    };
    let unit: Vec<Dual64> = (0..n)
        .map(|i| Dual64::new(0.0, f64::from(i == k)))
        .collect();
    let mut qd = plain.clone();
    integrate(tree, &plain, &unit, Dual64::from(1.0), &mut qd);
    qd
}

/// The tangent-space slope of dual positions q (see the module docs).
pub(super) fn tangent_slope(tree: &Tree<Dual64>, q: &[Dual64]) -> DVector<f64> {
    let mut out = DVector::zeros(tree.nv());
    for (i, joint) in tree.joint.iter().enumerate() {
        out[i] = match joint.coordinates {
            Coordinates::Scalar { at } => q[at].eps,
            Coordinates::Rotation { at, axis } => {
                let [w, x, y, z] = [0, 1, 2, 3].map(|k| q[at + k].re);
                let slope = [0, 1, 2, 3].map(|k| q[at + k].eps);
                2.0 * multiply(&[w, -x, -y, -z], &slope)[1 + axis]
            }
        };
    }
    out
}
