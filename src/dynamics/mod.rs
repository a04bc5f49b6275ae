//! Rigid-body dynamics on a [`Tree`]: kinematics, inverse dynamics (RNEA), the
//! mass matrix (CRBA), forward dynamics (ABA), passive forces, soft contact
//! and joint limits, and the step.
//!
//! Every algorithm is generic over the scalar (f64 or dual numbers) and works in
//! a [`Data`] workspace allocated once per tree, so nothing allocates per call.
//! The equation of motion is M(q) a = tau + tau_passive + tau_soft - c(q, v), with M
//! including the joints' armature on its diagonal and c the Coriolis,
//! centrifugal and gravity forces and tau_soft the contact and joint-limit
//! forces of [`contact`].

// The algorithms sweep tree nodes by index and read several per-node arrays at
// that index; the index is the node, not an incidental loop counter.
#![allow(clippy::needless_range_loop)]

mod aba;
pub mod actuation;
pub mod cholesky;
pub mod collision;
pub mod configuration;
pub mod constraint;
pub mod contact;
mod crba;
pub mod fluid;
pub mod gravcomp;
pub mod implicit;
pub mod integrator;
mod kinematics;
mod ltdl;
pub mod mocap;
mod passive;
mod rnea;
mod step;
pub mod tendon;
mod tree;
pub mod wrap;

pub use aba::{aba, aba_with_transforms};
pub use collision::{body_contact_forces, Contact};
pub use contact::{add_soft_forces, add_soft_forces_with_transforms};
pub use crba::{crba, crba_with_transforms};
pub use integrator::{implicit_terms, integrate_euler};
pub use kinematics::{
    body_force_to_joints, body_pose, body_poses, point_jacobian, update_transforms, world_frames,
};
pub use ltdl::{ltdl_factor, ltdl_inverse, ltdl_solve, ltdl_solve_columns};
pub use passive::{passive_forces, stretch};
pub use rnea::{bias_forces, bias_forces_with_transforms, rnea, rnea_with_transforms};
pub use step::{
    acceleration, check_actuation, check_colliders, check_inputs, implicit_acceleration, step,
    step_actuated, step_applied, Constrained, StepError,
};
pub use tendon::{add_tendon_forces, tendon_states, TendonConsts, TendonState};
pub use tree::{BodyFrame, NodeJoint, Tree};

use crate::spatial::{ArticulatedInertia, Force, Inertia, Motion, Real, Transform};
use nalgebra::DMatrix;

/// Per-call workspace of the algorithms, sized for one tree.
#[derive(Clone, Debug)]
pub struct Data<T: Real> {
    /// From the parent node's frame to node i's frame at the current q.
    pub x_up: Vec<Transform<T>>,
    pub vel: Vec<Motion<T>>,
    pub acc: Vec<Motion<T>>,
    pub force: Vec<Force<T>>,
    /// Velocity-product acceleration v_i x S_i qd_i (ABA's c_i).
    pub bias_acc: Vec<Motion<T>>,
    pub art_inertia: Vec<ArticulatedInertia<T>>,
    pub art_bias: Vec<Force<T>>,
    /// ABA's U_i = I^A_i S_i, D_i and u_i.
    pub u_force: Vec<Force<T>>,
    pub d: Vec<T>,
    pub u: Vec<T>,
    pub composite: Vec<Inertia<T>>,
    pub mass_matrix: DMatrix<T>,
    /// Filled by [`world_frames`]: from the world to node i's frame; node i's
    /// motion axis S_i and spatial velocity in world coordinates. Filled by
    /// [`add_soft_forces`] for a tree with contact pairs: the contact forces
    /// on node i's subtree (world coordinates, about the world origin).
    pub world: Vec<Transform<T>>,
    pub world_axis: Vec<Motion<T>>,
    pub world_vel: Vec<Motion<T>>,
    pub world_force: Vec<Force<T>>,
    /// The contacts of the last force evaluation (smooth model).
    pub contacts: Vec<Contact<T>>,
    /// The constraint model's last evaluation: its contacts, rows and solution.
    pub constrained: Option<Constrained<T>>,
    /// From the world to each mocap body's frame: the step's mocap input
    /// ([`mocap::set_mocap`]; the compiled poses until set).
    pub mocap: Vec<Transform<T>>,
    /// The tendons' kinematics at the last force evaluation's state
    /// ([`tendon_states`]), in model order: what every consumer of a
    /// tendon's length, velocity and moment reads.
    pub tendon: Vec<TendonState<T>>,
    /// The actuators' transmissions (length, velocity, moment) at the last
    /// evaluation's state ([`actuation::transmissions`]), in actuator order.
    pub actuator: Vec<TendonState<T>>,
    /// Scratch vectors: the acceleration's (nv each), and the integrator's.
    scratch: [Vec<T>; 3],
    /// The step's applied forces with the actuators' (nv) and the
    /// activation rates (na).
    actuated: Vec<T>,
    act_rate: Vec<T>,
    stage: integrator::Stages<T>,
    /// The constraint model's buffers.
    reuse: step::Reuse<T>,
    /// The implicit integrators' buffers.
    implicit: implicit::Buffers<T>,
}

impl<T: Real> Data<T> {
    /// The mass matrix the last constraint-model acceleration with rows
    /// solved with, factored by [`ltdl_factor`]: M + E (E the implicit
    /// passive diagonal) under Euler's implicit passive forces, else M
    /// (under the implicit integrators too, whose solve with M - h qDeriv
    /// follows the constraint solver's, [`implicit`]).
    pub fn factored_mass(&self) -> &DMatrix<T> {
        self.reuse.factored_mass()
    }

    pub fn new(tree: &Tree<T>) -> Self {
        let n = tree.nv();
        Data {
            x_up: vec![Transform::identity(); n],
            vel: vec![Motion::zero(); n],
            acc: vec![Motion::zero(); n],
            force: vec![Force::zero(); n],
            bias_acc: vec![Motion::zero(); n],
            art_inertia: vec![Inertia::zero().into(); n],
            art_bias: vec![Force::zero(); n],
            u_force: vec![Force::zero(); n],
            d: vec![T::zero(); n],
            u: vec![T::zero(); n],
            composite: vec![Inertia::zero(); n],
            mass_matrix: DMatrix::zeros(n, n),
            world: vec![Transform::identity(); n],
            world_axis: vec![Motion::zero(); n],
            world_vel: vec![Motion::zero(); n],
            world_force: vec![Force::zero(); n],
            contacts: vec![],
            constrained: None,
            mocap: mocap::poses(&tree.mocap_pos, &tree.mocap_quat),
            tendon: vec![],
            actuator: vec![],
            scratch: std::array::from_fn(|_| vec![T::zero(); n]),
            actuated: vec![T::zero(); n],
            act_rate: vec![T::zero(); tree.na],
            stage: integrator::Stages::new(tree),
            reuse: step::Reuse::new(n),
            implicit: implicit::Buffers::new(n),
        }
    }
}
