//! Actuation as MuJoCo's mj_transmission and mj_fwdActuation compute it,
//! for actuators on a hinge or slide joint, a tendon or a site
//! ([`crate::model::Actuator`] states the law and its conventions): each
//! actuator's length l, velocity l' and moment ([`transmissions`], the one
//! place they are computed, into [`Data::actuator`]), controls
//! clamped to their ranges, activation rates, the actuators' scalar forces
//! clamped to their force ranges, and the generalized force moment f. The
//! activation integrates as MuJoCo's
//! nextActivation: act + h act' (filterexact: act + act' tau (1 - e^(-h/tau)))
//! clamped to the actuator's activation range.
//!
//! Inputs may be empty: an empty ctrl is zero controls, an empty act zero
//! activations (so a step without them is MuJoCo's with ctrl = 0, act = 0).

use nalgebra::{DMatrix, Matrix3, Rotation3, UnitQuaternion, Vector3};

use super::configuration::difference;
use super::kinematics::body_pose;
use super::tendon::{Path, TendonState};
use super::{tendon_states, update_transforms, world_frames, Data, Tree};
use crate::model::{ActDynamics, Actuator, Bias, Gain};
use crate::spatial::{lift, lift_vector, Real};

/// MuJoCo's mjMINVAL: the smallest filter time constant used.
const MIN_TIME_CONSTANT: f64 = crate::model::MINVAL;

/// One actuator in the compiled tree: what it drives, and its
/// activation's index if it has one.
#[derive(Clone, Debug, PartialEq)]
pub struct ActuatorTerm {
    pub law: Actuator,
    pub target: Target,
    pub act: Option<usize>,
}

/// An actuator's transmission in the compiled tree: a joint's coordinate
/// address and dof, a tendon's index into [`Tree::tendons`], or a site
/// with its reference site.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Target {
    Joint {
        q_at: usize,
        dof: usize,
    },
    Tendon(usize),
    Site {
        site: SiteFrame,
        refsite: Option<SiteFrame>,
    },
}

/// A site as a transmission reads it: its body (model index), and its
/// position and axes (columns) in the body's frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SiteFrame {
    pub body: usize,
    pub pos: Vector3<f64>,
    pub rot: Matrix3<f64>,
}

impl ActuatorTerm {
    /// Whether its length and moment read the world frames (a site, a
    /// spatial tendon); otherwise they need (q, v) alone and its moment is
    /// the same at every q.
    pub fn reads_frames<T: Real>(&self, tree: &Tree<T>) -> bool {
        match self.target {
            Target::Joint { .. } => false,
            Target::Tendon(t) => matches!(tree.tendons[t].path, Path::Spatial(_)),
            Target::Site { .. } => true,
        }
    }

    /// Its length l, velocity l' and moment (nv) into `out` at (q, v), the
    /// frames (and the tendons' states) in `data` being those at (q, v)
    /// when it [reads them](Self::reads_frames).
    fn transmission<T: Real>(
        &self,
        tree: &Tree<T>,
        data: &Data<T>,
        (q, v): (&[T], &[T]),
        out: &mut TendonState<T>,
    ) {
        let gear: T = lift(self.law.gear[0]);
        out.moment.fill(T::zero());
        let (x, xd) = match self.target {
            Target::Joint { q_at, dof } => {
                out.moment[dof] = gear;
                (q[q_at], v[dof])
            }
            Target::Tendon(t) => match tree.tendons[t].fixed_length((q, v)) {
                Some(length) => {
                    tree.tendons[t].add_fixed_moment(gear, &mut out.moment);
                    length
                }
                None => {
                    let s = &data.tendon[t];
                    s.add_moment(gear, &tree.tendons[t].support, &mut out.moment);
                    (s.length, s.velocity)
                }
            },
            Target::Site { site, refsite } => {
                out.length = site_transmission(
                    tree,
                    data,
                    (&site, refsite.as_ref()),
                    self.law.gear,
                    &mut out.moment,
                );
                out.velocity = out
                    .moment
                    .iter()
                    .zip(v)
                    .fold(T::zero(), |s, (m, v)| s + *m * *v);
                return;
            }
        };
        (out.length, out.velocity) = (gear * x, gear * xd);
    }

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

    /// The scalar force at length l, velocity ld, control c and
    /// activation a (its rate `rate`), clamped to the force range.
    fn force<T: Real>(&self, (l, ld): (T, T), (c, a, rate): (T, T, T), h: f64) -> T {
        clamp(
            self.raw_force((l, ld), (c, a, rate), h).0,
            self.law.force_range,
        )
    }

    /// What the gain multiplies: the control without activation, else the
    /// activation (the next one under actearly).
    fn input<T: Real>(&self, (c, a, rate): (T, T, T), h: f64) -> T {
        match (self.act, self.law.act_early) {
            (None, _) => c,
            (Some(_), false) => a,
            (Some(_), true) => self.next_act(a, rate, h),
        }
    }

    /// The scalar force before clamping at length and velocity (l, l'), and
    /// its derivative in l' (the velocity terms of gain and bias).
    fn raw_force<T: Real>(
        &self,
        (length, velocity): (T, T),
        (c, a, rate): (T, T, T),
        h: f64,
    ) -> (T, T) {
        let affine =
            |p: [f64; 3]| lift::<T>(p[0]) + lift::<T>(p[1]) * length + lift::<T>(p[2]) * velocity;
        let gain = match self.law.gain {
            Gain::Fixed(g) => lift(g),
            Gain::Affine(p) => affine(p),
        };
        let input = self.input((c, a, rate), h);
        let (bias, bias_v) = match self.law.bias {
            Bias::None => (T::zero(), 0.0),
            Bias::Affine(p) => (affine(p), p[2]),
        };
        let gain_v = match self.law.gain {
            Gain::Fixed(_) => 0.0,
            Gain::Affine(p) => p[2],
        };
        let slope = lift::<T>(gain_v) * input + lift(bias_v);
        (gain * input + bias, slope)
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
            && law
                .force_range
                .is_none_or(|(lo, hi)| lo <= 0.0 && 0.0 <= hi)
    })
}

impl ActuatorTerm {
    /// Its scalar force (MuJoCo's actuator_force) at length l, velocity
    /// ld (the transmission's, [`transmissions`]), control c (before clamping) and activation a.
    pub fn scalar_force<T: Real>(&self, h: f64, (l, ld): (T, T), (c, a): (T, T)) -> T {
        let c = clamp(c, self.law.ctrl_range);
        self.force((l, ld), (c, a, self.rate(c, a)), h)
    }

    /// Its scalar force and its next activation after a step h (a itself
    /// without dynamics) at length l, velocity ld, control c (before
    /// clamping) and activation a: one actuator of [`add_actuator_forces`]
    /// (which applies moment f) and [`next_acts`] under Euler.
    pub fn output<T: Real>(&self, h: f64, (l, ld): (T, T), (c, a): (T, T)) -> (T, T) {
        let force = self.scalar_force(h, (l, ld), (c, a));
        let c = clamp(c, self.law.ctrl_range);
        let rate = self.rate(c, a);
        let next = if self.act.is_some() {
            self.next_act(a, rate, h)
        } else {
            a
        };
        (force, next)
    }

    /// The derivatives of its scalar force in gainprm[0..3] and in
    /// biasprm[0..3] (the parameters `actuator/<name>/gain` and `bias`) at
    /// length l, velocity ld, control c (before clamping) and activation a:
    /// w (1, l, l') and (1, l, l'), w what the gain multiplies. A fixed gain
    /// reads gainprm\[0] alone, no bias reads nothing, and while the force
    /// range clamps the force both are zero.
    pub fn law_slopes(&self, h: f64, (l, ld): (f64, f64), (c, a): (f64, f64)) -> [[f64; 3]; 2] {
        let c = clamp(c, self.law.ctrl_range);
        let rate = self.rate(c, a);
        let force = self.raw_force((l, ld), (c, a, rate), h).0;
        if clamp(force, self.law.force_range) != force {
            return [[0.0; 3]; 2];
        }
        let basis = [1.0, l, ld];
        let w = self.input((c, a, rate), h);
        let gain = match self.law.gain {
            Gain::Fixed(_) => [w, 0.0, 0.0],
            Gain::Affine(_) => basis.map(|b| b * w),
        };
        let bias = match self.law.bias {
            Bias::None => [0.0; 3],
            Bias::Affine(_) => basis,
        };
        [gain, bias]
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

/// Adds the derivative of the actuators' generalized forces in v at the
/// transmissions `states` ([`transmissions`]) and (ctrl, act) to `qderiv`
/// (nv x nv): an actuator's adds moment^T moment (gain_v w + bias_v)
/// (gain_v, bias_v the velocity coefficients of an affine gain and bias, w
/// its control or activation), nothing while its force range clamps it.
/// This is MuJoCo's actuator term of qDeriv (mjd_actuator_vel), which its
/// implicit and implicitfast integrators take implicitly (Euler does not);
/// `rates` as in [`add_actuator_forces`].
pub fn add_force_velocity_derivatives<T: Real>(
    tree: &Tree<T>,
    h: f64,
    states: &[TendonState<T>],
    (ctrl, act, rates): (&[T], &[T], &[T]),
    qderiv: &mut DMatrix<T>,
) {
    let actuated = with_inputs(&tree.actuators, (ctrl, act, rates)).zip(states);
    for ((a, inputs), s) in actuated {
        let (force, slope) = a.raw_force((s.length, s.velocity), inputs, h);
        if clamp(force, a.law.force_range) == force && slope != T::zero() {
            let m = &s.moment;
            let on: Vec<usize> = (0..m.len()).filter(|&i| m[i] != T::zero()).collect();
            for &i in &on {
                for &j in &on {
                    qderiv[(i, j)] += slope * m[i] * m[j];
                }
            }
        }
    }
}

/// Each actuator with what its force reads besides the state: its clamped
/// control, its activation and activation rate (0 and 0 without one).
fn with_inputs<'a, T: Real>(
    actuators: &'a [ActuatorTerm],
    (ctrl, act, rates): (&'a [T], &'a [T], &'a [T]),
) -> impl Iterator<Item = (&'a ActuatorTerm, (T, T, T))> + 'a {
    actuators.iter().enumerate().map(move |(i, a)| {
        let (current, rate) = match a.act {
            Some(k) => (act.get(k).copied().unwrap_or(T::zero()), rates[k]),
            None => (T::zero(), T::zero()),
        };
        (a, (a.control(ctrl, i), current, rate))
    })
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

/// Each actuator's length, velocity and moment at (q, v) into
/// `data.actuator` (in actuator order), the world frames and the tendons'
/// states computed first when an actuator reads them
/// ([`ActuatorTerm::reads_frames`]).
pub fn transmissions<T: Real>(tree: &Tree<T>, data: &mut Data<T>, (q, v): (&[T], &[T])) {
    if tree.actuators.iter().any(|a| a.reads_frames(tree)) {
        update_transforms(tree, data, q);
        world_frames(tree, data, v);
        tendon_states(tree, data, (q, v));
    }
    let mut states = std::mem::take(&mut data.actuator);
    states.resize_with(tree.actuators.len(), || TendonState::zero(tree.nv()));
    for (a, out) in tree.actuators.iter().zip(&mut states) {
        a.transmission(tree, data, (q, v), out);
    }
    data.actuator = states;
}

/// Adds the actuators' generalized forces moment f at (q, v, ctrl, act)
/// to `force` (nv), their transmissions left in `data.actuator`
/// ([`transmissions`]); `rates` are the activation rates at (ctrl, act)
/// ([`act_rates`]), which actearly actuators read.
pub fn add_actuator_forces<T: Real>(
    tree: &Tree<T>,
    h: f64,
    data: &mut Data<T>,
    (q, v): (&[T], &[T]),
    (ctrl, act, rates): (&[T], &[T], &[T]),
    force: &mut [T],
) {
    transmissions(tree, data, (q, v));
    let actuated = with_inputs(&tree.actuators, (ctrl, act, rates)).zip(&data.actuator);
    for ((a, inputs), s) in actuated {
        let f = a.force((s.length, s.velocity), inputs, h);
        s.add_dense(f, force);
    }
}

/// A site transmission's length (its moment into `moment`), as MuJoCo's
/// mj_transmission computes it ([`crate::model::Actuator`]): without a
/// reference site, the length is 0 and the moment J^T (R g_f, R g_t) (J the
/// site's translation and rotation Jacobians, R its axes); with one (axes
/// R_r), the length is g_f . R_r^T (p - p_r) + g_t . r, r the rotation
/// vector of the site relative to the reference site (MuJoCo's mju_subQuat
/// of their world quaternions), and the moment
/// (J - J_r)^T (R_r g_f, R_r g_t) with the dofs both share cleared.
fn site_transmission<T: Real>(
    tree: &Tree<T>,
    data: &Data<T>,
    (site, refsite): (&SiteFrame, Option<&SiteFrame>),
    gear: [f64; 6],
    moment: &mut [T],
) -> T {
    let (force, torque) = (
        Vector3::new(gear[0], gear[1], gear[2]).map(lift::<T>),
        Vector3::new(gear[3], gear[4], gear[5]).map(lift::<T>),
    );
    let at = site_pose(tree, data, site);
    let Some(refsite) = refsite else {
        let wrench = (at.axes * force, at.axes * torque);
        add_jacobian(tree, data, (at.node, &at.pos), wrench, T::one(), moment);
        return T::zero();
    };
    let reference = site_pose(tree, data, refsite);
    let offset = reference.axes.tr_mul(&(at.pos - reference.pos));
    let turn = difference(&quaternion(&at.axes), &quaternion(&reference.axes));
    let wrench = (reference.axes * force, reference.axes * torque);
    add_jacobian(tree, data, (at.node, &at.pos), wrench, T::one(), moment);
    let back = (reference.node, &reference.pos);
    add_jacobian(tree, data, back, wrench, -T::one(), moment);
    let mut shared = common_ancestor(tree, at.node, reference.node);
    while let Some(k) = shared {
        moment[k] = T::zero();
        shared = tree.parent[k];
    }
    offset.dot(&force) + turn.dot(&torque)
}

/// A site's world pose at the frames `data` holds.
struct SitePose<T: Real> {
    pos: Vector3<T>,
    axes: Matrix3<T>,
    node: Option<usize>,
}

fn site_pose<T: Real>(tree: &Tree<T>, data: &Data<T>, site: &SiteFrame) -> SitePose<T> {
    let x = body_pose(tree, data, site.body);
    SitePose {
        pos: x.trans + x.axes() * lift_vector(&site.pos),
        axes: x.axes() * site.rot.map(lift::<T>),
        node: tree.body[site.body].node,
    }
}

/// The quaternion (w, x, y, z) of the rotation with axes `axes`.
fn quaternion<T: Real>(axes: &Matrix3<T>) -> [T; 4] {
    let q = UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(*axes));
    [q.w, q.i, q.j, q.k]
}

/// Adds s J^T (f, t) to `moment`, J the translation and rotation Jacobians
/// of the world point p fixed to `node`'s frame.
fn add_jacobian<T: Real>(
    tree: &Tree<T>,
    data: &Data<T>,
    (node, p): (Option<usize>, &Vector3<T>),
    (f, t): (Vector3<T>, Vector3<T>),
    s: T,
    moment: &mut [T],
) {
    let mut k = node;
    while let Some(i) = k {
        let axis = &data.world_axis[i];
        moment[i] += s * (f.dot(&(axis.lin + axis.ang.cross(p))) + t.dot(&axis.ang));
        k = tree.parent[i];
    }
}

/// The deepest node both chains to the root pass through (parents precede
/// their children).
fn common_ancestor<T: Real>(
    tree: &Tree<T>,
    mut a: Option<usize>,
    mut b: Option<usize>,
) -> Option<usize> {
    while let (Some(i), Some(j)) = (a, b) {
        match i.cmp(&j) {
            std::cmp::Ordering::Equal => return a,
            std::cmp::Ordering::Less => b = tree.parent[j],
            std::cmp::Ordering::Greater => a = tree.parent[i],
        }
    }
    None
}

/// The activations after a step h from act at `rates` (MuJoCo's
/// nextActivation for each).
pub fn next_acts<T: Real>(
    actuators: &[ActuatorTerm],
    h: f64,
    (act, rates): (&[T], &[T]),
    out: &mut [T],
) {
    for a in actuators {
        if let Some(k) = a.act {
            let current = act.get(k).copied().unwrap_or(T::zero());
            out[k] = a.next_act(current, rates[k], h);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Model;
    use num_dual::Dual64;

    const XML: &str = r#"<mujoco><compiler autolimits="true"/><worldbody>
      <body><joint name="a" axis="0 1 0"/><geom size="0.1"/>
        <body pos="0.3 0 0"><joint name="b" type="slide"/><geom size="0.1"/></body></body>
      </worldbody><actuator>
        <position joint="a" kp="20" kv="2" gear="1.5"/>
        <general joint="b" gaintype="affine" gainprm="1 0.5 -0.7" biastype="affine"
                 biasprm="0 -1 -0.3" dyntype="filter" dynprm="0.2" actearly="true"/>
        <velocity joint="b" kv="4" forcerange="-0.1 0.1"/>
      </actuator></mujoco>"#;

    /// The velocity derivative equals the dual-number slope of the forces in v,
    /// and a clamped force (the velocity servo) contributes nothing.
    #[test]
    fn velocity_derivative_is_the_forces_slope() {
        let model = Model::from_mjcf(XML, "t.xml").unwrap();
        let tree = model.tree();
        let (q, ctrl, act) = ([0.3, -0.1], [0.4, 0.9, 2.0], [0.25]);
        let v = [0.7, -1.2];
        let mut rates = [0.0];
        act_rates(&tree.actuators, (&ctrl[..], &act[..]), &mut rates);
        let mut qderiv = DMatrix::zeros(2, 2);
        let inputs = (&ctrl[..], &act[..], &rates[..]);
        let mut data = Data::new(tree);
        transmissions(tree, &mut data, (&q, &v));
        add_force_velocity_derivatives(tree, 0.01, &data.actuator, inputs, &mut qderiv);
        let diagonal = qderiv.diagonal();
        let dual_tree = Tree::build_with(&model, |_, _, x| Dual64::from(x));
        let mut dual_data = Data::new(&dual_tree);
        assert_eq!((qderiv[(0, 1)], qderiv[(1, 0)]), (0.0, 0.0));
        for dof in 0..2 {
            let lift = |x: &[f64]| x.iter().map(|&x| Dual64::from(x)).collect::<Vec<_>>();
            let mut vd = lift(&v);
            vd[dof].eps = 1.0;
            let (cd, ad, rd) = (lift(&ctrl), lift(&act), lift(&rates));
            let mut force = lift(&[0.0, 0.0]);
            add_actuator_forces(
                &dual_tree,
                0.01,
                &mut dual_data,
                (&lift(&q), &vd),
                (&cd, &ad, &rd),
                &mut force,
            );
            assert!((force[dof].eps - diagonal[dof]).abs() < 1e-14, "dof {dof}");
        }
        // Position servo: -kv gear^2. The general: its gain slope times its early
        // activation 0.25 + 0.01 (0.9 - 0.25) / 0.2, plus its bias slope (gear 1).
        assert!((diagonal[0] + 2.0 * 1.5 * 1.5).abs() < 1e-14);
        let early = 0.25 + 0.01 * (0.9 - 0.25) / 0.2;
        assert!((diagonal[1] - (-0.7 * early - 0.3)).abs() < 1e-14);
    }

    /// A translational site transmission relative to a reference site on an
    /// ancestor: its moment is dl/dq (the dofs both share cleared, where l
    /// is constant), its velocity moment v; a Cartesian motor's length is 0.
    /// (A rotational gear's moment is MuJoCo's angular Jacobian, not the
    /// slope of its rotation vector; the harness checks it against MuJoCo.)
    #[test]
    fn site_moment_is_the_lengths_slope() {
        let xml = r#"<mujoco><worldbody><body><joint axis="0 0 1"/><geom size="0.1"/>
          <site name="r" pos="0.1 0 0.05" euler="0.3 -0.2 0.5"/>
          <body pos="0.2 0 0"><joint axis="0 1 0"/><geom size="0.1"/>
            <body pos="0.3 0 0"><joint axis="1 0 0"/><geom size="0.1"/>
              <site name="s" pos="0.1 0.05 0" euler="-0.4 0.1 0.2"/></body></body></body>
          </worldbody><actuator>
            <motor site="s" refsite="r" gear="0.6 -0.8 0.3 0 0 0"/>
            <motor site="s" gear="1 2 3 4 5 6"/></actuator></mujoco>"#;
        let model = Model::from_mjcf(xml, "t.xml").unwrap();
        let dual_tree = Tree::build_with(&model, |_, _, x| Dual64::from(x));
        let mut data = Data::new(&dual_tree);
        let (q, v) = ([0.4, -0.7, 1.1], [0.3, -0.5, 0.9]);
        let lift = |x: &[f64]| x.iter().map(|&x| Dual64::from(x)).collect::<Vec<_>>();
        for dof in 0..3 {
            let mut qd = lift(&q);
            qd[dof].eps = 1.0;
            transmissions(&dual_tree, &mut data, (&qd, &lift(&v)));
            let [relative, motor] = [0, 1].map(|i| &data.actuator[i]);
            let slope = relative.length.eps;
            assert!((relative.moment[dof].re - slope).abs() < 1e-14, "dof {dof}");
            assert_eq!(motor.length.re, 0.0);
            let speed: f64 = relative.moment.iter().zip(&v).map(|(m, v)| m.re * v).sum();
            assert!((relative.velocity.re - speed).abs() < 1e-14);
        }
        assert_eq!(data.actuator[0].moment[0].re, 0.0);
    }
}
