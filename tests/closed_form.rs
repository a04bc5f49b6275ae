//! The reference models against physics worked out by hand.

mod common;

use diffosi::dynamics::{bias_forces, crba, Data};
use diffosi::model::{Inputs, State};
use diffosi::Model;
use nalgebra::{Matrix2, Vector2, Vector3};

fn load(name: &str) -> Model {
    let path = format!("{}/reference_models/{name}", env!("CARGO_MANIFEST_DIR"));
    Model::load(&path).unwrap_or_else(|e| panic!("{e}"))
}

/// The cartpole's Lagrangian equations of motion, for a pole COM anywhere in
/// the x-z plane of the pole: with d the hinge-to-COM offset, L^2 = dx^2 + dz^2,
/// px = c dx + s dz and pz = -s dx + c dz (the rotated offset),
///   M = [[m_c + m, m pz], [m pz, m L^2 + I_yy]] + diag(armature)
///   c = [-m thd^2 px, -m g px].
fn cartpole_closed_form(model: &Model, q: &[f64], v: &[f64]) -> (Matrix2<f64>, Vector2<f64>) {
    let cart = &model.bodies[model.body_index("cart").unwrap()];
    let pole = &model.bodies[model.body_index("pole").unwrap()];
    let hinge = &model.joints[model.joint_index("hinge").unwrap()];
    let slider = &model.joints[model.joint_index("slider").unwrap()];
    let (m_c, m) = (cart.mass, pole.mass);
    let d = pole.com - hinge.anchor;
    let (s, c) = (q[1] - hinge.reference).sin_cos();
    let (px, pz) = (c * d.x + s * d.z, -s * d.x + c * d.z);
    let inertia = m * (d.x * d.x + d.z * d.z) + pole.inertia[(1, 1)];
    let g = -model.opt.gravity.z;
    let mass = Matrix2::new(
        m_c + m + slider.armature,
        m * pz,
        m * pz,
        inertia + hinge.armature,
    );
    let bias = Vector2::new(-m * v[1] * v[1] * px, -m * g * px);
    (mass, bias)
}

#[test]
fn cartpole_matches_its_closed_form_equations() {
    let base = load("cartpole.xml");
    let pole = base.body_index("pole").unwrap();
    // The model's frames are the ones the closed form assumes.
    assert_eq!(
        base.joints[base.joint_index("slider").unwrap()].axis,
        Vector3::x()
    );
    assert_eq!(
        base.joints[base.joint_index("hinge").unwrap()].axis,
        Vector3::y()
    );
    assert!(base.bodies[pole].rot.angle() == 0.0 && base.bodies[1].rot.angle() == 0.0);
    let mut r = common::rng(5);
    for mu in [-0.6, -0.2, 0.0, 0.35, 0.6] {
        // The paper's COM offset (mu, 0, 0.5 + 0.2 mu) from the pole's centre.
        let model = base
            .edited(|s| s.bodies[pole].com = Vector3::new(mu, 0.0, 0.5 + 0.2 * mu))
            .unwrap();
        let mut data = Data::new(model.tree());
        for _ in 0..20 {
            let q = [
                common::uniform(&mut r, -2.0, 2.0),
                common::uniform(&mut r, -3.2, 3.2),
            ];
            let v = [
                common::uniform(&mut r, -3.0, 3.0),
                common::uniform(&mut r, -8.0, 8.0),
            ];
            let (mass, bias) = cartpole_closed_form(&model, &q, &v);
            crba(model.tree(), &mut data, &q);
            let mut c = [0.0; 2];
            bias_forces(model.tree(), &mut data, &q, &v, &mut c);
            let m_err = (data.mass_matrix.fixed_view::<2, 2>(0, 0) - mass).amax();
            let c_err = (Vector2::from(c) - bias).amax();
            assert!(
                m_err < 1e-13 && c_err < 1e-12,
                "mu {mu}: |dM| {m_err:e}, |dc| {c_err:e}"
            );
        }
    }
}

/// A small swing of the pendulum has period 2 pi sqrt(I_axis / (m g l)), with
/// I_axis its inertia about the hinge axis and l the COM's distance from it.
#[test]
fn pendulum_small_angle_period() {
    let model = load("pendulum.xml");
    assert_eq!(model.nv(), 1);
    let (body, joint) = (&model.bodies[1], &model.joints[0]);
    let n = joint.axis;
    let d = body.com - joint.anchor;
    let d_perp = d - n * n.dot(&d);
    let inertia_axis = n.dot(&(body.inertia * n)) + body.mass * d_perp.norm_squared();
    let g = model.opt.gravity.norm();
    // Hanging at rest at the reference: the COM straight below the axis.
    let down = (body.rot * d_perp).normalize();
    assert!(
        (down - model.opt.gravity.normalize()).norm() < 1e-12,
        "pendulum must hang at q = ref"
    );
    let expected =
        2.0 * std::f64::consts::PI * (inertia_axis / (body.mass * g * d_perp.norm())).sqrt();

    let amplitude = 1e-3;
    let h = model.opt.timestep;
    let mut data = model.data();
    let (mut q, mut v) = (vec![joint.reference + amplitude], vec![0.0]);
    let mut crossings = vec![];
    for t in 0..((6.0 * expected / h) as usize) {
        let next = model
            .step(
                &mut data,
                &State::new(q.clone(), v.clone()),
                &Inputs::tau(&[0.0]),
            )
            .unwrap();
        let (q1, v1) = (next.q, next.v);
        let (a, b) = (q[0] - joint.reference, q1[0] - joint.reference);
        if a > 0.0 && b <= 0.0 {
            crossings.push((t as f64 + a / (a - b)) * h);
        }
        (q, v) = (q1, v1);
    }
    let periods: Vec<f64> = crossings.windows(2).map(|w| w[1] - w[0]).collect();
    assert!(periods.len() >= 4, "too few swings: {crossings:?}");
    for p in periods {
        // Semi-implicit Euler's period error is (omega h)^2 / 24 ~ 1e-6 here.
        assert!(
            (p / expected - 1.0).abs() < 1e-4,
            "period {p} vs {expected}"
        );
    }
}
