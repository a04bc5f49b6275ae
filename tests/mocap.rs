//! The mocap poses are an argument wherever they are read: contacts and
//! sensor readings take them from Inputs, not from whatever the Data last
//! held. Numbers from MuJoCo 4.0.0's mj_forward on the same file
//! (d.mocap_pos set, d.contact, d.sensordata).

use diffosi::model::{Inputs, State};
use diffosi::Model;

/// A mocap box beside a sphere resting 2 mm into the floor; a site on the
/// box's face.
const XML: &str = r#"<mujoco><option timestep="0.005"/><worldbody>
<geom type="plane" size="2 2 .1"/>
<body name="pusher" mocap="true" pos="-0.3 0 0.1" quat="1 0 0 0.2">
  <geom type="box" size=".05 .1 .05"/><site name="tip" pos=".05 0 0"/></body>
<body name="ball" pos="0 0 .1"><freejoint/><geom size=".1" mass="1"/></body>
</worldbody>
<sensor><framepos objtype="site" objname="tip"/></sensor>
</mujoco>"#;

/// The box at x (its compiled orientation, w x y z).
fn pushed_to(x: f64) -> Inputs {
    Inputs {
        mocap_pos: vec![x, 0.0, 0.1],
        mocap_quat: vec![0.9805806756909201, 0.0, 0.0, 0.19611613513818402],
        ..Inputs::tau(&[0.0; 6])
    }
}

fn setup() -> (Model, State) {
    let model = Model::from_mjcf(XML, "mocap.xml").unwrap();
    let mut q = model.reference_q();
    q[2] -= 0.002;
    let x = State::new(q, vec![0.0; 6]);
    (model, x)
}

#[test]
fn contacts_read_the_mocap_pose_they_are_given() {
    let (model, x) = setup();
    let mut data = model.data();
    let near = pushed_to(-0.14);
    // The same Data, evaluated at the near pose first, then at the compiled one.
    let pressed = model.contacts(&mut data, &x, &near).unwrap();
    let apart = model
        .contacts(&mut data, &x, &Inputs::tau(&[0.0; 6]))
        .unwrap();
    let dists = |cs: &[diffosi::dynamics::Contact<f64>]| -> Vec<(usize, usize, f64)> {
        cs.iter()
            .map(|c| (c.geoms[0], c.geoms[1], c.dist))
            .collect()
    };
    // MuJoCo: the floor and the sphere at -0.002 both times; the box and the
    // sphere (geoms 2 and 1) at -0.020769230769230776 only when pushed.
    let floor = (0, 2, -0.0020000000000000018);
    assert_eq!(dists(&apart).len(), 1, "{:?}", dists(&apart));
    assert!((dists(&apart)[0].2 - floor.2).abs() < 1e-15);
    let box_sphere = dists(&pressed)
        .into_iter()
        .find(|&(a, b, _)| [a, b] == [2, 1] || [a, b] == [1, 2])
        .expect("the pushed box touches the sphere");
    assert_eq!(pressed.len(), 2);
    assert!(
        (box_sphere.2 - -0.020769230769230776).abs() < 1e-12,
        "{box_sphere:?}"
    );
    // The compiled pose again, after the near one: no trace of it.
    let again = model.contacts(&mut data, &x, &near).unwrap();
    assert_eq!(dists(&again), dists(&pressed));
    // The step from the same Data reads its own inputs too.
    let fresh = model.step(&mut model.data(), &x, &near).unwrap();
    assert_eq!(model.step(&mut data, &x, &near).unwrap(), fresh);
}

#[test]
fn sensor_readings_read_the_mocap_pose_they_are_given() {
    let (model, x) = setup();
    let mut data = model.data();
    // MuJoCo's framepos of the site on the box's face at each pose.
    for (at, expected) in [
        (-0.14, [-0.09384615384615386, 0.019230769230769232, 0.1]),
        (-0.3, [-0.25384615384615383, 0.019230769230769232, 0.1]),
    ] {
        let readings = model
            .sensor_readings(&mut data, &x, &pushed_to(at))
            .unwrap();
        for (a, b) in readings.iter().zip(expected) {
            assert!((a - b).abs() < 1e-15, "{at}: {readings:?}");
        }
    }
}

#[test]
fn contacts_refuse_controls_they_would_ignore() {
    let (model, x) = setup();
    let ctrl = Inputs {
        ctrl: vec![1.0],
        ..Inputs::tau(&[0.0; 6])
    };
    let err = model.contacts(&mut model.data(), &x, &ctrl).unwrap_err();
    assert!(
        err.to_string().starts_with("ctrl is not read here"),
        "{err}"
    );
    let with_act = State {
        act: vec![0.5],
        ..x.clone()
    };
    let none = Inputs::tau(&[0.0; 6]);
    let err = model.contacts(&mut model.data(), &with_act, &none);
    assert!(err
        .unwrap_err()
        .to_string()
        .starts_with("act is not read here"));
}

#[test]
fn a_rollout_takes_the_mocap_pose_of_each_step() {
    let (model, x) = setup();
    // Pushed on the first step only, or on every step.
    let once = [pushed_to(-0.14), pushed_to(-0.3), pushed_to(-0.3)];
    let always = [pushed_to(-0.14), pushed_to(-0.14), pushed_to(-0.14)];
    let a = model.rollout(&x, &once).unwrap();
    let b = model.rollout(&x, &always).unwrap();
    assert_eq!(a[1], b[1]);
    assert_ne!(a[3], b[3]);
    // Each step as a single step with its own inputs.
    let mut data = model.data();
    let mut state = x.clone();
    for (k, u) in once.iter().enumerate() {
        state = model.step(&mut data, &state, u).unwrap();
        assert_eq!(state, a[k + 1]);
    }
}
