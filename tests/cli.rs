//! The `diffosi` binary, run as a user runs it.

mod common;

use common::{run_cli, temp_path};
use diffosi::model::{Inputs, State};

#[test]
fn simulate_writes_the_rollout_with_given_torques() {
    let torques = temp_path("cli", "taus.csv");
    let rows: Vec<String> = (0..50)
        .map(|t| format!("{},{}", (t as f64 * 0.1).sin(), 0.0))
        .collect();
    std::fs::write(&torques, format!("slider,hinge\n{}\n", rows.join("\n"))).unwrap();
    let out = temp_path("cli", "cartpole.csv");
    let (ok, _, err) = run_cli(&[
        "simulate",
        "reference_models/cartpole.xml",
        "--steps",
        "50",
        "--torques",
        torques.to_str().unwrap(),
        "--q0",
        "0.1,-0.2",
        "--v0",
        "0,0.5",
        "-o",
        out.to_str().unwrap(),
    ]);
    assert!(ok, "{err}");
    let csv = std::fs::read_to_string(&out).unwrap();
    let lines: Vec<&str> = csv.lines().collect();
    assert_eq!(
        lines[0],
        "t,q_slider,q_hinge,v_slider,v_hinge,tau_slider,tau_hinge,\
         q_next_slider,q_next_hinge,v_next_slider,v_next_hinge"
    );
    assert_eq!(lines.len(), 51);

    let model = diffosi::Model::load("reference_models/cartpole.xml").unwrap();
    let taus: Vec<Vec<f64>> = rows
        .iter()
        .map(|r| r.split(',').map(|x| x.parse().unwrap()).collect())
        .collect();
    let states = model
        .rollout(
            &State::new(vec![0.1, -0.2], vec![0.0, 0.5]),
            taus.iter().map(|t| Inputs::tau(t)),
        )
        .unwrap();
    // One transition per row: the state at t, the torque of the step from
    // it, the state after it.
    for (t, line) in lines[1..].iter().enumerate() {
        let row: Vec<f64> = line.split(',').map(|x| x.parse().unwrap()).collect();
        let (x, next) = (&states[t], &states[t + 1]);
        assert!((row[0] - t as f64 * model.opt.timestep).abs() < 1e-12);
        assert_eq!(&row[1..3], x.q.as_slice(), "row {t}");
        assert_eq!(&row[3..5], x.v.as_slice(), "row {t}");
        assert_eq!(&row[5..7], taus[t].as_slice(), "row {t}");
        assert_eq!(&row[7..9], next.q.as_slice(), "row {t}");
        assert_eq!(&row[9..11], next.v.as_slice(), "row {t}");
    }
}

/// A state of the wrong length names its flag and leaves no half-written
/// CSV; numbers are written as numpy and pandas write them ("0.0", "0.1").
#[test]
fn simulate_refuses_a_wrong_initial_state_before_writing() {
    let out = temp_path("cli", "wrong-q0.csv");
    let _ = std::fs::remove_file(&out);
    let args = ["simulate", "reference_models/cartpole.xml", "--steps", "2"];
    let (ok, _, err) = run_cli(&[&args[..], &["--q0", "0", "-o", out.to_str().unwrap()]].concat());
    assert!(
        !ok && err.contains("--q0: q has length 1, expected 2"),
        "{err}"
    );
    assert!(!out.exists(), "a CSV was left behind");
    let (ok, _, err) =
        run_cli(&[&args[..], &["--q0", "0.1,0", "-o", out.to_str().unwrap()]].concat());
    assert!(ok, "{err}");
    let csv = std::fs::read_to_string(&out).unwrap();
    let first: Vec<&str> = csv.lines().nth(1).unwrap().split(',').collect();
    assert_eq!(
        first[..7],
        ["0.0", "0.1", "0.0", "0.0", "0.0", "0.0", "0.0"]
    );
}

/// Force sensing: a 2 kg box dropped from 5 cm with a tilt settles on the
/// floor and its `fn_box_floor` column reads m g (the exact balance, once at
/// rest, to far below the 1e-9 N asked); while it falls the column is ~0.
#[test]
fn simulate_names_each_coordinate_of_free_and_ball_joints() {
    let out = temp_path("cli", "free_ball.csv");
    let (ok, _, err) = run_cli(&[
        "simulate",
        "reference_models/free_ball.xml",
        "--steps",
        "3",
        "-o",
        out.to_str().unwrap(),
    ]);
    assert!(ok, "{err}");
    let csv = std::fs::read_to_string(&out).unwrap();
    let header: Vec<&str> = csv.lines().next().unwrap().split(',').collect();
    // t, nq = 16 positions, nv = 13 velocities, 13 torques, then the next
    // state (no geom pairs: contype 0)
    assert_eq!(header.len(), 1 + 2 * (16 + 13) + 13, "{header:?}");
    assert_eq!(
        header[1..8],
        [
            "q_root:x",
            "q_root:y",
            "q_root:z",
            "q_root:qw",
            "q_root:qx",
            "q_root:qy",
            "q_root:qz"
        ]
    );
    assert_eq!(header[17..20], ["v_root:vx", "v_root:vy", "v_root:vz"]);
    assert_eq!(header[30..32], ["tau_root:vx", "tau_root:vy"]);
    assert_eq!(header[43..45], ["q_next_root:x", "q_next_root:y"]);
    assert_eq!(header[59], "v_next_root:vx");
    assert!(csv
        .lines()
        .skip(1)
        .all(|l| l.split(',').count() == header.len()));
}

#[test]
fn simulate_reports_each_pairs_normal_force() {
    let out = temp_path("cli", "box.csv");
    let (ok, _, err) = run_cli(&[
        "simulate",
        "reference_models/box.xml",
        "--steps",
        "5000",
        "--q0",
        "0,0,0.05,0.05,0,0",
        "-o",
        out.to_str().unwrap(),
    ]);
    assert!(ok, "{err}");
    let csv = std::fs::read_to_string(&out).unwrap();
    let lines: Vec<&str> = csv.lines().collect();
    let header: Vec<&str> = lines[0].split(',').collect();
    assert_eq!(header.last(), Some(&"fn_box_floor"));
    let sensed = |line: &str| -> f64 { line.rsplit(',').next().unwrap().parse().unwrap() };
    assert!(
        sensed(lines[1]).abs() < 1e-9,
        "falling: {}",
        sensed(lines[1])
    );
    let weight = 2.0 * 9.81;
    let last = sensed(lines.last().unwrap());
    assert!(
        (last - weight).abs() < 1e-9,
        "at rest: {last} N vs m g {weight} N"
    );
}

#[test]
fn simulate_explains_bad_input() {
    let out = temp_path("cli", "bad.csv");
    let out = out.to_str().unwrap();
    let (ok, _, err) = run_cli(&[
        "simulate",
        "reference_models/nonexistent.xml",
        "--steps",
        "5",
        "-o",
        out,
    ]);
    assert!(
        !ok && err.contains("cannot read reference_models/nonexistent.xml"),
        "{err}"
    );

    let torques = temp_path("cli", "short.csv");
    std::fs::write(&torques, "1,2,3\n").unwrap();
    let args = [
        "simulate",
        "reference_models/cartpole.xml",
        "--steps",
        "5",
        "--torques",
        torques.to_str().unwrap(),
        "-o",
        out,
    ];
    let (ok, _, err) = run_cli(&args);
    assert!(
        !ok && err.contains("short.csv:1: 3 values, expected nv = 2"),
        "{err}"
    );

    let (ok, _, err) = run_cli(&[
        "simulate",
        "reference_models/cartpole.xml",
        "--steps",
        "5",
        "--q0",
        "1",
        "-o",
        out,
    ]);
    assert!(!ok && err.contains("q has length 1, expected 2"), "{err}");

    let (ok, _, err) = run_cli(&[
        "simulate",
        "reference_models/cartpole.xml",
        "--steps",
        "5",
        "--v0",
        "0,nan",
        "-o",
        out,
    ]);
    assert!(!ok && err.contains("v[1] is not finite"), "{err}");
}

/// `--set` changes a named parameter as Python's `Model.set_param`, and
/// simulate's CSV is what identify reads: the pole mass set (0.3, the file's
/// is 0.1) comes back from it to 1e-9, with no flag.
#[test]
fn simulate_with_set_feeds_identify() {
    let out = temp_path("cli", "set.csv");
    let out = out.to_str().unwrap();
    let cartpole = "reference_models/cartpole.xml";
    let args = ["simulate", cartpole, "--steps", "40", "--q0", "0.1,0.3"];
    let set = [
        "--set",
        "body/pole/mass=0.3",
        "--set",
        "joint/hinge/damping=0.05",
    ];
    let (ok, _, err) = run_cli(&[&args[..], &set, &["--v0", "0,-1", "-o", out]].concat());
    assert!(ok, "{err}");
    let (ok, json, err) = run_cli(&[
        "identify",
        cartpole,
        "--params",
        "body/pole/mass",
        "--set",
        "joint/hinge/damping=0.05",
        "--contact-model",
        "constraint", // a law edit keeps the --set values
        "--transitions",
        out,
        "--json",
    ]);
    assert!(ok, "{err}");
    let v: serde_json::Value = serde_json::from_str(&json).unwrap();
    let mass = v["params"][0].as_f64().unwrap();
    assert!((mass - 0.3).abs() < 1e-9, "{v}");
    assert_eq!(v["flags"], serde_json::json!([]), "{v}");
    assert_eq!(v["transitions"], 40);

    // Without the damping the transitions are not explained: misfit.
    let (ok, json, err) = run_cli(&[
        "identify",
        cartpole,
        "--params",
        "body/pole/mass",
        "--transitions",
        out,
        "--json",
    ]);
    assert!(ok, "{err}");
    let v: serde_json::Value = serde_json::from_str(&json).unwrap();
    assert!(
        v["flags"].as_array().unwrap().contains(&"misfit".into()),
        "{v}"
    );

    for (bad, says) in [
        ("body/pole/mass", "no '='"),
        ("body/pole/mass=heavy", "'heavy' is not a finite number"),
        ("body/pole/mass=nan", "'nan' is not a finite number"),
        ("body/pole/mass=-1", "body/pole/mass"),
        ("body/pole/colour=1", "unknown parameter 'body/pole/colour'"),
        ("body/pole/com=1", "--set body/pole/com=1"),
    ] {
        let (ok, _, err) = run_cli(&[&args[..], &["--set", bad, "-o", out]].concat());
        assert!(!ok && err.contains(says), "{bad}: {err}");
    }
}

#[test]
fn jacobian_prints_the_library_result_as_json() {
    let (ok, out, err) = run_cli(&[
        "jacobian",
        "reference_models/cartpole.xml",
        "--q",
        "0.1,0.2",
        "--v",
        "-0.3,0.4",
        "--tau",
        "2,0",
        "--params",
        "body/pole/com,joint/hinge/damping",
        "--json",
    ]);
    assert!(ok, "{err}");
    let json: serde_json::Value = serde_json::from_str(&out).unwrap();
    let model = diffosi::Model::load("reference_models/cartpole.xml").unwrap();
    let params = [
        model.param("body/pole/com").unwrap(),
        model.param("joint/hinge/damping").unwrap(),
    ];
    let wrt = diffosi::derivatives::Wrt {
        state: true,
        control: true,
        params: &params,
    };
    let mut ws = diffosi::derivatives::Workspace::new(&model);
    let j = diffosi::derivatives::step_jacobians(
        &model,
        &mut ws,
        (&[0.1, 0.2], &[-0.3, 0.4], &[2.0, 0.0]),
        &wrt,
    )
    .unwrap();
    let matrix =
        |name: &str| -> Vec<Vec<f64>> { serde_json::from_value(json[name].clone()).unwrap() };
    assert_eq!(matrix("dv_dp").len(), 2);
    for (r, row) in matrix("dv_dp").iter().enumerate() {
        assert_eq!(row.len(), 4);
        for (c, x) in row.iter().enumerate() {
            assert_eq!(*x, j.dv_dp()[(r, c)]);
        }
    }
    assert_eq!(matrix("dq_dtau")[1][1], j.dq_dtau()[(1, 1)]);
    let v_next: Vec<f64> = serde_json::from_value(json["v_next"].clone()).unwrap();
    assert_eq!(v_next, j.v_next);
}

#[test]
fn jacobian_explains_bad_input() {
    let (ok, _, err) = run_cli(&[
        "jacobian",
        "reference_models/cartpole.xml",
        "--params",
        "body/pole/colour",
    ]);
    assert!(
        !ok && err
            .contains("unknown parameter 'body/pole/colour': body fields are mass, com, inertia"),
        "{err}"
    );
    let (ok, _, err) = run_cli(&["jacobian", "reference_models/cartpole.xml", "--q", "0,inf"]);
    assert!(!ok && err.contains("q[1] is not finite"), "{err}");
}

/// Every command of `diffosi --help` has its own description.
#[test]
fn help_describes_every_command() {
    let (ok, out, err) = run_cli(&["--help"]);
    assert!(ok, "{err}");
    let described = |command: &str, words: &str| {
        out.lines()
            .any(|l| l.trim_start().starts_with(command) && l.contains(words))
    };
    assert!(
        described("reproduce", "Reproduce the paper's experiments"),
        "{out}"
    );
    assert!(
        described("wipe ", "One episode of the wiping task"),
        "{out}"
    );
    assert!(!described("wipe ", "Reproduce"), "{out}");
    for line in out
        .lines()
        .skip_while(|l| !l.starts_with("Commands:"))
        .skip(1)
    {
        if line.trim().is_empty() {
            break;
        }
        assert!(
            line.split_whitespace().count() > 1,
            "no description: {line}"
        );
    }
}

#[test]
fn train_refines_a_policy_by_analytic_gradients() {
    let out = temp_path("cli", "apg.json");
    let out_s = out.to_str().unwrap();
    let base = [
        "train", "--task", "cartpole", "--policy", "uc", "--method", "apg", "--seed", "3",
        "--steps", "5000", "-o", out_s,
    ];
    let (ok, _, err) = run_cli(&base);
    assert!(!ok && err.contains("--init"), "{err}");
    let init = ["--init", "policies/cartpole/uc-seed0.json"];
    let (ok, stdout, err) = run_cli(&[&base[..], &init[..]].concat());
    assert!(ok, "{err}");
    assert!(stdout.contains("analytic policy gradients"), "{stdout}");
    let policy = diffosi::rl::Policy::load(&out).unwrap();
    assert_eq!(policy.kind, diffosi::rl::PolicyKind::Uc);
    let curve = std::fs::read_to_string(out.with_extension("curve.csv")).unwrap();
    // 5000 steps of 32 rollouts of 80 control steps: two iterations.
    assert_eq!(curve.lines().count(), 3, "{curve}");
    let dr = ["--init", "policies/cartpole/dr-seed0.json"];
    let (ok, _, err) = run_cli(&[&base[..], &dr[..]].concat());
    assert!(!ok && err.contains("--init"), "{err}");
}
