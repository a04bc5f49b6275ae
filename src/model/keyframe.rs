//! Keyframes: named states a model file ships with (MJCF `<key>`).

/// A named state of the model, as MuJoCo's `key_*` arrays hold it: the
/// simulation `time`, positions `q` (nq, MuJoCo's qpos), velocities `v`
/// (nv), actuator activations `act` (na), controls `ctrl` (nu), and the
/// positions (3 each) and quaternions (4 each, w x y z) of the mocap bodies.
/// A vector the file leaves out is MuJoCo's default: `q` the reference
/// configuration (qpos0), mpos and mquat the mocap bodies' compiled poses
/// ([`super::Spec::mocap_default`]), the others zero.
#[derive(Clone, Debug, PartialEq)]
pub struct Keyframe {
    pub name: String,
    pub time: f64,
    pub q: Vec<f64>,
    pub v: Vec<f64>,
    pub act: Vec<f64>,
    pub ctrl: Vec<f64>,
    pub mpos: Vec<f64>,
    pub mquat: Vec<f64>,
}
