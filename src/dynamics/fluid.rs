//! Fluid forces: MuJoCo's two models, the inertia-box model (its default)
//! and the ellipsoid model (geom `fluidshape="ellipsoid"`).
//!
//! Every body with mass moves in a medium of density rho, viscosity beta and
//! wind w (model option [`Fluid`](crate::model::Fluid)). A body with a geom
//! under the ellipsoid model feels it on each such geom ([`FluidEllipsoid`]);
//! any other body moves as the box with its
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
//! and the box model's velocity derivative joins qDeriv under the implicit
//! integrators ([`add_fluid_derivative`]; the ellipsoid model is refused
//! there).
//! The principal axes are the body's inertial frame
//! ([`crate::model::Body::inertia_frame`], MuJoCo's body_iquat), the moments
//! the inertia's diagonal there: where two moments are equal, the frame tells
//! their axes apart as MuJoCo does.

use nalgebra::{DMatrix, Matrix3, Vector3};

use super::{body_force_to_joints, Data, Tree};
use crate::spatial::{lift, lift_vector, Force, Real, Transform};

/// What the medium acts on: the bodies under the inertia-box model and the
/// geoms under the ellipsoid model.
#[derive(Clone, Debug, PartialEq)]
pub struct FluidTerms<T: Real> {
    pub boxes: Vec<FluidBody<T>>,
    pub ellipsoids: Vec<FluidEllipsoid<T>>,
}

impl<T: Real> FluidTerms<T> {
    pub fn none() -> Self {
        FluidTerms {
            boxes: vec![],
            ellipsoids: vec![],
        }
    }

    pub fn is_empty(&self) -> bool {
        self.boxes.is_empty() && self.ellipsoids.is_empty()
    }
}

/// A body the fluid acts on by the inertia-box model, in its node's frame.
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
    for e in &tree.fluid.ellipsoids {
        let to_geom = e.offset.compose(&data.world[e.node]);
        let vel = to_geom.apply_motion(&data.world_vel[e.node]);
        let u = vel.lin - to_geom.rot * wind;
        let in_geom = e.wrench((rho, beta), &vel.ang, &u);
        let in_node = e.offset.inverse_apply_force(&in_geom);
        body_force_to_joints(tree, &data.x_up, e.node, in_node, out);
    }
    for f in &tree.fluid.boxes {
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
    for f in &tree.fluid.boxes {
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

/// A geom under MuJoCo's ellipsoid fluid model, in its node's frame: the
/// ellipsoid with semi-axes `semiaxes` along the geom's axes (MuJoCo's
/// mju_geomSemiAxes: a sphere's radius thrice; a capsule's or cylinder's
/// radius twice, then its half-length, plus the radius for a capsule).
/// With (omega, u) the geom's angular velocity and the velocity of its
/// origin less the wind, in its axes, it feels at its origin (all terms
/// MuJoCo's mj_addedMassForces and mj_viscousForces; V = 4/3 pi a b c):
/// - the added mass's: p = rho m_v . u and L = rho I_v . omega give the
///   force p x omega and the torque p x u + L x omega;
/// - Magnus lift c_M rho V omega x u;
/// - Kutta lift (c_K rho cos(alpha) A_proj (n x u)) x u, n the (not unit)
///   normal of the ellipsoid's section across u, A_proj its projected area
///   along u, cos(alpha) the cosine between n and u;
/// - linear drag -(beta 3 pi D + rho |u| (c_B A_proj + c_S (A_max - A_proj))) u,
///   D = 2/3 (a + b + c), A_max = pi d_max d_mid;
/// - angular drag -(beta pi D^3 + rho |m|) omega, m_k = omega_k (c_A I_k +
///   c_S (I_max - I_k)), I_k = 8/15 pi s_k max(s_j, s_l)^4 and
///   I_max = 8/15 pi d_mid d_max^4;
///
/// with c_B, c_S, c_A, c_K, c_M the geom's [`crate::model::FluidCoefs`].
#[derive(Clone, Debug, PartialEq)]
pub struct FluidEllipsoid<T: Real> {
    pub node: usize,
    /// From the node's frame to the geom's.
    pub offset: Transform<T>,
    pub semiaxes: Vector3<T>,
    /// Blunt drag, slender drag, angular drag, Kutta lift, Magnus lift.
    pub coefs: [T; 5],
    /// The added (virtual) mass and moments of inertia per unit density
    /// (computed when the model is compiled).
    pub virtual_mass: Vector3<T>,
    pub virtual_inertia: Vector3<T>,
}

impl<T: Real> FluidEllipsoid<T> {
    /// The wrench on the geom (its coordinates, about its origin) in a
    /// medium of density and viscosity `(rho, beta)`.
    fn wrench(&self, (rho, beta): (T, T), omega: &Vector3<T>, u: &Vector3<T>) -> Force<T> {
        let [blunt, slender, angular, kutta, magnus] = self.coefs;
        let s = self.semiaxes;
        let pi = T::pi();
        let lin_momentum = self.virtual_mass.component_mul(u) * rho;
        let ang_momentum = self.virtual_inertia.component_mul(omega) * rho;
        let mut force = lin_momentum.cross(omega);
        let mut torque = lin_momentum.cross(u) + ang_momentum.cross(omega);

        let volume = lift::<T>(4.0 / 3.0) * pi * s.x * s.y * s.z;
        let d_max = s.x.max(s.y).max(s.z);
        let d_min = s.x.min(s.y).min(s.z);
        let d_mid = s.x + s.y + s.z - d_max - d_min;
        let a_max = pi * d_max * d_mid;
        force += omega.cross(u) * (magnus * rho * volume);

        // The section's normal n_k = (s_j s_l)^2 u_k; A_proj = pi
        // sqrt(denom / num), cos(alpha) = num / (|u| denom).
        let area = Vector3::new(s.y * s.z, s.z * s.x, s.x * s.y);
        let normal = area.component_mul(&area).component_mul(u);
        let num = normal.dot(u);
        let denom = normal.dot(&normal);
        let minval = lift::<T>(crate::model::MINVAL);
        let speed = norm(u);
        let a_proj = pi * sqrt(denom / num.max(minval));
        let cos_alpha = num / (speed * denom).max(minval);
        let circulation = normal.cross(u) * (kutta * rho * cos_alpha * a_proj);
        force += circulation.cross(u);

        let diameter = lift::<T>(2.0 / 3.0) * (s.x + s.y + s.z);
        let moment = |k: usize| {
            let (j, l) = (s[(k + 1) % 3], s[(k + 2) % 3]);
            lift::<T>(8.0 / 15.0) * pi * s[k] * fourth(j.max(l))
        };
        let i_max = lift::<T>(8.0 / 15.0) * pi * d_mid * fourth(d_max);
        let spin = Vector3::from_fn(|k, _| {
            omega[k] * (angular * moment(k) + slender * (i_max - moment(k)))
        });
        let drag_lin = beta * lift::<T>(3.0) * pi * diameter
            + rho * speed * (a_proj * blunt + slender * (a_max - a_proj));
        let drag_ang = beta * pi * diameter * diameter * diameter + rho * norm(&spin);
        force -= u * drag_lin;
        torque -= omega * drag_ang;
        Force::new(torque, force)
    }
}

/// |x|, with a zero derivative at 0 (where MuJoCo's terms in it vanish).
fn norm<T: Real>(x: &Vector3<T>) -> T {
    sqrt(x.norm_squared())
}

/// The square root, with a zero derivative at 0.
fn sqrt<T: Real>(x: T) -> T {
    if x == T::zero() {
        T::zero()
    } else {
        x.sqrt()
    }
}
