//! The identification loss over a window of transitions: zero at the true
//! parameters, exact gradient, the same rows as the step and its Jacobians
//! on random trees, and Gauss-Newton on its residual Jacobian finds the
//! cartpole's COM offset.

mod common;

use diffosi::derivatives::{
    step_jacobians, window_residuals, window_residuals_into, Transition, WindowFit, Workspace, Wrt,
};
use diffosi::model::{Inputs, Integrator, MapEntry, Param, ParamMap, PassiveMode, State};
use diffosi::Model;
use nalgebra::{DMatrix, DVector};

fn cartpole() -> (Model, ParamMap) {
    common::cartpole_with_mu()
}

/// Transitions of the true system (mu) from random states and forces.
fn window(model: &Model, map: &ParamMap, mu: f64, len: usize) -> Vec<Transition> {
    let mut truth = model.clone();
    map.apply(&mut truth, &[mu]).unwrap();
    let mut r = common::rng(3);
    (0..len)
        .map(|_| {
            let q = vec![
                common::uniform(&mut r, -1.0, 1.0),
                common::uniform(&mut r, -0.5, 0.5),
            ];
            let v = vec![
                common::uniform(&mut r, -1.0, 1.0),
                common::uniform(&mut r, -2.0, 2.0),
            ];
            let tau = vec![common::uniform(&mut r, -10.0, 10.0), 0.0];
            Transition::simulated(&truth, &mut truth.data(), State::new(q, v), tau).unwrap()
        })
        .collect()
}

const SCALE: [f64; 4] = [1e-3, 1e-3, 1e-2, 1e-2];

#[test]
fn loss_vanishes_at_the_true_parameters_only() {
    let (mut model, map) = cartpole();
    let data = window(&model, &map, 0.3, 5);
    let mut ws = Workspace::new(&model);
    let at_truth = window_residuals(&mut model, &mut ws, &map, &[0.3], &data, &SCALE).unwrap();
    assert!(
        at_truth.residuals.amax() < 1e-12,
        "{}",
        at_truth.residuals.amax()
    );
    let away = window_residuals(&mut model, &mut ws, &map, &[0.0], &data, &SCALE).unwrap();
    assert!(away.loss > 1e-3, "{}", away.loss);
    assert_eq!(away.residuals.len(), 5 * 4);
}

#[test]
fn gradient_matches_finite_differences() {
    let (mut model, map) = cartpole();
    let data = window(&model, &map, -0.4, 3);
    let mut ws = Workspace::new(&model);
    for mu in [-0.5, 0.0, 0.2] {
        let fit = window_residuals(&mut model, &mut ws, &map, &[mu], &data, &SCALE).unwrap();
        let eps = 1e-6;
        let mut loss = |m: f64| {
            window_residuals(&mut model, &mut ws, &map, &[m], &data, &SCALE)
                .unwrap()
                .loss
        };
        let fd = (loss(mu + eps) - loss(mu - eps)) / (2.0 * eps);
        assert!(
            (fit.gradient[0] - fd).abs() < 1e-6 * (1.0 + fd.abs()),
            "mu {mu}: {} vs {fd}",
            fit.gradient[0]
        );
        // The gradient is 2 J^T r.
        assert!(
            (fit.gradient[0] - 2.0 * fit.jacobian.column(0).dot(&fit.residuals)).abs()
                < 1e-12 * (1.0 + fd.abs())
        );
    }
}

/// A map of two mu onto every body and joint parameter of `model`, with
/// seeded gains in [0, 1e-3] (several scalars per column; non-negative,
/// so zero damping or armature stays physical at positive mu).
fn every_parameter(model: &Model, seed: u64) -> ParamMap {
    let mut r = common::rng(seed);
    let params = Param::all(model);
    let values: Vec<(String, Vec<f64>, Vec<[f64; 2]>)> = params
        .iter()
        .map(|p| {
            let gains = (0..p.size())
                .map(|_| [0, 1].map(|_| common::uniform(&mut r, 0.0, 1e-3)))
                .collect();
            (p.name(model), p.get(model), gains)
        })
        .collect();
    let rows: Vec<Vec<&[f64]>> = values
        .iter()
        .map(|(_, _, g)| g.iter().map(|row| &row[..]).collect())
        .collect();
    let entries: Vec<MapEntry> = values
        .iter()
        .zip(&rows)
        .map(|((name, offset, _), gain)| MapEntry { name, offset, gain })
        .collect();
    ParamMap::new(model, 2, &entries).unwrap()
}

/// Evaluates the window and asserts that its residuals equal the model's
/// steps and its Jacobian rows the step Jacobians of the map's parameters
/// times its gains (to 1e-12 relative); returns the fit.
fn assert_rows_match(
    model: &mut Model,
    ws: &mut Workspace,
    (map, mu): (&ParamMap, &[f64]),
    (window, scale): (&[Transition], &[f64]),
) -> WindowFit {
    let n = model.nv();
    let fit = window_residuals(model, ws, map, mu, window, scale).unwrap();
    // The evaluation edited the model in place: its tree is the one a
    // rebuild from the edited description gives, bit for bit.
    let rebuilt = Model::from_spec((**model).clone()).unwrap();
    assert_eq!(model.tree(), rebuilt.tree(), "tree rebuilt");
    // The same rows from the model's step and the step Jacobians of
    // every parameter, times the map's gains.
    let params = map.params();
    let wrt = Wrt {
        params: &params,
        ..Wrt::default()
    };
    let gains = map.jacobian();
    let mut worst = (0.0f64, 0.0f64);
    for (t, tr) in window.iter().enumerate() {
        let j = step_jacobians(
            model,
            &mut Workspace::new(model),
            (&tr.start.q, &tr.start.v, &tr.tau),
            &wrt,
        )
        .unwrap();
        let State {
            q: q_next,
            v: v_next,
            ..
        } = model
            .step(&mut model.data(), &tr.start, &Inputs::tau(&tr.tau))
            .unwrap();
        let predicted = q_next.iter().chain(&v_next);
        let observed = tr.next.q.iter().chain(&tr.next.v);
        let expected = DMatrix::from_fn(2 * n, map.nmu, |i, c| {
            let block = if i < n { j.dq_dp() } else { j.dv_dp() };
            (block.row(i % n) * gains.column(c))[0] / scale[i]
        });
        let rows = fit.jacobian.rows(2 * n * t, 2 * n);
        let size = expected.amax().max(1e-300);
        worst.1 = worst.1.max((rows - &expected).amax() / size);
        for (i, (p, o)) in predicted.zip(observed).enumerate() {
            let r = fit.residuals[2 * n * t + i];
            worst.0 = worst.0.max((r - (p - o) / scale[i]).abs());
        }
    }
    println!(
        "residuals {:.1e}, Jacobian {:.1e} (relative)",
        worst.0, worst.1
    );
    // The residuals come from the same articulated-body pass as the step.
    assert!(worst.0 == 0.0 && worst.1 < 1e-12, "{worst:?}");
    fit
}

#[test]
fn rows_match_the_step_and_its_parameter_jacobians() {
    let settings = [
        (Integrator::Euler, PassiveMode::Explicit),
        (Integrator::Euler, PassiveMode::ImplicitDamping),
        (Integrator::Euler, PassiveMode::ImplicitDampingStiffness),
        (Integrator::Rk4, PassiveMode::Explicit),
    ];
    for seed in 0..8u64 {
        let (integrator, passive) = settings[seed as usize % 4];
        let mut model = common::random_model(seed, 3 + seed as usize % 3, passive, integrator);
        let map = every_parameter(&model, seed);
        let mu = [0.3, 0.2];
        let mut truth = model.clone();
        map.apply(&mut truth, &mu).unwrap();
        let n = model.nv();
        let scale: Vec<f64> = (0..2 * n).map(|i| 1e-3 * (1.0 + i as f64)).collect();
        let window: Vec<Transition> = (0..3)
            .map(|k| {
                let (q, v, tau) = common::random_state(&model, 100 * seed + k);
                let start = State::new(q, v);
                let pushed: Vec<f64> = tau.iter().map(|t| t + 0.1).collect();
                let u = Inputs::tau(&pushed);
                let next = truth.step(&mut truth.data(), &start, &u).unwrap();
                Transition { start, tau, next }
            })
            .collect();
        let mut ws = Workspace::new(&model);
        let fit = assert_rows_match(&mut model, &mut ws, (&map, &mu), (&window, &scale));
        println!("seed {seed} {integrator:?} {passive:?}");
        // Residuals only: the same residuals and loss, no Jacobian columns.
        let mut only = WindowFit::empty();
        window_residuals_into(
            &mut model,
            &mut ws,
            (&map, &mu),
            (&window, &scale),
            false,
            &mut only,
        )
        .unwrap();
        assert_eq!(
            (only.residuals.clone(), only.loss),
            (fit.residuals.clone(), fit.loss)
        );
        assert_eq!((only.jacobian.ncols(), only.gradient.len()), (0, 0));
    }
}

#[test]
fn gauss_newton_on_the_residual_jacobian_finds_mu() {
    let (mut model, map) = cartpole();
    let data = window(&model, &map, 0.45, 2);
    let mut ws = Workspace::new(&model);
    let mut mu = DVector::from_element(1, 0.0);
    for _ in 0..6 {
        let fit =
            window_residuals(&mut model, &mut ws, &map, mu.as_slice(), &data, &SCALE).unwrap();
        let jtj = fit.jacobian.tr_mul(&fit.jacobian);
        mu -= jtj
            .cholesky()
            .unwrap()
            .solve(&fit.jacobian.tr_mul(&fit.residuals));
    }
    assert!(
        (mu[0] - 0.45).abs() < 1e-9,
        "Gauss-Newton reached {}",
        mu[0]
    );
}

#[test]
fn bad_windows_are_clear_errors() {
    let (mut model, map) = cartpole();
    let mut data = window(&model, &map, 0.1, 3);
    let mut ws = Workspace::new(&model);
    data[1].next.v[0] = f64::NAN;
    let err = window_residuals(&mut model, &mut ws, &map, &[0.0], &data, &SCALE).unwrap_err();
    assert_eq!(
        err.to_string(),
        "transition 1: v_next[0] = NaN is not finite"
    );
    data[1].next.v = vec![0.0];
    let err = window_residuals(&mut model, &mut ws, &map, &[0.0], &data, &SCALE).unwrap_err();
    assert_eq!(
        err.to_string(),
        "transition 1: v_next has length 1, expected 2"
    );
    let err =
        window_residuals(&mut model, &mut ws, &map, &[0.0], &data[..1], &[1.0; 3]).unwrap_err();
    assert_eq!(err.to_string(), "scale must hold 2 nv = 4 positive values");
    let err = window_residuals(
        &mut model,
        &mut ws,
        &map,
        &[f64::INFINITY],
        &data[..1],
        &SCALE,
    )
    .unwrap_err();
    assert_eq!(err.to_string(), "mu value inf is not finite");
}

/// With contact (the half cheetah's feet in its floor): a map onto the torso
/// mass takes the articulated-body path, one that also moves contact
/// parameters goes through step_jacobians; both give the step's rows.
#[test]
fn rows_match_through_contact() {
    let mut model = common::smooth(
        Model::load(common::model_path("reference_models/half_cheetah.xml")).unwrap(),
    );
    let n = model.nv();
    let scale: Vec<f64> = (0..2 * n).map(|i| 1e-3 * (1.0 + i as f64)).collect();
    let one = [1.0];
    let torso = MapEntry {
        name: "body/torso/mass",
        offset: &[6.25],
        gain: &[&one],
    };
    let stiffness = MapEntry {
        name: "contact/stiffness",
        offset: &[1e4],
        gain: &[&[1e3, 0.0]],
    };
    let friction = MapEntry {
        name: "contact/friction",
        offset: &[0.8],
        gain: &[&[0.0, 0.1]],
    };
    let mass_only = ParamMap::new(&model, 1, &[torso]).unwrap();
    let two = [1.0, 0.0];
    let torso2 = MapEntry {
        gain: &[&two],
        ..torso
    };
    let with_contact = ParamMap::new(&model, 2, &[torso2, stiffness, friction]).unwrap();
    for (map, mu) in [(mass_only, vec![0.5]), (with_contact, vec![0.5, 1.0])] {
        let mut truth = model.clone();
        map.apply(&mut truth, &mu).unwrap();
        let window: Vec<Transition> = (0..3)
            .map(|k| {
                let (mut q, v, tau) = common::random_state(&model, 40 + k);
                q[1] = -0.15; // the feet in the floor
                let next = truth
                    .step(
                        &mut truth.data(),
                        &State::new(q.clone(), v.clone()),
                        &Inputs::tau(&tau),
                    )
                    .unwrap();
                let (q_next, v_next) = (next.q, next.v);
                Transition {
                    start: State::new(q, v),
                    tau,
                    next: State::new(q_next, v_next),
                }
            })
            .collect();
        let contacts = model
            .contacts(
                &mut model.data(),
                &State::new(window[0].start.q.to_vec(), window[0].start.v.to_vec()),
                &Inputs::tau(&vec![0.0; window[0].start.v.len()]),
            )
            .unwrap();
        assert!(contacts.iter().any(|c| c.dist < 0.0));
        let mut ws = Workspace::new(&model);
        let fit = assert_rows_match(&mut model, &mut ws, (&map, &mu), (&window, &scale));
        assert!(
            fit.loss == 0.0 || fit.loss < 1e-20,
            "true mu: loss {}",
            fit.loss
        );
        assert!(fit.jacobian.amax() > 0.0);
    }
}
