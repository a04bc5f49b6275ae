//! The numeric form of a model that the algorithms run on, in any scalar.
//!
//! Every dof is one node of the tree: a hinge or slide joint is one node, a
//! ball three (its body-frame axes x, y, z: the first turns the frame by the
//! quaternion, the other two share that frame), a free joint six (slides
//! along the world axes, then a ball). Node i has a frame: its body's frame
//! after the joints of the body up to and including node i have moved it
//! (module `model` defines the order). Node i's parent is the previous node
//! on the path to the world, or the world itself (`None`). A node carries the
//! inertia of its body if it is the body's last node, plus the inertia of
//! every body welded (jointless) below that body.

use nalgebra::{Matrix3, Vector3};

use super::collision::{collision_pairs, CollisionPair, GeomFrame};
use super::configuration::{rotation_matrix, Coordinates};
use super::constraint::{invweight0, ConstraintConsts, Limit};
use super::contact::{contact_pairs, Pair, Soft};
use super::fluid::{fluid_bodies, FluidBody};
use crate::model::params::inertia_to_six;
use crate::model::{Body, ContactModel, Fluid, JointKind, Param, SoftOptions, Spec};
use crate::spatial::{lift, lift_vector, Inertia, Motion, Real, Transform};

/// A node's dof in its frame: a hinge (a ball's axis too) or a slide. Its
/// motion subspace `s` is the same before and after the joint moves.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NodeJoint<T: Real> {
    /// Hinge, Slide or Ball (a ball's axis; a free joint's nodes are slides
    /// and a ball's).
    pub kind: JointKind,
    pub axis: Vector3<T>,
    pub anchor: Vector3<T>,
    /// The coordinate at which a hinge or slide's transform is the identity.
    pub reference: T,
    pub s: Motion<T>,
    /// Where its coordinates are in q.
    pub coordinates: Coordinates,
}

/// The rotation by `angle` about the unit `axis` (Rodrigues' formula).
/// Written out rather than nalgebra's `from_axis_angle`, which returns the
/// identity at a zero angle, dropping the derivative part of a dual angle.
fn rotation<T: Real>(axis: &Vector3<T>, angle: T) -> Matrix3<T> {
    let (sin, cos) = angle.sin_cos();
    let one_minus_cos = T::one() - cos;
    let (x, y, z) = (axis.x, axis.y, axis.z);
    let (xy, xz, yz) = (
        x * y * one_minus_cos,
        x * z * one_minus_cos,
        y * z * one_minus_cos,
    );
    let (sq_x, sq_y, sq_z) = (x * x, y * y, z * z);
    Matrix3::new(
        sq_x + (T::one() - sq_x) * cos,
        xy - z * sin,
        xz + y * sin,
        xy + z * sin,
        sq_y + (T::one() - sq_y) * cos,
        yz - x * sin,
        xz - y * sin,
        yz + x * sin,
        sq_z + (T::one() - sq_z) * cos,
    )
}

impl<T: Real> NodeJoint<T> {
    fn new(
        kind: JointKind,
        (axis, anchor): (Vector3<T>, Vector3<T>),
        reference: T,
        coordinates: Coordinates,
    ) -> Self {
        let s = match kind {
            JointKind::Slide => Motion::new(Vector3::zeros(), axis),
            _ => Motion::new(axis, anchor.cross(&axis)),
        };
        NodeJoint {
            kind,
            axis,
            anchor,
            reference,
            s,
            coordinates,
        }
    }

    /// X_J(q) (q: the whole configuration): from the frame before the joint
    /// to the frame after it. A ball's first axis carries its rotation, the
    /// other two the identity.
    #[inline]
    pub fn transform(&self, q: &[T]) -> Transform<T> {
        let turn = |r: Matrix3<T>| Transform::from_pose(&r, &(self.anchor - r * self.anchor));
        match (self.kind, self.coordinates) {
            (JointKind::Slide, Coordinates::Scalar { at }) => Transform::from_pose(
                &Matrix3::identity(),
                &(self.axis * (q[at] - self.reference)),
            ),
            (_, Coordinates::Scalar { at }) => turn(rotation(&self.axis, q[at] - self.reference)),
            (_, Coordinates::Rotation { at, axis: 0 }) => turn(rotation_matrix(&q[at..at + 4])),
            (_, Coordinates::Rotation { .. }) => Transform::identity(),
        }
    }

    /// A hinge's or slide's coordinate in q (None on a ball's axes, which
    /// have no limits).
    pub fn coordinate(&self) -> Option<usize> {
        match self.coordinates {
            Coordinates::Scalar { at } => Some(at),
            Coordinates::Rotation { .. } => None,
        }
    }

    /// The axes of its ball before it (0, 1 or 2; 0 for any other joint):
    /// their velocities are not part of the velocity its own dof's motion
    /// crosses (the velocity-product term uses the velocity entering the
    /// ball, as MuJoCo's cdof_dot does).
    pub fn ball_axes_before(&self) -> usize {
        match self.coordinates {
            Coordinates::Rotation { axis, .. } => axis,
            Coordinates::Scalar { .. } => 0,
        }
    }
}

/// Where a body's frame sits: a fixed offset from a node's frame (or the world's).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BodyFrame<T: Real> {
    pub node: Option<usize>,
    /// From the node's frame to the body's frame.
    pub offset: Transform<T>,
}

/// The model's tree in scalar T. See the module documentation.
#[derive(Clone, Debug, PartialEq)]
pub struct Tree<T: Real> {
    pub parent: Vec<Option<usize>>,
    /// From the parent node's frame (or the world) to node i's frame with its
    /// joint at the reference position.
    pub x_tree: Vec<Transform<T>>,
    pub joint: Vec<NodeJoint<T>>,
    /// Inertia carried by each node, in the node's frame.
    pub inertia: Vec<Inertia<T>>,
    pub damping: Vec<T>,
    pub stiffness: Vec<T>,
    /// The springs' rest configuration (nq; MuJoCo's qpos_spring): a hinge's
    /// or slide's springref, a ball's or free joint's reference.
    pub spring_q: Vec<T>,
    pub armature: Vec<T>,
    /// Per node, the model joint it belongs to.
    pub node_joint: Vec<usize>,
    pub gravity: Vector3<T>,
    pub body: Vec<BodyFrame<T>>,
    /// The geoms in contact pairs, and the pairs (indices into `geoms`, see
    /// [`super::contact`]); both empty when contacts are off.
    pub geoms: Vec<GeomFrame<T>>,
    pub pairs: Vec<Pair>,
    /// Per node: the joint's range if it is limited and limits are on
    /// (smooth model).
    pub limits: Vec<Option<(f64, f64)>>,
    pub soft: Soft<T>,
    /// Which law contacts, limits and dry friction follow; the constraint
    /// model's constants (empty under the smooth model).
    pub contact_model: ContactModel,
    pub constraint: ConstraintConsts<T>,
    /// The medium and the bodies it acts on (none without one).
    pub medium: Fluid,
    pub fluid: Vec<FluidBody<T>>,
}

impl<T: Real> Tree<T> {
    /// A tree with no nodes (placeholder before a model is validated).
    pub fn empty() -> Self {
        Tree {
            parent: vec![],
            x_tree: vec![],
            joint: vec![],
            inertia: vec![],
            damping: vec![],
            stiffness: vec![],
            spring_q: vec![],
            armature: vec![],
            node_joint: vec![],
            gravity: Vector3::zeros(),
            body: vec![],
            geoms: vec![],
            pairs: vec![],
            limits: vec![],
            soft: Soft::new(&SoftOptions::default(), [T::zero(); 3]),
            contact_model: ContactModel::Smooth,
            constraint: ConstraintConsts::empty(),
            medium: Fluid::default(),
            fluid: vec![],
        }
    }

    /// Whether contact or limit forces can act (else the step is the plain
    /// articulated dynamics).
    pub fn has_soft_forces(&self) -> bool {
        !self.pairs.is_empty() || self.limits.iter().any(Option::is_some)
    }

    /// Whether constraint rows can exist (else the step is the plain
    /// articulated dynamics under either model); never under the smooth
    /// model, whose tree holds no constraint constants.
    pub fn has_constraints(&self) -> bool {
        let c = &self.constraint;
        !c.pairs.is_empty()
            || c.limits.iter().any(Option::is_some)
            || c.frictionloss.iter().any(|(f, _)| *f > T::zero())
    }

    pub fn nv(&self) -> usize {
        self.parent.len()
    }

    pub fn nq(&self) -> usize {
        self.spring_q.len()
    }

    /// The velocity node i's dof moves within, for its velocity-product
    /// term: `vel` (node i's) less the motion of the axes of its ball before
    /// it (see [`NodeJoint::ball_axes_before`]); `vel` itself elsewhere.
    pub fn crossed_velocity(&self, i: usize, vel: Motion<T>, v: &[T]) -> Motion<T> {
        let before = self.joint[i].ball_axes_before();
        (1..=before).fold(vel, |m, k| m - self.joint[i - k].s * v[i - k])
    }

    /// Each body's (node, offset) (see [`BodyFrame`]).
    pub fn body_frames(&self) -> Vec<(Option<usize>, Transform<T>)> {
        self.body.iter().map(|b| (b.node, b.offset)).collect()
    }

    /// Builds the tree of a validated model, lifting its numbers into T.
    pub fn build(model: &Spec) -> Self {
        Self::build_with(model, |_, _, x| lift(x))
    }

    /// Builds the tree with each scalar of a named physical parameter lifted by
    /// `lift_param(param, component, value)`: the way derivatives seed the
    /// directions of parameters (components as in [`Param::get`]).
    pub fn build_with(model: &Spec, lift_param: impl Fn(Param, usize, f64) -> T) -> Self {
        let mut tree = Tree::empty();
        tree.gravity = lift_vector(&model.opt.gravity);
        tree.body.push(BodyFrame {
            node: None,
            offset: Transform::identity(),
        });
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
                for node_joint in node_joints(j, at) {
                    tree.parent.push(node);
                    tree.x_tree.push(x_tree);
                    tree.joint.push(node_joint);
                    tree.damping
                        .push(lift_param(Param::Damping(k), 0, j.damping));
                    tree.stiffness
                        .push(lift_param(Param::Stiffness(k), 0, j.stiffness));
                    tree.armature
                        .push(lift_param(Param::Armature(k), 0, j.armature));
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
            tree.body.push(BodyFrame {
                node,
                offset: x_tree,
            });
            if let Some(n) = node {
                let own = body_inertia(index, b, &lift_param);
                tree.inertia[n] += own.to_source(&x_tree);
            }
        }
        tree.medium = model.opt.fluid;
        tree.fluid = fluid_bodies(model, &tree.body_frames(), &lift_param);
        let soft = &model.opt.soft;
        let constants = [
            (Param::ContactStiffness, soft.stiffness),
            (Param::ContactDamping, soft.damping),
            (Param::ContactFriction, soft.friction),
        ];
        tree.soft = Soft::new(soft, constants.map(|(p, x)| lift_param(p, 0, x)));
        tree.contact_model = model.opt.contact_model;
        match model.opt.contact_model {
            ContactModel::Smooth => tree.add_pairs(model),
            ContactModel::Constraint => tree.add_constraints(model, &lift_param),
        }
        tree
    }

    /// The constraint model's constants: collision pairs, limits, dry
    /// friction, invweight0 (at the reference configuration, as MuJoCo's
    /// mj_setConst computes them).
    fn add_constraints(&mut self, model: &Spec, lift_param: &impl Fn(Param, usize, f64) -> T) {
        let limits = std::mem::take(&mut self.limits);
        let opt = &model.opt;
        let c = &mut self.constraint;
        c.solver = opt.solver;
        c.timestep = opt.timestep;
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
        for (geoms, params, supported) in collision_pairs(model, lift_param) {
            let geoms = geoms.map(|g| self.geom_frame(model, g));
            self.constraint.pairs.push(CollisionPair {
                geoms,
                params,
                supported,
            });
        }
        let (bodies, dofs) = invweight0(self, model, lift_param);
        self.constraint.body_invweight = bodies;
        self.constraint.dof_invweight = dofs;
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
            (g, geom.body, frame.node),
            offset,
            geom.shape,
        ));
        self.geoms.len() - 1
    }

    /// Places the geoms of the model's contact pairs and indexes the pairs.
    fn add_pairs(&mut self, model: &Spec) {
        for [a, b] in contact_pairs(model) {
            let geoms = [a, b].map(|g| self.geom_frame(model, g));
            let friction = model.geoms[a].friction[0].max(model.geoms[b].friction[0]);
            self.pairs.push(Pair { geoms, friction });
        }
    }
}

/// The nodes of joint `j`, whose coordinates start at q[at] (see the module
/// documentation).
fn node_joints<T: Real>(j: &crate::model::Joint, at: usize) -> Vec<NodeJoint<T>> {
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hinge_transform_keeps_anchor_and_axis_fixed() {
        let axis = Vector3::new(0.0, 0.6, 0.8);
        let anchor = Vector3::new(0.3, -0.2, 0.5);
        let j = NodeJoint::new(
            JointKind::Hinge,
            (axis, anchor),
            0.1,
            Coordinates::Scalar { at: 0 },
        );
        let x = j.transform(&[1.3]);
        // The anchor point has the same coordinates before and after the joint.
        let moved = x.rot * (anchor - x.trans);
        assert!((moved - anchor).norm() < 1e-14);
        assert!((x.rot * axis - axis).norm() < 1e-14);
        assert!((x.apply_motion(&j.s) - j.s).ang.norm() < 1e-14);
        assert!((x.apply_motion(&j.s) - j.s).lin.norm() < 1e-14);
        assert_eq!(j.transform(&[0.1]), Transform::identity());
    }
}
