//! Our constraint contact model against MuJoCo's converged solver on MuJoCo's own
//! states in contact and at joint limits (reference_models/golden/contact/*.json,
//! written by `python -m harness golden-contact`; gymnasium's ant and humanoid on their free
//! joints among them): one step to 1e-12 (the chain
//! of 50 overlapping spheres, 4704 rows on 50 dofs, to 1e-10: its Newton system's
//! conditioning), the same contacts, and each contact's force in its frame
//! (normal, tangential, torsional, rolling: mj_contactForce) to 1e-9.

mod common;

use common::rel_err;
use diffosi::model::Inputs;
use diffosi::Model;
use serde::Deserialize;
use sha2::Digest;

#[derive(Deserialize)]
struct Golden {
    model: String,
    model_sha256: String,
    states: Vec<State>,
}

#[derive(Deserialize)]
struct State {
    q: Vec<f64>,
    v: Vec<f64>,
    tau: Vec<f64>,
    q_next: Vec<f64>,
    v_next: Vec<f64>,
    limit_rows: usize,
    contacts: Vec<GoldenContact>,
}

/// MuJoCo's contact: geoms 1 and 2, dist, and the force in its frame (normal first).
#[derive(Deserialize)]
struct GoldenContact {
    geoms: [String; 2],
    dist: f64,
    force: Vec<f64>,
}

fn load(golden: &Golden) -> Model {
    let path = common::model_path(&golden.model);
    let bytes = std::fs::read(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    assert_eq!(
        format!("{:x}", sha2::Sha256::digest(&bytes)),
        golden.model_sha256,
        "{} changed since its golden data was recorded: run `make golden`",
        path.display()
    );
    Model::load(&path).unwrap_or_else(|e| panic!("{e}"))
}

/// Worst one-step error and worst force error of one model's states; counts the
/// states at limits.
fn compare(name: &str, golden: &Golden) -> (f64, f64, usize) {
    let model = load(golden);
    let mut data = model.data();
    let (mut step, mut force, mut limits) = (0.0f64, 0.0f64, 0);
    for (k, s) in golden.states.iter().enumerate() {
        let x = diffosi::model::State::new(s.q.clone(), s.v.clone());
        let u = Inputs::tau(&s.tau);
        let next = model.step(&mut data, &x, &u).unwrap();
        let (q1, v1) = (next.q, next.v);
        step = step
            .max(rel_err(&q1, &s.q_next))
            .max(rel_err(&v1, &s.v_next));
        let ours = model.contacts(&mut data, &x, &u).unwrap();
        assert_eq!(ours.len(), s.contacts.len(), "{name} state {k}: contacts");
        for theirs in &s.contacts {
            let c = ours
                .iter()
                .find(|c| {
                    let [g1, g2] = c.geoms.map(|g| model.geoms[g].name.as_str());
                    [g1, g2] == [theirs.geoms[0].as_str(), theirs.geoms[1].as_str()]
                        && (c.dist - theirs.dist).abs() < 1e-12
                })
                .unwrap_or_else(|| panic!("{name} state {k}: no contact {:?}", theirs.geoms));
            // mj_contactForce: normal, tangential, torsional, rolling, in the frame.
            let local = c.in_frame();
            force = force.max(rel_err(&local[..theirs.force.len()], &theirs.force));
        }
        limits += usize::from(s.limit_rows > 0);
    }
    (step, force, limits)
}

#[test]
fn steps_and_contact_forces_equal_mujocos() {
    let files = common::golden_files("reference_models/golden/contact");
    assert_eq!(files.len(), 13, "one file per model");
    let mut limits = 0;
    for file in &files {
        let name = file.file_stem().unwrap().to_string_lossy().to_string();
        let golden: Golden = serde_json::from_str(&std::fs::read_to_string(file).unwrap()).unwrap();
        let (step, force, at_limits) = compare(&name, &golden);
        println!(
            "{name:<14} {} states ({at_limits} at limits): one step {step:.1e}, forces {force:.1e}",
            golden.states.len()
        );
        let tolerance = if name == "overlapping_chain" {
            1e-10
        } else {
            1e-12
        };
        assert!(step <= tolerance, "{name}: one step {step:e}");
        assert!(force <= 1e-9, "{name}: contact forces {force:e}");
        limits += at_limits;
    }
    assert!(limits > 0, "no state at a joint limit");
}
