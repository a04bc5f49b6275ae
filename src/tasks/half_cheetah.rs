//! The paper's half cheetah (Section 4.3) on `reference_models/half_cheetah.xml`,
//! with gymnasium HalfCheetah-v5's conventions.
//!
//! - State q = (rootx, rootz, rooty, bthigh, bshin, bfoot, fthigh, fshin,
//!   ffoot): torso position along world x and z (m, relative to its modelled
//!   pose at height 0.7 m), torso pitch about +y and the six leg hinges (rad);
//!   v their rates. Contact with the floor and the joint limits are on, as
//!   MuJoCo's soft constraints (the constraint contact model, MuJoCo's step
//!   to 1e-9): at dt 0.01 random torques stay bounded over the whole mu
//!   range and the cheetah comes to rest under zero torques
//!   (`tests/half_cheetah.rs`). One control step (5 physics steps) costs
//!   about 20 us.
//! - mu (kg), uniform in [1, 50], is the torso's mass (`body/torso/mass`); its
//!   COM and its inertia about the COM stay as modelled. The model's own torso
//!   mass is 6.25 kg (gymnasium's file after MuJoCo's settotalmass 14; the
//!   paper's 4.9 kg is the file before that scaling).
//! - `half_cheetah_contact` ([`HalfCheetah::contact`]) widens mu with what
//!   other engines do differently ([`Contact`]): mu = (torso mass in kg, the
//!   six leg joints' armature in kg m^2 in [0, 0.15], the sliding friction
//!   of every geom in [0.3, 0.5]; MuJoCo takes the larger of a pair's). The
//!   file's own values: armature 0.1, friction 0.4. The contact's hardness is
//!   not in it: over solimp from the file's soft floor to (0.9, 0.95) PPO
//!   learns no gait at this budget (a UC's training return 635 against 2552
//!   over the armature, 600 000 steps each).
//! - Observation (17): q[1..] (gymnasium drops rootx) then v.
//! - Action: six components in [-1, 1] (clamped), the motors' controls; the
//!   joint torques are gear * a with gears 120, 90, 60, 120, 60, 30 N m
//!   (bthigh .. ffoot); the root dofs get no force.
//! - Timing: the model's timestep is 0.01 s and a control step holds its
//!   torques for 5 physics steps (gymnasium's frame_skip), 0.05 s.
//! - Reward per control step: (x' - x) / 0.05 - 0.1 |a|^2, forward speed of
//!   the torso minus the control cost (a clamped). No termination; an
//!   episode is 1000 control steps (50 s). The task metric is the reward, so
//!   an episode's score is its return (the paper's "task performance").
//! - Reset: gymnasium's noise, q uniform in +-0.1 around the modelled pose and
//!   v = 0.1 N(0, 1) per component.

use rand::rngs::StdRng;
use rand::RngExt;
use rand_distr::{Distribution, StandardNormal};

use super::Task;
use crate::model::{mjcf, ContactModel, MapEntry, ParamError, ParamMap, State};
use crate::Model;

/// The model file, compiled in so the task needs no path at run time.
const MJCF: &str = include_str!("../../reference_models/half_cheetah.xml");

pub struct HalfCheetah {
    name: &'static str,
    model: Model,
    map: ParamMap,
    lower: Vec<f64>,
    upper: Vec<f64>,
}

/// The contact variant's extra components of mu, after the torso mass: the
/// leg joints, and the bounds of armature and friction.
pub struct Contact;

impl Contact {
    pub const LEGS: [&'static str; 6] = ["bthigh", "bshin", "bfoot", "fthigh", "fshin", "ffoot"];
    pub const LOWER: [f64; 2] = [0.0, 0.3];
    pub const UPPER: [f64; 2] = [0.15, 0.5];
    /// The model file's own (armature, friction).
    pub const NOMINAL: [f64; 2] = [0.1, 0.4];
}

impl HalfCheetah {
    pub const MU_LOWER: [f64; 1] = [1.0];
    pub const MU_UPPER: [f64; 1] = [50.0];
    pub const HORIZON: usize = 1000;
    pub const SUBSTEPS: usize = 5;
    pub const CTRL_COST: f64 = 0.1;
    /// Half-width of the uniform noise on q at reset (rad or m).
    pub const RESET_Q_NOISE: f64 = 0.1;
    /// Standard deviation of the Gaussian noise on v at reset.
    pub const RESET_V_NOISE: f64 = 0.1;

    /// The task on the shipped `reference_models/half_cheetah.xml`, under
    /// MuJoCo's constraint contact (the MJCF default) that its shipped
    /// controllers were trained on.
    pub fn new() -> HalfCheetah {
        let model = mjcf::parse(MJCF, "reference_models/half_cheetah.xml")
            .and_then(|mut spec| {
                spec.opt.contact_model = ContactModel::Constraint;
                Model::from_spec(spec)
            })
            .expect("the shipped half cheetah model loads");
        HalfCheetah::with_model(model).expect("the shipped half cheetah has a torso")
    }

    /// The task on another half cheetah model (e.g. other options).
    pub fn with_model(model: Model) -> Result<HalfCheetah, ParamError> {
        let map = ParamMap::new(
            &model,
            1,
            &[MapEntry {
                name: "body/torso/mass",
                offset: &[0.0],
                gain: &[&[1.0]],
            }],
        )?;
        Ok(HalfCheetah {
            name: "half_cheetah",
            model,
            map,
            lower: Self::MU_LOWER.to_vec(),
            upper: Self::MU_UPPER.to_vec(),
        })
    }

    /// `half_cheetah_contact`: mu = (torso mass, leg armature, friction), see
    /// the module docs.
    pub fn contact() -> HalfCheetah {
        let task = HalfCheetah::new();
        let model = task.model;
        let names: Vec<String> = std::iter::once("body/torso/mass".to_string())
            .chain(Contact::LEGS.iter().map(|j| format!("joint/{j}/armature")))
            .chain(
                model
                    .geoms
                    .iter()
                    .map(|g| format!("geom/{}/friction", g.name)),
            )
            .collect();
        // Rows of each parameter's gain over mu's three components.
        let mass: [&[f64]; 1] = [&[1.0, 0.0, 0.0]];
        let armature: [&[f64]; 1] = [&[0.0, 1.0, 0.0]];
        let zero: &[f64] = &[0.0; 3];
        let friction: [&[f64]; 3] = [&[0.0, 0.0, 1.0], zero, zero];
        let entries: Vec<MapEntry> = names
            .iter()
            .map(|name| {
                let (offset, gain): (&[f64], &[&[f64]]) = match name.rsplit('/').next() {
                    Some("mass") => (&[0.0], &mass),
                    Some("armature") => (&[0.0], &armature),
                    _ => (&[0.0, 0.1, 0.1], &friction),
                };
                MapEntry { name, offset, gain }
            })
            .collect();
        let map = ParamMap::new(&model, 3, &entries).expect("the half cheetah's contact map");
        let mut lower = Self::MU_LOWER.to_vec();
        lower.extend(Contact::LOWER);
        let mut upper = Self::MU_UPPER.to_vec();
        upper.extend(Contact::UPPER);
        HalfCheetah {
            name: "half_cheetah_contact",
            model,
            map,
            lower,
            upper,
        }
    }

    /// The duration of one control step (s).
    pub fn control_dt(&self) -> f64 {
        self.model.opt.timestep * Self::SUBSTEPS as f64
    }
}

impl Default for HalfCheetah {
    fn default() -> Self {
        HalfCheetah::new()
    }
}

impl Task for HalfCheetah {
    fn name(&self) -> &'static str {
        self.name
    }

    fn model(&self) -> &Model {
        &self.model
    }

    fn mu_map(&self) -> &ParamMap {
        &self.map
    }

    fn mu_range(&self) -> (&[f64], &[f64]) {
        (&self.lower, &self.upper)
    }

    fn horizon(&self) -> usize {
        Self::HORIZON
    }

    fn substeps(&self) -> usize {
        Self::SUBSTEPS
    }

    fn obs_dim(&self) -> usize {
        self.model.nq() - 1 + self.model.nv()
    }

    fn act_dim(&self) -> usize {
        self.model.nu()
    }

    fn reset(&self, rng: &mut StdRng) -> State {
        let w = Self::RESET_Q_NOISE;
        let q = self
            .model
            .reference_q()
            .iter()
            .map(|r| r + rng.random_range(-w..=w))
            .collect();
        let v = (0..self.model.nv())
            .map(|_| {
                let z: f64 = StandardNormal.sample(rng);
                Self::RESET_V_NOISE * z
            })
            .collect();
        State::new(q, v)
    }

    fn observe(&self, State { q, v, .. }: &State, out: &mut Vec<f64>) {
        out.extend_from_slice(&q[1..]);
        out.extend_from_slice(v);
    }

    fn forces(&self, action: &[f64]) -> Vec<f64> {
        let a: Vec<f64> = action.iter().map(|a| a.clamp(-1.0, 1.0)).collect();
        self.model.actuator_forces(&a)
    }

    fn reward(&self, _mu: &[f64], state: &State, action: &[f64], next: &State) -> f64 {
        self.metric(state, action, next)
    }

    fn terminated(&self, _state: &State) -> bool {
        false
    }

    fn metric(&self, state: &State, action: &[f64], next: &State) -> f64 {
        let speed = (next.q[0] - state.q[0]) / self.control_dt();
        let effort: f64 = action.iter().map(|a| a.clamp(-1.0, 1.0).powi(2)).sum();
        speed - Self::CTRL_COST * effort
    }

    fn metric_description(&self) -> String {
        format!(
            "episode return (forward speed minus control cost per control step, {} steps)",
            Self::HORIZON
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::Inputs;

    #[test]
    fn the_contact_variant_at_the_files_values_is_the_task() {
        let (plain, wide) = (HalfCheetah::new(), HalfCheetah::contact());
        assert_eq!(
            (wide.name(), wide.mu_map().nmu),
            ("half_cheetah_contact", 3)
        );
        let mass = 20.0;
        let mut a = plain.model().clone();
        plain.mu_map().apply(&mut a, &[mass]).unwrap();
        let mut b = wide.model().clone();
        let mu: Vec<f64> = std::iter::once(mass).chain(Contact::NOMINAL).collect();
        wide.mu_map().apply(&mut b, &mu).unwrap();
        // A state with both feet pressed into the floor: contact rows act.
        let State { mut q, v, .. } = plain.reset(&mut rand::SeedableRng::seed_from_u64(3));
        q[1] -= 0.3;
        let (x, u) = (State::new(q, v), Inputs::tau(&vec![0.0; a.nv()]));
        let (mut da, mut db) = (a.data(), b.data());
        assert_eq!(a.step(&mut da, &x, &u), b.step(&mut db, &x, &u));
        // No armature, more friction: another step.
        wide.mu_map().apply(&mut b, &[mass, 0.0, 0.5]).unwrap();
        assert_ne!(a.step(&mut da, &x, &u), b.step(&mut db, &x, &u));
        assert_eq!(b.get_param("joint/bfoot/armature").unwrap(), vec![0.0]);
        assert_eq!(
            b.get_param("geom/floor/friction").unwrap(),
            vec![0.5, 0.1, 0.1]
        );
    }
}
