//! One timestep of the equations of motion.

use nalgebra::DMatrix;

use std::mem::take;

use super::actuation::{
    act_rates, add_actuator_forces, add_force_velocity_derivatives, idle_without_inputs, next_acts,
};
use super::collision::{ConstraintContact, Pre};
use super::constraint::noslip::{self, noslip};
use super::constraint::solver::{solve, Scratch, Solution, Start};
use super::constraint::{rows, unreachable_pair, Rows};
use super::contact::lawless_within_reach;
use super::fluid::add_fluid_forces;
use super::gravcomp::add_gravcomp_forces;
use super::implicit::{implicit_matrix, lu_solve};
use super::integrator::{
    euler_step, implicit_step, implicit_terms, runge_kutta, tableau, ImplicitPassive,
};
use super::{
    aba_with_transforms, add_soft_forces_with_transforms, add_tendon_forces,
    bias_forces_with_transforms, crba_with_transforms, ltdl_factor, ltdl_solve, passive_forces,
    tendon_states, update_transforms, world_frames, Data, Tree,
};
use crate::model::{ContactModel, Integrator, PassiveMode};
use crate::spatial::{lift, Real};

#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum StepError {
    #[error("{name} has length {got}, expected {expected}")]
    Length {
        name: &'static str,
        got: usize,
        expected: usize,
    },
    #[error("{name}[{index}] is not finite")]
    NotFinite { name: &'static str, index: usize },
    #[error("the step diverged: the next state is not finite (timestep too large?)")]
    Diverged,
    /// The same, its likely cause named from the state stepped from (by
    /// [`crate::Model::step`], which knows the names).
    #[error("the step diverged: the next state is not finite; {cause}")]
    DivergedAt { cause: String },
    /// Two geoms within reach of each other whose shapes have no collider.
    #[error(
        "geoms {} and {} (model geom indices) are within reach and the constraint model has \
         no collider for their shapes yet (see diffosi::dynamics::collision); switch their \
         contacts off (contype/conaffinity, <exclude>) or use the smooth contact model",
        .0[0], .0[1]
    )]
    NoCollider([usize; 2]),
    /// The same under the smooth model: two geoms within its reach whose
    /// shapes its law has no force for.
    #[error(
        "geoms {} and {} (model geom indices) are within reach and the smooth contact model \
         has no force law for their shapes (it has plane against sphere, capsule and box, and \
         spheres and capsules against each other; see diffosi::dynamics::contact); switch \
         their contacts off (contype/conaffinity) or use the constraint model",
        .0[0], .0[1]
    )]
    NoSmoothLaw([usize; 2]),
    /// The residuals with unknown constraints (analytic, q and v indexed
    /// alike) of models with ball or free joints are not written yet.
    #[error(
        "identification with unknown constraints of models with ball or free joints is not \
         supported yet (their identification with modelled constraints is)"
    )]
    NoTangentDerivatives,
    /// The same for models in a fluid.
    #[error(
        "identification with unknown constraints of models with fluid forces is not supported \
         yet (their identification with modelled constraints is)"
    )]
    NoFluidDerivatives,
    /// A sensor of a kind that is read but not computed
    /// ([`crate::model::SensorKind::Unsupported`]).
    #[error("sensor '{name}' (<{element}>) cannot be evaluated: {why}")]
    SensorNotComputed {
        name: String,
        element: String,
        why: String,
    },
    /// The residuals with unknown constraints of models whose actuators act
    /// at zero control (servos, activations) are not written yet.
    #[error(
        "identification with unknown constraints of models whose actuators act at zero control \
         (position or velocity servos, activations) is not supported yet"
    )]
    NoActuatorDerivatives,
    /// Derivatives in an actuator's gain or bias where every block comes
    /// from dual numbers (RK4 or the implicit integrators with actuators
    /// whose force reads the state or an activation; any integrator with
    /// actuators on sites or spatial tendons).
    #[error(
        "derivatives in an actuator's gain or bias are not supported yet under the {0:?} \
         integrator with actuators whose force reads the joint or an activation (servos, \
         filters), nor with actuators on sites or spatial tendons; use Euler with actuators \
         on joints or fixed tendons"
    )]
    NoActuatorParamDerivatives(crate::model::Integrator),
    /// The same for models with gravity compensation.
    #[error(
        "identification with unknown constraints of models with gravity compensation \
         (gravcomp) is not supported yet (their identification with modelled constraints is)"
    )]
    NoGravcompDerivatives,
    /// The same for models whose tendons act.
    #[error(
        "identification with unknown constraints of models whose tendons act (springs, \
         dampers, limits, frictionloss) is not supported yet (their identification with \
         modelled constraints is)"
    )]
    NoTendonDerivatives,
    /// An input an evaluation would ignore: contacts
    /// ([`crate::Model::contacts`]) leave the actuators out, so they take no
    /// ctrl or act.
    #[error("{name} is not read here: contacts leave the actuators out (pass it empty)")]
    NotRead { name: &'static str },
    /// The next state is finite but a Jacobian block overflowed.
    #[error("the step Jacobian {block} is not finite (state, forces or parameters too large)")]
    JacobianNotFinite { block: &'static str },
}

/// Advances (q, v) by one timestep under generalized forces tau, writing the
/// next state into (q_next, v_next); the timestep, integrator and passive
/// mode are the tree's options (`tree.opt`). q has nq coordinates, v, tau and qdd nv
/// (module `model`); q (+) h v moves q along v
/// ([`integrate`](super::configuration::integrate): q + h v for
/// hinges and slides, the quaternions turned by their body-frame angular
/// velocity), and s(q) is the springs' stretch ([`stretch`](super::stretch): q - q_s).
///
/// Semi-implicit Euler: v' = v + h qdd, q' = q (+) h v', where qdd solves
/// - `Explicit`:                 M qdd = tau - c - D v  - K s(q)
/// - `ImplicitDamping`:          (M + hD) qdd = tau - c - D v - K s(q),
///   i.e. damping acts at v' (MuJoCo's Euler)
/// - `ImplicitDampingStiffness`: (M + hD + h^2 K) qdd = tau - c - D v - K (s(q) + h v),
///   i.e. damping at v' and the spring at q' (DART)
///
/// `implicitfast` and `implicit` solve (M - h qDeriv) qdd = tau - c - D v - K s(q)
/// (+ the constraint forces), MuJoCo's mj_implicit ([`super::implicit`]);
/// the passive mode is not used there (damping enters through qDeriv).
///
/// RK4 integrates dq/dt = v, dv/dt = M^-1 (tau - c - D v - K s(q)) classically
/// by its Butcher tableau, its stages and result moved along the manifold as
/// MuJoCo's mj_RungeKutta does ([`super::integrator`], which holds the
/// implicit passive term too).
///
/// Contact and joint-limit forces ([`super::contact`]) join tau on the right:
/// explicit in the Euler step (evaluated at (q, v)), at each stage under RK4.
///
/// Actuators with ctrl = 0 and act = 0 act too (a position servo's bias
/// pulls toward 0): this is [`step_actuated`] with empty ctrl and act.
pub fn step<T: Real>(
    tree: &Tree<T>,
    data: &mut Data<T>,
    (q, v, tau): (&[T], &[T], &[T]),
    (q_next, v_next): (&mut [T], &mut [T]),
) -> Result<(), StepError> {
    let next = (q_next, v_next, &mut [][..]);
    step_actuated(tree, data, (q, v, &[]), (&[], tau), next)
}

/// One step as MuJoCo's mj_step takes it: from the state (q, v, act) under
/// the inputs ctrl (nu, through the actuators, [`super::actuation`]) and
/// tau (nv, applied at the dofs), writing (q', v', act'). The actuators'
/// generalized forces join tau (under RK4 at each stage, from the stage's
/// q, v and act); act moves at its rate as MuJoCo's Euler and RK4 move it
/// (RK4: its stages at act + h sum a_ij act'_j, then MuJoCo's
/// nextActivation from act at the rate sum b_i act'_i). ctrl and act may be
/// empty (zero); act_next is written when it has na entries (else empty).
pub fn step_actuated<T: Real>(
    tree: &Tree<T>,
    data: &mut Data<T>,
    (q, v, act): (&[T], &[T], &[T]),
    (ctrl, tau): (&[T], &[T]),
    (q_next, v_next, act_next): (&mut [T], &mut [T], &mut [T]),
) -> Result<(), StepError> {
    check_actuation(tree, (ctrl, act))?;
    let expected = if act_next.is_empty() { 0 } else { tree.na };
    if act_next.len() != expected {
        let got = act_next.len();
        let name = "act_next";
        return Err(StepError::Length {
            name,
            got,
            expected,
        });
    }
    let idle = ctrl.is_empty() && act.is_empty() && idle_without_inputs(&tree.actuators);
    if idle {
        return step_applied(tree, data, (q, v, tau), (q_next, v_next));
    }
    prepare(tree, data, (q, v, tau), (q_next.len(), v_next.len()))?;
    let next = (&mut *q_next, &mut *v_next);
    let opt = &tree.opt;
    let h = opt.timestep;
    match tableau(opt.integrator) {
        None => {
            let (mut total, mut rate) = (take(&mut data.actuated), take(&mut data.act_rate));
            act_rates(&tree.actuators, (ctrl, act), &mut rate);
            total.copy_from_slice(tau);
            let inputs = (ctrl, act, &rate[..]);
            add_actuator_forces(tree, h, data, (q, v), inputs, &mut total);
            if opt.integrator.is_implicit() {
                let slope = data.implicit.actuator_slope();
                add_force_velocity_derivatives(tree, h, &data.actuator, inputs, slope);
                implicit_step(tree, data, (q, v, &total), next);
                data.implicit.actuator_slope();
            } else {
                euler_step(tree, (opt.passive, h), data, (q, v, &total), next);
            }
            if !act_next.is_empty() {
                next_acts(&tree.actuators, h, (act, &rate), act_next);
            }
            (data.actuated, data.act_rate) = (total, rate);
        }
        Some(t) => runge_kutta(
            tree,
            (t, h),
            data,
            (q, v),
            (ctrl, Some(act), tau),
            next,
            act_next,
        ),
    }
    if q_next
        .iter()
        .chain(v_next.iter())
        .chain(act_next.iter())
        .all(|x| x.is_finite())
    {
        Ok(())
    } else {
        Err(StepError::Diverged)
    }
}

/// A step under the generalized forces tau alone, the actuators left out
/// (the derivatives add theirs to tau, [`crate::derivatives`]).
pub fn step_applied<T: Real>(
    tree: &Tree<T>,
    data: &mut Data<T>,
    (q, v, tau): (&[T], &[T], &[T]),
    (q_next, v_next): (&mut [T], &mut [T]),
) -> Result<(), StepError> {
    prepare(tree, data, (q, v, tau), (q_next.len(), v_next.len()))?;
    let next = (&mut *q_next, &mut *v_next);
    let opt = &tree.opt;
    match tableau(opt.integrator) {
        None if opt.integrator.is_implicit() => implicit_step(tree, data, (q, v, tau), next),
        None => euler_step(tree, (opt.passive, opt.timestep), data, (q, v, tau), next),
        Some(t) => {
            let inputs = (&[][..], None, tau);
            runge_kutta(tree, (t, opt.timestep), data, (q, v), inputs, next, &mut [])
        }
    }
    if q_next.iter().chain(v_next.iter()).all(|x| x.is_finite()) {
        Ok(())
    } else {
        Err(StepError::Diverged)
    }
}

/// The checks before a step: q, v, tau and the next state's lengths (nq_next,
/// nv_next), and no pair within reach whose contact the model would miss
/// ([`check_colliders`]).
fn prepare<T: Real>(
    tree: &Tree<T>,
    data: &mut Data<T>,
    (q, v, tau): (&[T], &[T], &[T]),
    (nq_next, nv_next): (usize, usize),
) -> Result<(), StepError> {
    check_inputs(tree, (q, v, tau))?;
    let lengths = [("q_next", nq_next, q.len()), ("v_next", nv_next, v.len())];
    for (name, got, expected) in lengths {
        if got != expected {
            return Err(StepError::Length {
                name,
                got,
                expected,
            });
        }
    }
    check_colliders(tree, data, (q, v))
}

/// Refuses a state at which two geoms are within reach whose contact the
/// model would miss: under the constraint model a pair without a collider,
/// under the smooth model one without a force law.
pub fn check_colliders<T: Real>(
    tree: &Tree<T>,
    data: &mut Data<T>,
    (q, v): (&[T], &[T]),
) -> Result<(), StepError> {
    let missing = match tree.opt.contact_model {
        ContactModel::Constraint => tree.constraint.pairs.iter().any(|p| !p.supported),
        ContactModel::Smooth => !tree.lawless.is_empty(),
    };
    if !missing {
        return Ok(());
    }
    update_transforms(tree, data, q);
    world_frames(tree, data, v);
    if let Some(pair) = unreachable_pair(tree, data) {
        return Err(StepError::NoCollider(pair));
    }
    match lawless_within_reach(tree, data) {
        Some(pair) => Err(StepError::NoSmoothLaw(pair)),
        None => Ok(()),
    }
}

/// Checks that q has length nq, v and tau nv, and all are finite.
pub fn check_inputs<T: Real>(
    tree: &Tree<T>,
    (q, v, tau): (&[T], &[T], &[T]),
) -> Result<(), StepError> {
    let (nq, nv) = (tree.nq(), tree.nv());
    for (name, x, n) in [("q", q, nq), ("v", v, nv), ("tau", tau, nv)] {
        check(name, x, n)?;
    }
    Ok(())
}

/// Checks that ctrl has length nu and act na (either may be empty: zero),
/// and both are finite.
pub fn check_actuation<T: Real>(
    tree: &Tree<T>,
    (ctrl, act): (&[T], &[T]),
) -> Result<(), StepError> {
    check("ctrl", ctrl, if ctrl.is_empty() { 0 } else { tree.nu() })?;
    check("act", act, if act.is_empty() { 0 } else { tree.na })
}

pub(super) fn check<T: Real>(name: &'static str, x: &[T], n: usize) -> Result<(), StepError> {
    if x.len() != n {
        return Err(StepError::Length {
            name,
            got: x.len(),
            expected: n,
        });
    }
    match x.iter().position(|xi| !xi.is_finite()) {
        Some(index) => Err(StepError::NotFinite { name, index }),
        None => Ok(()),
    }
}

/// The acceleration of a semi-implicit Euler step of length h under passive
/// mode `mode`: qdd solving (M + diag(extra)) qdd = tau + tau_passive + tau_soft - c, with
/// the spring position and implicit diagonal of [`implicit_terms`]. Under
/// `Explicit` this is the plain forward dynamics with passive forces, which
/// RK4 evaluates at its stages.
pub fn acceleration<T: Real>(
    tree: &Tree<T>,
    data: &mut Data<T>,
    (mode, h): (PassiveMode, f64),
    state: (&[T], &[T], &[T]),
    qdd: &mut [T],
) {
    accelerate(tree, data, (mode, h), None, state, qdd);
}

/// The acceleration of an `implicitfast` or `implicit` step (`integrator`):
/// qdd solving (M - h qDeriv) qdd = tau + tau_passive + tau_soft - c (+ J^T f,
/// the constraint forces solved under M) ([`super::implicit`]).
pub fn implicit_acceleration<T: Real>(
    tree: &Tree<T>,
    data: &mut Data<T>,
    integrator: Integrator,
    state: (&[T], &[T], &[T]),
    qdd: &mut [T],
) {
    let explicit = (PassiveMode::Explicit, tree.opt.timestep);
    accelerate(tree, data, explicit, Some(integrator), state, qdd);
}

/// What the acceleration's solve adds to M on the left.
#[derive(Clone, Copy)]
enum Lhs<'a, T> {
    /// The implicit passive diagonal of a semi-implicit Euler step.
    Diagonal(&'a [T]),
    /// -h qDeriv, MuJoCo's implicit integrators.
    Implicit(Integrator),
}

/// [`acceleration`] (`integrator` None) or [`implicit_acceleration`].
fn accelerate<T: Real>(
    tree: &Tree<T>,
    data: &mut Data<T>,
    (mode, h): (PassiveMode, f64),
    integrator: Option<Integrator>,
    (q, v, tau): (&[T], &[T], &[T]),
    qdd: &mut [T],
) {
    update_transforms(tree, data, q);
    let constraints = tree.opt.contact_model == ContactModel::Constraint && tree.has_constraints();
    let spatial = tree.has_spatial_tendons();
    if constraints || spatial || !tree.fluid.is_empty() || !tree.gravcomp.is_empty() {
        world_frames(tree, data, v);
    }
    tendon_states(tree, data, (q, v));
    let mut scratch = std::mem::take(&mut data.scratch);
    let [force, extra, stretched, ..] = &mut scratch;
    implicit_terms(tree, (mode, h), (q, v), stretched, extra);
    passive_forces(tree, stretched, v, force);
    add_tendon_forces(tree, data, force);
    for i in 0..tree.nv() {
        force[i] += tau[i];
    }
    let implicit = ImplicitPassive::new(mode, lift::<T>(h)).acts();
    let lhs = match integrator {
        Some(integrator) => Some(Lhs::Implicit(integrator)),
        None => implicit.then_some(Lhs::Diagonal(&extra[..])),
    };
    if !tree.fluid.is_empty() {
        add_fluid_forces(tree, data, force);
    }
    if !tree.gravcomp.is_empty() {
        add_gravcomp_forces(tree, data, force);
    }
    let previous = data.constrained.take();
    if constraints {
        // From the previous RK4 stage's solution if it had one.
        let start = match previous {
            Some(_) => data.reuse.start,
            None => Start::Unconstrained,
        };
        // The last evaluation's buffers, refilled.
        let mut c = previous
            .or_else(|| data.reuse.spare.take())
            .unwrap_or_default();
        let mut pre = std::mem::take(&mut data.reuse.pre);
        rows(tree, data, (q, v), (&mut c.contacts, &mut c.rows, &mut pre));
        data.reuse.pre = pre;
        if !c.rows.is_empty() {
            constrained(tree, data, (v, start), force, lhs, &mut c, qdd);
            data.constrained = Some(c);
            data.scratch = scratch;
            return;
        }
        data.reuse.spare = Some(c);
    } else {
        add_soft_forces_with_transforms(tree, data, (q, v), force);
    }
    match lhs {
        Some(Lhs::Implicit(integrator)) => {
            bias_forces_with_transforms(tree, data, v, qdd);
            for i in 0..tree.nv() {
                qdd[i] = force[i] - qdd[i];
            }
            crba_with_transforms(tree, data);
            implicit_solve(tree, data, integrator, v, qdd);
        }
        Some(Lhs::Diagonal(extra)) => aba_with_transforms(tree, data, v, force, Some(extra), qdd),
        None => aba_with_transforms(tree, data, v, force, None, qdd),
    }
    data.scratch = scratch;
}

/// Solves (M - h qDeriv) qdd = f for the implicit integrators, f in `qdd`
/// on entry (`data.mass_matrix` holds M, `data.x_up` is at q); a singular
/// matrix gives a qdd that is not finite (the step reports divergence).
fn implicit_solve<T: Real>(
    tree: &Tree<T>,
    data: &mut Data<T>,
    integrator: Integrator,
    v: &[T],
    qdd: &mut [T],
) {
    implicit_matrix(tree, data, integrator, v);
    if !lu_solve(&mut data.implicit.matrix, qdd) {
        qdd.fill(lift(f64::NAN));
    }
}

/// The constraint model's last evaluation (see `constrained`).
#[derive(Clone, Debug)]
pub struct Constrained<T: Real> {
    pub contacts: Vec<ConstraintContact<T>>,
    pub rows: Rows<T>,
    pub solution: Solution<T>,
}

impl<T: Real> Default for Constrained<T> {
    fn default() -> Self {
        Constrained {
            contacts: vec![],
            rows: Rows::default(),
            solution: Solution::default(),
        }
    }
}

/// The constraint model's buffers, kept in [`Data`] so that a step allocates
/// nothing once they have grown: a last evaluation without rows (whose
/// vectors the next one refills), the colliders' and the solver's scratch,
/// a factored mass matrix and a vector of length nv; and where the next
/// solve starts: at the last solution only between the stages of one
/// Runge-Kutta step ([`super::integrator`]), so that a step depends on its
/// arguments alone.
#[derive(Clone, Debug)]
pub struct Reuse<T: Real> {
    pub(super) start: Start,
    spare: Option<Constrained<T>>,
    pre: Vec<Pre<T>>,
    solver: Scratch<T>,
    noslip: noslip::Scratch<T>,
    factor: DMatrix<T>,
    a0: Vec<T>,
}

impl<T: Real> Reuse<T> {
    /// See [`Data::factored_mass`].
    pub fn factored_mass(&self) -> &DMatrix<T> {
        &self.factor
    }

    pub fn new(nv: usize) -> Self {
        Reuse {
            start: Start::Unconstrained,
            spare: None,
            pre: vec![],
            solver: Scratch::default(),
            noslip: noslip::Scratch::default(),
            factor: DMatrix::zeros(nv, nv),
            a0: vec![T::zero(); nv],
        }
    }
}

/// The acceleration under the constraint model, as MuJoCo's forward pass
/// computes it:
/// 1. collision and constraint rows at (q, v) ([`super::constraint`]; with
///    none, the step is the plain articulated dynamics, bit for bit);
/// 2. a0 = M^-1 (tau + tau_passive - c), M from CRBA (armature included);
/// 3. the constrained acceleration and forces f ([`super::constraint::solver`]),
///    then MuJoCo's noslip sweeps where the model asks for them
///    ([`super::constraint::noslip`]);
/// 4. with implicit passive terms (MuJoCo's Euler), the acceleration is
///    solved again with them, (M + diag(extra)) qdd = tau + tau_passive - c
///    plus J^T f, and under the implicit integrators with M - h qDeriv
///    instead (mj_implicit); otherwise qdd is the solver's.
///
/// `force` holds tau + tau_passive on entry; `data.x_up` is at q; `c` holds
/// the contacts and rows, and receives the solution.
fn constrained<T: Real>(
    tree: &Tree<T>,
    data: &mut Data<T>,
    (v, start): (&[T], Start),
    force: &mut [T],
    lhs: Option<Lhs<'_, T>>,
    c: &mut Constrained<T>,
    qdd: &mut [T],
) {
    let n = tree.nv();
    // c into qdd, then subtracted.
    bias_forces_with_transforms(tree, data, v, qdd);
    for i in 0..n {
        force[i] -= qdd[i];
    }
    crba_with_transforms(tree, data);
    let (mass, r) = (&data.mass_matrix, &mut data.reuse);
    r.factor.copy_from(mass);
    ltdl_factor(tree, &mut r.factor);
    r.a0.copy_from_slice(force);
    ltdl_solve(tree, &r.factor, &mut r.a0);
    let iterations = tree.opt.solver.iterations;
    solve(
        mass,
        &r.a0,
        &c.rows,
        (iterations, start),
        (&mut c.solution, &mut r.solver),
    );
    let factor = &r.factor;
    noslip(
        &c.rows,
        &r.a0,
        |x: &mut [T]| ltdl_solve(tree, factor, x),
        (&tree.parent, tree.constraint.mean_inertia),
        tree.opt.solver.noslip,
        (&mut c.solution, &mut r.noslip),
    );
    let Some(lhs) = lhs else {
        qdd.copy_from_slice(&c.solution.qacc);
        return;
    };
    // tau + tau_passive - c + J^T f
    qdd.copy_from_slice(force);
    for (row, f) in c.rows.j.chunks_exact(n).zip(&c.solution.force) {
        for i in 0..n {
            qdd[i] += row[i] * *f;
        }
    }
    match lhs {
        Lhs::Implicit(integrator) => implicit_solve(tree, data, integrator, v, qdd),
        Lhs::Diagonal(extra) => {
            let (mass, r) = (&data.mass_matrix, &mut data.reuse);
            r.factor.copy_from(mass);
            for i in 0..n {
                r.factor[(i, i)] += extra[i];
            }
            ltdl_factor(tree, &mut r.factor);
            ltdl_solve(tree, &r.factor, qdd);
        }
    }
}
