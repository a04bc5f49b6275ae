//! The paper's cartpole (Section 4.2) on `reference_models/cartpole.xml`.
//!
//! - State q = (x, theta), v = (x_dot, theta_dot): cart position along world x
//!   (m) and pole angle about +y (rad), theta = 0 upright, positive theta
//!   tilting the pole's top toward +x.
//! - mu (m), uniform in [-0.6, 0.6], offsets the pole's COM from its geometric
//!   centre by (mu, 0.2 mu): mu across the pole (pole-frame x, in the plane of
//!   motion) and 0.2 mu along it (pole-frame z). The pole frame sits at the
//!   hinge with +z along the pole, and the model's COM is the centre of the
//!   1 m pole, (0, 0, 0.5), so COM = (mu, 0, 0.5 + 0.2 mu) (`body/pole/com`).
//!   Mass and inertia about the COM are unchanged.
//! - Reset: x, theta, x_dot, theta_dot each uniform in [-0.05, 0.05].
//! - Action: one component a; the cart force is 500 clamp(a, -1, 1) N.
//! - Timing: the paper's controller applies "an impulse of [-500 N, 500 N] dt at
//!   50 Hz". We read it as a force F in [-500, 500] N held for one control
//!   period dt = 0.02 s (an impulse F dt). The model's timestep is 0.02 s, so a
//!   control step is one physics step (semi-implicit Euler).
//! - An episode is 500 control steps (10 s). It ends early when |theta| > pi/2
//!   or |x| > 2.5 m; the task metric counts the steps whose resulting state has
//!   |theta| <= pi/2 and |x| <= 2.5, so a full episode scores 500.
//! - Training reward, for a step that ends in bounds (0 otherwise):
//!   0.5 + 0.5 cos(psi) - 0.1 (x / 2.5)^2, where psi is the angle of the
//!   hinge-to-COM line from vertical (psi = theta + atan2(com_x, com_z), zero
//!   when the offset COM is balanced above the hinge). Surviving dominates;
//!   the terms guide the pole toward its mu-dependent balance angle and keep
//!   the cart from drifting to the track's end late in an episode.
//! - Planning cost (what iLQR minimises, [`Task::cost`]), smooth where the
//!   reward is not: psi^2 / 4 + 0.1 (x / 2.5)^2 (the reward's terms to second
//!   order, with psi unwrapped so that a full turn of the pole costs) +
//!   2.5e-4 x_dot^2 + 1.25e-3 theta_dot^2 + 2.5e-4 a^2, plus quadratic walls
//!   5 (|x| - 2)^2 past |x| = 2 m and 50 (|theta| - 1.4)^2 past 1.4 rad,
//!   inside the metric's bounds, all at the step's end state. Its optimum is
//!   the reward's: the pole still at its balance angle, the cart at rest at 0.

use std::f64::consts::FRAC_PI_2;

use rand::rngs::StdRng;
use rand::RngExt;

use super::Task;
use crate::model::{mjcf, MapEntry, ParamError, ParamMap, State};
use crate::Model;

/// The model file, compiled in so the task needs no path at run time.
const MJCF: &str = include_str!("../../reference_models/cartpole.xml");

pub struct Cartpole {
    model: Model,
    map: ParamMap,
}

impl Cartpole {
    pub const MU_LOWER: [f64; 1] = [-0.6];
    pub const MU_UPPER: [f64; 1] = [0.6];
    /// Largest cart force (N).
    pub const FORCE_LIMIT: f64 = 500.0;
    pub const HORIZON: usize = 500;
    /// Bounds of the task metric: |x| <= X_LIMIT (m), |theta| <= THETA_LIMIT (rad).
    pub const X_LIMIT: f64 = 2.5;
    pub const THETA_LIMIT: f64 = FRAC_PI_2;
    /// Half-width of the uniform reset distribution of each state component.
    pub const RESET_HALF_WIDTH: f64 = 0.05;

    /// The task on the shipped `reference_models/cartpole.xml`.
    pub fn new() -> Cartpole {
        let model = mjcf::parse(MJCF, "reference_models/cartpole.xml")
            .and_then(Model::from_spec)
            .expect("the shipped cartpole model loads");
        Cartpole::with_model(model).expect("the shipped cartpole has a pole")
    }

    /// The task on another cartpole model (e.g. the URDF twin, or other options).
    pub fn with_model(model: Model) -> Result<Cartpole, ParamError> {
        let map = Cartpole::mu_map_of(&model)?;
        Ok(Cartpole { model, map })
    }

    /// The mu map on a cartpole model: `body/pole/com` = (0, 0, 0.5) + (1, 0, 0.2) mu.
    pub fn mu_map_of(model: &Model) -> Result<ParamMap, ParamError> {
        ParamMap::new(
            model,
            1,
            &[MapEntry {
                name: "body/pole/com",
                offset: &[0.0, 0.0, 0.5],
                gain: &[&[1.0], &[0.0], &[0.2]],
            }],
        )
    }

    /// psi, the angle of the hinge-to-COM line from vertical, at pole angle
    /// theta with parameters mu.
    fn tilt(&self, mu: &[f64], theta: f64) -> f64 {
        let com = &self.map.values(mu)[0];
        theta + com[0].atan2(com[2])
    }

    fn in_bounds(State { q, .. }: &State) -> bool {
        q[0].abs() <= Self::X_LIMIT && q[1].abs() <= Self::THETA_LIMIT
    }
}

impl Default for Cartpole {
    fn default() -> Self {
        Cartpole::new()
    }
}

impl Task for Cartpole {
    fn name(&self) -> &'static str {
        "cartpole"
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
        1
    }

    fn obs_dim(&self) -> usize {
        4
    }

    fn act_dim(&self) -> usize {
        1
    }

    fn reset(&self, rng: &mut StdRng) -> State {
        let w = Self::RESET_HALF_WIDTH;
        let mut draw = || rng.random_range(-w..=w);
        let (x, theta, x_dot, theta_dot) = (draw(), draw(), draw(), draw());
        State::new(vec![x, theta], vec![x_dot, theta_dot])
    }

    fn observe(&self, State { q, v, .. }: &State, out: &mut Vec<f64>) {
        out.extend_from_slice(q);
        out.extend_from_slice(v);
    }

    fn forces(&self, action: &[f64]) -> Vec<f64> {
        vec![Self::FORCE_LIMIT * action[0].clamp(-1.0, 1.0), 0.0]
    }

    fn reward(&self, mu: &[f64], _state: &State, _action: &[f64], next: &State) -> f64 {
        if !Self::in_bounds(next) {
            return 0.0;
        }
        let psi = self.tilt(mu, next.q[1]);
        0.5 + 0.5 * psi.cos() - 0.1 * (next.q[0] / Self::X_LIMIT).powi(2)
    }

    fn cost(&self, mu: &[f64], _state: &State, action: &[f64], State { q, v, .. }: &State) -> f64 {
        let wall = |z: f64, at: f64| (z.abs() - at).max(0.0).powi(2);
        let psi = self.tilt(mu, q[1]);
        0.25 * psi * psi
            + 0.1 * (q[0] / Self::X_LIMIT).powi(2)
            + 2.5e-4 * v[0] * v[0]
            + 1.25e-3 * v[1] * v[1]
            + 2.5e-4 * action[0] * action[0]
            + 5.0 * wall(q[0], 2.0)
            + 50.0 * wall(q[1], 1.4)
    }

    fn terminated(&self, state: &State) -> bool {
        !Self::in_bounds(state)
    }

    fn metric(&self, _state: &State, _action: &[f64], next: &State) -> f64 {
        if Self::in_bounds(next) {
            1.0
        } else {
            0.0
        }
    }

    fn metric_description(&self) -> String {
        format!("steps within the bounds (of {})", Self::HORIZON)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::tasks::{average_mu, sample_mu, Env};
    use rand::SeedableRng;

    #[test]
    fn mu_moves_the_pole_com_across_and_along_the_pole() {
        let task = Cartpole::new();
        // The pole frame: hinge at the origin, pole along +z, centre at 0.5.
        assert_eq!(
            task.model().get_param("body/pole/com").unwrap(),
            vec![0.0, 0.0, 0.5]
        );
        let mut model = task.model().clone();
        task.mu_map().apply(&mut model, &[-0.5]).unwrap();
        let com = model.get_param("body/pole/com").unwrap();
        assert_eq!(com, vec![-0.5, 0.0, 0.4]);
        assert_eq!(average_mu(&task), vec![0.0]);
    }

    #[test]
    fn a_com_offset_to_plus_x_tips_the_pole_toward_plus_theta() {
        let task = Cartpole::new();
        let mut rng = StdRng::seed_from_u64(0);
        for (mu, sign) in [(0.3, 1.0), (-0.3, -1.0)] {
            let mut env = Env::new(&task);
            env.reset(&[mu], &mut rng).unwrap();
            env.state = State::new(vec![0.0, 0.0], vec![0.0, 0.0]);
            env.step(&[0.0]).unwrap();
            assert!(sign * env.state().v[1] > 0.0, "mu {mu}: {:?}", env.state());
        }
    }

    #[test]
    fn resets_are_uniform_in_the_small_box() {
        let task = Cartpole::new();
        let mut rng = StdRng::seed_from_u64(3);
        let (mut lo, mut hi) = ([f64::MAX; 4], [f64::MIN; 4]);
        for _ in 0..2000 {
            let mut obs = vec![];
            task.observe(&task.reset(&mut rng), &mut obs);
            for i in 0..4 {
                lo[i] = lo[i].min(obs[i]);
                hi[i] = hi[i].max(obs[i]);
            }
        }
        for i in 0..4 {
            assert!(lo[i] >= -0.05 && lo[i] < -0.049, "{lo:?}");
            assert!(hi[i] <= 0.05 && hi[i] > 0.049, "{hi:?}");
        }
        let mus: Vec<f64> = (0..2000).map(|_| sample_mu(&task, &mut rng)[0]).collect();
        assert!(mus.iter().all(|m| (-0.6..=0.6).contains(m)));
        assert!(mus.iter().any(|&m| m < -0.59) && mus.iter().any(|&m| m > 0.59));
    }

    #[test]
    fn termination_and_metric_use_the_closed_bounds() {
        let task = Cartpole::new();
        let state = |x: f64, theta: f64| State::new(vec![x, theta], vec![0.0, 0.0]);
        let inside = [
            state(2.5, 0.0),
            state(-2.5, -FRAC_PI_2),
            state(0.0, FRAC_PI_2),
        ];
        for s in &inside {
            assert!(!task.terminated(s), "{s:?}");
            assert_eq!(task.metric(s, &[0.0], s), 1.0);
            assert!(task.reward(&[0.0], s, &[0.0], s) > 0.3);
        }
        // Best with the COM balanced above the hinge and the cart centred.
        let mu = 0.3_f64;
        let balanced = state(0.0, -mu.atan2(0.5 + 0.2 * mu));
        assert!((task.reward(&[mu], &balanced, &[0.0], &balanced) - 1.0).abs() < 1e-12);
        let upright = state(0.0, 0.0);
        assert!(task.reward(&[mu], &upright, &[0.0], &upright) < 0.95);
        for s in [state(2.5001, 0.0), state(0.0, -1.5709), state(-3.0, 2.0)] {
            assert!(task.terminated(&s), "{s:?}");
            assert_eq!(task.metric(&s, &[0.0], &s), 0.0);
            assert_eq!(task.reward(&[0.0], &s, &[0.0], &s), 0.0);
        }
        assert_eq!(task.forces(&[0.5]), vec![250.0, 0.0]);
        assert_eq!(task.forces(&[-3.0]), vec![-500.0, 0.0]);
    }

    #[test]
    fn an_unactuated_episode_scores_the_steps_before_the_pole_falls() {
        let task = Cartpole::new();
        let mut rng = StdRng::seed_from_u64(5);
        let mut env = Env::new(&task);
        env.reset(&[0.4], &mut rng).unwrap();
        let mut score = 0.0;
        let last = loop {
            let out = env.step(&[0.0]).unwrap();
            score += out.metric;
            if out.terminated || out.truncated {
                break out;
            }
        };
        // The offset COM tips the pole over in about a second; the failing
        // step itself does not count.
        assert!(last.terminated && !last.truncated);
        assert!(env.state().q[1] > FRAC_PI_2, "{:?}", env.state());
        assert_eq!(score, (env.t() - 1) as f64);
        assert!((20.0..100.0).contains(&score), "{score}");
    }

    #[test]
    fn a_held_pole_runs_to_the_horizon() {
        // Zero gravity and zero velocity: the state stays put for 500 steps.
        let model = Cartpole::new()
            .model()
            .edited(|spec| spec.opt.gravity = nalgebra::Vector3::zeros())
            .unwrap();
        let task = Cartpole::with_model(model).unwrap();
        let mut rng = StdRng::seed_from_u64(1);
        let mut env = Env::new(&task);
        env.reset(&[0.2], &mut rng).unwrap();
        env.state.v = vec![0.0, 0.0];
        let mut score = 0.0;
        let mut outcome = env.step(&[0.0]).unwrap();
        score += outcome.metric;
        while !(outcome.terminated || outcome.truncated) {
            outcome = env.step(&[0.0]).unwrap();
            score += outcome.metric;
        }
        assert!(outcome.truncated && !outcome.terminated);
        assert_eq!(score, 500.0);
    }
}
