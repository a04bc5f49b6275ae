//! Actuation as MuJoCo's mj_fwdActuation computes it, for actuators on one
//! hinge or slide joint ([`crate::model::Actuator`] states the law and its
//! conventions): controls clamped to their ranges, activation rates, the
//! actuators' scalar forces clamped to their force ranges, and the
//! generalized force gear f on each actuated dof (the moment of a joint
//! transmission is its gear). The activation integrates as MuJoCo's
//! nextActivation: act + h act' (filterexact: act + act' tau (1 - e^(-h/tau)))
//! clamped to the actuator's activation range.
//!
//! Inputs may be empty: an empty ctrl is zero controls, an empty act zero
//! activations (so a step without them is MuJoCo's with ctrl = 0, act = 0).

use crate::model::{ActDynamics, Actuator, Bias, Gain};
use crate::spatial::{lift, Real};

/// MuJoCo's mjMINVAL: the smallest filter time constant used.
const MIN_TIME_CONSTANT: f64 = 1e-15;

/// One actuator in the compiled tree: where its joint's coordinate and dof
/// are, and its activation's index if it has one.
#[derive(Clone, Debug, PartialEq)]
pub struct ActuatorTerm {
    pub law: Actuator,
    pub q_at: usize,
    pub dof: usize,
    pub act: Option<usize>,
}

impl ActuatorTerm {
    /// The clamped control (0 for an empty ctrl).
    fn control<T: Real>(&self, ctrl: &[T], i: usize) -> T {
        let c = ctrl.get(i).copied().unwrap_or(T::zero());
        clamp(c, self.law.ctrl_range)
    }

    /// The activation's rate at control c and activation a.
    fn rate<T: Real>(&self, c: T, a: T) -> T {
        match self.law.dynamics {
            ActDynamics::None | ActDynamics::Integrator => c,
            ActDynamics::Filter(tau) | ActDynamics::FilterExact(tau) => {
                (c - a) / lift(tau.max(MIN_TIME_CONSTANT))
            }
        }
    }

    /// The activation after a step h from a at rate `rate`, clamped.
    pub fn next_act<T: Real>(&self, a: T, rate: T, h: f64) -> T {
        let next = match self.law.dynamics {
            ActDynamics::FilterExact(tau) => {
                let tau = tau.max(MIN_TIME_CONSTANT);
                a + rate * lift(tau) * lift(1.0 - (-h / tau).exp())
            }
            _ => a + rate * lift(h),
        };
        clamp(next, self.law.act_range)
    }

    /// The scalar force at joint coordinate x, velocity xd, control c and
    /// activation a (its rate `rate`), clamped to the force range.
    fn force<T: Real>(&self, (x, xd): (T, T), (c, a, rate): (T, T, T), h: f64) -> T {
        let gear: T = lift(self.law.gear);
        let (length, velocity) = (gear * x, gear * xd);
        let affine = |p: [f64; 3]| lift::<T>(p[0]) + lift::<T>(p[1]) * length + lift::<T>(p[2]) * velocity;
        let gain = match self.law.gain {
            Gain::Fixed(g) => lift(g),
            Gain::Affine(p) => affine(p),
        };
        let input = match (self.act, self.law.act_early) {
            (None, _) => c,
            (Some(_), false) => a,
            (Some(_), true) => self.next_act(a, rate, h),
        };
        let bias = match self.law.bias {
            Bias::None => T::zero(),
            Bias::Affine(p) => affine(p),
        };
        clamp(gain * input + bias, self.law.force_range)
    }
}

/// Whether the actuators exert no force at zero controls and activations
/// whatever the state (no bias, no activation, a force range holding 0), so
/// that a step without ctrl skips them.
pub fn idle_without_inputs(actuators: &[ActuatorTerm]) -> bool {
    actuators.iter().all(|a| {
        let law = &a.law;
        law.bias == Bias::None
            && a.act.is_none()
            && law.force_range.is_none_or(|(lo, hi)| lo <= 0.0 && 0.0 <= hi)
    })
}

impl ActuatorTerm {
    /// Its generalized force on its dof and its next activation after a step
    /// h (a itself without dynamics) at joint coordinate x, velocity xd,
    /// control c (before clamping) and activation a: one actuator of
    /// [`add_actuator_forces`] and [`next_acts`] under Euler.
    pub fn output<T: Real>(&self, h: f64, (x, xd): (T, T), (c, a): (T, T)) -> (T, T) {
        let c = clamp(c, self.law.ctrl_range);
        let rate = self.rate(c, a);
        let force = lift::<T>(self.law.gear) * self.force((x, xd), (c, a, rate), h);
        let next = if self.act.is_some() { self.next_act(a, rate, h) } else { a };
        (force, next)
    }

    /// Whether its force is the same at every (q, v, act): no activation,
    /// no length or velocity term in gain and bias.
    pub fn state_independent(&self) -> bool {
        let fixed = |p: [f64; 3]| p[1] == 0.0 && p[2] == 0.0;
        let gain = match self.law.gain {
            Gain::Fixed(_) => true,
            Gain::Affine(p) => fixed(p),
        };
        let bias = match self.law.bias {
            Bias::None => true,
            Bias::Affine(p) => fixed(p),
        };
        self.act.is_none() && gain && bias
    }
}

/// x clamped to [lo, hi] as mju_clip does; x itself without a range.
fn clamp<T: Real>(x: T, range: Option<(f64, f64)>) -> T {
    match range {
        Some((lo, _)) if x < lift(lo) => lift(lo),
        Some((_, hi)) if x > lift(hi) => lift(hi),
        _ => x,
    }
}

/// The activation rates (na) at ctrl and act.
pub fn act_rates<T: Real>(actuators: &[ActuatorTerm], (ctrl, act): (&[T], &[T]), out: &mut [T]) {
    for (i, a) in actuators.iter().enumerate() {
        if let Some(k) = a.act {
            let current = act.get(k).copied().unwrap_or(T::zero());
            out[k] = a.rate(a.control(ctrl, i), current);
        }
    }
}

/// Adds the actuators' generalized forces at (q, v, ctrl, act) to `force`
/// (nv); `rates` are the activation rates at (ctrl, act) ([`act_rates`]),
/// which actearly actuators read.
pub fn add_actuator_forces<T: Real>(
    actuators: &[ActuatorTerm],
    h: f64,
    (q, v): (&[T], &[T]),
    (ctrl, act, rates): (&[T], &[T], &[T]),
    force: &mut [T],
) {
    for (i, a) in actuators.iter().enumerate() {
        let (current, rate) = match a.act {
            Some(k) => (act.get(k).copied().unwrap_or(T::zero()), rates[k]),
            None => (T::zero(), T::zero()),
        };
        let f = a.force((q[a.q_at], v[a.dof]), (a.control(ctrl, i), current, rate), h);
        force[a.dof] += lift::<T>(a.law.gear) * f;
    }
}

/// The activations after a step h from act at `rates` (MuJoCo's
/// nextActivation for each).
pub fn next_acts<T: Real>(actuators: &[ActuatorTerm], h: f64, (act, rates): (&[T], &[T]), out: &mut [T]) {
    for a in actuators {
        if let Some(k) = a.act {
            let current = act.get(k).copied().unwrap_or(T::zero());
            out[k] = a.next_act(current, rates[k], h);
        }
    }
}
