//! The identification loss over a window of transitions: zero at the true
//! parameters, exact gradient, and Gauss-Newton on its residual Jacobian finds
//! the cartpole's COM offset.

mod common;

use diffosi::derivatives::{window_residuals, Transition, Workspace};
use diffosi::model::{Model, ParamMap};
use nalgebra::DVector;

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
            let (q_next, v_next) = truth.step(&mut truth.data(), &q, &v, &tau).unwrap();
            Transition {
                q,
                v,
                tau,
                q_next,
                v_next,
            }
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
    data[1].v_next[0] = f64::NAN;
    let err = window_residuals(&mut model, &mut ws, &map, &[0.0], &data, &SCALE).unwrap_err();
    assert_eq!(err.to_string(), "transition 1: v_next is not finite");
    data[1].v_next = vec![0.0];
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
