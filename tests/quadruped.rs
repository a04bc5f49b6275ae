//! The quadruped task (src/tasks/quadruped): its model, its payload rule,
//! its servo inputs and its episodes.

use diffosi::control::{Source, Sources};
use diffosi::model::params::{inertia_from_six, inertia_to_six};
use diffosi::model::{Inputs, State};
use diffosi::tasks::{Env, Quadruped, Task};
use nalgebra::{Matrix3, Vector3};
use rand::rngs::StdRng;
use rand::SeedableRng;

/// The worst absolute difference of two states' (q, v).
fn gap(a: &State, b: &State) -> f64 {
    let q = a.q.iter().zip(&b.q).map(|(x, y)| (x - y).abs());
    let v = a.v.iter().zip(&b.v).map(|(x, y)| (x - y).abs());
    q.chain(v).fold(0.0, f64::max)
}

#[test]
fn the_unloaded_go1_stands_on_its_servos_at_the_zero_action() {
    let task = Quadruped::new();
    let m = task.model();
    assert_eq!((m.nq(), m.nv(), m.nu(), task.obs_dim()), (19, 18, 12, 34));
    let mut env = Env::new(&task);
    env.reset(&[0.0, 0.0], &mut StdRng::seed_from_u64(1))
        .unwrap();
    for _ in 0..250 {
        let out = env.step(&[0.0; 12]).unwrap();
        assert!(!out.terminated, "fell at {:?}", env.state().q);
    }
    let q = &env.state().q;
    assert!(q[2] > 0.2 && Quadruped::uprightness(q) > 0.99, "{q:?}");
}

/// The payload body carries the named-parameter rules onto the trunk: the
/// task's model with mu applied steps as the unloaded model whose trunk has
/// the composite's mass, COM and inertia about that COM (the trunk's and
/// the payload's box inertia, each moved by the parallel-axis theorem).
#[test]
fn the_payload_is_the_trunks_composite_by_the_parameter_rules() {
    let task = Quadruped::new();
    let (mass, x) = (5.0, 0.07);
    let mut loaded = task.model().clone();
    task.mu_map().apply(&mut loaded, &[mass, x]).unwrap();
    let mut composite = task.model().clone();
    let param = |name: &str| composite.get_param(name).unwrap();
    let (m_t, c_t) = (param("body/trunk/mass")[0], param("body/trunk/com"));
    let c_t = Vector3::from_column_slice(&c_t);
    let i_t = inertia_from_six(&param("body/trunk/inertia"));
    let c_p = Vector3::new(x, 0.0, 0.082);
    let per_kg = [0.01 + 0.0025, 0.04 + 0.0025, 0.04 + 0.01].map(|s| s / 12.0);
    let i_p = Matrix3::from_diagonal(&Vector3::from(per_kg)) * mass;
    let m = m_t + mass;
    let c = (c_t * m_t + c_p * mass) / m;
    let shift = |d: Vector3<f64>, mass: f64| {
        (Matrix3::identity() * d.norm_squared() - d * d.transpose()) * mass
    };
    let i = i_t + shift(c_t - c, m_t) + i_p + shift(c_p - c, mass);
    composite.set_param("body/trunk/mass", &[m]).unwrap();
    composite.set_param("body/trunk/com", c.as_slice()).unwrap();
    composite
        .set_param("body/trunk/inertia", &inertia_to_six(&i))
        .unwrap();
    // Standing with the feet pressed into the floor, moving, under servo targets.
    let mut x0 = task.reset(&mut StdRng::seed_from_u64(2));
    x0.q[2] -= 0.03;
    x0.v.iter_mut()
        .enumerate()
        .for_each(|(i, v)| *v = 0.1 * (i as f64).sin());
    let u = task.inputs(&[0.3; 12]);
    let (mut a, mut b) = (x0.clone(), x0);
    let (mut da, mut db) = (loaded.data(), composite.data());
    for _ in 0..20 {
        a = loaded.step(&mut da, &a, &u).unwrap();
        b = composite.step(&mut db, &b, &u).unwrap();
    }
    assert!(gap(&a, &b) < 1e-9, "{}", gap(&a, &b));
    assert!(
        gap(
            &a,
            &task.model().step(&mut task.model().data(), &a, &u).unwrap()
        ) > 1e-3
    );
}

/// The identifiers' view of a servo step: its start state and the forces
/// it held, the servos' at that state; a step under them alone (no ctrl)
/// is the step.
#[test]
fn a_servo_steps_transition_replays_under_its_held_forces() {
    let task = Quadruped::new();
    let mut env = Env::new(&task);
    env.reset(&[3.0, -0.05], &mut StdRng::seed_from_u64(3))
        .unwrap();
    for k in 0..30 {
        let action: Vec<f64> = (0..12).map(|j| ((j + k) as f64).cos()).collect();
        env.step(&action).unwrap();
    }
    let t = env.last_transition().unwrap();
    let mut model = task.model().clone();
    task.mu_map().apply(&mut model, env.mu()).unwrap();
    let replay = model
        .step(&mut model.data(), &t.start, &Inputs::tau(&t.tau))
        .unwrap();
    assert!(gap(&replay, &t.next) < 1e-12, "{}", gap(&replay, &t.next));
    assert!(t.tau[6..].iter().any(|f| f.abs() > 1.0), "{:?}", t.tau);
}

#[test]
fn a_fall_ends_the_episode() {
    let task = Quadruped::new();
    let mut state = task.reset(&mut StdRng::seed_from_u64(4));
    assert!(!task.terminated(&state));
    state.q[2] = 0.14;
    assert!(task.terminated(&state));
    state.q[2] = 0.3;
    // Tilted 70 degrees about x.
    let half = 70f64.to_radians() / 2.0;
    state.q[3..7].copy_from_slice(&[half.cos(), half.sin(), 0.0, 0.0]);
    assert!(task.terminated(&state));
}

/// The reward's yaw-rate term: a heading that turns by w rad/s over the
/// control step costs 0.5 (1 - exp(-w^2 / 0.05)), the same across the
/// heading's wrap at +-pi.
#[test]
fn turning_costs_the_yaw_rate_term() {
    let task = Quadruped::new();
    let dt = task.control_dt();
    let at = |yaw: f64| {
        let mut s = task.reset(&mut StdRng::seed_from_u64(5));
        let half = yaw / 2.0;
        s.q[3..7].copy_from_slice(&[half.cos(), 0.0, 0.0, half.sin()]);
        s
    };
    let action = [0.0; 12];
    let w: f64 = 0.3;
    for yaw in [0.0, std::f64::consts::PI - 0.002] {
        let start = at(yaw);
        let straight = task.metric(&start, &action, &at(yaw));
        let turned = task.metric(&start, &action, &at(yaw + w * dt));
        let cost = 0.5 * (1.0 - (-w * w / 0.05).exp());
        assert!(
            (straight - turned - cost).abs() < 1e-9,
            "at yaw {yaw}: {straight} - {turned} != {cost}"
        );
    }
}

/// DiffOSI on the task's own transitions (the last physics step of each
/// control step, window 4, Levenberg-Marquardt from the middle of the
/// range): standing on its servos, the Go1 gives away its payload's mass
/// and placement from the first transitions on.
#[test]
fn diffosi_identifies_the_payload_from_standing_transitions() {
    let task = Quadruped::new();
    let mut estimator = Sources::default()
        .estimator(Source::DiffosiNoCd, &task, 0)
        .unwrap();
    let mut env = Env::new(&task);
    let mu = [5.3, 0.06];
    env.reset(&mu, &mut StdRng::seed_from_u64(6)).unwrap();
    estimator.reset(&mu).unwrap();
    let mut worst = [0.0f64; 2];
    for _ in 0..40 {
        env.step(&[0.0; 12]).unwrap();
        estimator
            .observe(env.last_transition().unwrap(), &mu)
            .unwrap();
        for (w, (hat, truth)) in worst.iter_mut().zip(estimator.mu().iter().zip(mu)) {
            *w = w.max((hat - truth).abs());
        }
    }
    assert!(worst[0] < 0.1 && worst[1] < 0.01, "worst errors {worst:?}");
}
