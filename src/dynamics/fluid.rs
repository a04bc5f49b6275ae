//! Fluid forces: MuJoCo's inertia-box model (its default; the ellipsoid model,
//! geom `fluidshape`, is not supported).
//!
//! Every body with mass moves in a medium of density rho, viscosity beta and
//! wind w (model option [`Fluid`](crate::model::Fluid)) as the box with its
//! mass and principal moments would: full sides
//! b_k = sqrt(6 (I_j + I_l - I_k) / m) along its principal axes (k, j, l
//! distinct). With (omega, u) its angular velocity
//! and the velocity of its centre of mass less the wind, both on its
//! principal axes, it feels at its centre of mass
//!   torque  -pi d^3 beta omega   - rho b_k (b_j^4 + b_l^4) |omega_k| omega_k / 64
//!   force   -3 pi d beta u       - rho b_j b_l |u_k| u_k / 2
//! per axis k, d = (b_x + b_y + b_z) / 3 the diameter of the equivalent
//! sphere. The generalized force is J^T of that wrench; it is explicit in
//! every integrator (evaluated at (q, v)), as MuJoCo's passive forces are,
//! and its velocity derivative joins qDeriv under the implicit integrators
//! ([`add_fluid_derivative`]).
//! The principal axes are the body's inertial frame
//! ([`crate::model::Body::inertia_frame`], MuJoCo's body_iquat), the moments
//! the inertia's diagonal there: where two moments are equal, the frame tells
//! their axes apart as MuJoCo does.

use nalgebra::{DMatrix, Matrix3, Vector3};

use super::{body_force_to_joints, Data, Tree};
use crate::spatial::{lift, lift_vector, Force, Real, Transform};

/// A body the fluid acts on, in its node's frame.
#[derive(Clone, Debug, PartialEq)]
pub struct FluidBody<T: Real> {
    pub node: usize,
    /// From the node's frame to the body's.
    pub offset: Transform<T>,
    /// Centre of mass and principal axes (columns) in body coordinates.
    pub com: Vector3<T>,
    pub axes: Matrix3<T>,
    /// The equivalent box's full sides along the principal axes.
    pub sides: Vector3<T>,
}

/// Adds the medium's (`tree.opt.fluid`) generalized forces to `out`
/// (`data.world` and `data.world_vel` filled by [`super::world_frames`],
/// `data.x_up` at q).
pub fn add_fluid_forces<T: Real>(tree: &Tree<T>, data: &Data<T>, out: &mut [T]) {
    let medium = &tree.opt.fluid;
    let (rho, beta): (T, T) = (lift(medium.density), lift(medium.viscosity));
    let wind = lift_vector(&medium.wind);
    let pi = T::pi();
    for f in &tree.fluid {
        let (_, omega, u) = f.velocity(data, &wind);
        let b = f.sides;
        let d = (b.x + b.y + b.z) / lift(3.0);
        let mut torque = omega * (-pi * d * d * d * beta);
        let mut force = u * (-lift::<T>(3.0) * pi * d * beta);
        for k in 0..3 {
            let (j, l) = ((k + 1) % 3, (k + 2) % 3);
            force[k] -= rho * b[j] * b[l] * u[k].abs() * u[k] / lift(2.0);
            torque[k] -=
                rho * b[k] * (fourth(b[j]) + fourth(b[l])) * omega[k].abs() * omega[k] / lift(64.0);
        }
        let (torque, force) = (f.axes * torque, f.axes * force);
        let in_body = Force::new(torque + f.com.cross(&force), force);
        let in_node = f.offset.inverse_apply_force(&in_body);
        body_force_to_joints(tree, &data.x_up, f.node, in_node, out);
    }
}

fn fourth<T: Real>(x: T) -> T {
    x * x * x * x
}

impl<T: Real> FluidBody<T> {
    /// From the world to the body's frame, and its angular velocity and the
    /// velocity of its centre of mass less the wind, on its principal axes.
    fn velocity(
        &self,
        data: &Data<T>,
        wind: &Vector3<T>,
    ) -> (Transform<T>, Vector3<T>, Vector3<T>) {
        let to_body = self.offset.compose(&data.world[self.node]);
        let vel = to_body.apply_motion(&data.world_vel[self.node]);
        let at_com = vel.lin + vel.ang.cross(&self.com) - to_body.rot * *wind;
        let (omega, u) = (self.axes.tr_mul(&vel.ang), self.axes.tr_mul(&at_com));
        (to_body, omega, u)
    }
}

/// Adds the fluid forces' velocity derivative to `qderiv` (MuJoCo's
/// mjd_inertiaBoxFluid in mjd_passive_vel): per body J^T B J, J the
/// Jacobian of (omega, u) (see [`add_fluid_forces`]) in the dofs and B the
/// diagonal slope of each wrench entry in its own velocity, for the torque
/// -(pi d^3 beta + rho b_k (b_j^4 + b_l^4) |omega_k| / 32), for the force
/// -(3 pi d beta + rho b_j b_l |u_k|). Exact: the wind is constant and each
/// entry depends on its own velocity alone. `data.world`, `data.world_vel`
/// and `data.world_axis` are at (q, v).
pub fn add_fluid_derivative<T: Real>(tree: &Tree<T>, data: &Data<T>, qderiv: &mut DMatrix<T>) {
    let medium = &tree.opt.fluid;
    let (rho, beta): (T, T) = (lift(medium.density), lift(medium.viscosity));
    let wind = lift_vector(&medium.wind);
    let pi = T::pi();
    let mut jacobian: Vec<(usize, [T; 6])> = vec![];
    for f in &tree.fluid {
        let (to_body, omega, u) = f.velocity(data, &wind);
        let b = f.sides;
        let d = (b.x + b.y + b.z) / lift(3.0);
        let slope: [T; 6] = std::array::from_fn(|r| {
            let k = r % 3;
            let (j, l) = ((k + 1) % 3, (k + 2) % 3);
            if r < 3 {
                -pi * d * d * d * beta
                    - rho * b[k] * (fourth(b[j]) + fourth(b[l])) * omega[k].abs() / lift(32.0)
            } else {
                -lift::<T>(3.0) * pi * d * beta - rho * b[j] * b[l] * u[k].abs()
            }
        });
        jacobian.clear();
        let mut node = Some(f.node);
        while let Some(i) = node {
            let s = to_body.apply_motion(&data.world_axis[i]);
            let (ang, lin) = (
                f.axes.tr_mul(&s.ang),
                f.axes.tr_mul(&(s.lin + s.ang.cross(&f.com))),
            );
            jacobian.push((i, [ang.x, ang.y, ang.z, lin.x, lin.y, lin.z]));
            node = tree.parent[i];
        }
        for (i, ji) in &jacobian {
            for (j, jj) in &jacobian {
                let sum = (0..6).fold(T::zero(), |acc, r| acc + ji[r] * slope[r] * jj[r]);
                qderiv[(*i, *j)] += sum;
            }
        }
    }
}
