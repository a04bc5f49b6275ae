//! What the benchmarks share: the reference models and a fixed state.

use diffosi::model::{ContactModel, Inputs, State};
use diffosi::Model;

/// A reference model, contacts and joint limits off: the articulated dynamics
/// that the reference timings (MuJoCo with contacts off, Pinocchio) measure.
pub fn load(name: &str) -> Model {
    Model::load(format!(
        "{}/reference_models/{name}.xml",
        env!("CARGO_MANIFEST_DIR")
    ))
    .unwrap()
    .edited(|s| {
        s.opt.contact = false;
        s.opt.limits = false;
    })
    .unwrap()
}

/// A reference model with contacts and joint limits on, under contact model `law`.
pub fn load_with_contact(name: &str, law: ContactModel) -> Model {
    Model::load(format!(
        "{}/reference_models/{name}.xml",
        env!("CARGO_MANIFEST_DIR")
    ))
    .and_then(|m| m.edited(|s| s.opt.contact_model = law))
    .unwrap()
}

/// The state a model with contact settles into, and zero forces: `steps`
/// steps from its reference configuration at rest without forces (the half
/// cheetah stands on its feet after 300 steps, as MuJoCo's does).
pub fn settled(model: &Model, steps: usize) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
    let n = model.nv();
    let (mut q, mut v, tau) = (model.reference_q(), vec![0.0; n], vec![0.0; n]);
    let mut data = model.data();
    for _ in 0..steps {
        State { q, v, .. } = model
            .step(&mut data, &State::new(q, v), &Inputs::tau(&tau))
            .unwrap();
    }
    (q, v, tau)
}

/// A fixed, non-trivial state: q a little off the reference, v and tau nonzero.
pub fn state(model: &Model) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
    let n = model.nv();
    let q = model
        .reference_q()
        .iter()
        .enumerate()
        .map(|(i, q)| q + 0.1 * (i as f64 + 1.0).sin())
        .collect();
    let v = (0..n).map(|i| 0.5 * (i as f64 + 2.0).cos()).collect();
    let tau = (0..n).map(|i| (i as f64 + 3.0).sin()).collect();
    (q, v, tau)
}
