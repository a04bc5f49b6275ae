//! Soft contact and joint limits (the smooth contact model): which geoms pair up, forces at rest, the
//! step's determinism, and stability of the half cheetah on its floor.
//! (Jacobians through contact: tests/derivatives.rs; windows: tests/window.rs.)

mod common;

use diffosi::derivatives::{step_jacobians, Workspace, Wrt};
use diffosi::dynamics::body_contact_forces;
use diffosi::model::{Inputs, Param, State};
use diffosi::Model;

fn cheetah() -> Model {
    common::smooth(Model::load(common::model_path("reference_models/half_cheetah.xml")).unwrap())
}

#[test]
fn pairs_follow_masks_and_the_parent_child_rule() {
    let model = cheetah();
    let tree = model.tree();
    let names: Vec<[&str; 2]> = tree
        .pairs
        .iter()
        .map(|p| {
            p.geoms
                .map(|g| model.geoms[tree.geoms[g].geom].name.as_str())
        })
        .collect();
    // Body geoms have conaffinity 0: each pairs with the floor only.
    let expected = [
        "torso", "head", "bthigh", "bshin", "bfoot", "fthigh", "fshin", "ffoot",
    ];
    assert_eq!(names, expected.map(|g| [g, "floor"]));
    let names = model.param_names();
    assert_eq!(
        names[names.len() - 3..],
        ["contact/stiffness", "contact/damping", "contact/friction"]
    );
    // A parent and its child never touch; a grandchild does; the world is
    // nobody's parent; welded bodies are one body.
    let text = r#"<mujoco>
  <worldbody>
    <geom name="ground" type="sphere" size="0.1"/>
    <body name="a">
      <joint type="hinge" axis="0 1 0"/>
      <geom name="a" type="sphere" size="0.1" mass="1"/>
      <body name="b">
        <joint type="hinge" axis="0 1 0"/>
        <geom name="b" type="sphere" size="0.1" mass="1"/>
        <body name="welded">
          <geom name="w" type="sphere" size="0.1" mass="1"/>
          <body name="c">
            <joint type="hinge" axis="0 1 0"/>
            <geom name="c" type="sphere" size="0.1" mass="1"/>
          </body>
        </body>
      </body>
    </body>
  </worldbody>
</mujoco>"#;
    let model = common::smooth(Model::from_mjcf(text, "chain.xml").unwrap());
    let pairs: Vec<[&str; 2]> = common::contact_pair_names(&model);
    let expected = [
        ["ground", "a"],
        ["ground", "b"],
        ["ground", "w"],
        ["ground", "c"],
        ["a", "c"],
    ];
    assert_eq!(pairs, expected);
    // Switched off, there are no pairs and no contact parameters.
    let off = model.edited(|s| s.opt.contact = false).unwrap();
    assert!(off.tree().pairs.is_empty());
    assert!(!off.param_names().iter().any(|n| n.starts_with("contact/")));
}

#[test]
fn geoms_touch_where_their_shapes_say() {
    // Centre 0.095 above the floor: a sphere of 0.1 is 5 mm in, a capsule of
    // radius 0.1 lying along x has two end contacts at that depth, a box of
    // half height 0.1 four corners.
    let cases = [
        (r#"type="sphere" size="0.1""#, 1),
        (r#"type="capsule" size="0.1 0.2" axisangle="0 1 0 90""#, 2),
        (r#"type="box" size="0.2 0.15 0.1""#, 4),
    ];
    for (shape, count) in cases {
        let model = common::dropped(shape, 1.0, 0.095);
        let n = model.nv();
        let contacts = model
            .contacts(
                &mut model.data(),
                &State::new(vec![0.0; n].to_vec(), vec![0.0; n].to_vec()),
                &Inputs::tau(&vec![0.0; n]),
            )
            .unwrap();
        let touching: Vec<_> = contacts.iter().filter(|c| c.dist < 0.0).collect();
        assert_eq!(touching.len(), count, "{shape}");
        for c in touching {
            assert!((-c.dist - 0.005).abs() < 1e-12, "{shape}: {}", -c.dist);
            assert!((c.normal - nalgebra::Vector3::z()).norm() < 1e-12);
            assert!((c.pos.z + 0.0025).abs() < 1e-12, "{shape}: midpoint");
            assert_eq!(model.bodies[c.bodies[1]].name, "thing");
        }
    }
}

#[test]
fn a_pair_rubs_with_its_larger_friction_times_the_scale() {
    // A sphere 5 mm into the floor sliding along x at 0.3 m/s: |F_t| / N =
    // f max(mu_floor, mu_sphere) |v_t| / sqrt(|v_t|^2 + slip^2).
    for (floor, sphere, scale) in [(0.4, 0.4, 1.0), (0.3, 0.8, 1.0), (0.9, 0.2, 0.5)] {
        let text = format!(
            r#"<mujoco>
  <worldbody>
    <geom name="floor" type="plane" size="5 5 0.1" friction="{floor} 0.1 0.1"/>
    <body name="thing" pos="0 0 0.095">
      <joint name="x" type="slide" axis="1 0 0"/>
      <joint name="z" type="slide" axis="0 0 1"/>
      <geom name="thing" type="sphere" size="0.1" mass="1" friction="{sphere}"/>
    </body>
  </worldbody>
</mujoco>"#
        );
        let mut model = common::smooth(Model::from_mjcf(&text, "rub.xml").unwrap());
        model.set_param("contact/friction", &[scale]).unwrap();
        let contacts = model
            .contacts(
                &mut model.data(),
                &State::new(vec![0.0, 0.0], vec![0.3, 0.0]),
                &Inputs::tau(&[0.0, 0.0]),
            )
            .unwrap();
        let [c] = &contacts[..] else {
            panic!("one contact, got {}", contacts.len())
        };
        let slip = model.opt.soft.slip;
        let expected =
            scale * f64::max(floor, sphere) * c.normal_force * 0.3 / (0.09 + slip * slip).sqrt();
        assert!(c.normal_force > 1.0);
        assert!((c.friction + nalgebra::Vector3::x() * expected).norm() < 1e-12 * expected);
    }
}

#[test]
fn spheres_and_capsules_touch_at_their_closest_points() {
    // (shape, centre) -> the expected contact point, depth. The bar is geom
    // 2 (the law's a): the normal points from the thing into it.
    let cases = [
        // A capsule along x below the bar, crossing it: the axes are 0.095
        // apart, the point halfway into the overlap under the bar's axis.
        (
            r#"type="capsule" size="0.05 0.2" axisangle="0 1 0 90""#,
            [0.0, 0.0, 0.205],
            [0.0, 0.0, 0.2525],
            0.005,
        ),
        // A sphere beyond the bar's end: its closest point is that end.
        (
            r#"type="sphere" size="0.1""#,
            [0.0, 0.3, 0.3],
            [0.0, 0.225, 0.3],
            0.05,
        ),
        // A sphere off the bar's side, 2 cm apart.
        (
            r#"type="sphere" size="0.1""#,
            [0.17, 0.0, 0.3],
            [0.06, 0.0, 0.3],
            -0.02,
        ),
    ];
    for (shape, at, point, depth) in cases {
        let model = common::crossing(shape, at);
        let zero = vec![0.0; model.nv()];
        let contacts = model
            .contacts(
                &mut model.data(),
                &State::new(zero.to_vec(), zero.to_vec()),
                &Inputs::tau(&zero),
            )
            .unwrap();
        let [c] = &contacts[..] else {
            panic!("{shape}: one contact, got {}", contacts.len())
        };
        assert_eq!(
            c.bodies.map(|b| model.bodies[b].name.as_str()),
            ["thing", "bar"]
        );
        assert!(
            (-c.dist - depth).abs() < 1e-12,
            "{shape}: depth {}",
            -c.dist
        );
        let expected = nalgebra::Vector3::from(point);
        assert!((c.pos - expected).norm() < 1e-12, "{shape}: {:?}", c.pos);
        let into_bar = (expected - nalgebra::Vector3::from(at)).normalize();
        assert!(
            (c.normal - into_bar).norm() < 1e-12,
            "{shape}: normal {:?}",
            c.normal
        );
    }
}

#[test]
fn a_resting_box_carries_its_weight() {
    let mass = 2.0;
    let model = common::dropped(r#"type="box" size="0.2 0.15 0.05""#, mass, 0.06);
    let n = model.nv();
    let (mut q, mut v) = (vec![0.0; n], vec![0.0; n]);
    // A slight tilt and push, then 4 s to settle.
    (q[3], v[0]) = (0.05, 0.3);
    let mut data = model.data();
    for _ in 0..2000 {
        State { q, v, .. } = model
            .step(&mut data, &State::new(q, v), &Inputs::tau(&vec![0.0; n]))
            .unwrap();
    }
    let contacts = model
        .contacts(
            &mut data,
            &State::new(q.to_vec(), v.to_vec()),
            &Inputs::tau(&vec![0.0; v.len()]),
        )
        .unwrap();
    let forces = body_contact_forces(&contacts, model.bodies.len());
    let weight = mass * 9.81;
    let thing = model.body_index("thing").unwrap();
    let error = (forces[thing] - nalgebra::Vector3::new(0.0, 0.0, weight)).amax();
    println!(
        "resting box: contact force {:?}, error {error:.1e} N",
        forces[thing]
    );
    assert!(error < 1e-6, "net contact force {:?}", forces[thing]);
    assert_eq!(forces[0], -forces[thing], "the floor feels the opposite");
    let normal: f64 = contacts.iter().map(|c| c.normal_force).sum();
    assert!((normal - weight).abs() < 1e-6, "normal force {normal}");
    assert!(v.iter().all(|x| x.abs() < 1e-6), "settled: {v:?}");
}

#[test]
fn steps_depend_on_their_inputs_only() {
    let model = cheetah();
    let n = model.nv();
    let (mut q, v, tau) = common::random_state(&model, 3);
    q[1] = -0.15; // feet in the floor
    let (other_q, other_v, other_tau) = common::random_state(&model, 4);
    let fresh = model
        .step(
            &mut model.data(),
            &State::new(q.to_vec(), v.to_vec()),
            &Inputs::tau(&tau),
        )
        .unwrap();
    let mut data = model.data();
    let mut ws = Workspace::new(&model);
    let params = [Param::ContactStiffness];
    let wrt = Wrt {
        state: true,
        control: true,
        params: &params,
    };
    let first = step_jacobians(&model, &mut ws, (&q, &v, &tau), &wrt).unwrap();
    for _ in 0..3 {
        model
            .step(
                &mut data,
                &State::new(other_q.to_vec(), other_v.to_vec()),
                &Inputs::tau(&other_tau),
            )
            .unwrap();
        step_jacobians(&model, &mut ws, (&other_q, &other_v, &other_tau), &wrt).unwrap();
        assert_eq!(
            model
                .step(
                    &mut data,
                    &State::new(q.to_vec(), v.to_vec()),
                    &Inputs::tau(&tau)
                )
                .unwrap(),
            fresh
        );
        let again = step_jacobians(&model, &mut ws, (&q, &v, &tau), &wrt).unwrap();
        assert_eq!(again, first);
    }
    assert_eq!((first.q_next, first.v_next), (fresh.q, fresh.v));
    let contacts = model
        .contacts(
            &mut data,
            &State::new(q.to_vec(), v.to_vec()),
            &Inputs::tau(&vec![0.0; v.len()]),
        )
        .unwrap();
    assert!(contacts.iter().any(|c| c.dist < 0.0), "in contact");
    assert_eq!(n, 9);
}

#[test]
fn the_half_cheetah_lands_and_stands() {
    let model = cheetah();
    let n = model.nv();
    let (mut q, mut v) = (vec![0.0; n], vec![0.0; n]);
    let mut data = model.data();
    for _ in 0..300 {
        State { q, v, .. } = model
            .step(&mut data, &State::new(q, v), &Inputs::tau(&vec![0.0; n]))
            .unwrap();
    }
    let contacts = model
        .contacts(
            &mut data,
            &State::new(q.to_vec(), v.to_vec()),
            &Inputs::tau(&vec![0.0; v.len()]),
        )
        .unwrap();
    let deepest = contacts.iter().map(|c| -c.dist).fold(f64::MIN, f64::max);
    let forces = body_contact_forces(&contacts, model.bodies.len());
    let lift: f64 = forces[1..].iter().map(|f| f.z).sum();
    let weight = 14.0 * 9.81;
    println!(
        "cheetah after 3 s: torso z {:.3} m, deepest {deepest:.4} m, contact lift {lift:.2} N, |v| {:.1e}",
        0.7 + q[1],
        v.iter().map(|x| x.abs()).fold(0.0, f64::max)
    );
    assert!(deepest > 0.0 && deepest < 0.03, "deepest {deepest}");
    assert!((lift - weight).abs() < 0.01 * weight, "lift {lift}");
    // The limits hold the legs: every limited joint within 0.1 rad of its range.
    for (j, qj) in model.joints.iter().zip(&q) {
        if let Some((lo, hi)) = j.range {
            assert!(*qj > lo - 0.1 && *qj < hi + 0.1, "{} at {qj}", j.name);
        }
    }
}

#[test]
fn limits_push_back_and_switch_off() {
    let model = cheetah().edited(|s| s.opt.contact = false).unwrap();
    let n = model.nv();
    let bthigh = model.joint_index("bthigh").unwrap();
    let (lo, _) = model.joints[bthigh].range.unwrap();
    let mut q = vec![0.0; n];
    q[bthigh] = lo - 0.01;
    let v = vec![0.0; n];
    let tau = vec![0.0; n];
    let free = model.edited(|s| s.opt.limits = false).unwrap();
    let next = model
        .step(
            &mut model.data(),
            &State::new(q.clone(), v.clone()),
            &Inputs::tau(&tau),
        )
        .unwrap();
    let (_, v_limited) = (next.q, next.v);
    let next = free
        .step(
            &mut free.data(),
            &State::new(q.clone(), v.clone()),
            &Inputs::tau(&tau),
        )
        .unwrap();
    let (_, v_free) = (next.q, next.v);
    // 10 mrad past the lower limit: about k_l * 0.01 = 10 N m pushes up.
    assert!(v_limited[bthigh] - v_free[bthigh] > 0.01);
    // Inside the range the limits do nothing measurable.
    q[bthigh] = 0.0;
    let inside = model
        .step(
            &mut model.data(),
            &State::new(q.to_vec(), v.to_vec()),
            &Inputs::tau(&tau),
        )
        .unwrap();
    let inside_free = free
        .step(
            &mut free.data(),
            &State::new(q.to_vec(), v.to_vec()),
            &Inputs::tau(&tau),
        )
        .unwrap();
    assert_eq!(inside, inside_free);
}
