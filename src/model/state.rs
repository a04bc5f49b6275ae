//! What a step advances and what drives it, in MuJoCo's layouts.

/// A model's state: positions q (nq coordinates, MuJoCo's qpos), velocities
/// v (nv, qvel) and actuator activations act (na, act), laid out as the
/// module documentation of [`crate::model`] gives q and v; act holds one
/// entry per actuator with activation dynamics, in actuator order.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct State {
    pub q: Vec<f64>,
    pub v: Vec<f64>,
    pub act: Vec<f64>,
}

impl State {
    /// The state at (q, v), with no activations.
    pub fn new(q: Vec<f64>, v: Vec<f64>) -> State {
        State { q, v, act: vec![] }
    }
}

/// What drives a step: controls ctrl (nu, through the actuators, MuJoCo's
/// ctrl), generalized forces tau (nv, applied at the dofs directly, its
/// qfrc_applied), and the mocap bodies' poses (MuJoCo's mocap_pos, 3 per
/// mocap body, and mocap_quat, 4 per mocap body, w x y z; either empty: the
/// compiled poses; see [`crate::dynamics::mocap`]).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Inputs {
    pub ctrl: Vec<f64>,
    pub tau: Vec<f64>,
    pub mocap_pos: Vec<f64>,
    pub mocap_quat: Vec<f64>,
}

impl Inputs {
    /// Generalized forces tau alone: no controls (zero), the mocap bodies at
    /// their compiled poses.
    pub fn tau(tau: &[f64]) -> Inputs {
        Inputs {
            tau: tau.to_vec(),
            ..Inputs::default()
        }
    }
}

/// Written as the pair [q, v], with act third only when it has entries (the
/// form reports had before act existed).
impl serde::Serialize for State {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        if self.act.is_empty() {
            (&self.q, &self.v).serialize(s)
        } else {
            (&self.q, &self.v, &self.act).serialize(s)
        }
    }
}
