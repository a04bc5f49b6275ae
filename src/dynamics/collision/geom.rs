//! The geoms of a tree's pairs, placed on their nodes, and the broad phase:
//! whether two geoms' bounding spheres are apart.

use nalgebra::Vector3;

use crate::dynamics::{BodyFrame, Data};
use crate::model::Shape;
use crate::spatial::{lift, Real, Transform};

/// A geom that takes part in a pair, placed in its node's frame.
#[derive(Clone, Debug, PartialEq)]
pub struct GeomFrame<T: Real> {
    /// Index of the geom in the model, and its body.
    pub geom: usize,
    pub body: usize,
    pub node: Option<usize>,
    /// The mocap body it is fixed to (then `node` is None; see
    /// [`crate::dynamics::mocap`]).
    pub mocap: Option<usize>,
    /// From the node's frame (the mocap body's, or the world's) to the geom's frame.
    pub offset: Transform<T>,
    pub shape: Shape,
    /// The shape's bounding radius ([`Spec::rbound`](crate::model::Spec::rbound)), computed once.
    pub rbound: f64,
}

impl<T: Real> GeomFrame<T> {
    /// Model geom `geom` of body `body`, fixed to `frame`'s node or mocap
    /// body by `offset`, its shape bounded by a sphere of radius `rbound`.
    pub fn new(
        (geom, body, frame): (usize, usize, &BodyFrame<T>),
        offset: Transform<T>,
        (shape, rbound): (Shape, f64),
    ) -> Self {
        GeomFrame {
            geom,
            body,
            node: frame.node,
            mocap: frame.mocap,
            offset,
            shape,
            rbound,
        }
    }

    /// From the world to the geom's frame, given each node's world
    /// transform and each mocap body's (`data.world`, `data.mocap`).
    pub fn pose(&self, data: &Data<T>) -> Transform<T> {
        match self.carrier(data) {
            Some(x) => self.offset.compose(x),
            None => self.offset,
        }
    }

    /// The world-to-frame transform of what carries it: its node or mocap
    /// body (None: the world).
    fn carrier<'a>(&self, data: &'a Data<T>) -> Option<&'a Transform<T>> {
        match (self.node, self.mocap) {
            (Some(n), _) => Some(&data.world[n]),
            (None, Some(k)) => Some(&data.mocap[k]),
            (None, None) => None,
        }
    }

    /// The geom's centre in world coordinates.
    pub(super) fn centre(&self, data: &Data<T>) -> Vector3<T> {
        match self.carrier(data) {
            Some(x) => x.trans + x.rot.tr_mul(&self.offset.trans),
            None => self.offset.trans,
        }
    }
}

/// The broad phase of both contact models: whether geoms a and b are
/// farther apart than `reach` by their bounding spheres, a plane's being its
/// half-space (the gap along its normal). A plane may be either geom; when
/// neither is one, the bounding radii are summed as rbound(a) + reach +
/// rbound(b).
pub fn apart<T: Real>(a: &GeomFrame<T>, b: &GeomFrame<T>, data: &Data<T>, reach: f64) -> bool {
    let (a, b) = if a.shape == Shape::Plane && b.shape != Shape::Plane {
        (b, a)
    } else {
        (a, b)
    };
    let gap = a.centre(data) - b.centre(data);
    let limit: T = lift(a.rbound + reach);
    match b.shape {
        Shape::Plane => {
            let x = b.pose(data);
            x.rot.row(2).transpose().dot(&gap) > limit
        }
        _ => gap.norm() > limit + lift::<T>(b.rbound),
    }
}
