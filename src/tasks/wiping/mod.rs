//! The table-wiping task (paper Section 4.4) on the wiping arm
//! (reference_models/wiping_arm.xml: a KUKA iiwa 14 holding a tool through
//! a compliant slide joint over the table plane z = 0).
//!
//! Conventions:
//! - State (q, v) of the model: q = (a1 .. a7, tool), SI units; the
//!   episode runs at the model's timestep h = 1e-3 s, one control step per
//!   physics step; step k is at time t = k h.
//! - The scripted path ([`tip_target`]) is the tool tip sphere's centre:
//!   0.5 s of approach straight down from 3 cm above the table to touching
//!   it (the spring at rest), then back-and-forth strokes along x,
//!   x(t) = 0.55 + 0.1 sin(2 pi (t - 0.5) / 1.5) m, for [`STEPS`] steps in
//!   all (3 s). q_traj is its tool-down inverse kinematics ([`tool_down_at`]).
//! - Contact: the file's, MuJoCo's constraint model; the tip is frictionless
//!   against the table (the model file says why).
//! - Controller: [`Admittance`] with gains theta = (k_tau, k_xi), on the
//!   normal force sensed over the last step.
//! - mu: the unknown compliance, each component uniform in [1, 100] as the
//!   paper. Units make that range physical: the tool's k_p in N/cm (100 to
//!   10^4 N/m) and k_d in N s/m; in N/m, pressing 3 N would need a 3 m
//!   deflection and the 0.2 kg tool would sag 2 m under its own weight.
//!   The higher-dimensional variants add arm joints' damping and stiffness
//!   ([`Unknown`]).
//! - Task metric (lower is better): the mean over the steps in contact
//!   (sensed force above [`CONTACT_FORCE`]) of (F - F_goal)^2, in N^2.

mod segments;

pub use segments::{Segment, Segments};

use nalgebra::Vector3;
use rand::rngs::StdRng;

use crate::control::admittance::{sensed_force, Admittance, ArmJoint, Gains};
use crate::dynamics::{crba, step, Data, StepError, Tree};
use crate::model::{MapEntry, ParamError, ParamMap, State};
use crate::osi::Problem;
use crate::spatial::{lift, Real};
use crate::tasks::{middle_of, uniform_in};
use crate::Model;

/// The canonical gains theta_hat that collect identification data: good for
/// no mu in particular, stable for all (found by a sweep of the box below).
pub const CANONICAL: Gains = Gains {
    k_tau: 1600.0,
    k_xi: 0.01,
};
/// The box gains are searched in (log-uniformly): k_tau (1/s^2), k_xi (m/(N s)).
pub const GAINS_LOWER: Gains = Gains {
    k_tau: 100.0,
    k_xi: 1e-4,
};
pub const GAINS_UPPER: Gains = Gains {
    k_tau: 1e5,
    k_xi: 0.1,
};
/// Physics steps of an episode (3 s at 1 kHz).
pub const STEPS: usize = 3000;
/// Radius of the tool tip sphere (m).
pub const TIP_RADIUS: f64 = 0.02;
/// A step counts as in contact when the sensed force exceeds this (N): 1%
/// of the goal (the soft contact pushes a little before touching).
pub const CONTACT_FORCE: f64 = 0.03;
/// Where the strokes are centred, their amplitude and period (m, m, s), and
/// the approach's duration and height (s, m): the strokes start at t = APPROACH.
const CENTRE: f64 = 0.55;
const AMPLITUDE: f64 = 0.1;
const PERIOD: f64 = 1.5;
pub const APPROACH: f64 = 0.5;
const HEIGHT: f64 = 0.03;

/// Link lengths of the arm in its vertical plane (m): shoulder height (a2's
/// axis above the base), a2 to a4, a4 to a6, a6 to the tip sphere's centre
/// at q_tool = 0.
const SHOULDER: f64 = 0.1575 + 0.2025;
const UPPER: f64 = 0.2045 + 0.2155;
const FORE: f64 = 0.1845 + 0.2155;
const HAND: f64 = 0.081 + 0.045 + 0.12;

/// Arm joints (a1 .. a7) that put the tool straight down with the tip
/// sphere's centre at (x, 0, z) when q_tool = 0: a1 = a3 = a5 = a7 = 0, so the
/// arm moves in the x-z plane, where a2, -a4 and a6 add up to the hand's
/// angle from +z (towards +x), which is pi for "down". Elbow above the line
/// from shoulder to wrist.
pub fn tool_down_at<T: Real>(x: T, z: T) -> [T; 7] {
    let (upper, fore) = (lift::<T>(UPPER), lift::<T>(FORE));
    let (px, pz) = (x, z + lift(HAND - SHOULDER)); // wrist (a6) from the shoulder
    let reach = px.hypot(pz);
    let bend =
        ((upper * upper + reach * reach - fore * fore) / (lift::<T>(2.0) * upper * reach)).acos();
    let shoulder = px.atan2(pz) - bend;
    let elbow = (px - upper * shoulder.sin()).atan2(pz - upper * shoulder.cos());
    let zero = T::zero();
    [
        zero,
        shoulder,
        zero,
        shoulder - elbow,
        zero,
        T::pi() - elbow,
        zero,
    ]
}

/// The tip sphere centre's target at time t (s), world frame (m).
pub fn tip_target(t: f64) -> Vector3<f64> {
    if t < APPROACH {
        let blend = 0.5 * (1.0 + (std::f64::consts::PI * t / APPROACH).cos());
        return Vector3::new(CENTRE, 0.0, TIP_RADIUS + HEIGHT * blend);
    }
    let phase = 2.0 * std::f64::consts::PI * (t - APPROACH) / PERIOD;
    Vector3::new(CENTRE + AMPLITUDE * phase.sin(), 0.0, TIP_RADIUS)
}

/// One unknown of the compliance: a joint's stiffness or damping, with the
/// physical value per unit of its mu component (mu in [1, 100]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Unknown {
    /// The tool's k_p: 100 N/m per unit (mu in N/cm).
    ToolStiffness,
    /// The tool's k_d: 1 N s/m per unit.
    ToolDamping,
    /// An arm joint's damping: 0.01 N m s/rad per unit.
    Damping(&'static str),
    /// An arm joint's stiffness (spring to q = 0): 0.01 N m/rad per unit.
    Stiffness(&'static str),
}

impl Unknown {
    /// The unknowns of the d-dimensional study, d in 2..=6: the tool's
    /// (k_p, k_d), then a6's damping and stiffness, then a4's.
    pub fn first(d: usize) -> Result<Vec<Unknown>, String> {
        let all = [
            Unknown::ToolStiffness,
            Unknown::ToolDamping,
            Unknown::Damping("a6"),
            Unknown::Stiffness("a6"),
            Unknown::Damping("a4"),
            Unknown::Stiffness("a4"),
        ];
        if (2..=all.len()).contains(&d) {
            Ok(all[..d].to_vec())
        } else {
            Err(format!("{d} unknowns: the wiping task has 2 to 6"))
        }
    }

    /// The named parameter and its value per unit of mu.
    fn param(self) -> (String, f64) {
        match self {
            Unknown::ToolStiffness => ("joint/tool/stiffness".into(), 100.0),
            Unknown::ToolDamping => ("joint/tool/damping".into(), 1.0),
            Unknown::Damping(j) => (format!("joint/{j}/damping"), 0.01),
            Unknown::Stiffness(j) => (format!("joint/{j}/stiffness"), 0.01),
        }
    }

    /// A label for reports, with the unit of mu.
    pub fn label(self) -> String {
        match self {
            Unknown::ToolStiffness => "tool k_p (N/cm)".into(),
            Unknown::ToolDamping => "tool k_d (N s/m)".into(),
            Unknown::Damping(j) => format!("{j} damping (0.01 N m s/rad)"),
            Unknown::Stiffness(j) => format!("{j} stiffness (0.01 N m/rad)"),
        }
    }
}

#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum WipingError {
    #[error("setting mu: {0}")]
    Mu(#[from] ParamError),
    #[error("mu[{i}] = {value} lies outside [{lower}, {upper}]")]
    MuOutside {
        i: usize,
        value: f64,
        lower: f64,
        upper: f64,
    },
    #[error("{0}")]
    Gains(String),
    #[error("step {step}: {source}")]
    Step { step: usize, source: StepError },
    #[error("the tool never touched the table: no step to score")]
    NoContact,
}

/// The task: the arm, the map from mu and the box of mu.
#[derive(Clone, Debug)]
pub struct Wiping {
    model: Model,
    map: ParamMap,
    unknowns: Vec<Unknown>,
    /// The arm's joints for the controller: torque limits, and inertias at
    /// the start of the path.
    arm: Vec<ArmJoint>,
}

/// A recorded episode: per step k = 0 ..= steps, the state, the controller's
/// torques there (those the step from k applies), the normal force it sensed
/// there (over the step into k, N) and the admittance offset xi (m).
#[derive(Clone, Debug, PartialEq)]
pub struct Episode {
    pub states: Vec<State>,
    pub taus: Vec<Vec<f64>>,
    pub forces: Vec<f64>,
    pub xi: Vec<f64>,
    /// The task metric (N^2).
    pub metric: f64,
}

impl Wiping {
    /// The paper's task: mu = the tool's (k_p, k_d).
    pub fn new() -> Wiping {
        Wiping::with_unknowns(&[Unknown::ToolStiffness, Unknown::ToolDamping])
            .expect("the tool's compliance maps")
    }

    pub fn with_unknowns(unknowns: &[Unknown]) -> Result<Wiping, ParamError> {
        let path = concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/reference_models/wiping_arm.xml"
        );
        let model = Model::load(path).map_err(|e| ParamError::Map(e.to_string()))?;
        let n = unknowns.len();
        let rows: Vec<(String, Vec<f64>)> = unknowns
            .iter()
            .enumerate()
            .map(|(i, u)| {
                let (name, unit) = u.param();
                let mut row = vec![0.0; n];
                row[i] = unit;
                (name, row)
            })
            .collect();
        let gains: Vec<[&[f64]; 1]> = rows.iter().map(|(_, r)| [r.as_slice()]).collect();
        let entries: Vec<MapEntry> = rows
            .iter()
            .zip(&gains)
            .map(|((name, _), gain)| MapEntry {
                name,
                offset: &[0.0],
                gain,
            })
            .collect();
        let map = ParamMap::new(&model, n, &entries)?;
        let mut wiping = Wiping {
            model,
            map,
            unknowns: unknowns.to_vec(),
            arm: vec![],
        };
        wiping.arm = wiping.arm_joints();
        Ok(wiping)
    }

    /// The nominal model (its own compliance, before any mu).
    pub fn model(&self) -> &Model {
        &self.model
    }

    pub fn map(&self) -> &ParamMap {
        &self.map
    }

    pub fn unknowns(&self) -> &[Unknown] {
        &self.unknowns
    }

    /// Lower and upper bounds of mu: [1, 100] per component.
    pub fn mu_range(&self) -> (Vec<f64>, Vec<f64>) {
        let n = self.unknowns.len();
        (vec![1.0; n], vec![100.0; n])
    }

    /// The middle of mu's box: the identifiers' prior, UC-Average's mu.
    pub fn prior(&self) -> Vec<f64> {
        let (lo, hi) = self.mu_range();
        middle_of(&lo, &hi)
    }

    /// mu drawn uniformly in its box.
    pub fn sample_mu(&self, rng: &mut StdRng) -> Vec<f64> {
        let (lo, hi) = self.mu_range();
        uniform_in(&lo, &hi, rng)
    }

    /// Identifying mu from this task's [`Segments`]: mu's box, the prior in
    /// its middle, residuals scaled by 1 um on positions and 1 mm/s (mrad/s)
    /// on velocities.
    pub fn problem(&self) -> Problem {
        let (lo, hi) = self.mu_range();
        let nv = self.model.nv();
        let scale: Vec<f64> = (0..2 * nv)
            .map(|i| if i < nv { 1e-6 } else { 1e-3 })
            .collect();
        Problem::new(
            &self.model,
            self.map.clone(),
            &lo,
            &hi,
            &self.prior(),
            &scale,
        )
        .expect("the task's box, prior and scale are valid")
    }

    /// The model with mu applied, after checking mu against its box.
    pub fn model_at(&self, mu: &[f64]) -> Result<Model, WipingError> {
        let (lo, hi) = self.mu_range();
        for (i, &value) in mu.iter().enumerate() {
            if !(value >= lo[i] && value <= hi[i]) {
                return Err(WipingError::MuOutside {
                    i,
                    value,
                    lower: lo[i],
                    upper: hi[i],
                });
            }
        }
        let mut model = self.model.clone();
        self.map.apply(&mut model, mu)?;
        Ok(model)
    }

    /// The state an episode starts from: the arm on the path's first point,
    /// the tool spring at rest, everything still.
    pub fn start(&self) -> State {
        let target = tip_target(0.0);
        let arm = tool_down_at(target.x, target.z);
        let q = arm.iter().copied().chain([0.0]).collect();
        State::new(q, vec![0.0; self.model.nv()])
    }

    /// Each motor's joint with its torque limit and the joint's inertia at
    /// the start state.
    fn arm_joints(&self) -> Vec<ArmJoint> {
        let mut data = self.model.data();
        crba(self.model.tree(), &mut data, &self.start().q);
        self.model
            .actuators
            .iter()
            .filter_map(|a| {
                let j = a.joint()?;
                Some(ArmJoint {
                    limit: a
                        .ctrl_range
                        .zip(a.force_per_control())
                        .map_or(f64::INFINITY, |((_, hi), k)| hi * k.abs()),
                    inertia: data.mass_matrix[(j, j)],
                })
            })
            .collect()
    }

    /// The controller for a model of this task.
    pub fn controller<T: Real>(&self, gains: Gains) -> Admittance<T> {
        Admittance::new(gains, &self.arm, self.model.nv())
    }

    /// Runs one episode of `steps` steps at mu under `gains`.
    pub fn episode(&self, mu: &[f64], gains: Gains, steps: usize) -> Result<Episode, WipingError> {
        let gains = gains.check().map_err(WipingError::Gains)?;
        let model = self.model_at(mu)?;
        let tree = model.tree();
        let mut data = model.data();
        let mut ctrl = self.controller::<f64>(gains);
        let (nv, h) = (model.nv(), model.opt.timestep);
        let State { mut q, mut v, .. } = self.start();
        let mut carry = LoopState {
            xi: 0.0,
            force: 0.0,
        };
        let mut episode = Episode {
            states: Vec::with_capacity(steps + 1),
            taus: Vec::with_capacity(steps + 1),
            forces: Vec::with_capacity(steps + 1),
            xi: Vec::with_capacity(steps + 1),
            metric: 0.0,
        };
        let (mut q1, mut v1, mut tau) = (vec![0.0; nv], vec![0.0; nv], vec![0.0; nv]);
        let mut record = |(q, v): (&[f64], &[f64]), tau: &[f64], carry: LoopState<f64>| {
            episode.states.push(State::new(q.to_vec(), v.to_vec()));
            episode.taus.push(tau.to_vec());
            episode.forces.push(carry.force);
            episode.xi.push(carry.xi);
        };
        for k in 0..steps {
            let next = closed_loop_step(
                tree,
                &mut data,
                &mut ctrl,
                (k, q.as_slice(), v.as_slice(), carry),
                &mut tau,
                (&mut q1, &mut v1),
            )
            .map_err(|source| WipingError::Step { step: k, source })?;
            record((&q, &v), &tau, carry);
            std::mem::swap(&mut q, &mut q1);
            std::mem::swap(&mut v, &mut v1);
            carry = next;
        }
        // The last row: the torques the controller would apply there.
        let last = (tip_target(steps as f64 * h), h);
        ctrl.act(
            tree,
            &mut data,
            (&q, &v, carry.force),
            carry.xi,
            last,
            &mut tau,
        );
        record((&q, &v), &tau, carry);
        episode.metric = metric(&episode.forces)?;
        Ok(episode)
    }
}

impl Default for Wiping {
    fn default() -> Self {
        Wiping::new()
    }
}

/// The task metric of a force record (see the module docs).
pub fn metric(forces: &[f64]) -> Result<f64, WipingError> {
    use crate::control::admittance::F_GOAL;
    let touching: Vec<f64> = forces
        .iter()
        .filter(|f| **f > CONTACT_FORCE)
        .map(|f| (f - F_GOAL).powi(2))
        .collect();
    if touching.is_empty() {
        return Err(WipingError::NoContact);
    }
    Ok(touching.iter().sum::<f64>() / touching.len() as f64)
}

/// What the closed loop carries from one step to the next besides (q, v):
/// the admittance offset xi (m) and the normal force sensed over the last
/// step (N), both known to the controller.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LoopState<T> {
    pub xi: T,
    pub force: T,
}

/// One closed-loop step from step index k at (q, v) with `carry`: the
/// controller's torques into `tau`, the model's step into (q1, v1); returns
/// the loop's state after the step.
pub fn closed_loop_step<T: Real>(
    tree: &Tree<T>,
    data: &mut Data<T>,
    ctrl: &mut Admittance<T>,
    (k, q, v, carry): (usize, &[T], &[T], LoopState<T>),
    tau: &mut [T],
    (q1, v1): (&mut [T], &mut [T]),
) -> Result<LoopState<T>, StepError> {
    let h = tree.opt.timestep;
    let target = (tip_target(k as f64 * h), h);
    let xi = ctrl.act(tree, data, (q, v, carry.force), carry.xi, target, tau);
    step(tree, data, (q, v, tau), (q1, v1))?;
    Ok(LoopState {
        xi,
        force: sensed_force(tree, data),
    })
}
