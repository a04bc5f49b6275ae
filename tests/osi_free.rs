//! Identification on models with ball and free joints and fluid forces: the q
//! residual is the tangent vector from the observed q' to the predicted one
//! (rotations as body-frame rotation vectors), its Jacobian exact (central
//! differences of the residuals agree), and LM recovers masses, a COM and a
//! damping from noise-free windows.

mod common;

use diffosi::derivatives::Transition;
use diffosi::dynamics::configuration::integrate;
use diffosi::model::{Fluid, Inputs, Integrator, ParamMap, State};
use diffosi::osi::{Identifier, Lm, Problem};
use diffosi::Model;

fn model(name: &str, edit: impl FnOnce(&mut diffosi::model::Spec)) -> Model {
    Model::load(common::model_path(&format!("reference_models/{name}.xml")))
        .unwrap()
        .edited(edit)
        .unwrap()
}

/// The free_ball model (a free box with a ball-jointed arm) under RK4 in a
/// wind, and the floating arm under Euler: every way ball and free joints
/// and fluid reach the residuals.
fn cases() -> Vec<(&'static str, Model, Vec<&'static str>)> {
    let ball = model("free_ball", |s| {
        s.opt.integrator = Integrator::Rk4;
        s.opt.fluid = Fluid {
            density: 1000.0,
            viscosity: 0.02,
            wind: [0.5, -1.0, 0.3].into(),
        };
    });
    let arm = model("floating_arm", |_| {});
    vec![
        (
            "free_ball, RK4, wind",
            ball,
            vec!["body/box/mass", "body/arm/com", "joint/swivel/damping"],
        ),
        (
            "floating_arm, Euler",
            arm,
            vec![
                "body/base/mass",
                "body/upper/mass",
                "joint/shoulder/damping",
            ],
        ),
    ]
}

/// `len` transitions of `truth` from random valid states (a step from
/// common::random_state's, which puts every quaternion back on the sphere)
/// under random forces.
fn window(truth: &Model, len: usize, seed: u64) -> Vec<Transition> {
    let mut data = truth.data();
    (0..len as u64)
        .map(|k| {
            let (q0, v, tau) = common::random_state(truth, 100 * seed + k);
            let State { q, v: _, .. } = truth
                .step(
                    &mut data,
                    &State::new(q0.to_vec(), v.to_vec()),
                    &Inputs::tau(&tau),
                )
                .unwrap();
            Transition::simulated(truth, &mut data, State::new(q, v), tau).unwrap()
        })
        .collect()
}

/// The observed q' turned by `angle` (rad) about every rotation's own axes
/// and moved along every other coordinate: large q residuals, where the
/// rotation residual's Jacobian J_r(r)^-1 departs from the identity.
fn far_from(model: &Model, window: &mut [Transition], angle: f64) {
    let shift = vec![angle; model.nv()];
    for tr in window {
        let observed = tr.next.q.clone();
        integrate(model.tree(), &observed, &shift, 1.0, &mut tr.next.q);
    }
}

fn problem(model: &Model, names: &[&str]) -> (Problem, Vec<f64>) {
    let names: Vec<String> = names.iter().map(|s| s.to_string()).collect();
    let map = ParamMap::identity(model, &names).unwrap();
    let prior: Vec<f64> = names
        .iter()
        .flat_map(|n| model.get_param(n).unwrap())
        .collect();
    let lower: Vec<f64> = prior.iter().map(|p| p - 0.5 * p.abs() - 0.1).collect();
    let upper: Vec<f64> = prior.iter().map(|p| p + 0.5 * p.abs() + 0.1).collect();
    let scale: Vec<f64> = (0..2 * model.nv())
        .map(|i| {
            if i < model.nv() {
                model.opt.timestep * 1e-3
            } else {
                1e-3
            }
        })
        .collect();
    let problem = Problem::new(model, map, &lower, &upper, &prior, &scale).unwrap();
    (problem, prior)
}

#[test]
fn the_window_jacobian_is_the_residuals_derivative() {
    for (name, model, params) in cases() {
        let (mut problem, prior) = problem(&model, &params);
        let mut observed = window(&model, 3, 1);
        far_from(&model, &mut observed, 0.4);
        let fit = problem.fit(&prior, &observed[..]).unwrap();
        let rows = fit.residuals.len();
        assert_eq!(
            rows,
            3 * 2 * model.nv(),
            "{name}: 2 nv residuals per transition"
        );
        let mut worst = 0.0f64;
        for j in 0..prior.len() {
            // large: the residuals are large (q' far off), and cancellation would dominate
            let eps = 1e-4 * prior[j].abs().max(1.0);
            let mut at = |d: f64| {
                let mut mu = prior.clone();
                mu[j] += d;
                problem.fit(&mu, &observed[..]).unwrap().residuals
            };
            let fd = (at(eps) - at(-eps)) / (2.0 * eps);
            let exact = fit.jacobian.column(j);
            let err = (&fd - exact).amax() / exact.amax().max(1e-300);
            worst = worst.max(err);
        }
        println!("{name}: window Jacobian within {worst:.1e} of central differences");
        assert!(worst < 1e-6, "{name}: {worst:e}");
    }
}

#[test]
fn lm_recovers_the_parameters_from_a_noise_free_window() {
    for (name, truth, params) in cases() {
        let (mut problem, prior) = problem(&truth, &params);
        // the truth: each parameter 20% off the prior the problem starts from
        let shifted: Vec<f64> = prior.iter().map(|p| p * 1.2 + 0.01).collect();
        let names: Vec<String> = params.iter().map(|s| s.to_string()).collect();
        let mut real = truth.clone();
        ParamMap::identity(&truth, &names)
            .unwrap()
            .apply(&mut real, &shifted)
            .unwrap();
        let observed = window(&real, 6, 2);
        let estimate = Lm::default()
            .identify(&mut problem, &observed, &prior)
            .unwrap();
        let worst = estimate
            .mu
            .iter()
            .zip(&shifted)
            .map(|(e, t)| ((e - t) / t).abs())
            .fold(0.0, f64::max);
        println!(
            "{name}: mu recovered within {worst:.1e} (relative), loss {:.1e}",
            estimate.loss
        );
        assert!(
            worst < 1e-6 && !estimate.flags.unexcited,
            "{name}: {estimate:?}"
        );
    }
}
