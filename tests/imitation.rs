//! Imitation of the iLQR MPC expert (DAgger) on the cartpole: the expert's
//! own noisy episodes score near the maximum, later rounds are the student's,
//! and the same seed gives bitwise the same policy.

use diffosi::rl::{train_dagger, DaggerConfig, PolicyKind};
use diffosi::tasks::Cartpole;

fn small(seed: u64) -> DaggerConfig {
    DaggerConfig {
        seed,
        rounds: 2,
        episodes: 3,
        epochs: 5,
        ..DaggerConfig::default()
    }
}

#[test]
fn dagger_learns_from_the_expert_and_is_deterministic() {
    let task = Cartpole::new();
    let mut seen = vec![];
    let (policy, rows) =
        train_dagger(&task, PolicyKind::Uc, &small(4), |row| seen.push(row.round)).unwrap();
    assert_eq!(seen, vec![0, 1]);
    // Round 0 is the expert with action noise: it balances.
    assert!(rows[0].mean_metric > 450.0, "{rows:?}");
    assert!(rows[1].env_steps > rows[0].env_steps);
    assert!(rows.iter().all(|r| r.held_out_mse.is_finite()));
    assert_eq!(policy.kind, PolicyKind::Uc);
    assert_eq!(policy.actor.inputs(), 5);
    let (again, _) = train_dagger(&task, PolicyKind::Uc, &small(4), |_| {}).unwrap();
    assert_eq!(policy.actor, again.actor);
    let (other, _) = train_dagger(&task, PolicyKind::Dr, &small(5), |_| {}).unwrap();
    assert_eq!(other.actor.inputs(), 4);
}
