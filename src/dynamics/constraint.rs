//! Constraint rows of the constraint model, as MuJoCo builds them: dry
//! friction, joint limits and contacts as rows of a Jacobian J (nefc x nv),
//! each with its regulariser R and reference acceleration aref.
//!
//! Conventions (MuJoCo's, from its Computation chapter):
//! - Row order: dry friction (one row per dof with `frictionloss`), joint
//!   limits (one row per violated side), contacts in collision order.
//! - A limit row has J = +e_i below the range (dist = q - lo) and -e_i
//!   above it (dist = hi - q); it exists while dist < margin.
//! - A contact's rows project J(body 2) - J(body 1) at the contact point on
//!   its frame: condim 1 one normal row; pyramidal cones 2 (condim - 1)
//!   rows, the normal plus and minus mu_k times tangent k (k = 1, 2 sliding,
//!   3 torsional, 4, 5 rolling; torsional and rolling rows use the angular
//!   Jacobian); elliptic cones condim rows (normal, tangents, then angular).
//! - Impedance d = imp(|dist - margin|) in (0, 1) from solimp (clamped as
//!   MuJoCo clamps it); R = max(1e-15, (1 - d) / d * A_ii) with A_ii the
//!   diagonal approximation of J M^-1 J^T from the invweight0 constants;
//!   D = 1 / R. A contact's frictional rows take R_normal / impratio; a
//!   pyramid's rows all take 2 mu^2 R_normal with mu = friction_1 /
//!   sqrt(impratio); an elliptic cone's friction row k takes R_1 mu_1^2 /
//!   mu_k^2.
//! - aref = -B (J v) - K d (dist - margin), with from solref (timeconst,
//!   dampratio) K = 1 / (dmax^2 timeconst^2 dampratio^2) and B = 2 / (dmax
//!   timeconst), or from the direct form (-k, -b) K = k / dmax^2 and B = b /
//!   dmax; timeconst is at least 2 timesteps (`refsafe`); friction rows (dry
//!   friction, an elliptic cone's tangents) have K = 0.

use nalgebra::{Matrix3, Vector3};

use super::collision::{apart, collide, CollisionPair, ConstraintContact, Pre, MINVAL};
use super::kinematics::{point_jacobian, world_frames};
use super::{crba, ltdl_factor, ltdl_solve, Contact, Data, Tree};
use crate::model::{Cone, JointKind, Param, SolParams, SolverOptions, Spec};
use crate::spatial::{lift, Real};

/// MuJoCo's bounds on impedance.
const MIN_IMP: f64 = 0.0001;
const MAX_IMP: f64 = 0.9999;

/// The constants of the constraint model in a tree's scalar.
#[derive(Clone, Debug, PartialEq)]
pub struct ConstraintConsts<T: Real> {
    pub pairs: Vec<CollisionPair<T>>,
    /// Per model body: MuJoCo's body_invweight0 (translation, rotation).
    pub body_invweight: Vec<[T; 2]>,
    /// Per node (dof): dof_invweight0.
    pub dof_invweight: Vec<T>,
    /// Per node: the limit, if the joint is limited and limits are on.
    pub limits: Vec<Option<Limit<T>>>,
    /// Per node: dry friction and its solver parameters (0 when off).
    pub frictionloss: Vec<(T, SolParams<T>)>,
    pub solver: SolverOptions,
    pub timestep: f64,
}

impl<T: Real> ConstraintConsts<T> {
    pub fn empty() -> Self {
        ConstraintConsts {
            pairs: vec![],
            body_invweight: vec![],
            dof_invweight: vec![],
            limits: vec![],
            frictionloss: vec![],
            solver: SolverOptions::default(),
            timestep: 0.0,
        }
    }
}

/// A joint limit: the range, the margin within which its rows exist, and
/// its solver parameters.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Limit<T: Real> {
    pub range: (f64, f64),
    pub margin: f64,
    pub sol: SolParams<T>,
}

/// What a row is, for the solver's cost.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum RowKind {
    /// Dry friction with this bound on the force.
    Friction,
    /// Limits, frictionless contacts and pyramid edges: force >= 0.
    Unilateral,
    /// An elliptic cone of `dim` rows starting at this one (on its first row;
    /// its other rows are `ConeRest`), with its entry in [`Rows::cone`].
    Cone {
        dim: usize,
        cone: usize,
    },
    ConeRest,
}

/// The rows at one state; see the module documentation.
#[derive(Clone, Debug)]
pub struct Rows<T: Real> {
    /// J, row-major: row i is `j[i nv..(i + 1) nv]` ([`Rows::row`]).
    pub j: Vec<T>,
    pub nv: usize,
    /// Per row, the dofs it can move, ascending: `dofs[span.0..span.1]`
    /// ([`Rows::support`]); its other entries of J are zero. A contact's
    /// rows share one span: the dofs on its bodies' paths to the world.
    pub dofs: Vec<usize>,
    pub span: Vec<(usize, usize)>,
    pub kind: Vec<RowKind>,
    pub aref: Vec<T>,
    pub r: Vec<T>,
    /// Dry friction bound (0 for other rows).
    pub floss: Vec<T>,
    /// What the state derivatives read: B of aref = -B (J v) - ..., and
    /// d aref / d dist and d ln R / d dist for the distance of the row's
    /// constraint (a contact's or a limit's; a dry friction row has none).
    pub damping: Vec<T>,
    pub daref_ddist: Vec<T>,
    pub dlog_r_ddist: Vec<T>,
    /// Per elliptic cone: mu of the regularised cone and the five friction
    /// coefficients.
    pub cone: Vec<(T, [T; 5])>,
    /// Per contact of the state: its first row and number of rows (none
    /// when the contact moves no dof).
    pub contact_rows: Vec<(usize, usize)>,
}

impl<T: Real> Default for Rows<T> {
    fn default() -> Self {
        Rows {
            j: vec![],
            nv: 0,
            dofs: vec![],
            span: vec![],
            kind: vec![],
            aref: vec![],
            r: vec![],
            floss: vec![],
            damping: vec![],
            daref_ddist: vec![],
            dlog_r_ddist: vec![],
            cone: vec![],
            contact_rows: vec![],
        }
    }
}

impl<T: Real> Rows<T> {
    /// Empties the rows (keeping their memory) for `nv` dofs.
    fn clear(&mut self, nv: usize) {
        self.nv = nv;
        self.j.clear();
        self.dofs.clear();
        self.span.clear();
        self.kind.clear();
        self.aref.clear();
        self.r.clear();
        self.floss.clear();
        self.damping.clear();
        self.daref_ddist.clear();
        self.dlog_r_ddist.clear();
        self.cone.clear();
        self.contact_rows.clear();
    }

    pub fn row(&self, i: usize) -> &[T] {
        &self.j[i * self.nv..(i + 1) * self.nv]
    }

    /// The dofs row i can move, ascending.
    pub fn support(&self, i: usize) -> &[usize] {
        let (start, end) = self.span[i];
        &self.dofs[start..end]
    }

    /// J_i x, summed over the row's support in ascending order (the dense
    /// sum's value: the other terms are zero).
    pub fn dot(&self, i: usize, x: &[T]) -> T {
        let row = self.row(i);
        self.support(i)
            .iter()
            .fold(T::zero(), |s, &k| s + row[k] * x[k])
    }

    /// out -= J_i^T f.
    pub fn sub_transposed(&self, i: usize, f: T, out: &mut [T]) {
        let row = self.row(i);
        for &k in self.support(i) {
            out[k] -= row[k] * f;
        }
    }

    /// h += w J_i^T J_i (h: nv x nv, column-major), over the row's support.
    pub fn add_outer(&self, h: &mut [T], w: T, i: usize) {
        let (row, n) = (self.row(i), self.nv);
        let support = self.support(i);
        for &c in support {
            let x = row[c];
            for &r in support {
                h[c * n + r] += w * row[r] * x;
            }
        }
    }

    /// Declares the dofs (given descending, distinct) of the next `count` rows.
    fn moving(&mut self, count: usize, dofs: impl IntoIterator<Item = usize>) {
        let start = self.dofs.len();
        self.dofs.extend(dofs);
        self.dofs[start..].reverse();
        let span = (start, self.dofs.len());
        self.span.extend(std::iter::repeat_n(span, count));
    }

    pub fn len(&self) -> usize {
        self.kind.len()
    }

    pub fn is_empty(&self) -> bool {
        self.kind.is_empty()
    }
}

/// MuJoCo's body_invweight0 and dof_invweight0 of a tree built from `spec`,
/// at the reference configuration (mj_setConst), with the body masses and
/// COMs lifted as the tree's were (`lift_param`, see [`Tree::build_with`]).
/// A value that is not finite (inertia so large the mass matrix overflows) is 0.
pub fn invweight0<T: Real>(
    tree: &Tree<T>,
    spec: &Spec,
    lift_param: &impl Fn(Param, usize, f64) -> T,
) -> (Vec<[T; 2]>, Vec<T>) {
    let (bodies, dofs) = invweight0_raw(tree, spec, lift_param);
    let finite = |x: T| if x.is_finite() { x } else { T::zero() };
    (
        bodies.into_iter().map(|b| b.map(finite)).collect(),
        dofs.into_iter().map(finite).collect(),
    )
}

fn invweight0_raw<T: Real>(
    tree: &Tree<T>,
    spec: &Spec,
    lift_param: &impl Fn(Param, usize, f64) -> T,
) -> (Vec<[T; 2]>, Vec<T>) {
    let n = tree.nv();
    let mut data = Data::new(tree);
    let q: Vec<T> = spec.reference_q().into_iter().map(lift).collect();
    crba(tree, &mut data, &q);
    let mut factored = data.mass_matrix.clone();
    ltdl_factor(tree, &mut factored);
    world_frames(tree, &mut data, &vec![T::zero(); n]);
    let three: T = lift(3.0);
    let simple: Vec<bool> = (0..spec.bodies.len())
        .map(|b| slides_only(spec, b))
        .collect();
    let mut bodies = vec![[T::zero(); 2]; spec.bodies.len()];
    for (b, body) in spec.bodies.iter().enumerate().skip(1) {
        let frame = tree.body[b];
        let Some(node) = frame.node else { continue };
        let mass = lift_param(Param::Mass(b), 0, body.mass);
        if simple[b] {
            bodies[b] = [T::one() / mass.max(lift(MINVAL)), T::zero()];
            continue;
        }
        let x = frame.offset.compose(&data.world[node]);
        let com = Vector3::from_fn(|r, _| lift_param(Param::Com(b), r, body.com[r]));
        let com = x.trans + x.axes() * com;
        let (jp, jr) = point_jacobian(tree, &data, node, &com);
        let mut trace = [T::zero(); 2];
        for (k, jac) in [jp, jr].iter().enumerate() {
            for row in jac.row_iter() {
                let mut x: Vec<T> = row.iter().copied().collect();
                ltdl_solve(tree, &factored, &mut x);
                trace[k] += row.iter().zip(&x).fold(T::zero(), |s, (a, b)| s + *a * *b);
            }
        }
        bodies[b] = trace.map(|t| t / three);
    }
    let dofs = (0..n)
        .map(|i| {
            let body = spec.joints[tree.node_joint[i]].body;
            if simple[body] {
                let mass = lift_param(Param::Mass(body), 0, spec.bodies[body].mass);
                return T::one() / mass.max(lift(MINVAL));
            }
            let mut e = vec![T::zero(); n];
            e[i] = T::one();
            ltdl_solve(tree, &factored, &mut e);
            e[i]
        })
        .collect();
    (bodies, dofs)
}

/// MuJoCo's "simple" bodies of level 2, whose invweight0 is 1 / mass: only
/// slide joints along coordinate axes through the body origin, the COM at
/// the origin with principal axes along the body's, a child of the world or
/// of a static child of the world, and no children.
fn slides_only(spec: &Spec, b: usize) -> bool {
    let body = &spec.bodies[b];
    let parent = &spec.bodies[body.parent];
    let root = body.parent == 0 || (parent.parent == 0 && parent.joints.is_empty());
    let joints = &spec.joints[body.joints.clone()];
    let aligned = |a: &Vector3<f64>| a.iter().filter(|x| x.abs() > 1e-14).count() == 1;
    let inertia = body.inertia;
    let diagonal = inertia == Matrix3::from_diagonal(&inertia.diagonal());
    b > 0
        && !joints.is_empty()
        && root
        && body.com == Vector3::zeros()
        && diagonal
        && !spec.bodies.iter().any(|c| c.parent == b)
        && joints
            .iter()
            .all(|j| j.kind == JointKind::Slide && j.anchor == Vector3::zeros() && aligned(&j.axis))
}

/// The contacts at the current state into `out` (`data.world` filled by
/// [`world_frames`]; `pre`: the colliders' scratch).
pub fn contacts<T: Real>(
    tree: &Tree<T>,
    data: &Data<T>,
    (out, pre): (&mut Vec<ConstraintContact<T>>, &mut Vec<Pre<T>>),
) {
    out.clear();
    let pairs = &tree.constraint.pairs;
    for (index, pair) in pairs.iter().enumerate().filter(|(_, p)| p.supported) {
        let geoms = pair.geoms.map(|g| &tree.geoms[g]);
        // Bounding spheres farther apart than the pair's reach hold no contact
        // (MuJoCo's broad phase): the colliders need not run.
        if apart(
            geoms[0],
            geoms[1],
            &data.world,
            pair.params.margin + pair.params.gap,
        ) {
            continue;
        }
        let poses = geoms.map(|g| g.pose(&data.world));
        collide((pairs, index), geoms, poses, (&mut *out, &mut *pre));
    }
}

/// Solver parameters as MuJoCo uses them: solref with its time constant at
/// least two timesteps (when `refsafe`), solimp clamped.
fn effective<T: Real>(sol: &SolParams<T>, solver: &SolverOptions, timestep: f64) -> SolParams<T> {
    let mut s = *sol;
    // At a bound the derivative is the mean of the one-sided ones (what
    // central differences give), as at the ties of pair mixing.
    let at_least = |x: T, lo: f64| {
        let lo: T = lift(lo);
        match x.partial_cmp(&lo) {
            Some(std::cmp::Ordering::Less) => lo,
            Some(std::cmp::Ordering::Equal) => (x + lo) * lift(0.5),
            _ => x,
        }
    };
    let clamp = |x: T| {
        if x > lift(MAX_IMP) {
            lift(MAX_IMP)
        } else {
            at_least(x, MIN_IMP)
        }
    };
    if solver.refsafe && s.solref[0] > T::zero() {
        s.solref[0] = at_least(s.solref[0], 2.0 * timestep);
    }
    s.solimp[0] = clamp(s.solimp[0]);
    s.solimp[1] = clamp(s.solimp[1]);
    s.solimp[2] = at_least(s.solimp[2], 0.0);
    s.solimp[3] = clamp(s.solimp[3]);
    s.solimp[4] = at_least(s.solimp[4], 1.0);
    s
}

/// MuJoCo's impedance at violation `x` = dist - margin (see the module
/// documentation), for an effective solimp.
pub fn impedance<T: Real>(solimp: &[T; 5], x: T) -> T {
    let [dmin, dmax, width, mid, power] = *solimp;
    let one = T::one();
    // MuJoCo takes the mean when dmin = dmax too; the sigmoid below gives
    // the same value there, and the derivatives in dmin and dmax.
    if width <= lift(MINVAL) {
        return (dmin + dmax) * lift(0.5);
    }
    let x = (x / width).abs();
    if x >= one {
        return dmax;
    }
    if x <= T::zero() {
        return dmin;
    }
    let y = if power == one {
        x
    } else if x <= mid {
        x.powf(power) / mid.powf(power - one)
    } else {
        one - (one - x).powf(power) / (one - mid).powf(power - one)
    };
    dmin + y * (dmax - dmin)
}

/// d impedance / d x (see [`impedance`]). Where the law has a kink (x = 0
/// under a linear law, the ends of the width) it is the mean of the
/// one-sided slopes at x = 0 (zero) and the outer side's (zero) at the ends.
pub fn impedance_slope<T: Real>(solimp: &[T; 5], x: T) -> T {
    let [dmin, dmax, width, mid, power] = *solimp;
    let one = T::one();
    if width <= lift(MINVAL) {
        return T::zero();
    }
    let y = (x / width).abs();
    if y >= one || y <= T::zero() {
        return T::zero();
    }
    let dy = if power == one {
        one
    } else if y <= mid {
        power * y.powf(power - one) / mid.powf(power - one)
    } else {
        power * (one - y).powf(power - one) / (one - mid).powf(power - one)
    };
    let sign = if x < T::zero() { -one } else { one };
    (dmax - dmin) * dy * sign / width
}

/// K and B of a reference (see the module documentation).
fn stiffness_damping<T: Real>(solref: &[T; 2], dmax: T) -> (T, T) {
    let [timeconst, ratio] = *solref;
    let floor = |x: T| x.max(lift(MINVAL));
    let k = if timeconst > T::zero() {
        T::one() / floor(dmax * dmax * timeconst * timeconst * ratio * ratio)
    } else {
        -timeconst / floor(dmax * dmax)
    };
    let b = if ratio > T::zero() {
        lift::<T>(2.0) / floor(dmax * timeconst)
    } else {
        -ratio / floor(dmax)
    };
    (k, b)
}

/// One constraint (a block of rows sharing impedance) joining the rows.
struct Block<'a, T: Real> {
    kind: &'a [RowKind],
    /// A_ii per row.
    diag: &'a [T],
    dist: T,
    margin: f64,
    sol: SolParams<T>,
    floss: T,
}

impl<T: Real> Rows<T> {
    /// Appends a block whose rows of J were just appended to `j`:
    /// impedance, R (before a contact's adjustment), aref.
    fn push(
        &mut self,
        block: Block<T>,
        v: &[T],
        consts: &ConstraintConsts<T>,
        friction_ref: Option<[T; 2]>,
    ) {
        let sol = effective(&block.sol, &consts.solver, consts.timestep);
        let x = block.dist - lift::<T>(block.margin);
        let imp = impedance(&sol.solimp, x);
        let slope = impedance_slope(&sol.solimp, x);
        let dmax = sol.solimp[1];
        let first = self.len();
        for (k, &kind) in block.kind.iter().enumerate() {
            let vel = self.dot(first + k, v);
            let elliptic_friction = matches!(kind, RowKind::ConeRest);
            let solref = match friction_ref {
                Some(r) if elliptic_friction && r != [T::zero(); 2] => {
                    effective(
                        &SolParams { solref: r, ..sol },
                        &consts.solver,
                        consts.timestep,
                    )
                    .solref
                }
                _ => sol.solref,
            };
            let (stiff, damp) = stiffness_damping(&solref, dmax);
            let stiff = if kind == RowKind::Friction || elliptic_friction {
                T::zero()
            } else {
                stiff
            };
            let r = (T::one() - imp) * block.diag[k] / imp;
            let clamped = r <= lift(MINVAL);
            self.r.push(if clamped { lift(MINVAL) } else { r });
            self.aref.push(-vel * damp - x * imp * stiff);
            self.damping.push(damp);
            self.daref_ddist.push(-stiff * (slope * x + imp));
            self.dlog_r_ddist.push(if clamped {
                T::zero()
            } else {
                -slope / (imp * (T::one() - imp))
            });
            self.floss.push(block.floss);
            self.kind.push(kind);
        }
    }
}

/// The contacts and rows at (q, v) into `contacts` and `rows`: `data.x_up`
/// at q and [`world_frames`] filled (`pre`: the colliders' scratch).
pub fn rows<T: Real>(
    tree: &Tree<T>,
    data: &Data<T>,
    (q, v): (&[T], &[T]),
    (contacts_out, rows, pre): (
        &mut Vec<ConstraintContact<T>>,
        &mut Rows<T>,
        &mut Vec<Pre<T>>,
    ),
) {
    let consts = &tree.constraint;
    let n = tree.nv();
    contacts(tree, data, (&mut *contacts_out, pre));
    contacts_out.retain(|c| c.dist < lift(c.params.margin));
    rows.clear(n);
    let unit = |rows: &mut Rows<T>, i: usize, sign: T| {
        rows.j
            .extend((0..n).map(|k| if k == i { sign } else { T::zero() }));
        rows.moving(1, [i]);
    };
    for i in 0..n {
        let (floss, sol) = consts.frictionloss[i];
        if floss > T::zero() {
            unit(rows, i, T::one());
            let block = Block {
                kind: &[RowKind::Friction],
                diag: &[consts.dof_invweight[i]],
                dist: T::zero(),
                margin: 0.0,
                sol,
                floss,
            };
            rows.push(block, v, consts, None);
        }
    }
    for i in 0..n {
        let Some(Limit {
            range: (lo, hi),
            margin,
            sol,
        }) = consts.limits[i]
        else {
            continue;
        };
        let x = q[tree.joint[i]
            .coordinate()
            .expect("limits are on hinges and slides")];
        for (dist, sign) in [(x - lift(lo), T::one()), (lift::<T>(hi) - x, -T::one())] {
            if dist < lift(margin) {
                unit(rows, i, sign);
                let block = Block {
                    kind: &[RowKind::Unilateral],
                    diag: &[consts.dof_invweight[i]],
                    dist,
                    margin,
                    sol,
                    floss: T::zero(),
                };
                rows.push(block, v, consts, None);
            }
        }
    }
    for c in contacts_out.iter() {
        contact_rows(tree, data, c, v, rows);
    }
}

/// Appends the rows of contact `c` at velocity `v`.
fn contact_rows<T: Real>(
    tree: &Tree<T>,
    data: &Data<T>,
    c: &ConstraintContact<T>,
    v: &[T],
    rows: &mut Rows<T>,
) {
    let consts = &tree.constraint;
    let n = tree.nv();
    let [b1, b2] = c.bodies;
    let first = rows.len();
    if tree.body[b1].node == tree.body[b2].node {
        // Both bodies on the same dofs: the contact moves none.
        rows.contact_rows.push((first, 0));
        return;
    }
    let dim = c.params.condim;
    let elliptic = consts.solver.cone == Cone::Elliptic && dim > 1;
    let mixes = mixing(dim, elliptic, &c.params.friction);
    // J(body 2) - J(body 1) at the contact point projected on the frame rows
    // (normal, tangents, then angular) per dof, and the contact's rows as
    // their combinations; a dof on both paths adds opposite terms.
    let start = rows.j.len();
    rows.j.resize(start + mixes.len() * n, T::zero());
    let j = &mut rows.j[start..];
    for (body, sign) in [(b2, T::one()), (b1, -T::one())] {
        let mut k = tree.body[body].node;
        while let Some(i) = k {
            let s = &data.world_axis[i];
            let (jp, jr) = ((s.lin + s.ang.cross(&c.pos)) * sign, s.ang * sign);
            let mut frame = [T::zero(); 6];
            for (m, f) in frame.iter_mut().enumerate().take(dim) {
                let (jac, axis) = if m < 3 { (&jp, m) } else { (&jr, m - 3) };
                *f = c.frame.row(axis).transpose().dot(jac);
            }
            for (row, mix) in j.chunks_exact_mut(n).zip(mixes.iter()) {
                row[i] += mix
                    .iter()
                    .zip(&frame)
                    .fold(T::zero(), |s, (m, f)| s + *m * *f);
            }
            k = tree.parent[i];
        }
    }
    let [w1, w2] = [b1, b2].map(|b| consts.body_invweight[b]);
    let (tran, rot) = (w1[0] + w2[0], w1[1] + w2[1]);
    let friction = clamped_friction(&c.params.friction);
    let mut kind = [RowKind::Unilateral; 10];
    let mut diag = [T::zero(); 10];
    let count = mixes.len();
    if dim == 1 {
        diag[0] = tran;
    } else if elliptic {
        for k in 0..dim {
            kind[k] = if k == 0 {
                RowKind::Cone {
                    dim,
                    cone: rows.cone.len(),
                }
            } else {
                RowKind::ConeRest
            };
            diag[k] = if k < 3 { tran } else { rot };
        }
    } else {
        for k in 1..dim {
            let mu = friction[k - 1];
            let a = if k < 3 { tran } else { rot };
            diag[2 * k - 2] = tran + mu * mu * a;
            diag[2 * k - 1] = tran + mu * mu * a;
        }
    }
    let block = Block {
        kind: &kind[..count],
        diag: &diag[..count],
        dist: c.dist,
        margin: c.params.margin,
        sol: c.params.sol,
        floss: T::zero(),
    };
    rows.contact_rows.push((first, count));
    rows.moving(count, path_dofs(tree, [b1, b2]));
    rows.push(block, v, consts, Some(c.params.solreffriction));
    if dim == 1 {
        return;
    }
    let r0 = rows.r[first];
    // Every R of the contact is proportional to the normal's.
    let dlog_r = rows.dlog_r_ddist[first];
    rows.dlog_r_ddist[first..first + count].fill(dlog_r);
    let r1 = r0 / lift(consts.solver.impratio);
    let mu = friction[0] * (r1 / r0).sqrt();
    if elliptic {
        rows.cone.push((mu, friction));
        rows.r[first + 1] = r1;
        for k in 1..dim - 1 {
            rows.r[first + k + 1] = r1 * friction[0] * friction[0] / (friction[k] * friction[k]);
        }
    } else {
        let rpy = (mu * mu + mu * mu) * r0;
        for r in &mut rows.r[first..first + count] {
            *r = rpy;
        }
    }
}

/// The dofs on the paths from two bodies to the world, descending, each once.
fn path_dofs<T: Real>(tree: &Tree<T>, bodies: [usize; 2]) -> impl Iterator<Item = usize> + '_ {
    // Each path descends (a parent's dof comes before its children's): merge.
    let path = |b: usize| std::iter::successors(tree.body[b].node, |&i| tree.parent[i]);
    let (mut a, mut b) = (path(bodies[0]).peekable(), path(bodies[1]).peekable());
    std::iter::from_fn(move || match (a.peek(), b.peek()) {
        (Some(&x), Some(&y)) if x == y => {
            b.next();
            a.next()
        }
        (Some(&x), Some(&y)) if x < y => b.next(),
        (Some(_), _) => a.next(),
        (None, _) => b.next(),
    })
}

/// A contact's friction coefficients as its rows use them (at least 1e-5).
fn clamped_friction<T: Real>(friction: &[T; 5]) -> [T; 5] {
    friction.map(|f| f.max(lift(1e-5)))
}

/// The rows of a contact of `dim` frame rows (normal, tangents, then
/// angular) as combinations of them: row i = sum_k mix[i][k] frame_k. One
/// row (condim 1); an elliptic cone's frame rows; else the pyramid's edges,
/// normal + mu_k tangent_k and normal - mu_k tangent_k for k = 1..dim.
pub fn mixing<T: Real>(dim: usize, elliptic: bool, friction: &[T; 5]) -> Mixing<T> {
    let unit = |k: usize| std::array::from_fn(|j| if j == k { T::one() } else { T::zero() });
    let mut out = Mixing {
        rows: [[T::zero(); 6]; 10],
        len: 0,
    };
    let mut push = |mix: [T; 6]| {
        out.rows[out.len] = mix;
        out.len += 1;
    };
    if dim == 1 || elliptic {
        (0..dim).map(unit).for_each(push);
        return out;
    }
    let friction = clamped_friction(friction);
    for k in 1..dim {
        for sign in [T::one(), -T::one()] {
            let mut mix = unit(0);
            mix[k] = sign * friction[k - 1];
            push(mix);
        }
    }
    out
}

/// A contact's rows as [`mixing`] gives them (at most 10: a pyramid of
/// condim 6), without allocating; derefs to the rows.
#[derive(Clone, Copy, Debug)]
pub struct Mixing<T: Real> {
    rows: [[T; 6]; 10],
    len: usize,
}

impl<T: Real> std::ops::Deref for Mixing<T> {
    type Target = [[T; 6]];
    fn deref(&self) -> &Self::Target {
        &self.rows[..self.len]
    }
}

/// The force of each contact from the rows' forces, as a [`Contact`]
/// (MuJoCo's mj_contactForce, in world coordinates): in the contact frame,
/// a pyramid's normal force is the sum of its edge forces and
/// its k-th frictional component mu_k (f+ - f-) of edge pair k; an elliptic
/// cone's are its row forces. Tangential forces and torsional and rolling
/// moments go to world coordinates through the frame.
pub fn contact_forces<T: Real>(
    contacts: &[ConstraintContact<T>],
    rows: &Rows<T>,
    force: &[T],
) -> Vec<Contact<T>> {
    contacts
        .iter()
        .zip(&rows.contact_rows)
        .map(|(c, &(first, count))| {
            let local = in_frame(c, &force[first..first + count]);
            let row = |k: usize| c.frame.row(k).transpose();
            Contact {
                geoms: c.geoms,
                bodies: c.bodies,
                pos: c.pos,
                normal: row(0),
                dist: c.dist,
                normal_force: local[0],
                friction: row(1) * local[1] + row(2) * local[2],
                torque: row(0) * local[3] + row(1) * local[4] + row(2) * local[5],
                frame: c.frame,
            }
        })
        .collect()
}

/// The first geom pair without a collider that is within reach at the
/// current state (`data.world` filled by [`world_frames`]), as model geom indices.
pub fn unreachable_pair<T: Real>(tree: &Tree<T>, data: &Data<T>) -> Option<[usize; 2]> {
    tree.constraint
        .pairs
        .iter()
        .filter(|p| !p.supported)
        .find(|p| {
            let geoms = p.geoms.map(|g| &tree.geoms[g]);
            !apart(
                geoms[0],
                geoms[1],
                &data.world,
                p.params.margin + p.params.gap,
            )
        })
        .map(|p| p.geoms.map(|g| tree.geoms[g].geom))
}

/// A contact's force in its frame from its rows' forces `f` (see [`contact_forces`]).
fn in_frame<T: Real>(c: &ConstraintContact<T>, f: &[T]) -> [T; 6] {
    let dim = c.params.condim;
    let mut local = [T::zero(); 6];
    if f.is_empty() {
        return local;
    }
    if f.len() == dim {
        local[..dim].copy_from_slice(f);
        return local;
    }
    local[0] = f.iter().fold(T::zero(), |s, x| s + *x);
    for k in 1..dim {
        local[k] = (f[2 * k - 2] - f[2 * k - 1]) * c.params.friction[k - 1];
    }
    local
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn impedance_follows_the_solimp_sigmoid() {
        // dmin 0.9, dmax 0.95, width 0.001, midpoint 0.5, power 2 (MuJoCo's default).
        let s = [0.9, 0.95, 0.001, 0.5, 2.0];
        assert_eq!(impedance::<f64>(&s, 0.0), 0.9);
        assert_eq!(impedance::<f64>(&s, -0.002), 0.95);
        // x = 0.25: below the midpoint, y = x^2 / 0.5 = 0.125.
        assert!((impedance::<f64>(&s, -0.00025) - (0.9 + 0.125 * 0.05)).abs() < 1e-15);
        // x = 0.75: above it, y = 1 - (1 - x)^2 / 0.5 = 0.875; symmetric in the sign.
        assert!((impedance::<f64>(&s, 0.00075) - (0.9 + 0.875 * 0.05)).abs() < 1e-15);
        // Linear (power 1) and flat (dmin = dmax) laws.
        assert!((impedance::<f64>(&[0.5, 0.9, 0.01, 0.5, 1.0], 0.005) - 0.7).abs() < 1e-15);
        assert_eq!(impedance::<f64>(&[0.8, 0.8, 0.01, 0.5, 2.0], 0.3), 0.8);
    }

    #[test]
    fn references_have_mujocos_stiffness_and_damping() {
        // Time constant 0.02 s, damping ratio 1, dmax 0.95.
        let (k, b) = stiffness_damping(&[0.02, 1.0], 0.95);
        assert!((k - 1.0 / (0.95f64.powi(2) * 0.02f64.powi(2))).abs() < 1e-9);
        assert!((b - 2.0 / (0.95 * 0.02)).abs() < 1e-12);
        // The direct form: -k, -b, scaled by dmax.
        assert_eq!(stiffness_damping(&[-1000.0, -10.0], 0.5), (4000.0, 20.0));
        // refsafe raises a time constant below two timesteps.
        let solver = SolverOptions::default();
        let sol = effective(&SolParams::default(), &solver, 0.02);
        assert_eq!(sol.solref[0], 0.04);
        let clamped = effective(
            &SolParams {
                solimp: [0.0, 1.0, -1.0, 0.0, 0.5],
                ..SolParams::default()
            },
            &solver,
            0.001,
        );
        assert_eq!(clamped.solimp, [MIN_IMP, MAX_IMP, 0.0, MIN_IMP, 1.0]);
    }
}
