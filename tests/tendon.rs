//! Fixed tendons (tests/data/tendon_fixed.xml: a spring with a deadband and
//! a damper, a limited tendon with dry friction, a tendon equality): one
//! step with the tendon equality, friction and upper-limit rows acting
//! against mj_step's (MuJoCo 4.0.0, computed in the venv), and the step's
//! exact Jacobians (dual numbers through the tendon forces and rows)
//! against central differences of the step.

use std::path::PathBuf;

use diffosi::derivatives::{step_jacobians, Workspace, Wrt};
use diffosi::Model;

fn model() -> Model {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    Model::load(root.join("tests/data/tendon_fixed.xml")).unwrap()
}

const Q: [f64; 5] = [0.1, -0.25, 0.5, 0.2, -0.02];
const V: [f64; 5] = [0.3, -0.7, 1.1, 0.4, -0.2];
const TAU: [f64; 5] = [0.2, -0.1, 0.05, 0.3, -0.4];

#[test]
fn one_step_matches_mj_step() {
    let m = model();
    let (mut q1, mut v1) = (vec![0.0; 5], vec![0.0; 5]);
    let mut data = m.data();
    diffosi::dynamics::step(m.tree(), &mut data, (&Q, &V, &TAU), (&mut q1, &mut v1)).unwrap();
    let mujoco_q = [
        0.10023113705401923,
        -0.2505585196421424,
        0.4940300067739109,
        0.20080055529847293,
        -0.02027524600600573,
    ];
    let mujoco_v = [
        0.11556852700961215,
        -0.27925982107118075,
        -2.9849966130445575,
        0.40027764923646464,
        -0.13762300300286442,
    ];
    for (ours, theirs) in q1.iter().chain(&v1).zip(mujoco_q.iter().chain(&mujoco_v)) {
        assert!(
            (ours - theirs).abs() < 1e-12,
            "ours {ours}, MuJoCo {theirs}"
        );
    }
}

#[test]
fn jacobians_match_central_differences() {
    let m = model();
    let mut ws = Workspace::new(&m);
    let wrt = Wrt {
        state: true,
        control: true,
        params: &[],
    };
    let j = step_jacobians(&m, &mut ws, (&Q, &V, &TAU), &wrt).unwrap();
    let step = |q: &[f64], v: &[f64], tau: &[f64]| {
        let (mut q1, mut v1) = (vec![0.0; 5], vec![0.0; 5]);
        let mut data = m.data();
        diffosi::dynamics::step(m.tree(), &mut data, (q, v, tau), (&mut q1, &mut v1)).unwrap();
        [q1, v1].concat()
    };
    let eps = 1e-6;
    for k in 0..15 {
        let moved = |s: f64| {
            let mut x = [Q.to_vec(), V.to_vec(), TAU.to_vec()].concat();
            x[k] += s * eps;
            step(&x[..5], &x[5..10], &x[10..])
        };
        let (plus, minus) = (moved(1.0), moved(-1.0));
        for r in 0..10 {
            let fd = (plus[r] - minus[r]) / (2.0 * eps);
            let exact = j.jacobian[(r, k)];
            assert!(
                (fd - exact).abs() < 1e-6 * exact.abs().max(1.0),
                "row {r} column {k}: exact {exact}, differences {fd}"
            );
        }
    }
}
