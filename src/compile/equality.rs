//! The active equalities compiled into what their rows read
//! ([`crate::dynamics::constraint::equality`]), as MuJoCo's mj_setConst
//! completes them at qpos0 (the reference configuration): a body connect's
//! anchor on body 2 is the point that coincides with body 1's anchor, a
//! body weld without relpose takes body 2's pose in body 1 (anchor point
//! included); site forms use the sites' frames.

use nalgebra::{Quaternion, UnitQuaternion};

use crate::dynamics::constraint::{EqualityConsts, Held, Weld};
use crate::dynamics::{body_poses, Tree};
use crate::model::{EqualityKind, Objects, Param, Spec};
use crate::spatial::{lift, lift_vector, Real};

/// The active equalities of `spec` on `tree` (its bodies and nodes built).
pub fn equality_consts<T: Real>(
    tree: &Tree<T>,
    spec: &Spec,
    lift_param: &impl Fn(Param, usize, f64) -> T,
) -> Vec<EqualityConsts<T>> {
    if !spec.opt.solver.equality {
        return vec![];
    }
    let q0: Vec<T> = spec.reference_q().into_iter().map(lift).collect();
    let poses = body_poses(tree, &q0);
    let quat = |r: &nalgebra::Matrix3<T>| {
        let rot = nalgebra::Rotation3::from_matrix_unchecked(*r);
        UnitQuaternion::from_rotation_matrix(&rot).into_inner()
    };
    let lift_quat = |q: &UnitQuaternion<f64>| {
        let q = q.into_inner();
        Quaternion::new(lift(q.w), lift(q.i), lift(q.j), lift(q.k))
    };
    let node_of = |joint: usize| {
        let node = tree.node_joint.iter().position(|&j| j == joint);
        let node = node.expect("an equality's joint is a hinge or slide with one node");
        let coord = tree.joint[node].coordinate().expect("hinge or slide");
        (coord, node, q0[coord])
    };
    let mut out = vec![];
    for (id, eq) in spec.equalities.iter().enumerate().filter(|(_, e)| e.active) {
        let held = match &eq.kind {
            EqualityKind::Joint { joints, polycoef } => Held::Joints {
                first: node_of(joints[0].expect("checked")),
                second: joints[1].map(node_of),
                polycoef: polycoef.map(lift),
            },
            EqualityKind::Tendon { tendons, polycoef } => Held::Tendons {
                first: tendons[0].expect("checked"),
                second: tendons[1],
                polycoef: polycoef.map(lift),
            },
            EqualityKind::Connect { objects, anchor } => match objects {
                Objects::Bodies(bodies) => {
                    let anchor = lift_vector(anchor);
                    let [(r1, x1), (r2, x2)] = bodies.map(|b| poses[b]);
                    let second = r2.transpose() * (x1 + r1 * anchor - x2);
                    Held::Points {
                        bodies: *bodies,
                        anchors: [anchor, second],
                        weld: None,
                    }
                }
                Objects::Sites(sites) => Held::Points {
                    bodies: sites.map(|s| spec.sites[s].body),
                    anchors: sites.map(|s| lift_vector(&spec.sites[s].pos)),
                    weld: None,
                },
            },
            EqualityKind::Weld {
                objects,
                anchor,
                relpose,
                torquescale,
            } => {
                let torquescale = lift(*torquescale);
                match objects {
                    Objects::Bodies(bodies) => {
                        let anchor = lift_vector(anchor);
                        let [(r1, x1), (r2, x2)] = bodies.map(|b| poses[b]);
                        let (first, frame) = match relpose {
                            Some((pos, q)) => (
                                lift_vector(pos),
                                lift_quat(&UnitQuaternion::from_quaternion(*q)),
                            ),
                            None => (
                                r1.transpose() * (x2 + r2 * anchor - x1),
                                quat(&r1).conjugate() * quat(&r2),
                            ),
                        };
                        Held::Points {
                            bodies: *bodies,
                            anchors: [first, anchor],
                            weld: Some(Weld {
                                frames: [frame, Quaternion::identity()],
                                torquescale,
                            }),
                        }
                    }
                    Objects::Sites(sites) => Held::Points {
                        bodies: sites.map(|s| spec.sites[s].body),
                        anchors: sites.map(|s| lift_vector(&spec.sites[s].pos)),
                        weld: Some(Weld {
                            frames: sites.map(|s| {
                                lift_quat(&UnitQuaternion::from_rotation_matrix(&spec.sites[s].rot))
                            }),
                            torquescale,
                        }),
                    },
                }
            }
        };
        let sol = eq.sol.lift(
            |k, x| lift_param(Param::EqualitySolref(id), k, x),
            |k, x| lift_param(Param::EqualitySolimp(id), k, x),
        );
        out.push(EqualityConsts { id, held, sol });
    }
    out
}
