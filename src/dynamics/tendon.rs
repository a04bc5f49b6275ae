//! Fixed tendons in the compiled tree: length, velocity and moment
//! (MuJoCo's mj_tendon for mjWRAP_JOINT), and their passive forces
//! (mj_passive's tendon spring and damper). Conventions are the model's
//! ([`crate::model::tendon`]): L(q) = sum_k coef_k q_k, J = dL/dq (nv),
//! L-dot = J v, generalized force J^T f for a force f along the tendon.

use super::constraint::Limit;
use super::Tree;
use crate::model::SolParams;
use crate::spatial::Real;

/// One tendon as the algorithms read it.
#[derive(Clone, Debug, PartialEq)]
pub struct TendonConsts<T: Real> {
    /// Its terms: (address in q, dof, coefficient).
    pub path: Vec<(usize, usize, T)>,
    pub stiffness: T,
    pub damping: T,
    /// The spring's deadband (lo, hi), resolved at qpos0.
    pub lengthspring: [T; 2],
    /// Its length at qpos0 (MuJoCo's tendon_length0).
    pub length0: T,
    /// J M^-1 J^T at qpos0 (tendon_invweight0), A_ii of its rows.
    pub invweight: T,
    /// The limit, if limited and limits are on (constraint model).
    pub limit: Option<Limit<T>>,
    /// Dry friction (0 when off) and its solver parameters.
    pub frictionloss: (T, SolParams<T>),
}

impl<T: Real> TendonConsts<T> {
    /// L(q).
    pub fn length(&self, q: &[T]) -> T {
        self.path
            .iter()
            .fold(T::zero(), |s, (at, _, c)| s + *c * q[*at])
    }

    /// L-dot = J v.
    pub fn velocity(&self, v: &[T]) -> T {
        self.path
            .iter()
            .fold(T::zero(), |s, (_, dof, c)| s + *c * v[*dof])
    }

    /// Adds s J to `out` (nv).
    pub fn add_moment(&self, s: T, out: &mut [T]) {
        for (_, dof, c) in &self.path {
            out[*dof] += s * *c;
        }
    }

    /// The dofs it moves, descending and distinct.
    pub fn dofs(&self) -> Vec<usize> {
        let mut dofs: Vec<usize> = self.path.iter().map(|(_, d, _)| *d).collect();
        dofs.sort_unstable_by(|a, b| b.cmp(a));
        dofs.dedup();
        dofs
    }

    /// The force along it of its spring and damper at length l and rate ldot.
    fn passive_force(&self, l: T, ldot: T) -> T {
        let [lo, hi] = self.lengthspring;
        let stretch = if l > hi {
            l - hi
        } else if l < lo {
            l - lo
        } else {
            T::zero()
        };
        -self.stiffness * stretch - self.damping * ldot
    }
}

/// Adds every tendon's spring and damper force J^T f to `out` at (q, v).
pub fn add_tendon_forces<T: Real>(tree: &Tree<T>, (q, v): (&[T], &[T]), out: &mut [T]) {
    for t in &tree.tendons {
        let f = t.passive_force(t.length(q), t.velocity(v));
        t.add_moment(f, out);
    }
}
