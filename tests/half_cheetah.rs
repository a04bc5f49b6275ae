//! The half cheetah task: physics stable over the whole torso-mass range at
//! dt 0.01 on the soft floor, the reward's sign and scale, determinism, and
//! DiffOSI identifying the torso mass from single transitions through contact.

use diffosi::control::{task_problem, Episode};
use diffosi::model::{Inputs, State};
use diffosi::osi::{Identifier, Lm};
use diffosi::tasks::{self, Env, HalfCheetah, Task};
use rand::rngs::StdRng;
use rand::{RngExt, SeedableRng};

/// Runs `steps` control steps of random actions (uniform in [-1, 1]^6,
/// redrawn every `hold` steps) from a reset; returns the states visited.
fn random_episode(task: &HalfCheetah, mu: f64, seed: u64, steps: usize, hold: usize) -> Vec<State> {
    let mut rng = StdRng::seed_from_u64(seed);
    let mut env = Env::new(task);
    env.reset(&[mu], &mut rng).unwrap();
    let mut action = vec![0.0; 6];
    let mut states = vec![env.state().clone()];
    for t in 0..steps {
        if t % hold == 0 {
            action = (0..6).map(|_| rng.random_range(-1.0..=1.0)).collect();
        }
        let out = env.step(&action).unwrap();
        assert!(!out.terminated);
        states.push(env.state().clone());
    }
    states
}

#[test]
fn the_task_follows_gymnasium_half_cheetah() {
    let task = tasks::by_name("half_cheetah").unwrap();
    assert_eq!(task.name(), "half_cheetah");
    assert_eq!((task.obs_dim(), task.act_dim()), (17, 6));
    assert_eq!((task.horizon(), task.substeps()), (1000, 5));
    assert_eq!(task.model().opt.timestep, 0.01);
    assert_eq!(task.mu_range(), (&[1.0][..], &[50.0][..]));
    // The motors' gears, on the leg hinges only; actions are clamped.
    let tau = task.forces(&[1.0, 1.0, 1.0, -1.0, -1.0, -2.0]);
    assert_eq!(
        tau,
        vec![0.0, 0.0, 0.0, 120.0, 90.0, 60.0, -120.0, -60.0, -30.0]
    );
    // mu is the torso mass; the COM stays.
    let mut model = task.model().clone();
    let com = model.get_param("body/torso/com").unwrap();
    assert!((model.get_param("body/torso/mass").unwrap()[0] - 6.2502).abs() < 1e-3);
    task.mu_map().apply(&mut model, &[42.0]).unwrap();
    assert_eq!(model.get_param("body/torso/mass").unwrap(), vec![42.0]);
    assert_eq!(model.get_param("body/torso/com").unwrap(), com);
    // Observation: q without rootx, then v.
    let q: Vec<f64> = (0..9).map(|i| i as f64).collect();
    let v: Vec<f64> = (10..19).map(|i| i as f64).collect();
    let mut obs = vec![];
    task.observe(&State::new(q.clone(), v.clone()), &mut obs);
    assert_eq!(obs, [&q[1..], &v[..]].concat());
}

#[test]
fn resets_carry_gymnasium_noise() {
    let task = HalfCheetah::new();
    let mut rng = StdRng::seed_from_u64(2);
    let (mut q_max, mut v_sq, mut n) = (0.0f64, 0.0, 0.0);
    for _ in 0..500 {
        let State { q, v, .. } = task.reset(&mut rng);
        q_max = q.iter().fold(q_max, |m, x| m.max(x.abs()));
        v_sq += v.iter().map(|x| x * x).sum::<f64>();
        n += v.len() as f64;
    }
    assert!(q_max <= 0.1 && q_max > 0.099, "{q_max}");
    let v_std = (v_sq / n).sqrt();
    assert!((v_std - 0.1).abs() < 0.005, "{v_std}");
}

#[test]
fn the_reward_is_forward_speed_minus_control_cost() {
    let task = HalfCheetah::new();
    let at = |x: f64| {
        State::new(
            vec![x, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
            vec![0.0; 9],
        )
    };
    let idle = [0.0; 6];
    // 0.1 m in one control step of 0.05 s: 2 m/s.
    assert!((task.reward(&[5.0], &at(1.0), &idle, &at(1.1)) - 2.0).abs() < 1e-12);
    assert!((task.reward(&[5.0], &at(1.0), &idle, &at(0.9)) + 2.0).abs() < 1e-12);
    let full = [1.0, -1.0, 1.0, -1.0, 1.0, -3.0];
    assert!((task.reward(&[5.0], &at(0.0), &full, &at(0.0)) + 0.6).abs() < 1e-12);
    assert_eq!(
        task.metric(&at(0.0), &full, &at(0.5)),
        task.reward(&[1.0], &at(0.0), &full, &at(0.5))
    );
    assert!(!task.terminated(&at(-100.0)));
}

#[test]
fn the_physics_is_stable_over_the_whole_mass_range() {
    let task = HalfCheetah::new();
    for (k, mu) in [1.0, 4.9, 25.0, 50.0].into_iter().enumerate() {
        // 20 s of random torques held for 0.25 s each.
        let states = random_episode(&task, mu, k as u64, 400, 5);
        let mut worst_v = 0.0f64;
        let mut lowest = f64::MAX;
        for State { q, v, .. } in &states {
            assert!(
                q.iter().chain(v).all(|x| x.is_finite()),
                "mu {mu}: {q:?} {v:?}"
            );
            worst_v = v.iter().fold(worst_v, |m, x| m.max(x.abs()));
            lowest = lowest.min(0.7 + q[1]);
        }
        println!("mu {mu}: largest |v| {worst_v:.1}, lowest torso height {lowest:.3} m");
        assert!(worst_v < 60.0, "mu {mu}: |v| reached {worst_v}");
        // The torso (a 0.046 m capsule) never sinks through the floor.
        assert!(lowest > 0.0, "mu {mu}: torso at {lowest} m");
        // Then 10 s under zero torques: it settles on the floor.
        let mut env = Env::new(&task);
        env.reset_to(&[mu], states.last().unwrap().clone()).unwrap();
        for _ in 0..200 {
            env.step(&[0.0; 6]).unwrap();
        }
        let State { q, v, .. } = env.state();
        let speed = v.iter().fold(0.0f64, |m, x| m.max(x.abs()));
        println!(
            "mu {mu}: after 10 s at rest |v| {speed:.2e}, torso height {:.3} m",
            0.7 + q[1]
        );
        // Light torsos come to rest; a heavy one standing on its legs can keep
        // a small bounded rocking (about 1 rad/s in the legs) on the soft,
        // explicitly integrated floor: bounded, not growing.
        assert!(speed < 5.0, "mu {mu}: still moving, |v| {speed}");
    }
}

#[test]
fn episodes_are_deterministic() {
    let task = HalfCheetah::new();
    let a = random_episode(&task, 17.0, 9, 100, 3);
    let _ = random_episode(&task, 45.0, 1, 50, 1);
    let b = random_episode(&task, 17.0, 9, 100, 3);
    assert_eq!(a, b);
    let mut rng = StdRng::seed_from_u64(4);
    let e1 = Episode::draw(&task, &mut rng);
    let mut rng = StdRng::seed_from_u64(4);
    assert_eq!(e1, Episode::draw(&task, &mut rng));
}

#[test]
fn diffosi_finds_the_torso_mass_from_one_transition_through_contact() {
    let task = HalfCheetah::new();
    let mut problem = task_problem(&task).unwrap();
    let mut rng = StdRng::seed_from_u64(11);
    let mut worst = 0.0f64;
    let mut in_contact = 0;
    for k in 0..12 {
        let mu = 1.0 + 49.0 * rng.random::<f64>();
        let mut env = Env::new(&task);
        env.reset(&[mu], &mut rng).unwrap();
        for _ in 0..(10 + 7 * k) {
            let action: Vec<f64> = (0..6).map(|_| rng.random_range(-1.0..=1.0)).collect();
            env.step(&action).unwrap();
        }
        let transition = env.last_transition().unwrap();
        let mut data = task.model().data();
        let contacts = task
            .model()
            .contacts(
                &mut data,
                &transition.start,
                &Inputs::tau(&vec![0.0; transition.start.v.len()]),
            )
            .unwrap();
        in_contact += usize::from(!contacts.is_empty());
        let est = Lm::default()
            .identify(&mut problem, std::slice::from_ref(&transition), &[25.5])
            .unwrap();
        let err = (est.mu[0] - mu).abs();
        worst = worst.max(err);
        assert!(err < 0.05, "mu {mu}: estimate {:?}", est.mu);
    }
    println!("worst torso-mass error {worst:.2e} kg; {in_contact} of 12 transitions in contact");
    assert!(in_contact >= 6, "{in_contact}");
}
