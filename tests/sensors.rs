//! Sensor readings against MuJoCo's sensordata after mj_forward
//! (`scripts/mujoco_sensors.py` writes reference_models/golden/sensors/): a
//! hinge chain with a slide and a ball (joint, frame, site and subtree
//! sensors, references, cutoffs) and a free box resting on a plane under the
//! constraint model (accelerometer, force and torque with the contact
//! forces). Errors are relative with a floor of 1, within 1e-12.

use std::path::PathBuf;

use diffosi::dynamics::StepError;
use diffosi::model::{Inputs, State};
use diffosi::Model;
use serde_json::Value;

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn numbers(v: &Value) -> Vec<f64> {
    v.as_array()
        .expect("an array")
        .iter()
        .map(|x| x.as_f64().expect("a number"))
        .collect()
}

fn compare(name: &str) {
    let model = Model::load(root().join(format!("tests/data/{name}.xml"))).unwrap();
    let path = root().join(format!("reference_models/golden/sensors/{name}.json"));
    let golden: Value = serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap();
    let (adr, dim): (Vec<usize>, Vec<usize>) = model.sensor_layout().into_iter().unzip();
    let sizes = |key: &str| {
        numbers(&golden[key])
            .iter()
            .map(|x| *x as usize)
            .collect::<Vec<_>>()
    };
    assert_eq!((adr, dim), (sizes("sensor_adr"), sizes("sensor_dim")));
    let mut data = model.data();
    for (k, state) in golden["states"].as_array().unwrap().iter().enumerate() {
        let [q, v, tau, theirs] = ["q", "v", "tau", "sensordata"].map(|key| numbers(&state[key]));
        let ours = model
            .sensor_readings(
                &mut data,
                &State::new(q.to_vec(), v.to_vec()),
                &Inputs::tau(&tau),
            )
            .unwrap();
        assert_eq!(ours.len(), theirs.len());
        for (i, (a, b)) in ours.iter().zip(&theirs).enumerate() {
            let sensor = model
                .sensor_layout()
                .iter()
                .rposition(|l| l.0 <= i)
                .unwrap();
            let error = (a - b).abs() / b.abs().max(1.0);
            assert!(
                error < 1e-12,
                "{name} state {k}: sensor '{}' entry {i}: ours {a}, MuJoCo {b}",
                model.sensors[sensor].name
            );
        }
    }
}

#[test]
fn hinge_chain_sensors_match_mujoco() {
    compare("sensor_chain");
}

#[test]
fn sensors_of_a_box_resting_on_a_plane_match_mujoco() {
    compare("sensor_box");
}

#[test]
fn sensors_not_computed_fail_by_name() {
    let xml = r#"<mujoco><worldbody><body><joint/><geom size="0.1"/><site name="s"/></body>
        </worldbody><sensor><gyro site="s"/><clock name="foot"/></sensor></mujoco>"#;
    let model = Model::from_mjcf(xml, "clock.xml").unwrap();
    let err = model
        .sensor_readings(
            &mut model.data(),
            &State::new(vec![0.0], vec![0.0]),
            &Inputs::tau(&[0.0]),
        )
        .unwrap_err();
    assert!(matches!(err, StepError::SensorNotComputed { .. }));
    let message = err.to_string();
    assert!(
        message.contains("'foot'") && message.contains("<clock>"),
        "{message}"
    );
}

/// Under the smooth contact model (no MuJoCo twin) force and torque sensors
/// read the smooth model's own contact forces: a free body under no applied
/// force receives nothing from the world through its joint, so the sensors
/// at its root read zero while the box is pressed into the floor and
/// sliding, and the mast's read what holds the mast up.
#[test]
fn smooth_contact_forces_enter_force_sensors() {
    let model = Model::load(root().join("tests/data/sensor_box.xml")).unwrap();
    let smooth = model
        .edited(|s| s.opt.contact_model = diffosi::model::ContactModel::Smooth)
        .unwrap();
    let q = [0.1, 0.2, 0.098, 1.0, 0.0, 0.0, 0.0];
    let v = [0.3, -0.1, -0.05, 0.2, 0.1, -0.3];
    let mut data = smooth.data();
    let readings = smooth
        .sensor_readings(
            &mut data,
            &State::new(q.to_vec(), v.to_vec()),
            &Inputs::tau(&[0.0; 6]),
        )
        .unwrap();
    let contacts = smooth
        .contacts(
            &mut data,
            &State::new(q.to_vec(), v.to_vec()),
            &Inputs::tau(&[0.0; 6]),
        )
        .unwrap();
    assert!(contacts.iter().any(|c| c.normal_force > 10.0));
    let layout = smooth.sensor_layout();
    let at = |name: &str| {
        let i = smooth.sensors.iter().position(|s| s.name == name).unwrap();
        &readings[layout[i].0..layout[i].0 + 3]
    };
    for name in ["base_force", "base_torque"] {
        assert!(
            at(name).iter().all(|x| x.abs() < 1e-12),
            "{name}: {:?}",
            at(name)
        );
    }
    let mast = &readings[layout[7].0..layout[7].0 + 3];
    assert!(
        mast.iter().map(|x| x * x).sum::<f64>().sqrt() > 2.0,
        "{mast:?}"
    );
}

/// Limit sensors read the constraint model's limit rows; the smooth model
/// has none, so they fail there, naming the sensor.
#[test]
fn limit_sensors_need_the_constraint_model() {
    let model = Model::load(root().join("tests/data/sensor_chain.xml")).unwrap();
    let smooth = model
        .edited(|s| s.opt.contact_model = diffosi::model::ContactModel::Smooth)
        .unwrap();
    let (q, v) = (smooth.reference_q(), vec![0.0; smooth.nv()]);
    let err = smooth
        .sensor_readings(
            &mut smooth.data(),
            &State::new(q.to_vec(), v.to_vec()),
            &Inputs::tau(&v),
        )
        .unwrap_err();
    assert!(
        err.to_string()
            .contains("smooth contact model has no limit rows"),
        "{err}"
    );
}
