//! What a step advances, in MuJoCo's layout.

/// A model's state: positions q (nq coordinates, MuJoCo's qpos), velocities
/// v (nv, qvel) and actuator activations act (na, act), laid out as the
/// module documentation of [`crate::model`] gives q and v. act is empty
/// today: no actuator has activation dynamics yet.
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
