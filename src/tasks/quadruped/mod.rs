//! The quadruped task (issue 41): a Unitree Go1 carrying a payload of
//! unknown mass and placement walks forward at a commanded 0.5 m/s on a flat
//! floor. The model is [`go1::model`] (its docs state the floor, the
//! collisions, the servos and the payload).
//!
//! - State q = (base position (m), base orientation (w x y z), the twelve
//!   leg joints (rad): FR, FL, RR, RL legs, each hip, thigh, calf); v = (the
//!   base's linear velocity in world axes (m/s), its angular velocity in
//!   base axes (rad/s), the joint rates): MuJoCo's free joint.
//! - mu = (payload mass in [0, 8] kg, payload COM offset x_p along the
//!   trunk's x in [-0.1, 0.1] m).
//! - Action: twelve components in [-1, 1] (clamped), the servos' targets
//!   ctrl = q_default + 0.5 a (rad) about the standing pose q_default (hips
//!   +-0.1, thighs 0.8 front and 1.0 rear, calves -1.5: legged_gym's Go1
//!   pose); the servos are the model's position actuators (kp 20, kd 0.5).
//! - Timing: the timestep is 0.005 s and a control step holds its targets
//!   for 4 physics steps: 50 Hz control; an episode is 1000 control steps
//!   (20 s).
//! - Observation (34): the base height, gravity's direction in base axes,
//!   the base's linear velocity in base axes, its angular velocity, the
//!   joints' offsets from q_default and the joint rates.
//! - Reward per control step: forward tracking exp(-((v_x - 0.5)^2 + v_y^2)
//!   / 0.25), (v_x, v_y) the base's mean velocity over the step (its
//!   displacement over 0.02 s, m/s) along and across its heading (its x
//!   axis laid flat) at the step's end, plus yaw-rate tracking (command 0)
//!   0.5 exp(-w^2 / 0.05), w the heading's mean turning rate over the step
//!   (its angle change over 0.02 s, rad/s), plus 0.5 u_z (u the base's z
//!   axis in world axes: 1 upright) minus 0.001 times the servos'
//!   mechanical power sum |tau_j q'_j| (W) at the step's end. Weights 1,
//!   0.5, 0.5, 0.001 (legged_gym's 1 and 0.5 for the two tracking terms;
//!   its yaw width 0.25 rad^2/s^2 narrowed to 0.05 so that a slow circle,
//!   0.1-0.2 rad/s, costs 0.18-0.55 of the term rather than 0.04-0.15).
//!   Without that term a policy learnt to walk in circles, which scores as
//!   well as walking straight. The mean velocities, not the end state's: a
//!   policy fed the latter learnt to shake so that each step ended moving
//!   forward while the base stayed put. The task metric is the reward: an
//!   episode's score is its return.
//! - Termination, a fall: the base below 0.15 m or tilted past 60 degrees
//!   (u_z < 0.5). Reports give the fraction of episodes that end so.
//! - Reset: the base at (0, 0, 0.33) m upright and at rest (the feet 1 to
//!   2 cm above the floor), the joints at q_default plus uniform noise of
//!   +-0.05 rad.

pub mod go1;

use std::f64::consts::PI;

use nalgebra::{UnitQuaternion, Vector3};
use rand::rngs::StdRng;
use rand::RngExt;

use super::Task;
use crate::model::{Inputs, MapEntry, ParamMap, State};
use crate::Model;

pub struct Quadruped {
    model: Model,
    map: ParamMap,
    /// The servos' URDF effort limits (N m), by joint.
    effort: Vec<f64>,
}

impl Quadruped {
    pub const MU_LOWER: [f64; 2] = [0.0, -0.1];
    pub const MU_UPPER: [f64; 2] = [8.0, 0.1];
    pub const HORIZON: usize = 1000;
    pub const SUBSTEPS: usize = 4;
    /// Servo target offset (rad) per unit of action.
    pub const ACTION_SCALE: f64 = 0.5;
    pub const TARGET_SPEED: f64 = 0.5;
    pub const TRACKING_WIDTH: f64 = 0.25;
    pub const YAW_WEIGHT: f64 = 0.5;
    pub const YAW_WIDTH: f64 = 0.05;
    pub const UPRIGHT_WEIGHT: f64 = 0.5;
    pub const ENERGY_WEIGHT: f64 = 0.001;
    pub const FALL_HEIGHT: f64 = 0.15;
    pub const FALL_TILT: f64 = 0.5;
    pub const RESET_HEIGHT: f64 = 0.33;
    pub const RESET_Q_NOISE: f64 = 0.05;
    const NJ: usize = 12;

    pub fn new() -> Quadruped {
        let model = go1::model();
        let [ixx, iyy, izz] = go1::payload_inertia_per_kg();
        let entries = [
            MapEntry {
                name: "body/payload/mass",
                offset: &[0.0],
                gain: &[&[1.0, 0.0]],
            },
            MapEntry {
                name: "body/payload/com",
                offset: &[0.0, 0.0, go1::PAYLOAD_HEIGHT],
                gain: &[&[0.0, 1.0], &[0.0, 0.0], &[0.0, 0.0]],
            },
            MapEntry {
                name: "body/payload/inertia",
                offset: &[0.0; 6],
                gain: &[
                    &[ixx, 0.0],
                    &[iyy, 0.0],
                    &[izz, 0.0],
                    &[0.0, 0.0],
                    &[0.0, 0.0],
                    &[0.0, 0.0],
                ],
            },
        ];
        let map = ParamMap::new(&model, 2, &entries).expect("the payload map");
        let effort = model
            .actuators
            .iter()
            .map(|a| {
                go1::effort_of(
                    &model.joints[a.joint().expect("the task's servos sit on joints")].name,
                )
            })
            .collect();
        Quadruped { model, map, effort }
    }

    /// The standing pose q_default of the twelve joints (FR, FL, RR, RL).
    pub fn default_q() -> [f64; 12] {
        let leg = |right: bool, front: bool| {
            let hip = if right { -0.1 } else { 0.1 };
            [hip, if front { 0.8 } else { 1.0 }, -1.5]
        };
        let mut q = [0.0; 12];
        for (k, (right, front)) in [(true, true), (false, true), (true, false), (false, false)]
            .into_iter()
            .enumerate()
        {
            q[3 * k..3 * k + 3].copy_from_slice(&leg(right, front));
        }
        q
    }

    /// The servo targets of an action (rad, one per joint).
    pub fn targets(&self, action: &[f64]) -> Vec<f64> {
        Self::default_q()
            .iter()
            .zip(action)
            .map(|(q0, a)| q0 + Self::ACTION_SCALE * a.clamp(-1.0, 1.0))
            .collect()
    }

    /// The duration of one control step (s).
    pub fn control_dt(&self) -> f64 {
        self.model.opt.timestep * Self::SUBSTEPS as f64
    }

    /// The base's orientation.
    fn orientation(q: &[f64]) -> UnitQuaternion<f64> {
        UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(q[3], q[4], q[5], q[6]))
    }

    /// The z component of the base's z axis in world axes (1 upright).
    pub fn uprightness(q: &[f64]) -> f64 {
        (Self::orientation(q) * Vector3::z())[2]
    }

    /// The base's linear velocity in base axes.
    fn base_velocity(State { q, v, .. }: &State) -> Vector3<f64> {
        Self::orientation(q).inverse() * Vector3::new(v[0], v[1], v[2])
    }

    /// The base's mean velocity from `state` to `next` (a control step)
    /// along and across its heading at `next` (m/s).
    fn mean_velocity(&self, state: &State, next: &State) -> (f64, f64) {
        let step = Vector3::new(next.q[0] - state.q[0], next.q[1] - state.q[1], 0.0);
        let x = Self::orientation(&next.q) * Vector3::x();
        let heading = Vector3::new(x[0], x[1], 0.0)
            .try_normalize(1e-9)
            .unwrap_or_else(Vector3::x);
        let across = Vector3::z().cross(&heading);
        let dt = self.control_dt();
        (step.dot(&heading) / dt, step.dot(&across) / dt)
    }

    /// The heading's mean turning rate from `state` to `next` (rad/s,
    /// positive counter-clockwise seen from above).
    fn yaw_rate(&self, state: &State, next: &State) -> f64 {
        let heading = |q: &[f64]| {
            let x = Self::orientation(q) * Vector3::x();
            x[1].atan2(x[0])
        };
        let turn = heading(&next.q) - heading(&state.q);
        let wrapped = (turn + PI).rem_euclid(2.0 * PI) - PI;
        wrapped / self.control_dt()
    }

    /// The servos' mechanical power sum |tau_j q'_j| (W) at `state` under
    /// `targets`, each torque clamped to its effort limit.
    fn power(&self, targets: &[f64], State { q, v, .. }: &State) -> f64 {
        (0..Self::NJ)
            .map(|j| {
                let (qj, vj) = (q[7 + j], v[6 + j]);
                let tau = go1::KP * (targets[j] - qj) - go1::KD * vj;
                (tau.clamp(-self.effort[j], self.effort[j]) * vj).abs()
            })
            .sum()
    }
}

impl Default for Quadruped {
    fn default() -> Self {
        Quadruped::new()
    }
}

impl Task for Quadruped {
    fn name(&self) -> &'static str {
        "quadruped"
    }

    fn model(&self) -> &Model {
        &self.model
    }

    fn mu_map(&self) -> &ParamMap {
        &self.map
    }

    fn mu_range(&self) -> (&[f64], &[f64]) {
        (&Self::MU_LOWER, &Self::MU_UPPER)
    }

    fn horizon(&self) -> usize {
        Self::HORIZON
    }

    fn substeps(&self) -> usize {
        Self::SUBSTEPS
    }

    fn obs_dim(&self) -> usize {
        10 + 2 * Self::NJ
    }

    fn act_dim(&self) -> usize {
        Self::NJ
    }

    fn reset(&self, rng: &mut StdRng) -> State {
        let w = Self::RESET_Q_NOISE;
        let mut q = vec![0.0, 0.0, Self::RESET_HEIGHT, 1.0, 0.0, 0.0, 0.0];
        q.extend(Self::default_q().map(|q0| q0 + rng.random_range(-w..=w)));
        State::new(q, vec![0.0; self.model.nv()])
    }

    fn observe(&self, state: &State, out: &mut Vec<f64>) {
        let State { q, v, .. } = state;
        let down = Self::orientation(q).inverse() * -Vector3::z();
        out.push(q[2]);
        out.extend(down.iter());
        out.extend(Self::base_velocity(state).iter());
        out.extend_from_slice(&v[3..6]);
        out.extend(q[7..].iter().zip(Self::default_q()).map(|(q, q0)| q - q0));
        out.extend_from_slice(&v[6..]);
    }

    /// None: the actions are the servos' targets ([`Task::inputs`]).
    fn forces(&self, _action: &[f64]) -> Vec<f64> {
        vec![0.0; self.model.nv()]
    }

    fn inputs(&self, action: &[f64]) -> Inputs {
        Inputs {
            ctrl: self.targets(action),
            ..Inputs::tau(&self.forces(action))
        }
    }

    fn reward(&self, _mu: &[f64], state: &State, action: &[f64], next: &State) -> f64 {
        self.metric(state, action, next)
    }

    fn terminated(&self, State { q, .. }: &State) -> bool {
        q[2] < Self::FALL_HEIGHT || Self::uprightness(q) < Self::FALL_TILT
    }

    fn metric(&self, state: &State, action: &[f64], next: &State) -> f64 {
        let (forward, sideways) = self.mean_velocity(state, next);
        let miss = (forward - Self::TARGET_SPEED).powi(2) + sideways.powi(2);
        let tracking = (-miss / Self::TRACKING_WIDTH).exp();
        let yaw_rate = self.yaw_rate(state, next);
        let straight = Self::YAW_WEIGHT * (-yaw_rate.powi(2) / Self::YAW_WIDTH).exp();
        let upright = Self::UPRIGHT_WEIGHT * Self::uprightness(&next.q);
        tracking + straight + upright
            - Self::ENERGY_WEIGHT * self.power(&self.targets(action), next)
    }

    fn metric_description(&self) -> String {
        format!(
            "episode return (velocity tracking + yaw-rate tracking + uprightness - energy per control step, up to {} steps; a fall ends the episode)",
            Self::HORIZON
        )
    }
}
