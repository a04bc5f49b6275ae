//! PPO and the cartpole controllers: learning, determinism, the weights file
//! and the shipped policies.

use std::path::{Path, PathBuf};

use diffosi::rl::{evaluate, train, MuSource, Policy, PolicyKind, PpoConfig};
use diffosi::tasks::{Cartpole, Task};

/// Measured on the shipped policies (30 episodes each, seed 1): UC-Oracle
/// 500.0 over 3 x 30 episodes (the UCs imitate the MPC expert and are then
/// refined by analytic policy gradients; the imitation ones scored 468.4
/// here, the PPO ones 467.6), DR 339.6; the floor for the UCs, a
/// margin for DR.
const UC_ORACLE_FLOOR: f64 = 495.0;
const DR_GAP: f64 = 60.0;

fn short(seed: u64, steps: usize) -> PpoConfig {
    PpoConfig {
        seed,
        total_steps: steps,
        ..PpoConfig::default()
    }
}

fn shipped(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("policies/cartpole")
        .join(name)
}

fn temp_file(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("diffosi-ppo-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir.join(name)
}

#[test]
fn ppo_learns_to_balance_the_cartpole() {
    let task = Cartpole::new();
    let untrained = train(&task, PolicyKind::Uc, &short(3, 1), |_| {}).unwrap();
    let trained = train(&task, PolicyKind::Uc, &short(3, 80_000), |_| {}).unwrap();
    let score = |p: &Policy| evaluate(&task, p, MuSource::Oracle, 20, 11).unwrap().mean();
    let (before, after) = (score(&untrained.policy), score(&trained.policy));
    // After one iteration (4096 steps) the pole falls in about a second; 80k steps (a few
    // seconds) balance most poles for the whole 10 s episode.
    assert!(before < 100.0, "untrained policy scored {before}");
    assert!(
        after > 350.0,
        "trained policy scored {after} (untrained {before})"
    );
    let curve = &trained.curve;
    assert!(curve.last().unwrap().mean_metric > 5.0 * curve[0].mean_metric);
}

#[test]
fn the_same_seed_gives_bitwise_the_same_weights() {
    let task = Cartpole::new();
    let run = |seed| train(&task, PolicyKind::Dr, &short(seed, 6000), |_| {}).unwrap();
    let (a, b, c) = (run(5), run(5), run(6));
    assert_eq!(a.policy.actor.params(), b.policy.actor.params());
    assert_eq!(a.policy.obs_mean, b.policy.obs_mean);
    assert_eq!(a.policy.log_std, b.policy.log_std);
    assert_eq!(
        a.curve.iter().map(|r| r.mean_metric).collect::<Vec<_>>(),
        b.curve.iter().map(|r| r.mean_metric).collect::<Vec<_>>()
    );
    assert_ne!(a.policy.actor.params(), c.policy.actor.params());
}

#[test]
fn saved_weights_round_trip() {
    let task = Cartpole::new();
    let policy = train(&task, PolicyKind::Uc, &short(1, 4096), |_| {})
        .unwrap()
        .policy;
    let path = temp_file("uc.json");
    policy.save(&path).unwrap();
    let loaded = Policy::load(&path).unwrap();
    assert_eq!(loaded, policy);
    let input = [0.1, -0.02, 0.3, 0.05, -0.4];
    assert_eq!(loaded.act(&input), policy.act(&input));

    let text = std::fs::read_to_string(&path).unwrap();
    std::fs::write(&path, text.replace("diffosi-policy/1", "other/1")).unwrap();
    assert!(Policy::load(&path).unwrap_err().contains("format"));
    std::fs::remove_file(&path).unwrap();
}

/// The documented layout, read as plain JSON as a numpy user would, gives
/// the policy's action.
#[test]
fn the_weights_file_reads_as_documented() {
    let policy = Policy::load(&shipped("uc-seed0.json")).unwrap();
    let file: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(shipped("uc-seed0.json")).unwrap()).unwrap();
    let values = |v: &serde_json::Value| -> Vec<f64> {
        v.as_array()
            .unwrap()
            .iter()
            .map(|x| x.as_f64().unwrap())
            .collect()
    };
    assert_eq!(file["task"], "cartpole");
    assert_eq!(file["kind"], "uc");
    let (mean, std) = (values(&file["obs_mean"]), values(&file["obs_std"]));
    let clip = file["obs_clip"].as_f64().unwrap();
    let input = [0.3, -0.1, -0.5, 0.8, 0.45];
    let mut z: Vec<f64> = (0..5)
        .map(|i| ((input[i] - mean[i]) / std[i]).clamp(-clip, clip))
        .collect();
    let layers = file["layers"].as_array().unwrap();
    assert_eq!(layers.len(), 3);
    for (l, layer) in layers.iter().enumerate() {
        let b = values(&layer["b"]);
        let w: Vec<Vec<f64>> = layer["w"].as_array().unwrap().iter().map(values).collect();
        z = w
            .iter()
            .zip(&b)
            .map(|(row, b)| row.iter().zip(&z).map(|(w, z)| w * z).sum::<f64>() + b)
            .map(|y| if l + 1 < layers.len() { y.tanh() } else { y })
            .collect();
    }
    let action = z[0].clamp(-1.0, 1.0);
    assert!((action - policy.act(&input)[0]).abs() < 1e-5);
}

#[test]
fn shipped_universal_controllers_balance_with_the_true_mu() {
    let task = Cartpole::new();
    let mut scores = vec![];
    for seed in 0..3 {
        let policy = Policy::load(&shipped(&format!("uc-seed{seed}.json"))).unwrap();
        assert_eq!(
            (policy.task.as_str(), policy.kind),
            (task.name(), PolicyKind::Uc)
        );
        let result = evaluate(&task, &policy, MuSource::Oracle, 30, 1).unwrap();
        scores.extend(result.metrics);
    }
    let mean = scores.iter().sum::<f64>() / scores.len() as f64;
    assert!(mean > UC_ORACLE_FLOOR, "UC-Oracle scored {mean}");
}

#[test]
fn the_domain_randomised_policies_trail_the_oracle_controllers() {
    let task = Cartpole::new();
    let pooled = |kind: &str, source| {
        let scores: Vec<f64> = (0..3)
            .flat_map(|seed| {
                let policy = Policy::load(&shipped(&format!("{kind}-seed{seed}.json"))).unwrap();
                evaluate(&task, &policy, source, 30, 1).unwrap().metrics
            })
            .collect();
        scores.iter().sum::<f64>() / scores.len() as f64
    };
    let (uc, dr) = (
        pooled("uc", MuSource::Oracle),
        pooled("dr", MuSource::Oracle),
    );
    assert!(uc > dr + DR_GAP, "UC-Oracle {uc}, DR {dr}");
}
