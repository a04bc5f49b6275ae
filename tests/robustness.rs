//! Bad input at the Rust API and CLI boundaries (issue 10), and the
//! regression tests of what the fuzzers found (fuzz/, tests/fuzz_smoke.rs).
//! Every refusal is an error whose message names the offending value.

mod common;

use common::run_cli;
use diffosi::derivatives::{step_jacobians, Workspace, Wrt};
use diffosi::dynamics::StepError;
use diffosi::model::{Inputs, MapEntry, ParamMap, State};
use diffosi::Model;

fn load(name: &str) -> Model {
    Model::load(common::model_path(&format!("reference_models/{name}"))).unwrap()
}

fn all_params(model: &Model) -> Vec<diffosi::model::Param> {
    let names = model.param_names();
    names.iter().map(|n| model.param(n).unwrap()).collect()
}

/// Fuzz finding (step target): a finite COM far enough out (here 1e300 m)
/// made the body's inertia about its joint frame (m |c|^2) overflow to NaN
/// inside the dynamics tree while `set_param` reported success.
#[test]
fn a_com_whose_inertia_overflows_is_refused_and_changes_nothing() {
    let mut model = load("half_cheetah.xml");
    let before = model.clone();
    let err = model
        .set_param("body/bfoot/com", &[1e300, 0.0, 0.0])
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("'body/bfoot/com' = [1e300, 0.0, 0.0]"),
        "{err}"
    );
    assert!(err.contains("overflows"), "{err}");
    assert_eq!(*model, *before);
    assert_eq!(model.tree(), before.tree());
    // The same body built directly is refused too.
    let b = model.body_index("bfoot").unwrap();
    let err = model
        .edited(|s| s.bodies[b].com.x = 1e300)
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("body 'bfoot'") && err.contains("overflows"),
        "{err}"
    );
}

/// Fuzz finding (step target): a next state can be finite while a Jacobian
/// overflows (a 1e-300 kg pendulum under a 1 N m torque: qdd ~ 1/m, its
/// derivative by the mass ~ 1/m^2). The Jacobians were returned holding inf.
#[test]
fn jacobians_that_overflow_are_an_error_naming_the_block() {
    let mut model = load("pendulum.xml");
    model.set_param("body/pendulum/mass", &[1e-300]).unwrap();
    let tiny = [1e-300, 1e-300, 1e-300, 0.0, 0.0, 0.0];
    model.set_param("body/pendulum/inertia", &tiny).unwrap();
    let x = (&[0.3][..], &[0.0][..], &[1.0][..]);
    assert!(model
        .step(
            &mut model.data(),
            &State::new(x.0.to_vec(), x.1.to_vec()),
            &Inputs::tau(x.2)
        )
        .is_ok());
    let params = [model.param("body/pendulum/mass").unwrap()];
    let wrt = Wrt {
        state: true,
        control: true,
        params: &params,
    };
    let err = step_jacobians(&model, &mut Workspace::new(&model), x, &wrt).unwrap_err();
    assert_eq!(err, StepError::JacobianNotFinite { block: "dq_dp" });
    assert_eq!(
        err.to_string(),
        "the step Jacobian dq_dp is not finite (state, forces or parameters too large)"
    );
}

#[test]
fn step_jacobians_name_bad_inputs() {
    let model = load("double_pendulum.urdf");
    let params = all_params(&model);
    let wrt = Wrt {
        state: true,
        control: true,
        params: &params,
    };
    let mut ws = Workspace::new(&model);
    let ok = [0.1, 0.2];
    let mut call = |q: &[f64], v: &[f64], tau: &[f64]| {
        step_jacobians(&model, &mut ws, (q, v, tau), &wrt)
            .unwrap_err()
            .to_string()
    };
    assert_eq!(call(&[0.1], &ok, &ok), "q has length 1, expected 2");
    assert_eq!(
        call(&ok, &ok, &[0.0, f64::NEG_INFINITY]),
        "tau[1] is not finite"
    );
    assert_eq!(call(&ok, &[f64::NAN, 0.0], &ok), "v[0] is not finite");
    let rk4 = model
        .edited(|s| s.opt.integrator = diffosi::model::Integrator::Rk4)
        .unwrap();
    let err = step_jacobians(&rk4, &mut ws, (&ok, &[0.0, f64::NAN], &ok), &wrt).unwrap_err();
    assert_eq!(err.to_string(), "v[1] is not finite");
}

#[test]
fn a_rollout_names_the_step_and_the_value_that_failed() {
    let model = load("cartpole.xml");
    let mut taus = vec![vec![0.0, 0.0]; 5];
    taus[3][1] = f64::NAN;
    let start = State::new(vec![0.0, 0.1], vec![0.0, 0.0]);
    let err = model
        .rollout(&start, taus.iter().map(|t| Inputs::tau(t)))
        .unwrap_err();
    assert_eq!(err.to_string(), "step 3: tau[1] is not finite");
    taus[3] = vec![0.0];
    let err = model
        .rollout(&start, taus.iter().map(|t| Inputs::tau(t)))
        .unwrap_err();
    assert_eq!(err.to_string(), "step 3: tau has length 1, expected 2");
    // A state that overflows is divergence, not a NaN trajectory.
    let err = model
        .rollout(
            &State::new(vec![0.0, 0.1], vec![0.0, 1e200]),
            taus[..1].iter().map(|t| Inputs::tau(t)),
        )
        .unwrap_err();
    let StepError::DivergedAt { cause } = err.source else {
        panic!("expected a divergence, got {}", err.source);
    };
    assert!(cause.contains("dof 1 of joint 'hinge'"), "{cause}");
}

#[test]
fn options_that_are_not_physical_are_refused() {
    let model = load("cartpole.xml");
    for h in [0.0, -0.01, f64::NAN, f64::INFINITY] {
        let err = model
            .edited(|s| s.opt.timestep = h)
            .unwrap_err()
            .to_string();
        assert!(err.contains(&format!("got {h}")), "{err}");
    }
    let err = model
        .edited(|s| s.opt.gravity.z = f64::NAN)
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("gravity must be finite") && err.contains("NaN"),
        "{err}"
    );
}

#[test]
fn param_maps_name_bad_entries_and_mu() {
    let mut model = load("cartpole.xml");
    let entry = |name, offset, gain| MapEntry { name, offset, gain };
    let err = |entries: &[MapEntry]| ParamMap::new(&model, 1, entries).unwrap_err().to_string();
    assert_eq!(
        err(&[entry("body/cart/volume", &[1.0], &[&[1.0]])]),
        "unknown parameter 'body/cart/volume': body fields are mass, com, inertia"
    );
    assert_eq!(
        err(&[entry("body/cart/mass", &[1.0, 2.0], &[&[1.0]])]),
        "parameter 'body/cart/mass' takes 1 values, got 2"
    );
    assert_eq!(
        err(&[entry("body/cart/mass", &[f64::NAN], &[&[1.0]])]),
        "parameter 'body/cart/mass' value NaN is not finite"
    );
    assert_eq!(
        err(&[entry("body/cart/mass", &[1.0], &[&[1.0, 2.0]])]),
        "gain of 'body/cart/mass' must be 1 rows of 1 values"
    );
    assert_eq!(
        err(&[entry("body/cart/mass", &[1.0], &[&[f64::INFINITY]])]),
        "gain of 'body/cart/mass' holds inf: gains must be finite"
    );
    let map = ParamMap::new(&model, 1, &[entry("body/cart/mass", &[1.0], &[&[1.0]])]).unwrap();
    let apply = |model: &mut Model, mu: &[f64]| map.apply(model, mu).unwrap_err().to_string();
    assert_eq!(apply(&mut model, &[]), "mu has 0 values, the map takes 1");
    assert_eq!(apply(&mut model, &[f64::NAN]), "mu value NaN is not finite");
    let e = apply(&mut model, &[-2.0]);
    assert!(
        e.contains("'body/cart/mass' = [-1.0] is not physical"),
        "{e}"
    );
    assert_eq!(model.get_param("body/cart/mass").unwrap(), vec![1.0]);
}

#[test]
fn eval_explains_bad_input() {
    let policy = "policies/cartpole/uc-seed0.json";
    let cases: [(&[&str], &str); 5] = [
        (
            &["--task", "walker", "--policy", policy],
            "unknown task 'walker'",
        ),
        (
            &["--policy", policy, "--episodes", "0"],
            "--episodes must be at least 1",
        ),
        (
            &[
                "--policy",
                policy,
                "--mu-source",
                "diffosi",
                "--window",
                "0",
            ],
            "--window must be at least 1",
        ),
        (&["--policy", "policies/none.json"], "policies/none.json"),
        (&["--policy", policy, "--mu-source", "psychic"], "psychic"),
    ];
    for (args, want) in cases {
        let (ok, _, err) = run_cli(&[&["eval"], args].concat());
        assert!(!ok && err.contains(want), "{args:?}: {err}");
    }
}

#[test]
fn simulate_explains_bad_models_and_steps() {
    let dir = std::env::temp_dir().join(format!("diffosi-robustness-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let bad = dir.join("negative.xml");
    std::fs::write(
        &bad,
        "<mujoco><worldbody><body name='b'><joint name='j'/>\
         <inertial pos='0 0 0' mass='1' diaginertia='1 1 1e400'/></body></worldbody></mujoco>",
    )
    .unwrap();
    let out = dir.join("out.csv");
    let (ok, _, err) = run_cli(&[
        "simulate",
        bad.to_str().unwrap(),
        "--steps",
        "3",
        "-o",
        out.to_str().unwrap(),
    ]);
    assert!(
        !ok && err.contains("negative.xml") && err.contains("1e400"),
        "{err}"
    );
    // A state that blows up names the step.
    let (ok, _, err) = run_cli(&[
        "simulate",
        "reference_models/cartpole.xml",
        "--steps",
        "3",
        "--v0",
        "0,1e200",
        "-o",
        out.to_str().unwrap(),
    ]);
    assert!(!ok && err.contains("step 0: the step diverged"), "{err}");
}

/// Fuzz finding (step target, built by cargo-fuzz with overflow checks): the
/// Euler Jacobians' column count subtracted past zero (`0 - 3 n`) in a
/// debug build, for any input.
#[test]
fn euler_jacobians_count_their_columns_without_underflow() {
    let model = load("cartpole.xml");
    let wrt = Wrt {
        state: true,
        control: true,
        params: &[],
    };
    let j = step_jacobians(
        &model,
        &mut Workspace::new(&model),
        (&[0.0; 2], &[0.0; 2], &[0.0; 2]),
        &wrt,
    )
    .unwrap();
    assert_eq!((j.dq_dq().shape(), j.dv_dp().shape()), ((2, 2), (2, 0)));
}

/// Fuzz finding (MJCF target): a model without joints (nv = 0) loads, but
/// its step Jacobians panicked on a zero chunk size in the column solve.
#[test]
fn a_model_without_joints_steps_and_differentiates() {
    let text = "<mujoco><worldbody><body name='a' pos='0 0 1'>\
                <geom type='sphere' size='0.05'/></body></worldbody></mujoco>";
    let model = Model::from_mjcf(text, "static.xml").unwrap();
    assert_eq!(model.nv(), 0);
    let all = all_params(&model);
    for params in [&all[..], &[]] {
        let wrt = Wrt {
            state: true,
            control: true,
            params,
        };
        let x = (&[][..], &[][..], &[][..]);
        let j = step_jacobians(&model, &mut Workspace::new(&model), x, &wrt).unwrap();
        assert_eq!(
            j.dv_dp().shape(),
            (0, params.iter().map(|p| p.size()).sum())
        );
    }
    let empty = State::default();
    let next = model.step(&mut model.data(), &empty, &Inputs::default());
    assert_eq!(next.unwrap(), empty);
}

/// Fuzz finding (MJCF target): a body whose name holds '/' listed parameter
/// names (`body/a/b/mass`) that did not resolve.
#[test]
fn names_with_slashes_resolve() {
    let text = "<mujoco><worldbody><body name='leg/upper'><joint name='hip/y'/>\
                <geom type='sphere' size='0.05'/></body></worldbody></mujoco>";
    let mut model = Model::from_mjcf(text, "slashes.xml").unwrap();
    for name in model.param_names() {
        assert_eq!(model.param(&name).unwrap().name(&model), name);
    }
    model.set_param("body/leg/upper/mass", &[2.0]).unwrap();
    model.set_param("joint/hip/y/damping", &[0.5]).unwrap();
    let err = model.get_param("body/leg/mass").unwrap_err().to_string();
    assert_eq!(
        err,
        "unknown parameter 'body/leg/mass': no body named 'leg'"
    );
}

/// A model nested deeper than MuJoCo's XML reader allows is refused before any
/// recursive walk (20,000 levels aborted the process with a stack overflow).
#[test]
fn deep_nesting_is_refused() {
    let n = 20_000;
    let text = format!(
        "<mujoco><worldbody>{}{}</worldbody></mujoco>",
        r#"<body><joint/><geom size="0.1"/>"#.repeat(n),
        "</body>".repeat(n)
    );
    let err = Model::from_mjcf(&text, "deep.xml").unwrap_err();
    assert!(
        err.to_string().contains("element nesting is too deep"),
        "{err}"
    );
    // MuJoCo's limit: a chain of 496 bodies loads, one of 497 does not.
    let chain = |n: usize| {
        format!(
            "<mujoco><worldbody>{}{}</worldbody></mujoco>",
            r#"<body><joint/><geom size="0.1" contype="0"/>"#.repeat(n),
            "</body>".repeat(n)
        )
    };
    assert!(Model::from_mjcf(&chain(496), "chain.xml").is_ok());
    assert!(Model::from_mjcf(&chain(497), "chain.xml").is_err());
}

/// Each contact model refuses to step geoms within reach whose contact it
/// would miss: the constraint model a pair without a collider, the smooth
/// model one without a force law (an ellipsoid against a box), in the step
/// and in its Jacobians.
#[test]
fn the_contact_models_refuse_what_they_cannot_do_yet() {
    // A cylinder on a box has MuJoCo's multiccd collider, not its single-contact one.
    let text = r#"<mujoco><option><flag multiccd="disable"/></option><worldbody>
        <body><joint type="slide" axis="0 0 1"/><geom name="a" type="cylinder" size="0.1 0.1"/></body>
        <body pos="0 0 0.19"><joint type="slide" axis="0 0 1"/><geom name="b" type="box" size="0.1 0.1 0.1"/></body>
        </worldbody></mujoco>"#;
    let model = Model::from_mjcf(text, "cylinder.xml").unwrap();
    let zero = [0.0, 0.0];
    let err = model
        .step(
            &mut model.data(),
            &State::new(zero.to_vec(), zero.to_vec()),
            &Inputs::tau(&zero),
        )
        .unwrap_err();
    assert_eq!(err, StepError::NoCollider([0, 1]));
    assert!(err.to_string().contains("no collider"), "{err}");
    let smooth = common::smooth(model.clone());
    let err = smooth
        .step(
            &mut smooth.data(),
            &State::new(zero.to_vec(), zero.to_vec()),
            &Inputs::tau(&zero),
        )
        .unwrap_err();
    assert_eq!(err, StepError::NoSmoothLaw([0, 1]));
    assert!(err.to_string().contains("no force law"), "{err}");
    let wrt = Wrt {
        state: true,
        control: true,
        params: &[],
    };
    for m in [&model, &smooth] {
        let mut ws = Workspace::new(m);
        let refused = step_jacobians(m, &mut ws, (&zero, &zero, &zero), &wrt).unwrap_err();
        assert!(
            matches!(
                refused,
                StepError::NoCollider(_) | StepError::NoSmoothLaw(_)
            ),
            "{refused}"
        );
        // Out of reach they step.
        let apart = [0.0, 1.0];
        assert!(m
            .step(
                &mut m.data(),
                &State::new(apart.to_vec(), zero.to_vec()),
                &Inputs::tau(&zero)
            )
            .is_ok());
        assert!(step_jacobians(m, &mut ws, (&apart, &zero, &zero), &wrt).is_ok());
    }
}
