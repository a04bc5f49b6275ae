//! Compiling a [`Spec`] into the numeric [`Tree`] the algorithms run on, in
//! any scalar: bodies become nodes (one per dof, see [`crate::dynamics::Tree`]
//! for their frames), inertias are summed onto the node that carries them, and
//! the derived constants are computed once (the constraint model's collision
//! pairs and invweight0 at the reference configuration, the smooth model's
//! pairs, the fluid's equivalent boxes). Named physical parameters enter
//! through `lift_param`, which is how the derivatives seed their directions.

use std::sync::Arc;

use nalgebra::{Matrix3, Vector3};

use super::equality::equality_consts;
use super::fluid::fluid_bodies;
use super::gravcomp::gravcomp_bodies;
use super::invweight::invweight0;
use super::pairs::{collision_pairs, contact_pairs, lawless_pairs};
use super::tendon::tendon_consts;
use crate::dynamics::actuation::{ActuatorTerm, SiteFrame, Target};
use crate::dynamics::collision::{Assets, CollisionPair, GeomFrame, Sweep};
use crate::dynamics::configuration::Coordinates;
use crate::dynamics::constraint::Limit;
use crate::dynamics::contact::{Pair, Soft};
use crate::dynamics::{BodyFrame, NodeJoint, Tree};
use crate::model::params::inertia_to_six;
use crate::model::{Body, ContactModel, Joint, JointKind, Param, Spec, Transmission};
use crate::spatial::{lift, lift_vector, Inertia, Real, Transform};

impl<T: Real> Tree<T> {
    /// Builds the tree of a validated model, lifting its numbers into T.
    pub fn build(model: &Spec) -> Self {
        Self::build_with(model, |_, _, x| lift(x))
    }

    /// Builds the tree with each scalar of a named physical parameter lifted by
    /// `lift_param(param, component, value)`: the way derivatives seed the
    /// directions of parameters (components as in [`Param::get`]).
    pub fn build_with(model: &Spec, lift_param: impl Fn(Param, usize, f64) -> T) -> Self {
        let mut tree = Tree::empty();
        tree.opt = model.opt.clone();
        tree.gravity = lift_vector(&model.opt.gravity);
        tree.body.push(BodyFrame {
            node: None,
            mocap: None,
            offset: Transform::identity(),
        });
        (tree.mocap_pos, tree.mocap_quat) = model.mocap_default();
        let mut next_mocap = 0;
        let reference = model.reference_q();
        let mut at = 0;
        for (index, b) in model.bodies.iter().enumerate().skip(1) {
            let parent = tree.body[b.parent];
            let place = Transform::from_pose_f64(&b.rot, &b.pos).compose(&parent.offset);
            let mut node = parent.node;
            // A free joint places its body absolutely.
            let free = model.joints[b.joints.clone()]
                .iter()
                .any(|j| j.kind == JointKind::Free);
            let mut x_tree = if free { Transform::identity() } else { place };
            for (k, j) in model.joints[b.joints.clone()].iter().enumerate() {
                let k = b.joints.start + k;
                let (damping, armature) = model.actuator_passive(k);
                for node_joint in node_joints(j, at) {
                    tree.parent.push(node);
                    tree.x_tree.push(x_tree);
                    tree.joint.push(node_joint);
                    tree.damping
                        .push(lift_param(Param::Damping(k), 0, j.damping) + lift(damping));
                    tree.stiffness
                        .push(lift_param(Param::Stiffness(k), 0, j.stiffness));
                    tree.armature
                        .push(lift_param(Param::Armature(k), 0, j.armature) + lift(armature));
                    tree.node_joint.push(k);
                    tree.limits.push(j.range.filter(|_| model.opt.limits));
                    tree.inertia.push(Inertia::zero());
                    node = Some(tree.parent.len() - 1);
                    x_tree = Transform::identity();
                }
                let rest = reference[at..at + j.kind.nq()]
                    .iter()
                    .map(|x| lift::<T>(*x));
                match j.kind {
                    JointKind::Hinge | JointKind::Slide => tree.spring_q.push(lift(j.springref)),
                    _ => tree.spring_q.extend(rest),
                }
                at += j.kind.nq();
            }
            // Within the last node's frame, the body sits at `x_tree`: identity if
            // the body has joints, else its placement relative to its carrier.
            if b.mocap {
                tree.body.push(BodyFrame {
                    node: None,
                    mocap: Some(next_mocap),
                    offset: Transform::identity(),
                });
                next_mocap += 1;
                continue;
            }
            tree.body.push(BodyFrame {
                node,
                mocap: parent.mocap,
                offset: x_tree,
            });
            if let Some(n) = node {
                let own = body_inertia(index, b, &lift_param);
                tree.inertia[n] += own.to_source(&x_tree);
            }
        }
        tree.fluid = fluid_bodies(model, &tree.body_frames(), &lift_param);
        tree.actuators = actuator_terms(model);
        tree.na = model.na();
        tree.gravcomp = gravcomp_bodies(model, &tree.body_frames(), &lift_param);
        tree.free_bodies = free_bodies(model, &tree.body_frames());
        let soft = &model.opt.soft;
        let constants = [
            (Param::ContactStiffness, soft.stiffness),
            (Param::ContactDamping, soft.damping),
            (Param::ContactFriction, soft.friction),
        ];
        tree.soft = Soft::new(soft, constants.map(|(p, x)| lift_param(p, 0, x)));
        tree.tendons = tendon_consts(&tree, model, &lift_param);
        match model.opt.contact_model {
            ContactModel::Smooth => tree.add_pairs(model),
            ContactModel::Constraint => tree.add_constraints(model, &lift_param),
        }
        tree
    }

    /// The constraint model's constants: collision pairs, limits, dry
    /// friction, equalities, invweight0 (at the reference configuration, as MuJoCo's
    /// mj_setConst computes them).
    fn add_constraints(&mut self, model: &Spec, lift_param: &impl Fn(Param, usize, f64) -> T) {
        let limits = std::mem::take(&mut self.limits);
        let opt = &model.opt;
        let c = &mut self.constraint;
        let node_joint = &self.node_joint;
        c.limits = node_joint
            .iter()
            .zip(limits)
            .map(|(&k, range)| {
                let j = &model.joints[k];
                range.map(|range| Limit {
                    range,
                    margin: j.margin,
                    sol: j.limit_sol.lift(
                        |c, x| lift_param(Param::LimitSolref(k), c, x),
                        |c, x| lift_param(Param::LimitSolimp(k), c, x),
                    ),
                })
            })
            .collect();
        c.frictionloss = node_joint
            .iter()
            .map(|&k| {
                let j = &model.joints[k];
                let on = opt.solver.frictionloss && j.frictionloss > 0.0;
                let value = lift_param(Param::FrictionLoss(k), 0, j.frictionloss);
                let sol = j.friction_sol.lift(|_, x| lift(x), |_, x| lift(x));
                (if on { value } else { T::zero() }, sol)
            })
            .collect();
        self.constraint.assets = Arc::new(Assets {
            meshes: model.meshes.clone(),
            hfields: model.hfields.clone(),
        });
        for (geoms, params, supported) in collision_pairs(model, lift_param) {
            let geoms = geoms.map(|g| self.geom_frame(model, g));
            self.constraint.pairs.push(CollisionPair {
                geoms,
                params,
                supported,
            });
        }
        let reach = self.constraint.pairs.iter();
        let reach = reach.map(|p| (p.geoms, p.params.margin + p.params.gap));
        self.constraint.sweep = Sweep::new(&self.geoms, reach);
        let (bodies, dofs, mean_inertia) = invweight0(self, model, lift_param);
        self.constraint.body_invweight = bodies;
        self.constraint.dof_invweight = dofs;
        self.constraint.mean_inertia = mean_inertia;
        self.constraint.equalities = equality_consts(self, model, lift_param);
    }

    /// The index in `geoms` of model geom `g`, placed in its node's frame
    /// the first time it is asked for.
    fn geom_frame(&mut self, model: &Spec, g: usize) -> usize {
        if let Some(k) = self.geoms.iter().position(|f| f.geom == g) {
            return k;
        }
        let geom = &model.geoms[g];
        let frame = self.body[geom.body];
        let offset = Transform::from_pose_f64(&geom.rot, &geom.pos).compose(&frame.offset);
        self.geoms.push(GeomFrame::new(
            (g, geom.body, &frame),
            offset,
            (geom.shape, model.rbound(&geom.shape)),
        ));
        self.geoms.len() - 1
    }

    /// Places the geoms of the model's contact pairs and indexes the pairs
    /// (and the pairs the smooth law has no force for).
    fn add_pairs(&mut self, model: &Spec) {
        for [a, b] in contact_pairs(model) {
            let geoms = [a, b].map(|g| self.geom_frame(model, g));
            let friction = model.geoms[a].friction[0].max(model.geoms[b].friction[0]);
            self.pairs.push(Pair { geoms, friction });
        }
        for pair in lawless_pairs(model) {
            let geoms = pair.map(|g| self.geom_frame(model, g));
            self.lawless.push(geoms);
        }
    }
}

/// The first node of every standalone free body of `model` (see
/// [`Tree::free_bodies`]), with the tree's body frames.
pub(super) fn free_bodies<T: Real>(
    model: &Spec,
    frames: &[(Option<usize>, Transform<T>)],
) -> Vec<usize> {
    let descends = |k: usize, b: usize| {
        let mut p = k;
        while p != 0 {
            p = model.bodies[p].parent;
            if p == b {
                return true;
            }
        }
        false
    };
    let standalone = |b: usize| {
        let body = &model.bodies[b];
        let free = &model.joints[body.joints.clone()];
        free.len() == 1
            && free[0].kind == JointKind::Free
            && model
                .bodies
                .iter()
                .enumerate()
                .skip(b + 1)
                .all(|(k, d)| !descends(k, b) || (d.joints.is_empty() && d.mass == 0.0))
    };
    (1..model.bodies.len())
        .filter(|&b| standalone(b))
        .filter_map(|b| frames[b].0.map(|last| last - 5))
        .collect()
}

/// The nodes of joint `j`, whose coordinates start at q[at] (see the module
/// documentation).
fn node_joints<T: Real>(j: &Joint, at: usize) -> Vec<NodeJoint<T>> {
    let ball = |at: usize, anchor: Vector3<T>| {
        (0..3).map(move |k| {
            let coordinates = Coordinates::Rotation { at, axis: k };
            let axis = Vector3::ith(k, T::one());
            NodeJoint::new(JointKind::Ball, (axis, anchor), T::zero(), coordinates)
        })
    };
    match j.kind {
        JointKind::Hinge | JointKind::Slide => {
            let axis_anchor = (lift_vector(&j.axis), lift_vector(&j.anchor));
            let coordinates = Coordinates::Scalar { at };
            vec![NodeJoint::new(
                j.kind,
                axis_anchor,
                lift(j.reference),
                coordinates,
            )]
        }
        JointKind::Ball => ball(at, lift_vector(&j.anchor)).collect(),
        JointKind::Free => (0..3)
            .map(|k| {
                let axis_anchor = (Vector3::ith(k, T::one()), Vector3::zeros());
                let coordinates = Coordinates::Scalar { at: at + k };
                NodeJoint::new(JointKind::Slide, axis_anchor, T::zero(), coordinates)
            })
            .chain(ball(at + 3, Vector3::zeros()))
            .collect(),
    }
}

/// Body `index`'s spatial inertia about its own frame, with its mass, COM and
/// inertia lifted by `lift_param` (see [`Tree::build_with`]).
pub fn body_inertia<T: Real>(
    index: usize,
    b: &Body,
    lift_param: impl Fn(Param, usize, f64) -> T,
) -> Inertia<T> {
    let (mass, com, inertia) = mass_properties(index, b, &lift_param);
    Inertia::from_com(mass, &com, &inertia)
}

/// Body `index`'s mass, COM and inertia tensor about the COM (body axes),
/// lifted by `lift_param` (see [`Tree::build_with`]).
pub fn mass_properties<T: Real>(
    index: usize,
    b: &Body,
    lift_param: &impl Fn(Param, usize, f64) -> T,
) -> (T, Vector3<T>, Matrix3<T>) {
    let mass = lift_param(Param::Mass(index), 0, b.mass);
    let com = Vector3::from_fn(|r, _| lift_param(Param::Com(index), r, b.com[r]));
    let six = inertia_to_six(&b.inertia);
    let [xx, yy, zz, xy, xz, yz]: [T; 6] =
        std::array::from_fn(|r| lift_param(Param::Inertia(index), r, six[r]));
    (mass, com, Matrix3::new(xx, xy, xz, xy, yy, yz, xz, yz, zz))
}

/// The actuators with their targets (a joint's addresses, a tendon's
/// index, a site's frame) and their activations' indices (in actuator order).
pub(super) fn actuator_terms(model: &Spec) -> Vec<ActuatorTerm> {
    let mut next_act = 0;
    model
        .actuators
        .iter()
        .map(|a| {
            let target = match a.target {
                Transmission::Joint(j) => {
                    let (q_at, dof) = model.joint_address(j);
                    Target::Joint { q_at, dof }
                }
                Transmission::Tendon(t) => Target::Tendon(t),
                Transmission::Site { site, refsite } => {
                    let frame = |s: usize| {
                        let s = &model.sites[s];
                        SiteFrame {
                            body: s.body,
                            pos: s.pos,
                            rot: *s.rot.matrix(),
                        }
                    };
                    Target::Site {
                        site: frame(site),
                        refsite: refsite.map(frame),
                    }
                }
            };
            let act = a.has_act().then(|| {
                next_act += 1;
                next_act - 1
            });
            ActuatorTerm {
                law: a.clone(),
                target,
                act,
            }
        })
        .collect()
}
