//! The wiping arm (reference_models/wiping_arm.xml, issue 9): a KUKA LBR iiwa
//! 14 holding a wiping tool through a compliant slide joint over the table
//! plane z = 0.
//!
//! Its mass matrix, bias forces and steps against MuJoCo, PyBullet and DART
//! are covered by the golden data (tests/golden.rs: mujoco_wiping_arm*,
//! pybullet_wiping_arm, dart_wiping_arm) and the MJCF/URDF twins by
//! tests/twins.rs. Here: the model's shape and its one contact at rest.
//!
//! Conventions: q = (a1 .. a7, tool); angles in rad, the tool slide in m
//! (q_tool < 0 compresses the tool), forces in N, world z up.

mod common;

use diffosi::dynamics::body_poses;
use diffosi::model::{Inputs, State};
use diffosi::tasks::tool_down_at;
use diffosi::Model;
use nalgebra::{DVector, Vector3};

fn arm() -> Model {
    common::smooth(Model::load(common::model_path("reference_models/wiping_arm.xml")).unwrap())
}

#[test]
fn loads_with_eight_dofs_named_compliance_and_tool_table_contact_only() {
    let model = arm();
    assert_eq!((model.nq(), model.nv(), model.nu()), (8, 8, 7));
    assert_eq!(model.opt.timestep, 1e-3);
    let names: Vec<_> = model.joints.iter().map(|j| j.name.as_str()).collect();
    assert_eq!(names, ["a1", "a2", "a3", "a4", "a5", "a6", "a7", "tool"]);
    assert_eq!(model.get_param("joint/tool/stiffness").unwrap(), [50.0]);
    assert_eq!(model.get_param("joint/tool/damping").unwrap(), [50.0]);
    assert_eq!(model.get_param("body/tool/mass").unwrap(), [0.2]);
    // Torque limits as motor control ranges with gear 1: u = 1 is 1 N m.
    let tau = model.actuator_forces(&[1.0; 7]);
    assert_eq!(tau, [1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 0.0]);
    // The only contact pair: the tool's tip against the table.
    let pairs: Vec<_> = common::contact_pair_names(&model);
    assert_eq!(pairs, [["tip", "table"]]);
    // The inverse kinematics above: the tip where it was asked to be.
    let mut q = tool_down_at(0.55, 0.03).to_vec();
    q.push(0.0);
    let (axes, origin) = body_poses(model.tree(), &q)[model.body_index("tool").unwrap()];
    let tip = origin + axes * Vector3::new(0.0, 0.0, 0.12);
    assert!(
        (tip - Vector3::new(0.55, 0.0, 0.03)).amax() < 1e-12,
        "{tip}"
    );
    assert!((axes.column(2) + Vector3::z()).amax() < 1e-12);
}

/// The tool pressed on the table, the arm held by a stiff computed-torque PD
/// (tau_arm = c(q, v) + M (K_p (q* - q) - K_d v) on the arm rows, 100 rad/s,
/// critically damped; the tool joint free): at rest the table's normal force N
/// on the tip balances the tool's spring and weight along the tool axis,
/// N cos e = k_p * compression + m g cos e, with compression = -q_tool and e the
/// axis's tilt from straight down (the hold gives a little under the load).
///
/// Tolerance 1e-8 N: at rest the only other forces along the axis are
/// velocity terms (the tool's damping 50 N s/m, the contact's 100 N s/m, the
/// friction, regularised so that it vanishes with the slip speed), and the
/// state is asserted to be at rest to |v| < 1e-10, which bounds them by 1e-8 N.
#[test]
fn pressed_tool_balances_spring_and_weight() {
    let model = arm();
    let arm_q = tool_down_at(0.55, -0.02); // tip centre 4 cm below its resting height (radius 0.02)
    let (kp, kd) = (1e4, 200.0); // 100 rad/s, critically damped in every joint
    let (k_tool, m_tool, g) = (50.0, 0.2, 9.81);
    let mut q: Vec<f64> = arm_q.iter().copied().chain([-0.04]).collect();
    let mut v = vec![0.0; 8];
    let mut data = model.data();
    for _ in 0..4000 {
        let m = common::mass_matrix(&model, &q);
        let c = common::bias(&model, &q, &v);
        let mut a = DVector::zeros(8);
        for i in 0..7 {
            a[i] = kp * (arm_q[i] - q[i]) - kd * v[i];
        }
        let mut tau = c + m * a;
        tau[7] = 0.0;
        State { q, v, .. } = model
            .step(&mut data, &State::new(q, v), &Inputs::tau(tau.as_slice()))
            .unwrap();
    }
    let contacts = model
        .contacts(
            &mut data,
            &State::new(q.to_vec(), v.to_vec()),
            &Inputs::tau(&vec![0.0; v.len()]),
        )
        .unwrap();
    assert_eq!(contacts.len(), 1);
    let n = contacts[0].normal_force;
    let compression = -q[7];
    let (axes, _) = body_poses(model.tree(), &q)[model.body_index("tool").unwrap()];
    let cos_tilt = -axes[(2, 2)]; // the tool axis against straight down
    let along_axis = n * cos_tilt;
    let expected = k_tool * compression + m_tool * g * cos_tilt;
    let speed = v.iter().fold(0.0_f64, |a, x| a.max(x.abs()));
    println!(
        "compression {compression:.6} m, tilt {:.1e} rad, N cos e {along_axis:.9} N, \
         k_p x + m g cos e {expected:.9} N ({:.1e} apart), |v| {speed:.1e}",
        cos_tilt.acos(),
        along_axis - expected
    );
    assert!(speed < 1e-10, "not at rest: |v| = {speed:e}");
    assert!(compression > 0.03 && compression < 0.05, "{compression}");
    assert!(
        (along_axis - expected).abs() < 1e-8,
        "N cos e {along_axis} vs {expected}"
    );
}
