//! The wiping task's task-space admittance controller (paper Section 4.4),
//! gains theta = (k_tau, k_xi).
//!
//! The law, run at every physics step (1 kHz on the wiping arm), generic over
//! the scalar so that identification can differentiate the closed loop:
//! 1. Sense: F = the tool-table normal force that acted over the last step
//!    ([`sensed_force`]: the contact model's, the constraint solver's under
//!    MuJoCo's model; 0 out of contact and before the first step), as a
//!    force sensor sampled at 1 kHz reads it.
//! 2. Admittance along the table normal: the commanded tip point is
//!    p_cmd = p_traj(t) - xi e_z, where the offset xi (m, > 0 pushes into
//!    the table) integrates the force error,
//!    xi' = clamp(xi + h k_xi (F_goal - F), -XI_LIMIT, XI_LIMIT),
//!    k_xi in m/(N s), h the timestep. The clamp is hard (the law is smooth
//!    inside the band, its derivative zero on the clamp).
//! 3. Inner loop in joint space: q_cmd = the tool-down inverse kinematics of
//!    p_cmd ([`crate::tasks::tool_down_at`]), and on each arm joint i
//!    tau_i = g_i(q) + I_i (k_tau (q_cmd - q)_i - 2 sqrt(k_tau) v_i), clamped
//!    to the motor's torque limit, with g(q) the model's gravity torques and
//!    I_i the joint's inertia (the mass matrix's diagonal at the path's
//!    start, fixed): every joint responds like a critically damped unit
//!    mass on a spring of stiffness k_tau (1/s^2, natural frequency
//!    sqrt(k_tau) rad/s), whatever it carries. Scaling by I_i keeps the
//!    light wrist as stable under the explicit step as the shoulder. The
//!    tool joint gets no torque: it is the passive compliance.
//!
//! The sensed force is the last step's, known at the step's start, so a
//! single step's torque does not depend on the tool's stiffness or damping;
//! over several steps they reach the torque through the state, the force
//! and xi, and an exact closed-loop derivative has to follow them there.

use nalgebra::Vector3;

use crate::dynamics::constraint::contact_forces;
use crate::dynamics::{bias_forces, Contact, Data, Tree};
use crate::model::ContactModel;
use crate::spatial::{lift, Real};
use crate::tasks::tool_down_at;

/// The normal force the controller regulates to (N), the paper's.
pub const F_GOAL: f64 = 3.0;
/// The band of the admittance offset xi (m).
pub const XI_LIMIT: f64 = 0.05;

/// theta: the admittance gains.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Gains {
    /// Stiffness of the inner loop per unit of joint inertia (1/s^2).
    pub k_tau: f64,
    /// Admittance rate (m/(N s)).
    pub k_xi: f64,
}

impl Gains {
    pub fn to_vec(self) -> Vec<f64> {
        vec![self.k_tau, self.k_xi]
    }

    /// Rejects gains that are not finite and positive.
    pub fn check(self) -> Result<Gains, String> {
        if [self.k_tau, self.k_xi]
            .iter()
            .all(|g| g.is_finite() && *g > 0.0)
        {
            Ok(self)
        } else {
            Err(format!(
                "gains k_tau = {}, k_xi = {} must be finite and positive",
                self.k_tau, self.k_xi
            ))
        }
    }
}

/// One arm joint as the inner loop sees it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ArmJoint {
    /// The motor's torque limit (N m).
    pub limit: f64,
    /// The joint's inertia I_i (kg m^2).
    pub inertia: f64,
}

/// The controller on one model: its gains, the arm's joints and a buffer
/// for the gravity pass.
#[derive(Clone, Debug)]
pub struct Admittance<T: Real> {
    pub gains: Gains,
    /// The arm is the first `arm.len()` dofs; the rest get no torque.
    arm: Vec<ArmJoint>,
    zeros: Vec<T>,
}

impl<T: Real> Admittance<T> {
    pub fn new(gains: Gains, arm: &[ArmJoint], nv: usize) -> Self {
        Admittance {
            gains,
            arm: arm.to_vec(),
            zeros: vec![T::zero(); nv],
        }
    }

    /// The torques (length nv) at (q, v) on the sensed normal force (N: ours,
    /// [`sensed_force`], another engine's or a real sensor's) with offset `xi`
    /// toward the tip target `target` (m, world), `h` the control period (s);
    /// returns the offset for the next step (m).
    pub fn act(
        &mut self,
        tree: &Tree<T>,
        data: &mut Data<T>,
        (q, v, force): (&[T], &[T], T),
        xi: T,
        (target, h): (Vector3<f64>, f64),
        tau: &mut [T],
    ) -> T {
        let gains = self.gains;
        let step = xi + lift::<T>(h * gains.k_xi) * (lift::<T>(F_GOAL) - force);
        let xi_next = clamp(step, XI_LIMIT);
        let q_cmd = tool_down_at(lift::<T>(target.x), lift::<T>(target.z) - xi);
        bias_forces(tree, data, q, &self.zeros, tau);
        let (k, d) = (gains.k_tau, 2.0 * gains.k_tau.sqrt());
        for (i, joint) in self.arm.iter().enumerate() {
            let (k, d) = (lift::<T>(k * joint.inertia), lift::<T>(d * joint.inertia));
            tau[i] = clamp(tau[i] + k * (q_cmd[i] - q[i]) - d * v[i], joint.limit);
        }
        for t in &mut tau[self.arm.len()..] {
            *t = T::zero();
        }
        xi_next
    }
}

/// The tool-table normal force over the last step (N): the normal forces of
/// the contacts of the tree's last force evaluation ([`Data::contacts`] under
/// the smooth model, [`Data::constrained`] under the constraint model; a
/// semi-implicit Euler step has one evaluation), summed. 0 before any step.
pub fn sensed_force<T: Real>(tree: &Tree<T>, data: &Data<T>) -> T {
    let normal = |contacts: &[Contact<T>]| {
        contacts
            .iter()
            .fold(T::zero(), |sum, c| sum + c.normal_force)
    };
    match tree.opt.contact_model {
        ContactModel::Smooth => normal(&data.contacts),
        ContactModel::Constraint => data.constrained.as_ref().map_or(T::zero(), |c| {
            normal(&contact_forces(&c.contacts, &c.rows, &c.solution.force))
        }),
    }
}

/// x clamped into [-limit, limit].
fn clamp<T: Real>(x: T, limit: f64) -> T {
    let limit: T = lift(limit);
    if x > limit {
        limit
    } else if x < -limit {
        -limit
    } else {
        x
    }
}
