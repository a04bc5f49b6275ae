//! The broad phase on a model with thousands of pairs: sweeping and pruning
//! finds exactly the contacts, in exactly the order, that testing every pair
//! finds (src/dynamics/collision/sweep.rs).

use diffosi::dynamics::collision::{apart, collide, MIN_PAIRS};
use diffosi::dynamics::constraint::contacts;
use diffosi::dynamics::{update_transforms, world_frames};
use diffosi::Model;

/// 60 free bodies of four geoms each on a grid over a floor, close enough
/// that neighbours' geoms overlap and the lowest ones touch the floor.
fn crowd() -> Model {
    let mut bodies = String::new();
    for b in 0..60 {
        let (x, y) = ((b % 10) as f64 * 0.5, (b / 10) as f64 * 0.5);
        bodies += &format!(r#"<body pos="{x} {y} 0.04"><freejoint/>"#);
        for g in 0..4 {
            let a = g as f64 * 1.6;
            let kind = ["sphere", "capsule", "box", "sphere"][g];
            let size = ["0.05", "0.03 0.08", "0.04 0.05 0.06", "0.07"][g];
            let (gx, gy) = (0.25 * a.cos(), 0.25 * a.sin());
            bodies += &format!(
                r#"<geom type="{kind}" size="{size}" pos="{gx:.3} {gy:.3} {:.3}" margin="{:.3}"/>"#,
                0.05 * g as f64,
                0.01 * (b % 3) as f64
            );
        }
        bodies += "</body>";
    }
    let xml = format!(
        r#"<mujoco><worldbody><geom type="plane" size="10 10 0.1"/>{bodies}</worldbody></mujoco>"#
    );
    Model::from_mjcf(&xml, "crowd.xml").unwrap()
}

#[test]
fn sweeping_finds_the_contacts_that_testing_every_pair_finds() {
    let model = crowd();
    let tree = model.tree();
    let pairs = &tree.constraint.pairs;
    assert!(pairs.len() >= MIN_PAIRS, "{} pairs", pairs.len());
    let mut data = model.data();
    let q = model.reference_q();
    update_transforms(tree, &mut data, &q);
    world_frames(tree, &mut data, &vec![0.0; tree.nv()]);

    let (mut swept, mut pre) = (vec![], vec![]);
    contacts(tree, &data, (&mut swept, &mut pre));
    let mut every = vec![];
    for (index, pair) in pairs.iter().enumerate() {
        let geoms = pair.geoms.map(|g| &tree.geoms[g]);
        let reach = pair.params.margin + pair.params.gap;
        if pair.supported && !apart(geoms[0], geoms[1], &data, reach) {
            let poses = geoms.map(|g| g.pose(&data));
            collide(
                (&tree.constraint, index),
                geoms,
                poses,
                (&mut every, &mut pre),
            );
        }
    }
    assert_eq!(swept, every);
    // Both kinds: geoms of neighbours, and geoms on the floor.
    let on_floor = every.iter().filter(|c| c.bodies[0] == 0).count();
    assert!(
        on_floor > 30 && every.len() > on_floor + 30,
        "{on_floor} of {}",
        every.len()
    );
}
