//! Tendons in the compiled tree: their kinematics at a state, length,
//! velocity and moment (MuJoCo's mj_tendon and ten_velocity), and their
//! passive forces (mj_passive's tendon spring and damper). Conventions are
//! the model's ([`crate::model::tendon`]): J = dL/dq (nv), L-dot = J v,
//! generalized force J^T f for a force f along the tendon.
//!
//! A spatial tendon's moment is MuJoCo's: per straight segment from a to b
//! (unit direction u, divided by the branch's pulley divisor), u . (J_b -
//! J_a) with J_a, J_b the point Jacobians of a and b on their bodies; a
//! wrapped segment's tangent points move with the geom's body, and the arc
//! adds nothing (the path is stationary in the tangent points, so this is
//! dL/dq). Segments between points on one body add nothing. A segment
//! shorter than mjMINVAL takes u = x and adds no length.

use nalgebra::{Matrix3, Vector3};

use super::constraint::Limit;
use super::kinematics::body_pose;
use super::wrap::{wrap, Obstacle, MINVAL};
use super::{Data, Tree};
use crate::model::SolParams;
use crate::spatial::{lift, Real};

/// One tendon as the algorithms read it.
#[derive(Clone, Debug, PartialEq)]
pub struct TendonConsts<T: Real> {
    pub path: Path<T>,
    /// The dofs it can move, descending and distinct.
    pub support: Vec<usize>,
    pub stiffness: T,
    pub damping: T,
    /// The spring's deadband (lo, hi), resolved at qpos0.
    pub lengthspring: [T; 2],
    /// Its length at qpos0 (MuJoCo's tendon_length0).
    pub length0: T,
    /// J M^-1 J^T at qpos0 (tendon_invweight0), A_ii of its rows.
    pub invweight: T,
    /// The limit, if limited and limits are on (constraint model).
    pub limit: Option<Limit<T>>,
    /// Dry friction (0 when off) and its solver parameters.
    pub frictionloss: (T, SolParams<T>),
}

/// A tendon's path.
#[derive(Clone, Debug, PartialEq)]
pub enum Path<T: Real> {
    /// A fixed tendon's terms: (address in q, dof, coefficient).
    Fixed(Vec<(usize, usize, T)>),
    /// A spatial tendon's elements, in order.
    Spatial(Vec<Element<T>>),
}

/// A point fixed to a body: the body (model index) and its position in the
/// body's frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Point<T: Real> {
    pub body: usize,
    pub pos: Vector3<T>,
}

/// One element of a spatial path.
#[derive(Clone, Debug, PartialEq)]
pub enum Element<T: Real> {
    Site(Point<T>),
    /// A sphere or cylinder of `radius` at `frame` on its body (`rot`: its
    /// axes in the body's frame), with its sidesite if any.
    Geom {
        frame: Point<T>,
        rot: Matrix3<T>,
        radius: T,
        cylinder: bool,
        side: Option<Point<T>>,
    },
    Pulley(T),
}

/// A tendon's kinematics at one state (also an actuator's transmission,
/// [`super::actuation::transmissions`]).
#[derive(Clone, Debug, PartialEq)]
pub struct TendonState<T: Real> {
    /// L (metres, or radians for a fixed tendon of hinges).
    pub length: T,
    /// L-dot = J v.
    pub velocity: T,
    /// J = dL/dq (nv); zero off the tendon's support.
    pub moment: Vec<T>,
}

impl<T: Real> TendonState<T> {
    /// Zero length, velocity and moment (nv).
    pub fn zero(nv: usize) -> Self {
        TendonState {
            length: T::zero(),
            velocity: T::zero(),
            moment: vec![T::zero(); nv],
        }
    }

    /// Adds s J to `out` (nv) over the support `dofs`.
    pub fn add_moment(&self, s: T, dofs: &[usize], out: &mut [T]) {
        for &d in dofs {
            out[d] += s * self.moment[d];
        }
    }

    /// Adds s J to `out` (nv) over every dof.
    pub fn add_dense(&self, s: T, out: &mut [T]) {
        for (o, m) in out.iter_mut().zip(&self.moment) {
            *o += s * *m;
        }
    }
}

impl<T: Real> TendonConsts<T> {
    /// The dofs it moves, descending and distinct.
    pub fn dofs(&self) -> &[usize] {
        &self.support
    }

    /// Its length, velocity and moment at the state whose frames `data`
    /// holds (`x_up` at q; for a spatial tendon also
    /// [`world_frames`](super::world_frames)).
    pub fn state(&self, tree: &Tree<T>, data: &Data<T>, (q, v): (&[T], &[T])) -> TendonState<T> {
        let mut out = TendonState::zero(tree.nv());
        self.fill_state(tree, data, (q, v), &mut out);
        out
    }

    /// [`Self::state`] into `out` (its moment nv long).
    fn fill_state(
        &self,
        tree: &Tree<T>,
        data: &Data<T>,
        (q, v): (&[T], &[T]),
        out: &mut TendonState<T>,
    ) {
        let moment = &mut out.moment;
        moment.fill(T::zero());
        (out.length, out.velocity) = match &self.path {
            Path::Fixed(terms) => {
                self.add_fixed_moment(T::one(), moment);
                fixed_length(terms, (q, v))
            }
            Path::Spatial(elements) => {
                let length = spatial(tree, data, elements, moment);
                let velocity = self
                    .support
                    .iter()
                    .rev()
                    .fold(T::zero(), |s, &d| s + moment[d] * v[d]);
                (length, velocity)
            }
        };
    }

    /// A fixed tendon's length and velocity at (q, v), which need no
    /// frames; None for a spatial tendon.
    pub fn fixed_length(&self, (q, v): (&[T], &[T])) -> Option<(T, T)> {
        match &self.path {
            Path::Fixed(terms) => Some(fixed_length(terms, (q, v))),
            Path::Spatial(_) => None,
        }
    }

    /// Adds s J of a fixed tendon to `out` (nv); nothing for a spatial one.
    pub fn add_fixed_moment(&self, s: T, out: &mut [T]) {
        if let Path::Fixed(terms) = &self.path {
            for (_, dof, c) in terms {
                out[*dof] += s * *c;
            }
        }
    }

    /// The force along it of its spring and damper at length l and rate ldot.
    fn passive_force(&self, l: T, ldot: T) -> T {
        let [lo, hi] = self.lengthspring;
        let stretch = if l > hi {
            l - hi
        } else if l < lo {
            l - lo
        } else {
            T::zero()
        };
        -self.stiffness * stretch - self.damping * ldot
    }
}

/// L = sum c q and L-dot = sum c v over a fixed path's terms.
fn fixed_length<T: Real>(terms: &[(usize, usize, T)], (q, v): (&[T], &[T])) -> (T, T) {
    let sum = |x: &[T], at: fn(&(usize, usize, T)) -> usize| {
        terms.iter().fold(T::zero(), |s, t| s + t.2 * x[at(t)])
    };
    (sum(q, |t| t.0), sum(v, |t| t.1))
}

/// Every tendon's state into `data.tendon` (frames as [`TendonConsts::state`]),
/// reusing its buffers.
pub fn tendon_states<T: Real>(tree: &Tree<T>, data: &mut Data<T>, (q, v): (&[T], &[T])) {
    let mut states = std::mem::take(&mut data.tendon);
    states.resize_with(tree.tendons.len(), || TendonState::zero(tree.nv()));
    for (t, out) in tree.tendons.iter().zip(&mut states) {
        t.fill_state(tree, data, (q, v), out);
    }
    data.tendon = states;
}

/// Adds every tendon's spring and damper force J^T f to `out` at the
/// states in `data.tendon`.
pub fn add_tendon_forces<T: Real>(tree: &Tree<T>, data: &Data<T>, out: &mut [T]) {
    for (t, s) in tree.tendons.iter().zip(&data.tendon) {
        let f = t.passive_force(s.length, s.velocity);
        s.add_moment(f, &t.support, out);
    }
}

/// A point's world position and its body's node.
fn world_point<T: Real>(
    tree: &Tree<T>,
    data: &Data<T>,
    p: &Point<T>,
) -> (Vector3<T>, Option<usize>) {
    let x = body_pose(tree, data, p.body);
    (x.trans + x.axes() * p.pos, tree.body[p.body].node)
}

/// Adds s u . J_p to `moment`, J_p the Jacobian of the world point p fixed
/// to `node`'s frame.
fn add_point<T: Real>(
    tree: &Tree<T>,
    data: &Data<T>,
    (node, p): (Option<usize>, &Vector3<T>),
    (u, s): (&Vector3<T>, T),
    moment: &mut [T],
) {
    let mut k = node;
    while let Some(i) = k {
        let axis = &data.world_axis[i];
        moment[i] += s * u.dot(&(axis.lin + axis.ang.cross(p)));
        k = tree.parent[i];
    }
}

/// One straight segment a -> b (each a world point, its body and node)
/// scaled by `scale`: its length, its moment added to `moment`.
fn segment<T: Real>(
    tree: &Tree<T>,
    data: &Data<T>,
    ends: [(Vector3<T>, usize, Option<usize>); 2],
    scale: T,
    moment: &mut [T],
) -> T {
    let [(a, body_a, node_a), (b, body_b, node_b)] = ends;
    let dif = b - a;
    let norm = dif.norm();
    let (u, length) = if norm < lift(MINVAL) {
        (Vector3::x(), T::zero())
    } else {
        (dif / norm, norm)
    };
    if body_a != body_b {
        add_point(tree, data, (node_a, &a), (&u, -scale), moment);
        add_point(tree, data, (node_b, &b), (&u, scale), moment);
    }
    length * scale
}

/// A spatial path's length (its moment added to `moment`).
fn spatial<T: Real>(
    tree: &Tree<T>,
    data: &Data<T>,
    elements: &[Element<T>],
    moment: &mut [T],
) -> T {
    let site = |e: &Element<T>| match e {
        Element::Site(p) => {
            let (x, node) = world_point(tree, data, p);
            Some((x, p.body, node))
        }
        _ => None,
    };
    let mut scale = T::one();
    let mut length = T::zero();
    let mut k = 0;
    while k + 1 < elements.len() {
        let (first, second) = (&elements[k], &elements[k + 1]);
        if let Element::Pulley(divisor) = first {
            scale = T::one() / *divisor;
            k += 1;
            continue;
        }
        let Some(a) = site(first) else {
            k += 1;
            continue;
        };
        match second {
            Element::Pulley(_) => k += 1,
            Element::Site(_) => {
                let b = site(second).expect("a site");
                length += segment(tree, data, [a, b], scale, moment);
                k += 1;
            }
            Element::Geom {
                frame,
                rot,
                radius,
                cylinder,
                side,
            } => {
                let b = site(&elements[k + 2]).expect("a geom between sites");
                let x = body_pose(tree, data, frame.body);
                let geom = Obstacle {
                    pos: x.trans + x.axes() * frame.pos,
                    mat: x.axes() * rot,
                    radius: *radius,
                    cylinder: *cylinder,
                };
                let side = side.map(|s| world_point(tree, data, &s).0);
                let node = tree.body[frame.body].node;
                length += match wrap((&a.0, &b.0), &geom, side.as_ref()) {
                    Some((arc, p0, p1)) => {
                        let w0 = (p0, frame.body, node);
                        let w1 = (p1, frame.body, node);
                        let into = segment(tree, data, [a, w0], scale, moment);
                        let out = segment(tree, data, [w1, b], scale, moment);
                        into + arc * scale + out
                    }
                    None => segment(tree, data, [a, b], scale, moment),
                };
                k += 2;
            }
        }
    }
    length
}
