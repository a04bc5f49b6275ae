//! The identification problems of the OSI benchmarks (`benches/osi.rs`) and of
//! the evaluations-to-tolerance table (`examples/osi_evals.rs`), contact-free:
//!
//! - cartpole: mu = pole COM offset, COM at (mu, 0, 0.5 + 0.2 mu), bounds
//!   [-0.6, 0.6], prior 0 (the paper's task);
//! - half cheetah: mu = torso mass (`body/torso/mass`), bounds [1, 50], prior
//!   4.9, truth 7.0 (the paper's task, as in shared/notes/reference-engines.md).
//!
//! Transitions come from our own engine at the true mu, from seeded uniform
//! random states and generalized forces; in contact (`half_cheetah_contact`:
//! the torso mass of the half cheetah on its floor, MuJoCo's constraint
//! contact) from consecutive steps standing, under seeded random forces.
#![allow(dead_code)]

#[path = "../common/mod.rs"]
mod common;

pub use common::{load, load_with_contact, settled};
use diffosi::derivatives::Transition;
use diffosi::model::{ContactModel, Inputs, ParamMap, State};
use diffosi::osi::Problem;
use diffosi::tasks::{Cartpole, HalfCheetah, Task as _};
use diffosi::Model;
use rand::rngs::StdRng;
use rand::{RngExt, SeedableRng};

pub struct Task {
    pub name: &'static str,
    pub model: Model,
    pub map: ParamMap,
    pub lower: f64,
    pub upper: f64,
    pub prior: f64,
    /// Half-widths of the uniform draws of q, v and tau (one value each).
    pub ranges: [f64; 3],
}

pub fn cartpole() -> Task {
    let model = load("cartpole");
    let map = Cartpole::mu_map_of(&model).unwrap();
    Task {
        name: "cartpole",
        model,
        map,
        lower: -0.6,
        upper: 0.6,
        prior: 0.0,
        ranges: [1.0, 2.0, 5.0],
    }
}

pub fn half_cheetah() -> Task {
    let model = load("half_cheetah");
    let map = HalfCheetah::with_model(model.clone())
        .unwrap()
        .mu_map()
        .clone();
    Task {
        name: "half_cheetah",
        model,
        map,
        lower: 1.0,
        upper: 50.0,
        prior: 4.9,
        ranges: [0.5, 1.0, 5.0],
    }
}

pub fn half_cheetah_contact() -> Task {
    let model = load_with_contact("half_cheetah", ContactModel::Constraint);
    Task {
        name: "half_cheetah_contact",
        model,
        ..half_cheetah()
    }
}

/// The true mu the benchmarks identify.
pub fn truth(task: &Task) -> f64 {
    match task.name {
        "cartpole" => 0.3,
        _ => 7.0,
    }
}

impl Task {
    /// Noise-free data: residual scales at the level of rounding, q then v
    /// (a position error is dt times the velocity error that caused it).
    pub fn problem(&self) -> Problem {
        let n = self.model.nv();
        let dt = self.model.opt.timestep;
        let mut scale = vec![1e-6 * dt; n];
        scale.extend(vec![1e-6; n]);
        Problem::new(
            &self.model,
            self.map.clone(),
            &[self.lower],
            &[self.upper],
            &[self.prior],
            &scale,
        )
        .unwrap()
    }

    /// `len` transitions of the model at `mu`, from seeded random states and
    /// forces.
    pub fn window(&self, mu: f64, len: usize, seed: u64) -> Vec<Transition> {
        let mut truth = self.model.clone();
        self.map.apply(&mut truth, &[mu]).unwrap();
        let mut rng = StdRng::seed_from_u64(seed);
        let mut data = truth.data();
        let n = truth.nv();
        let q0 = truth.reference_q();
        (0..len)
            .map(|_| {
                let mut draw =
                    |h: f64| -> Vec<f64> { (0..n).map(|_| rng.random_range(-h..h)).collect() };
                let dq = draw(self.ranges[0]);
                let q: Vec<f64> = q0.iter().zip(&dq).map(|(a, b)| a + b).collect();
                let v = draw(self.ranges[1]);
                let tau = draw(self.ranges[2]);
                Transition::simulated(&truth, &mut data, State::new(q, v), tau).unwrap()
            })
            .collect()
    }

    /// `len` consecutive transitions of the model at `mu` standing on its
    /// floor (settled from rest), under seeded random forces.
    pub fn standing_window(&self, mu: f64, len: usize, seed: u64) -> Vec<Transition> {
        let mut truth = self.model.clone();
        self.map.apply(&mut truth, &[mu]).unwrap();
        let mut rng = StdRng::seed_from_u64(seed);
        let mut data = truth.data();
        let (mut q, mut v, _) = settled(&truth, 300);
        let n = truth.nv();
        (0..len)
            .map(|_| {
                let tau: Vec<f64> = (0..n)
                    .map(|_| rng.random_range(-self.ranges[2]..self.ranges[2]))
                    .collect();
                let next = truth
                    .step(
                        &mut data,
                        &State::new(q.clone(), v.clone()),
                        &Inputs::tau(&tau),
                    )
                    .unwrap();
                let (q_next, v_next) = (next.q, next.v);
                let t = Transition {
                    start: State::new(q.clone(), v.clone()),
                    tau,
                    next: State::new(q_next.clone(), v_next.clone()),
                };
                (q, v) = (q_next, v_next);
                t
            })
            .collect()
    }
}
