//! Step Jacobians of models with ball and free joints and fluid forces, in the tangent
//! space (mjd_transitionFD's layout: nv rows and columns for positions), against central
//! finite differences taken on the manifold: q moved by q (+) d, q' read as the tangent
//! of q'_+ against q'_- (mj_differentiatePos). Our free_ball model under Euler, RK4 and in
//! a wind, and gymnasium's ant as its file runs it (RK4, contacts and limits on, standing
//! on its floor), parameters included; under MuJoCo's implicitfast and implicit
//! integrators free_ball (with and without gravcomp), the lone free box (its
//! gyroscopic block) and the ant standing; the equality models of tests/data.

mod common;

use diffosi::derivatives::{
    step_jacobians, transition_jacobians, TransitionJacobians, Workspace, Wrt,
};
use diffosi::dynamics::configuration::{integrate, subtract};
use diffosi::model::{Fluid, Inputs, Integrator, PassiveMode, State};
use diffosi::Model;
use nalgebra::{DVector, Vector3};

const H: f64 = 1e-6;

/// (q', v') after one step from (q (+) dq, v + dv) under tau + dtau, with component
/// `k` of parameter `p` moved by dp.
fn stepped(
    model: &Model,
    x: (&[f64], &[f64], &[f64]),
    d: (&[f64], &[f64], &[f64]),
    p: Option<(&str, usize, f64)>,
) -> (Vec<f64>, Vec<f64>) {
    let mut model = model.clone();
    if let Some((name, k, dp)) = p {
        let mut value = model.get_param(name).unwrap();
        value[k] += dp;
        model.set_param(name, &value).unwrap();
    }
    let tree = model.tree();
    let mut q = vec![0.0; x.0.len()];
    integrate(tree, x.0, d.0, 1.0, &mut q);
    let v: Vec<f64> = x.1.iter().zip(d.1).map(|(a, b)| a + b).collect();
    let tau: Vec<f64> = x.2.iter().zip(d.2).map(|(a, b)| a + b).collect();
    let next = model.step(&mut model.data(), &State::new(q, v), &Inputs::tau(&tau));
    let State { q, v, .. } = next.unwrap();
    (q, v)
}

/// The central difference of the step along one input direction, as (dq' tangent, dv').
fn difference(
    model: &Model,
    x: (&[f64], &[f64], &[f64]),
    dir: (&[f64], &[f64], &[f64]),
    p: Option<(&str, usize)>,
) -> DVector<f64> {
    let n = model.nv();
    let scaled = |s: f64| -> (Vec<f64>, Vec<f64>, Vec<f64>) {
        let m = |a: &[f64]| a.iter().map(|x| x * s).collect::<Vec<_>>();
        (m(dir.0), m(dir.1), m(dir.2))
    };
    let (plus, minus) = (scaled(H), scaled(-H));
    let (qp, vp) = stepped(
        model,
        x,
        (&plus.0, &plus.1, &plus.2),
        p.map(|(p, k)| (p, k, H)),
    );
    let (qm, vm) = stepped(
        model,
        x,
        (&minus.0, &minus.1, &minus.2),
        p.map(|(p, k)| (p, k, -H)),
    );
    let mut dq = vec![0.0; n];
    subtract(model.tree(), &qp, &qm, &mut dq);
    DVector::from_iterator(
        2 * n,
        dq.iter()
            .chain(
                vp.iter()
                    .zip(&vm)
                    .map(|(a, b)| a - b)
                    .collect::<Vec<_>>()
                    .iter(),
            )
            .map(|x| x / (2.0 * H)),
    )
}

fn check(name: &str, model: &Model, x: (&[f64], &[f64], &[f64]), params: &[&str]) -> f64 {
    let n = model.nv();
    let ids: Vec<_> = params.iter().map(|p| model.param(p).unwrap()).collect();
    let wrt = Wrt {
        state: true,
        control: true,
        params: &ids,
    };
    let j = step_jacobians(model, &mut Workspace::new(model), x, &wrt).unwrap();
    let State { q: q1, v: v1, .. } = model
        .step(
            &mut model.data(),
            &State::new(x.0.to_vec(), x.1.to_vec()),
            &Inputs::tau(x.2),
        )
        .unwrap();
    assert!(
        j.q_next
            .iter()
            .zip(&q1)
            .chain(j.v_next.iter().zip(&v1))
            .all(|(a, b)| (a - b).abs() < 1e-12),
        "{name}: next state"
    );
    let mut worst = 0.0f64;
    let zero = vec![0.0; n];
    let mut compare = |col: DVector<f64>, ours: DVector<f64>, what: String| {
        let scale = col.amax().max(1.0);
        let err = (&col - &ours).amax() / scale;
        assert!(
            err < 1e-5,
            "{name} {what}: {err:e}\n fd {col}\n ours {ours}"
        );
        worst = worst.max(err);
    };
    // Columns of j.jacobian: q, v, tau, then the parameters.
    let ours = |c: usize| DVector::from(j.jacobian.column(c));
    for k in 0..n {
        let e: Vec<f64> = (0..n).map(|i| if i == k { 1.0 } else { 0.0 }).collect();
        compare(
            difference(model, x, (&e, &zero, &zero), None),
            ours(k),
            format!("d/dq {k}"),
        );
        compare(
            difference(model, x, (&zero, &e, &zero), None),
            ours(n + k),
            format!("d/dv {k}"),
        );
        compare(
            difference(model, x, (&zero, &zero, &e), None),
            ours(2 * n + k),
            format!("d/dtau {k}"),
        );
    }
    let components = params
        .iter()
        .flat_map(|p| (0..model.get_param(p).unwrap().len()).map(move |k| (*p, k)));
    for (c, (p, k)) in components.enumerate() {
        compare(
            difference(model, x, (&zero, &zero, &zero), Some((p, k))),
            ours(3 * n + c),
            format!("d/d {p}[{k}]"),
        );
    }
    // transition_jacobians: the same blocks in MuJoCo's layout
    let mut t = TransitionJacobians::new(model.nq(), n);
    transition_jacobians(model, &mut Workspace::new(model), x, &mut t).unwrap();
    assert_eq!(t.a.view((0, 0), (n, n)), j.dq_dq(), "{name}: A");
    assert_eq!(t.b.view((n, 0), (n, n)), j.dv_dtau(), "{name}: B");
    println!("{name}: Jacobians within {worst:.1e} of central differences on the manifold");
    worst
}

/// A state of the model: its reference turned and moved a little, moving.
fn state(model: &Model) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
    let n = model.nv();
    let tangent: Vec<f64> = (0..n).map(|i| 0.3 * (i as f64 + 1.0).sin()).collect();
    let mut q = vec![0.0; model.nq()];
    integrate(model.tree(), &model.reference_q(), &tangent, 1.0, &mut q);
    let v = (0..n).map(|i| (i as f64 + 2.0).cos()).collect();
    let tau = (0..n).map(|i| 0.5 * (i as f64 + 3.0).sin()).collect();
    (q, v, tau)
}

fn free_ball(integrator: Integrator, fluid: Fluid) -> Model {
    Model::load(common::model_path("reference_models/free_ball.xml"))
        .unwrap()
        .edited(|s| {
            s.opt.integrator = integrator;
            s.opt.passive = if integrator == Integrator::Euler {
                PassiveMode::ImplicitDamping
            } else {
                PassiveMode::Explicit
            };
            s.opt.fluid = fluid;
        })
        .unwrap()
}

#[test]
fn free_and_ball_jacobians_match_manifold_differences() {
    let wind = Fluid {
        density: 1000.0,
        viscosity: 0.02,
        wind: Vector3::new(0.5, -1.0, 0.3),
    };
    let params = [
        "body/box/mass",
        "body/arm/com",
        "joint/shoulder/damping",
        "joint/shoulder/stiffness",
    ];
    for (name, model) in [
        (
            "free_ball Euler",
            free_ball(Integrator::Euler, Fluid::default()),
        ),
        (
            "free_ball RK4",
            free_ball(Integrator::Rk4, Fluid::default()),
        ),
        ("free_ball RK4 in a wind", free_ball(Integrator::Rk4, wind)),
    ] {
        let (q, v, tau) = state(&model);
        check(name, &model, (&q, &v, &tau), &params);
    }
}

#[test]
fn implicit_integrators_jacobians_match_manifold_differences() {
    let params = [
        "body/box/mass",
        "body/arm/com",
        "joint/shoulder/damping",
        "joint/elbow/damping",
    ];
    for integrator in [Integrator::ImplicitFast, Integrator::Implicit] {
        let ball = free_ball(integrator, Fluid::default());
        let compensated = ball
            .edited(|s| {
                s.bodies[2].gravcomp = 0.6;
                s.bodies[4].gravcomp = 1.0;
            })
            .unwrap();
        let lone_box = Model::load(common::model_path("reference_models/free_box.xml"))
            .unwrap()
            .edited(|s| s.opt.integrator = integrator)
            .unwrap();
        for (name, model, params) in [
            (format!("free_ball {integrator:?}"), ball, &params[..]),
            (
                format!("free_ball {integrator:?} with gravcomp"),
                compensated,
                &params[..],
            ),
            (
                format!("free_box {integrator:?} in the air"),
                lone_box,
                &["body/box/inertia"][..],
            ),
        ] {
            let (q, v, tau) = state(&model);
            check(&name, &model, (&q, &v, &tau), params);
        }
        standing_ant(integrator);
    }
}

/// Equality rows (dual numbers through them, exact): a four-bar closed by a
/// connect, welds and a site connect on free and ball joints, joint
/// couplings; Euler and RK4, body and joint parameters included.
#[test]
fn equality_jacobians_match_manifold_differences() {
    for (file, params) in [
        ("equality_fourbar", ["body/coupler/mass", "joint/a/damping"]),
        (
            "equality_weld",
            ["body/tool/mass", "joint/shoulder/damping"],
        ),
        ("equality_joint", ["body/l2/com", "joint/h1/damping"]),
    ] {
        for integrator in [Integrator::Euler, Integrator::Rk4] {
            let model = Model::load(common::model_path(&format!("tests/data/{file}.xml")))
                .unwrap()
                .edited(|s| s.opt.integrator = integrator)
                .unwrap();
            let (q, v, tau) = state(&model);
            check(
                &format!("{file} {integrator:?}"),
                &model,
                (&q, &v, &tau),
                &params,
            );
        }
    }
}

#[test]
fn the_ants_jacobians_in_contact_match_manifold_differences() {
    standing_ant(Integrator::Rk4);
}

/// The ant standing on its floor under `integrator` (its file's RK4, or
/// another), its Jacobians checked.
fn standing_ant(integrator: Integrator) {
    let model = Model::load(common::model_path("gymnasium:ant.xml"))
        .unwrap()
        .edited(|s| s.opt.integrator = integrator)
        .unwrap();
    // standing on its floor: 100 steps from its reference pose
    let mut data = model.data();
    let (mut q, mut v) = (model.reference_q(), vec![0.0; model.nv()]);
    let tau = vec![0.0; model.nv()];
    for _ in 0..100 {
        State { q, v, .. } = model
            .step(&mut data, &State::new(q, v), &Inputs::tau(&tau))
            .unwrap();
    }
    assert!(
        !model
            .contacts(
                &mut data,
                &State::new(q.to_vec(), v.to_vec()),
                &Inputs::tau(&tau)
            )
            .unwrap()
            .is_empty(),
        "the ant stands"
    );
    let tau: Vec<f64> = (0..model.nv()).map(|i| (i as f64).sin()).collect();
    check(
        &format!("ant ({integrator:?}, in contact)"),
        &model,
        (&q, &v, &tau),
        &["body/torso/mass"],
    );
}
