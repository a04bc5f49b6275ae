//! Exact derivatives of a step with respect to state, control and named
//! physical parameters, and the identification loss built on them.
//!
//! A step's acceleration qdd solves R(q, v, qdd, tau; p) = 0, with
//! R = ID(q, v, a) + extra * a - tau - tau_passive(stretch, v) (see
//! [`crate::dynamics::step`] for the passive modes). Differentiating,
//! d qdd / d theta = -(M + diag(extra))^-1 dR/d theta, for theta any of q, v,
//! tau or p. dR/dq and dR/dv come from analytic RNEA derivatives
//! ([`rnea_derivatives`]); dR/dp analytically too: a body parameter adds one
//! body force along one path to the root (its inertia derivative by hand),
//! a joint parameter one entry. So a one-parameter Jacobian
//! costs one RNEA pass and a triangular solve, not a state Jacobian. Dual
//! numbers pushed through the whole scalar-generic step are the test oracle.
//! The integrator's chain rule (Euler or RK4) then gives d(q', v').
//! Contact and joint-limit forces add -tau_soft(q, v; k, c, mu) to R; their
//! derivatives come from dual numbers through the scalar-generic force code
//! (module `soft`), exact as the rest. Under the constraint model the
//! solver's acceleration is differentiated implicitly (module `constraint`:
//! state, tau, body and joint parameters), the contact parameters by dual
//! numbers through the whole step (module `constrained`): exact for the
//! solver's converged zones, one-sided where they switch.
//! When the target's constraint forces are unknown (another engine's contact
//! law), module `eliminated` fits the same residual R at the observed
//! acceleration with the impulses that may act eliminated.
//! No finite differences anywhere: they exist only in the tests.

// Node-indexed sweeps read several per-node arrays at the node's index.
#![allow(clippy::needless_range_loop)]

mod actuation;
mod constrained;
mod constraint;
mod eliminated;
mod gemm;
mod params;
mod rnea;
mod soft;
mod step;
mod tangent;
mod transition;
mod window;

pub use actuation::{input_jacobians, InputJacobians};
pub use eliminated::{eliminated_residuals_into, Elimination, Impulses};
pub use rnea::{rnea_derivatives, Sweep};
pub use step::{step_jacobians, StepJacobians, Workspace, Wrt};
pub use transition::{transition_jacobians, TransitionJacobians};
pub(crate) use window::check_transition;
pub use window::{window_residuals, window_residuals_into, Transition, WindowError, WindowFit};

use crate::dynamics::integrator::euler;
use crate::dynamics::StepError;
use crate::Model;

/// Whether a model's step Jacobians come from dual numbers alone: ball and
/// free joints (their columns in the tangent space, see module
/// `constrained`), fluid forces, gravity compensation and the implicit
/// integrators (`implicitfast`, `implicit`: exact through their generic
/// step) have no analytic derivatives yet.
fn dual_only(model: &Model) -> bool {
    !model.one_dof_joints()
        || model.opt.fluid.acts()
        || model.has_gravcomp()
        || model.has_tendon_springs()
        || model.opt.integrator.is_implicit()
}

/// Whether a step's Jacobian comes from dual numbers alone: as
/// [`dual_only`], but with ball and free joints the state, tau and body
/// parameter columns are analytic (module `tangent`) under semi-implicit
/// Euler without soft limits or DART's implicit springs on a rotation (and
/// without constraint rows or soft contacts at the point: `accel_derivatives`
/// declines those); the joint parameters' columns stay dual there.
fn dual_step(model: &Model) -> bool {
    let tree = model.tree();
    let springs =
        crate::dynamics::integrator::ImplicitPassive::new(model.opt.passive, model.opt.timestep)
            .spring_step()
            != 0.0;
    let rotations = !model.one_dof_joints()
        && (euler(&model.opt).is_none()
            || tree.limits.iter().any(Option::is_some)
            || springs
                && (0..tree.nv())
                    .any(|i| tangent::is_rotation(tree, i) && tree.stiffness[i] != 0.0));
    rotations
        || model.opt.fluid.acts()
        || model.has_gravcomp()
        || model.has_tendon_springs()
        || model.opt.integrator.is_implicit()
}

/// Refuses, for the residuals with unknown constraints (which index q and v
/// alike and differentiate analytically), a model with ball or free joints,
/// fluid forces, gravity compensation or acting tendons.
pub(crate) fn one_dof_joints(model: &Model) -> Result<(), StepError> {
    if !model.one_dof_joints() {
        Err(StepError::NoTangentDerivatives)
    } else if model.opt.fluid.acts() {
        Err(StepError::NoFluidDerivatives)
    } else if model.has_gravcomp() {
        Err(StepError::NoGravcompDerivatives)
    } else if model.tendons.iter().any(|t| t.acts()) {
        Err(StepError::NoTendonDerivatives)
    } else {
        Ok(())
    }
}
