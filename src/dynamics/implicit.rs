//! MuJoCo's implicit integrators, `implicitfast` and `implicit`
//! (mj_implicitSkip): the forces f at (q, v) (passive, applied, bias, and
//! the constraint forces solved under M as in the explicit step) give
//! qdd = (M - h D)^-1 f, then v' = v + h qdd, q' = q (+) h v'.
//!
//! D is MuJoCo's qDeriv, the velocity derivative of the smooth forces,
//! summed from named terms (`velocity_derivative`):
//! - joint damping: -diag(damping) (passive, MuJoCo's mjd_passive_vel);
//! - the fluid forces' J^T B J ([`super::fluid::add_fluid_derivative`],
//!   mjd_inertiaBoxFluid);
//! - the actuators' velocity terms (mjd_actuator_vel) have their slot there;
//! - under `implicit` only, the bias forces': -dc/dv (mjd_rne_vel), exact,
//!   from the linearised Newton-Euler recursion (`add_bias_derivative`).
//!
//! D keeps M's sparsity (`keep_mass_sparsity`): MuJoCo drops the terms
//! coupling dofs of different chains (a tendon's across two trees).
//!
//! `implicit` solves M - h D as it is, by LU. `implicitfast` drops the bias
//! term and uses D's lower triangle mirrored (MuJoCo gathers qDeriv's lower
//! triangle into its symmetric factor; D is symmetric for damping and
//! actuators), except on the block of a standalone free body (one free
//! joint, no massive or jointed descendants: [`Tree::free_bodies`]), where
//! MuJoCo (mjd_freeMhat) solves M - h D with the body's own gyroscopic
//! derivative -dc/dv added, unsymmetric, by itself. That block is decoupled
//! from the rest (M and D are block diagonal there), so one LU solve of the
//! whole matrix gives the same acceleration.

use nalgebra::DMatrix;

use super::fluid::add_fluid_derivative;
use super::{Data, Tree};
use crate::model::Integrator;
use crate::spatial::{lift, Force, Motion, Real};

/// The buffers of an implicit step, kept in [`Data`]: qDeriv and the
/// matrix solved (nv x nv); the actuators' term of qDeriv (nv x nv, zero
/// unless a step with actuator inputs filled it); per node the velocity and the linearised
/// recursion's velocity, acceleration and force; a unit direction (nv).
#[derive(Clone, Debug)]
pub struct Buffers<T: Real> {
    qderiv: DMatrix<T>,
    pub(super) matrix: DMatrix<T>,
    actuators: DMatrix<T>,
    vel: Vec<Motion<T>>,
    dvel: Vec<Motion<T>>,
    dacc: Vec<Motion<T>>,
    dforce: Vec<Force<T>>,
    unit: Vec<T>,
}

impl<T: Real> Buffers<T> {
    /// The actuators' slot of qDeriv (d tau_actuator / dv,
    /// [`super::actuation::add_force_velocity_derivatives`]), zeroed: a
    /// step with actuator inputs adds to it before it solves, and zeroes it
    /// again after.
    pub(super) fn actuator_slope(&mut self) -> &mut DMatrix<T> {
        self.actuators.fill(T::zero());
        &mut self.actuators
    }

    pub fn new(nv: usize) -> Self {
        Buffers {
            qderiv: DMatrix::zeros(nv, nv),
            matrix: DMatrix::zeros(nv, nv),
            actuators: DMatrix::zeros(nv, nv),
            vel: vec![Motion::zero(); nv],
            dvel: vec![Motion::zero(); nv],
            dacc: vec![Motion::zero(); nv],
            dforce: vec![Force::zero(); nv],
            unit: vec![T::zero(); nv],
        }
    }
}

/// Fills `data.implicit.matrix` with the matrix the step under `integrator`
/// solves: M - h D (see the module documentation). `data.mass_matrix` holds
/// M and `data.x_up` is at q.
pub fn implicit_matrix<T: Real>(
    tree: &Tree<T>,
    data: &mut Data<T>,
    integrator: Integrator,
    v: &[T],
) {
    let n = tree.nv();
    let h: T = lift(tree.opt.timestep);
    let full = integrator == Integrator::Implicit;
    let mut b = std::mem::replace(&mut data.implicit, Buffers::new(0));
    velocity_derivative(tree, data, v, full, &mut b);
    for i in 0..n {
        for j in 0..n {
            // implicitfast: the lower triangle, mirrored.
            let d = if full || j <= i {
                b.qderiv[(i, j)]
            } else {
                b.qderiv[(j, i)]
            };
            b.matrix[(i, j)] = data.mass_matrix[(i, j)] - h * d;
        }
    }
    if !full {
        // A lone free body's block: all of qDeriv (not mirrored) with its
        // own gyroscopic term (its columns of dc/dv vanish off the block).
        for &k in &tree.free_bodies {
            add_bias_derivative(tree, data, v, k..k + 6, &mut b);
            for i in k..k + 6 {
                for j in k..k + 6 {
                    b.matrix[(i, j)] = data.mass_matrix[(i, j)] - h * b.qderiv[(i, j)];
                }
            }
        }
    }
    data.implicit = b;
}

/// qDeriv = d(tau_passive + tau_fluid + tau_actuator)/dv, less dc/dv where `bias`
/// (MuJoCo's mjd_smooth_vel with flg_bias), into `b.qderiv`.
fn velocity_derivative<T: Real>(
    tree: &Tree<T>,
    data: &Data<T>,
    v: &[T],
    bias: bool,
    b: &mut Buffers<T>,
) {
    b.qderiv.fill(T::zero());
    add_damping_derivative(tree, &mut b.qderiv);
    add_tendon_damping_derivative(tree, data, &mut b.qderiv);
    add_fluid_derivative(tree, data, &mut b.qderiv);
    b.qderiv += &b.actuators;
    if bias {
        add_bias_derivative(tree, data, v, 0..tree.nv(), b);
    }
    keep_mass_sparsity(tree, &mut b.qderiv);
}

/// Drops qDeriv's entries outside the mass matrix's sparsity (dofs i, j
/// neither of which is the other's ancestor), as MuJoCo stores qDeriv in
/// M's pattern: a tendon's damper or actuator coupling two kinematic
/// chains is taken explicitly across them.
fn keep_mass_sparsity<T: Real>(tree: &Tree<T>, qderiv: &mut DMatrix<T>) {
    let n = tree.nv();
    let descends = |mut i: usize, j: usize| loop {
        if i == j {
            return true;
        }
        match tree.parent[i] {
            Some(p) => i = p,
            None => return false,
        }
    };
    for i in 0..n {
        for j in 0..n {
            if qderiv[(i, j)] != T::zero() && !descends(i, j) && !descends(j, i) {
                qderiv[(i, j)] = T::zero();
            }
        }
    }
}

/// The joint damping's derivative -diag(damping).
fn add_damping_derivative<T: Real>(tree: &Tree<T>, qderiv: &mut DMatrix<T>) {
    for i in 0..tree.nv() {
        qderiv[(i, i)] -= tree.damping[i];
    }
}

/// The tendons' damping derivative -sum damping J^T J (mjd_passive_vel),
/// J at the tendons' states in `data.tendon`.
fn add_tendon_damping_derivative<T: Real>(tree: &Tree<T>, data: &Data<T>, qderiv: &mut DMatrix<T>) {
    for (t, s) in tree.tendons.iter().zip(&data.tendon) {
        if t.damping == T::zero() {
            continue;
        }
        for &r in &t.support {
            for &c in &t.support {
                qderiv[(r, c)] -= t.damping * s.moment[r] * s.moment[c];
            }
        }
    }
}

/// Subtracts the bias forces' velocity derivative dc/dv, columns
/// `columns`, from `b.qderiv` (MuJoCo's mjd_rne_vel). Column j is the
/// Newton-Euler recursion at zero acceleration linearised along the unit
/// velocity e_j: node velocities dV = X dV_parent + S u, accelerations
/// dA = X dA_parent + dV' x S v + V' x S u (V' the velocity the node's
/// velocity-product term crosses, [`Tree::crossed_velocity`]), forces
/// dF = I dA + dV x* I V + V x* I dV, summed to the root and projected
/// on the axes. Exact: c is quadratic in v.
fn add_bias_derivative<T: Real>(
    tree: &Tree<T>,
    data: &Data<T>,
    v: &[T],
    columns: std::ops::Range<usize>,
    b: &mut Buffers<T>,
) {
    let n = tree.nv();
    for i in 0..n {
        let s = tree.joint[i].s;
        let parent = tree.parent[i].map(|p| data.x_up[i].apply_motion(&b.vel[p]));
        b.vel[i] = parent.unwrap_or_default() + s * v[i];
    }
    for j in columns {
        b.unit.fill(T::zero());
        b.unit[j] = T::one();
        for i in 0..n {
            let (s, x) = (tree.joint[i].s, &data.x_up[i]);
            let (dvel, dacc) = match tree.parent[i] {
                Some(p) => (x.apply_motion(&b.dvel[p]), x.apply_motion(&b.dacc[p])),
                None => (Motion::zero(), Motion::zero()),
            };
            let vel = b.vel[i];
            let dvel = dvel + s * b.unit[i];
            let crossed = tree.crossed_velocity(i, vel, v);
            let dcrossed = tree.crossed_velocity(i, dvel, &b.unit);
            let dacc =
                dacc + dcrossed.cross_motion(&(s * v[i])) + crossed.cross_motion(&(s * b.unit[i]));
            let inertia = &tree.inertia[i];
            b.dforce[i] = inertia.mul_motion(&dacc)
                + dvel.cross_force(&inertia.mul_motion(&vel))
                + vel.cross_force(&inertia.mul_motion(&dvel));
            (b.dvel[i], b.dacc[i]) = (dvel, dacc);
        }
        for i in (0..n).rev() {
            b.qderiv[(i, j)] -= tree.joint[i].s.dot(&b.dforce[i]);
            if let Some(p) = tree.parent[i] {
                let f = data.x_up[i].inverse_apply_force(&b.dforce[i]);
                b.dforce[p] += f;
            }
        }
    }
}

/// Solves A x = b in place (A overwritten by its elimination) by Gaussian
/// elimination with partial pivoting; false if A is singular.
pub fn lu_solve<T: Real>(a: &mut DMatrix<T>, x: &mut [T]) -> bool {
    let n = x.len();
    for k in 0..n {
        let pivot = (k..n)
            .max_by(|&i, &j| a[(i, k)].abs().partial_cmp(&a[(j, k)].abs()).unwrap())
            .unwrap_or(k);
        if a[(pivot, k)] == T::zero() {
            return false;
        }
        if pivot != k {
            a.swap_rows(pivot, k);
            x.swap(pivot, k);
        }
        for i in k + 1..n {
            let factor = a[(i, k)] / a[(k, k)];
            if factor == T::zero() {
                continue;
            }
            for j in k + 1..n {
                let akj = a[(k, j)];
                a[(i, j)] -= factor * akj;
            }
            let xk = x[k];
            x[i] -= factor * xk;
        }
    }
    for k in (0..n).rev() {
        let mut sum = x[k];
        for j in k + 1..n {
            sum -= a[(k, j)] * x[j];
        }
        x[k] = sum / a[(k, k)];
    }
    true
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lu_solves_an_unsymmetric_system_that_needs_pivoting() {
        let a = DMatrix::from_row_slice(3, 3, &[0.0, 2.0, 1.0, 1.0, 1.0, 0.0, 3.0, 0.0, 1.0]);
        let x = [1.0, -2.0, 0.5];
        let mut b: Vec<f64> = (a.clone() * nalgebra::DVector::from_row_slice(&x))
            .iter()
            .copied()
            .collect();
        assert!(lu_solve(&mut a.clone(), &mut b));
        for (got, want) in b.iter().zip(x) {
            assert!((got - want).abs() < 1e-15, "{got} vs {want}");
        }
        assert!(!lu_solve(&mut DMatrix::<f64>::zeros(2, 2), &mut [1.0, 1.0]));
    }
}
