//! Sensor readings against MuJoCo's sensordata after mj_forward
//! (`scripts/mujoco_sensors.py` writes reference_models/golden/sensors/): a
//! hinge chain with a slide and a ball (joint, frame, site and subtree
//! sensors, references, cutoffs) and a free box resting on a plane under the
//! constraint model (accelerometer, force and torque with the contact
//! forces). Errors are relative with a floor of 1, within 1e-12.

use std::path::PathBuf;

use diffosi::dynamics::StepError;
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
    let sizes = |key: &str| numbers(&golden[key]).iter().map(|x| *x as usize).collect::<Vec<_>>();
    assert_eq!((adr, dim), (sizes("sensor_adr"), sizes("sensor_dim")));
    let mut data = model.data();
    for (k, state) in golden["states"].as_array().unwrap().iter().enumerate() {
        let [q, v, tau, theirs] = ["q", "v", "tau", "sensordata"].map(|key| numbers(&state[key]));
        let ours = model.sensor_readings(&mut data, &q, &v, &tau).unwrap();
        assert_eq!(ours.len(), theirs.len());
        for (i, (a, b)) in ours.iter().zip(&theirs).enumerate() {
            let sensor = model.sensor_layout().iter().rposition(|l| l.0 <= i).unwrap();
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
        </worldbody><sensor><gyro site="s"/><touch name="foot" site="s"/></sensor></mujoco>"#;
    let model = Model::from_mjcf(xml, "touch.xml").unwrap();
    let err = model
        .sensor_readings(&mut model.data(), &[0.0], &[0.0], &[0.0])
        .unwrap_err();
    assert!(matches!(err, StepError::SensorNotComputed { .. }));
    let message = err.to_string();
    assert!(message.contains("'foot'") && message.contains("<touch>"), "{message}");
}
