//! Determinism (issue 10): the same seed gives bitwise the same numbers.
//!
//! Which test proves what:
//! - trajectories in Rust: here (`rollouts_are_bitwise_reproducible`), and
//!   through Python: harness/tests/test_determinism.py;
//! - PPO training: tests/ppo.rs `the_same_seed_gives_bitwise_the_same_weights`;
//! - UC-MLP training: here (`mlp_training_is_bitwise_reproducible`);
//! - DiffOSI and CMA-ES estimates: tests/osi.rs `same_seed_same_bits`,
//!   `cmaes_same_seed_same_bits`;
//! - experiment tables: tests/experiments.rs
//!   `the_same_seed_gives_the_same_json_on_any_number_of_threads`.

mod common;

use common::{random_model, random_state, rng};
use diffosi::model::{Inputs, Integrator, PassiveMode, State};
use diffosi::osi::mlp::{train_mlp, MlpConfig};
use diffosi::rl::Policy;
use diffosi::tasks::{Cartpole, Task};
use diffosi::Model;
use rand::RngExt;

/// A rollout of `steps` seeded random forces in [-1, 1] from a seeded state.
fn seeded_rollout(model: &Model, seed: u64, steps: usize) -> Vec<State> {
    let (q, v, _) = random_state(model, seed);
    let mut r = rng(seed);
    let taus: Vec<Vec<f64>> = (0..steps)
        .map(|_| (0..model.nv()).map(|_| r.random_range(-1.0..1.0)).collect())
        .collect();
    model
        .rollout(&State::new(q, v), taus.iter().map(|t| Inputs::tau(t)))
        .unwrap()
}

/// The bits of every number of a trajectory.
fn bits(states: &[State]) -> Vec<u64> {
    let numbers = states.iter().flat_map(|x| x.q.iter().chain(&x.v));
    numbers.map(|x| x.to_bits()).collect()
}

#[test]
fn rollouts_are_bitwise_reproducible() {
    let settings = [
        (Integrator::Euler, PassiveMode::ImplicitDamping),
        (Integrator::Euler, PassiveMode::ImplicitDampingStiffness),
        (Integrator::Rk4, PassiveMode::Explicit),
    ];
    for (k, (integrator, passive)) in settings.into_iter().enumerate() {
        let seed = 40 + k as u64;
        // Models built twice from the seed, the second run on another thread.
        let a = seeded_rollout(&random_model(seed, 5, passive, integrator), seed, 500);
        let b = std::thread::spawn(move || {
            seeded_rollout(&random_model(seed, 5, passive, integrator), seed, 500)
        })
        .join()
        .unwrap();
        assert_eq!(bits(&a), bits(&b), "{integrator:?} {passive:?}");
        let c = seeded_rollout(&random_model(seed + 1, 5, passive, integrator), seed, 500);
        assert_ne!(bits(&a), bits(&c), "another tree, another trajectory");
    }
    // A reference model loaded twice, and after a parameter edited and set back.
    let path = common::model_path("reference_models/half_cheetah.xml");
    let mut edited = Model::load(&path).unwrap();
    let mass = edited.get_param("body/torso/mass").unwrap();
    edited
        .set_param("body/torso/mass", &[2.0 * mass[0]])
        .unwrap();
    edited.set_param("body/torso/mass", &mass).unwrap();
    let fresh = Model::load(&path).unwrap();
    assert_eq!(
        bits(&seeded_rollout(&fresh, 7, 300)),
        bits(&seeded_rollout(&edited, 7, 300))
    );
}

#[test]
fn mlp_training_is_bitwise_reproducible() {
    let task = Cartpole::new();
    let path =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("policies/cartpole/uc-seed0.json");
    let uc = vec![Policy::load(&path).unwrap()];
    let (lo, hi) = task.mu_range();
    let train = |seed| {
        let config = MlpConfig {
            seed,
            episodes: 6,
            epochs: 2,
            hidden: vec![16],
            ..MlpConfig::new(lo, hi)
        };
        train_mlp(&task, &uc, &config, |_, _| {}).unwrap()
    };
    let (a, b, c) = (train(3), train(3), train(4));
    let losses =
        |m: &diffosi::osi::mlp::MuMlp| m.training.as_ref().unwrap().validation_loss.clone();
    assert_eq!(a.net, b.net);
    assert_eq!((&a.input_mean, &a.input_std), (&b.input_mean, &b.input_std));
    assert_eq!(losses(&a), losses(&b));
    assert_ne!(a.net, c.net);
}
