//! Step Jacobians against central finite differences of the step, and against
//! dual numbers pushed through the whole step, on the reference models and on
//! random trees, for every passive mode and both integrators.

mod common;

use diffosi::derivatives::{step_jacobians, StepJacobians, Workspace, Wrt};
use diffosi::dynamics::{step, Data, Tree};
use diffosi::model::{Inputs, Integrator, Param, PassiveMode, State};
use diffosi::Model;
use nalgebra::{DMatrix, DMatrixView};
use num_dual::Dual64;

const SETTINGS: [(Integrator, PassiveMode); 4] = [
    (Integrator::Euler, PassiveMode::Explicit),
    (Integrator::Euler, PassiveMode::ImplicitDamping),
    (Integrator::Euler, PassiveMode::ImplicitDampingStiffness),
    (Integrator::Rk4, PassiveMode::Explicit),
];

/// The model under the smooth contact model. It has no force law for the
/// half cheetah URDF twin's box floor against its cylinders and spheres
/// (a step with them within reach is refused), so the twin runs with its
/// contacts off: the same step as when the smooth model dropped those pairs.
fn load(name: &str) -> Model {
    let model = common::smooth(
        Model::load(common::model_path(&format!("reference_models/{name}"))).unwrap(),
    );
    if name != "half_cheetah.urdf" {
        return model;
    }
    model.edited(|s| s.opt.contact = false).unwrap()
}

fn with_settings(model: &Model, (integrator, passive): (Integrator, PassiveMode)) -> Model {
    model
        .edited(|s| {
            s.opt.integrator = integrator;
            s.opt.passive = passive;
        })
        .unwrap()
}

/// Max |a - b| over the block, relative to 1 + max |b|.
fn block_error(a: DMatrixView<f64>, b: DMatrixView<f64>) -> f64 {
    assert_eq!(a.shape(), b.shape());
    (a - b).amax() / (1.0 + b.amax())
}

/// Central differences of (q', v') along each input direction: columns of
/// q, v, tau, then each parameter scalar.
fn finite_differences(
    model: &Model,
    (q, v, tau): (&[f64], &[f64], &[f64]),
    params: &[Param],
) -> (DMatrix<f64>, DMatrix<f64>) {
    let n = model.nv();
    let n_p: usize = params.iter().map(|p| p.size()).sum();
    let mut dq = DMatrix::zeros(n, 3 * n + n_p);
    let mut dv = DMatrix::zeros(n, 3 * n + n_p);
    // Central differences; one-sided second-order ones (-3 f0 + 4 f1 - f2) / 2e
    // where the parameter sits on its lower bound 0.
    let mut column =
        |col: usize, eps: f64, one_sided: bool, f: &dyn Fn(f64) -> (Vec<f64>, Vec<f64>)| {
            let ((q1, v1), (q2, v2), w) = if one_sided {
                let (q0, v0) = f(0.0);
                let (qa, va) = f(eps);
                let (qb, vb) = f(2.0 * eps);
                let combine = |a: &[f64], b: &[f64], z: &[f64]| -> Vec<f64> {
                    (0..n).map(|i| 4.0 * a[i] - b[i] - 3.0 * z[i]).collect()
                };
                (
                    (combine(&qa, &qb, &q0), combine(&va, &vb, &v0)),
                    (vec![0.0; n], vec![0.0; n]),
                    2.0 * eps,
                )
            } else {
                (f(eps), f(-eps), 2.0 * eps)
            };
            for i in 0..n {
                dq[(i, col)] = (q1[i] - q2[i]) / w;
                dv[(i, col)] = (v1[i] - v2[i]) / w;
            }
        };
    let stepped = |m: &Model, q: &[f64], v: &[f64], tau: &[f64]| {
        let x = State::new(q.to_vec(), v.to_vec());
        let State { q, v, .. } = m.step(&mut m.data(), &x, &Inputs::tau(tau)).unwrap();
        (q, v)
    };
    for k in 0..3 * n {
        let shifted = |e: f64| {
            let mut x = [q.to_vec(), v.to_vec(), tau.to_vec()];
            x[k / n][k % n] += e;
            stepped(model, &x[0], &x[1], &x[2])
        };
        column(k, 1e-6, false, &shifted);
    }
    let mut col = 3 * n;
    for p in params {
        let base = p.get(model);
        for c in 0..p.size() {
            let eps = 1e-6 * base[c].abs().max(1e-2);
            let shifted = |e: f64| {
                let mut value = base.clone();
                value[c] += e;
                let mut m = model.clone();
                m.set(&[(*p, &value)]).unwrap();
                stepped(&m, q, v, tau)
            };
            let at_bound = !matches!(p, Param::Com(_) | Param::Inertia(_)) && base[c] < eps;
            column(col, eps, at_bound, &shifted);
            col += 1;
        }
    }
    (dq, dv)
}

fn all_blocks(
    j: &StepJacobians,
) -> [(&'static str, DMatrixView<'_, f64>, DMatrixView<'_, f64>); 4] {
    [
        ("d(q,v)/dq", j.dq_dq(), j.dv_dq()),
        ("d(q,v)/dv", j.dq_dv(), j.dv_dv()),
        ("d(q,v)/dtau", j.dq_dtau(), j.dv_dtau()),
        ("d(q,v)/dp", j.dq_dp(), j.dv_dp()),
    ]
}

/// Every parameter, but those of massless bodies (URDF helper links), whose
/// zero inertia cannot be perturbed both ways and stay physical.
fn perturbable(model: &Model) -> Vec<Param> {
    let massless = |b: usize| model.bodies[b].mass == 0.0;
    Param::all(model)
        .into_iter()
        .filter(
            |p| !matches!(*p, Param::Mass(b) | Param::Com(b) | Param::Inertia(b) if massless(b)),
        )
        .collect()
}

fn check_against_fd(model: &Model, seed: u64, label: &str) {
    check_state_against_fd(model, common::random_state(model, seed), label);
}

/// Every Jacobian block at (q, v, tau) against central differences.
fn check_state_against_fd(model: &Model, (q, v, tau): (Vec<f64>, Vec<f64>, Vec<f64>), label: &str) {
    let params = perturbable(model);
    let mut ws = Workspace::new(model);
    let wrt = Wrt {
        state: true,
        control: true,
        params: &params,
    };
    let j = step_jacobians(model, &mut ws, (&q, &v, &tau), &wrt).unwrap();
    let next = model
        .step(
            &mut model.data(),
            &State::new(q.clone(), v.clone()),
            &Inputs::tau(&tau),
        )
        .unwrap();
    let (plain_q, plain_v) = (next.q, next.v);
    assert_eq!(
        (&j.q_next, &j.v_next),
        (&plain_q, &plain_v),
        "{label}: values differ from step"
    );
    let (fq, fv) = finite_differences(model, (&q, &v, &tau), &params);
    let n = model.nv();
    for (k, (name, aq, av)) in all_blocks(&j).into_iter().enumerate() {
        let cols = if k < 3 {
            (k * n, n)
        } else {
            (3 * n, fq.ncols() - 3 * n)
        };
        let eq = block_error(aq, fq.columns(cols.0, cols.1));
        let ev = block_error(av, fv.columns(cols.0, cols.1));
        assert!(
            eq < 1e-6 && ev < 1e-6,
            "{label}: {name} differs from FD by {eq:e} (q'), {ev:e} (v')"
        );
    }
}

#[test]
fn jacobians_match_finite_differences_on_reference_models() {
    for name in [
        "pendulum.xml",
        "double_pendulum.xml",
        "cartpole.xml",
        "half_cheetah.xml",
        "half_cheetah.urdf",
    ] {
        let base = load(name);
        for settings in SETTINGS {
            let model = with_settings(&base, settings);
            for seed in 0..3 {
                check_against_fd(&model, seed, &format!("{name} {settings:?} seed {seed}"));
            }
        }
    }
}

#[test]
fn jacobians_match_finite_differences_on_random_trees() {
    for seed in 0..8 {
        let settings = SETTINGS[seed as usize % 4];
        let model = common::random_model(seed, 3 + seed as usize % 4, settings.1, settings.0);
        check_against_fd(&model, seed, &format!("random tree {seed} {settings:?}"));
    }
}

/// The whole step in dual numbers, one seeded direction at a time: an
/// independent exact oracle (no truncation error), so agreement is ~1e-12.
#[test]
fn jacobians_match_dual_numbers_through_the_step() {
    for name in ["double_pendulum.xml", "half_cheetah.xml"] {
        let base = load(name);
        for settings in SETTINGS {
            let model = with_settings(&base, settings);
            let n = model.nv();
            let params = Param::all(&model);
            let (q, v, tau) = common::random_state(&model, 9);
            let wrt = Wrt {
                state: true,
                control: true,
                params: &params,
            };
            let j =
                step_jacobians(&model, &mut Workspace::new(&model), (&q, &v, &tau), &wrt).unwrap();
            // Columns q, v, tau, p: all of them.
            let analytic_q = j.jacobian.rows(0, n);
            let analytic_v = j.jacobian.rows(n, n);
            let plain: Tree<Dual64> = Tree::build(&model);
            let mut data = Data::new(&plain);
            let run = |tree: &Tree<Dual64>, data: &mut Data<Dual64>, seed_input: Option<usize>| {
                let lift = |x: &[f64], offset: usize| -> Vec<Dual64> {
                    x.iter()
                        .enumerate()
                        .map(|(i, &xi)| {
                            Dual64::new(
                                xi,
                                if seed_input == Some(offset + i) {
                                    1.0
                                } else {
                                    0.0
                                },
                            )
                        })
                        .collect()
                };
                let (qd, vd, td) = (lift(&q, 0), lift(&v, n), lift(&tau, 2 * n));
                let (mut q1, mut v1) = (vec![Dual64::from(0.0); n], vec![Dual64::from(0.0); n]);
                step(tree, data, (&qd, &vd, &td), (&mut q1, &mut v1)).unwrap();
                (
                    q1.iter().map(|x| x.eps).collect::<Vec<_>>(),
                    v1.iter().map(|x| x.eps).collect::<Vec<_>>(),
                )
            };
            let mut col = 0;
            let check = |(dq, dv): (Vec<f64>, Vec<f64>), col: usize| {
                for i in 0..n {
                    let (a, b) = (analytic_q[(i, col)], dq[i]);
                    assert!(
                        (a - b).abs() < 1e-10 * (1.0 + b.abs()),
                        "{name} {settings:?}: dq'[{i}]/dx[{col}] {a} vs dual {b}"
                    );
                    let (a, b) = (analytic_v[(i, col)], dv[i]);
                    assert!(
                        (a - b).abs() < 1e-10 * (1.0 + b.abs()),
                        "{name} {settings:?}: dv'[{i}]/dx[{col}] {a} vs dual {b}"
                    );
                }
            };
            for k in 0..3 * n {
                check(run(&plain, &mut data, Some(k)), k);
            }
            col += 3 * n;
            for &p in &params {
                for c in 0..p.size() {
                    let seeded = Tree::<Dual64>::build_with(&model, |pp, cc, x| {
                        Dual64::new(x, if (pp, cc) == (p, c) { 1.0 } else { 0.0 })
                    });
                    check(run(&seeded, &mut data, None), col);
                    col += 1;
                }
            }
        }
    }
}

#[test]
fn only_requested_blocks_are_computed() {
    let model = load("cartpole.xml");
    let p = [model.param("body/pole/com").unwrap()];
    let wrt = Wrt {
        params: &p,
        ..Wrt::default()
    };
    let j = step_jacobians(
        &model,
        &mut Workspace::new(&model),
        (&[0.0, 0.1], &[0.2, -0.3], &[1.0, 0.0]),
        &wrt,
    )
    .unwrap();
    assert_eq!(j.dq_dq().shape(), (2, 0));
    assert_eq!(j.dv_dtau().shape(), (2, 0));
    assert_eq!(j.dv_dp().shape(), (2, 3));
}

#[test]
fn a_workspace_follows_the_model_it_is_used_with() {
    let (cartpole, cheetah) = (load("cartpole.xml"), load("half_cheetah.xml"));
    let mut ws = Workspace::new(&cartpole);
    let wrt = Wrt {
        state: true,
        ..Wrt::default()
    };
    let (q, v, tau) = common::random_state(&cheetah, 1);
    let shared = step_jacobians(&cheetah, &mut ws, (&q, &v, &tau), &wrt).unwrap();
    let own = step_jacobians(
        &cheetah,
        &mut Workspace::new(&cheetah),
        (&q, &v, &tau),
        &wrt,
    )
    .unwrap();
    assert_eq!(shared, own);
}

/// A random state of `model` (velocities in [-1, 1]) with its root joint
/// `height` moved so that the deepest contact is `depth` deep (negative: that
/// far above the floor).
fn at_depth(model: &Model, seed: u64, height: usize, depth: f64) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
    let (mut q, v, tau) = common::random_state(model, seed);
    q[height] = 0.0;
    let contacts = model
        .contacts(
            &mut model.data(),
            &State::new(q.to_vec(), v.to_vec()),
            &Inputs::tau(&vec![0.0; v.len()]),
        )
        .unwrap();
    let deepest = contacts.iter().map(|c| -c.dist).fold(f64::MIN, f64::max);
    // Contacts beyond the cutoff are not listed: start from a touching pose.
    assert!(deepest > -0.02, "seed {seed}: no contact to move from");
    q[height] += deepest - depth;
    (q, v, tau)
}

/// Jacobians through contact (state, control, every parameter including
/// contact/stiffness, damping, friction) against central differences, in
/// contact (5 mm and 0.5 mm deep) and out of it (2 cm above), for a sphere, a
/// box and the half cheetah on its floor. Soft forces are smooth everywhere
/// but at the 30-width cutoff, which these states stay away from.
#[test]
fn jacobians_through_contact_match_finite_differences() {
    let sphere = common::dropped(r#"type="sphere" size="0.1""#, 1.5, 0.0);
    let boxed = common::dropped(r#"type="box" size="0.2 0.15 0.1""#, 1.5, 0.0);
    let cheetah = load("half_cheetah.xml");
    let (mut touching, mut apart) = (0, 0);
    for (name, model, height) in [
        ("sphere", &sphere, 2),
        ("box", &boxed, 2),
        ("cheetah", &cheetah, 1),
    ] {
        // Start each from a pose whose lowest point touches the floor.
        let model = &model
            .edited(|s| {
                let b = s
                    .bodies
                    .iter()
                    .position(|b| b.name == "thing" || b.name == "torso");
                s.bodies[b.unwrap()].pos.z = if name == "cheetah" { 0.55 } else { 0.1 };
            })
            .unwrap();
        for (seed, depth) in [(0, 0.005), (1, 0.0005), (2, -0.02)] {
            let state = at_depth(model, seed, height, depth);
            let contacts = model
                .contacts(
                    &mut model.data(),
                    &State::new(state.0.to_vec(), state.1.to_vec()),
                    &Inputs::tau(&vec![0.0; state.1.len()]),
                )
                .unwrap();
            let deepest = contacts.iter().map(|c| -c.dist).fold(f64::MIN, f64::max);
            assert!(
                (deepest - depth).abs() < 1e-9,
                "{name} seed {seed}: {deepest}"
            );
            if depth > 0.0 {
                touching += 1
            } else {
                apart += 1
            }
            check_state_against_fd(model, state, &format!("{name} seed {seed} depth {depth}"));
        }
    }
    assert_eq!((touching, apart), (6, 3));
}

/// Jacobians through sphere-capsule and capsule-capsule contact against
/// central differences: the bar turning on its hinge, the thing free, both
/// tilted and moving a little (random slides within 2 mm, hinges within
/// 0.03 rad, v in [-1, 1]), 5 mm deep and 1 cm apart; a capsule crossing the bar, a sphere
/// against its side and one beyond its end (the clamped closest point). Away
/// from the non-smooth set of [`diffosi::dynamics::contact`].
#[test]
fn jacobians_through_capsule_contact_match_finite_differences() {
    let capsule = r#"type="capsule" size="0.05 0.2" axisangle="0 1 0 90""#;
    let sphere = r#"type="sphere" size="0.1""#;
    // (shape, centre at touching distance, the direction it moves away in)
    let cases = [
        (capsule, [0.03, 0.05, 0.2], [0.0, 0.0, -1.0]),
        (sphere, [0.0, 0.05, 0.15], [0.0, 0.0, -1.0]),
        (sphere, [0.0, 0.35, 0.3], [0.0, 1.0, 0.0]),
    ];
    for (k, (shape, touching, away)) in cases.into_iter().enumerate() {
        for (seed, gap) in [(0, -0.005), (1, 0.01)] {
            let at = [0, 1, 2].map(|i| touching[i] + gap * away[i]);
            let model = common::crossing(shape, at);
            let (q, v, tau) = common::random_state(&model, seed);
            // Slides (joints 1-3) within 2 mm, hinges within 0.03 rad.
            let scale = |i: usize| if (1..=3).contains(&i) { 0.002 } else { 0.03 };
            let q: Vec<f64> = q.iter().enumerate().map(|(i, x)| scale(i) * x).collect();
            let contacts = model
                .contacts(
                    &mut model.data(),
                    &State::new(q.to_vec(), v.to_vec()),
                    &Inputs::tau(&vec![0.0; v.len()]),
                )
                .unwrap();
            let [c] = &contacts[..] else {
                panic!("case {k}: one contact, got {}", contacts.len())
            };
            assert_eq!(c.dist < 0.0, gap < 0.0, "case {k}: depth {}", -c.dist);
            let label = format!("case {k} seed {seed} depth {}", -c.dist);
            check_state_against_fd(&model, (q, v, tau), &label);
        }
    }
}

/// Through the constraint model (MuJoCo's contact, the MJCF default): every
/// block, parameters included, against central differences at states in
/// contact and at limits reached by letting each model settle, under Euler
/// (the half cheetah, both feature models) and RK4 (gymnasium's hopper).
#[test]
fn jacobians_through_constraint_contact_match_finite_differences() {
    let cases = [
        ("reference_models/half_cheetah.xml", 150),
        ("tests/data/contact_features_pyramidal.xml", 120),
        ("tests/data/contact_features_elliptic.xml", 120),
        ("gymnasium:hopper.xml", 300),
    ];
    for (file, steps) in cases {
        let model = Model::load(common::model_path(file)).unwrap();
        let n = model.nv();
        let mut data = model.data();
        let (mut q, mut v) = (model.reference_q(), vec![0.0; n]);
        let tau = vec![0.0; n];
        for _ in 0..steps {
            State { q, v, .. } = model
                .step(&mut data, &State::new(q, v), &Inputs::tau(&tau))
                .unwrap();
        }
        let touching = model
            .contacts(
                &mut data,
                &State::new(q.to_vec(), v.to_vec()),
                &Inputs::tau(&tau),
            )
            .unwrap();
        assert!(!touching.is_empty(), "{file}: not in contact");
        check_state_against_fd(&model, (q, v, tau), file);
    }
}
