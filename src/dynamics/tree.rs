//! The numeric form of a model that the algorithms run on, in any scalar
//! (compiled from a spec by [`crate::compile`]).
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

use super::actuation::ActuatorTerm;
use super::collision::GeomFrame;
use super::configuration::{rotation_matrix, Coordinates};
use super::constraint::ConstraintConsts;
use super::contact::{Pair, Soft};
use super::fluid::FluidTerms;
use super::gravcomp::GravcompBody;
use super::tendon::TendonConsts;
use crate::model::{JointKind, Options, SoftOptions};
use crate::spatial::{Inertia, Motion, Real, Transform};

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
    /// The node's dof: its motion subspace follows from kind, axis and anchor.
    pub fn new(
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

/// Where a body's frame sits: a fixed offset from a node's frame, a mocap
/// body's (`mocap`, then `node` is None) or the world's.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BodyFrame<T: Real> {
    pub node: Option<usize>,
    pub mocap: Option<usize>,
    /// From the node's (mocap body's, world's) frame to the body's frame.
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
    /// `opt.gravity` in T.
    pub gravity: Vector3<T>,
    pub body: Vec<BodyFrame<T>>,
    /// The geoms in contact pairs, and the pairs (indices into `geoms`, see
    /// [`super::contact`]); both empty when contacts are off.
    pub geoms: Vec<GeomFrame<T>>,
    pub pairs: Vec<Pair>,
    /// The smooth model's candidate pairs its law has no force for
    /// (indices into `geoms`; see [`crate::compile::lawless_pairs`]).
    pub lawless: Vec<[usize; 2]>,
    /// Per node: the joint's range if it is limited and limits are on
    /// (smooth model).
    pub limits: Vec<Option<(f64, f64)>>,
    pub soft: Soft<T>,
    /// The constraint model's constants (empty under the smooth model).
    pub constraint: ConstraintConsts<T>,
    /// What the medium (`opt.fluid`) acts on (nothing without one).
    pub fluid: FluidTerms<T>,
    /// The actuators ([`super::actuation`]) and the number of activations.
    pub actuators: Vec<ActuatorTerm>,
    pub na: usize,
    /// The bodies with gravity compensation ([`super::gravcomp`]).
    pub gravcomp: Vec<GravcompBody<T>>,
    /// The first node of each standalone free body: a free joint whose body
    /// has no descendants with joints or mass (MuJoCo's mj_isFreeBody; see
    /// [`super::implicit`]).
    pub free_bodies: Vec<usize>,
    /// The mocap bodies' compiled poses, the default mocap input
    /// ([`super::mocap`]): 3 and 4 (w x y z) entries per mocap body.
    pub mocap_pos: Vec<f64>,
    pub mocap_quat: Vec<f64>,
    /// The model's tendons, in model order ([`super::tendon`]).
    pub tendons: Vec<TendonConsts<T>>,
    /// The model's options, as the spec gives them (timestep, integrator,
    /// which law contacts follow, solver, medium): the step reads them here.
    /// Those with a T-valued form are lifted beside them (`gravity`, `soft`).
    pub opt: Options,
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
            lawless: vec![],
            limits: vec![],
            soft: Soft::new(&SoftOptions::default(), [T::zero(); 3]),
            constraint: ConstraintConsts::empty(),
            fluid: FluidTerms::none(),
            actuators: vec![],
            na: 0,
            gravcomp: vec![],
            free_bodies: vec![],
            mocap_pos: vec![],
            mocap_quat: vec![],
            tendons: vec![],
            opt: Options::default(),
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
            || !c.equalities.is_empty()
            || self
                .tendons
                .iter()
                .any(|t| t.limit.is_some() || t.frictionloss.0 > T::zero())
    }

    /// Whether a tendon's path runs through sites (its kinematics read the
    /// world frames).
    pub fn has_spatial_tendons(&self) -> bool {
        self.tendons
            .iter()
            .any(|t| matches!(t.path, super::tendon::Path::Spatial(_)))
    }

    pub fn nv(&self) -> usize {
        self.parent.len()
    }

    pub fn nq(&self) -> usize {
        self.spring_q.len()
    }

    pub fn nu(&self) -> usize {
        self.actuators.len()
    }

    pub fn nmocap(&self) -> usize {
        self.mocap_quat.len() / 4
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
