//! Constraint rows of the constraint model, as MuJoCo builds them: dry
//! friction, joint limits and contacts as rows of a Jacobian J (nefc x nv),
//! each with its regulariser R and reference acceleration aref, and the
//! solver that finds their forces ([`solver`]).
//!
//! Conventions (MuJoCo's, from its Computation chapter):
//! - Every row records its origin ([`Origin`]: MuJoCo's efc_type and efc_id),
//!   the constraint it belongs to; what the solver's cost is ([`RowKind`])
//!   is another matter. What reads rows by constraint (the derivatives, the
//!   contacts' forces) reads the origin, never a row's position.
//! - Row order: the kinds in [`ConstraintKind::ORDER`], MuJoCo's
//!   (mj_instantiateEquality, Friction, Limit, Contact): equalities
//!   ([`equality`]), dry friction (one
//!   row per dof with `frictionloss`, [`friction`]), joint limits (one row
//!   per side within the margin, [`limit`]), contacts in collision order
//!   ([`contact`]). Each kind's file states its rows' J, distance and A_ii.
//! - R and aref from the rows' distance and solver parameters as
//!   [`impedance`](mod@impedance) states; A_ii from the invweight0
//!   constants ([`crate::compile::invweight0`]).
//!
//! # Adding a constraint-row kind
//!
//! A kind is a variant of [`ConstraintKind`] and one file that builds its
//! rows; every `match` on the kind is exhaustive, so the compiler lists the
//! places that must learn it. Worked example, [`equality`] (MuJoCo's
//! efc_type mjCNSTR_EQUALITY, efc_id the equality's index):
//! 1. The constants: `ConstraintConsts::equalities`, compiled where the
//!    tree is built (`src/compile/equality.rs`, as `limits` are).
//! 2. `ConstraintKind::Equality`, first in [`ConstraintKind::ORDER`] (MuJoCo
//!    builds equalities first), and its arm in `ConstraintKind::append`.
//! 3. `equality.rs`, its header stating the rows (J, error, A_ii): it
//!    appends J's rows to `rows.j`, declares their dofs (`Rows::moving`)
//!    and pushes a `impedance::Block` (per-row distances in `pos` where
//!    MuJoCo's efc_pos differs per row; its J-dot v taken off `aref`).
//! 4. A [`RowKind`] only if the solver's cost is new: equality rows are
//!    bilateral (1/2 D jar^2 on both sides), `RowKind::Equality` with its
//!    zone in [`solver`].
//! 5. The derivatives (`crate::derivatives`, module `constraint`): the
//!    kind's arm in `analytic` is false until its partials exist (the step's
//!    Jacobians then come from dual numbers, exact), then its file there
//!    (the rows' partials in q and in the invweight0 constants) and its
//!    arms in the dispatch. The eliminated constraints
//!    (`crate::derivatives::eliminated`, `Elimination::pushes_dof` and
//!    `touching`) learn which directions it may push (a connect or weld: a
//!    wrench on each of its bodies, as a contact's).

use std::ops::Range;
use std::sync::Arc;

use super::collision::{Assets, CollisionPair, ConstraintContact, Pre, Sweep};
use super::{Data, Tree};
use crate::model::SolParams;
use crate::spatial::{lift, Real};

pub mod contact;
pub mod equality;
pub mod friction;
pub mod impedance;
pub mod limit;
pub mod noslip;
pub mod solver;
pub mod tendon;

pub use contact::{contact_forces, contacts, mixing, unreachable_pair, Mixing};
pub use equality::{EqualityConsts, Held, Weld};
pub use impedance::{impedance, impedance_slope};
pub use limit::Limit;

/// The constants of the constraint model in a tree's scalar.
#[derive(Clone, Debug, PartialEq)]
pub struct ConstraintConsts<T: Real> {
    pub pairs: Vec<CollisionPair<T>>,
    /// The meshes and height fields the pairs' colliders read.
    pub assets: Arc<Assets>,
    /// The pairs' sweep-and-prune index (pair reach margin + gap).
    pub sweep: Sweep,
    /// Per model body: MuJoCo's body_invweight0 (translation, rotation).
    pub body_invweight: Vec<[T; 2]>,
    /// Per node (dof): dof_invweight0.
    pub dof_invweight: Vec<T>,
    /// MuJoCo's stat.meaninertia: the mean of M's diagonal at the
    /// reference configuration.
    pub mean_inertia: T,
    /// Per node: the limit, if the joint is limited and limits are on.
    pub limits: Vec<Option<Limit<T>>>,
    /// Per node: dry friction and its solver parameters (0 when off).
    pub frictionloss: Vec<(T, SolParams<T>)>,
    /// The active equalities (none when the `equality` flag is off).
    pub equalities: Vec<EqualityConsts<T>>,
}

impl<T: Real> ConstraintConsts<T> {
    pub fn empty() -> Self {
        ConstraintConsts {
            pairs: vec![],
            assets: Arc::default(),
            sweep: Sweep::default(),
            body_invweight: vec![],
            dof_invweight: vec![],
            mean_inertia: T::one(),
            limits: vec![],
            frictionloss: vec![],
            equalities: vec![],
        }
    }
}

/// Which constraint a row belongs to: its kind and its index among that
/// kind's (MuJoCo's efc_type and efc_id).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Origin {
    pub kind: ConstraintKind,
    /// The equality's index in the model; the dof of dry friction or a
    /// limit; the tendon's index; the contact's index in the state's
    /// contact list.
    pub id: usize,
}

/// The kinds of constraint, each built by its own file.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ConstraintKind {
    /// An equality's rows (mjCNSTR_EQUALITY, [`equality`]).
    Equality,
    /// Dry friction of a dof (mjCNSTR_FRICTION_DOF, [`friction`]).
    DofFriction,
    /// Dry friction of a tendon (mjCNSTR_FRICTION_TENDON, [`tendon`]).
    TendonFriction,
    /// A hinge's or slide's limit, either side (mjCNSTR_LIMIT_JOINT, [`limit`]).
    JointLimit,
    /// A tendon's limit, either side (mjCNSTR_LIMIT_TENDON, [`tendon`]).
    TendonLimit,
    /// A contact (mjCNSTR_CONTACT_*, [`contact`]).
    Contact,
}

impl ConstraintKind {
    /// The kinds in the order their rows are built: MuJoCo's.
    pub const ORDER: [ConstraintKind; 6] = [
        ConstraintKind::Equality,
        ConstraintKind::DofFriction,
        ConstraintKind::TendonFriction,
        ConstraintKind::JointLimit,
        ConstraintKind::TendonLimit,
        ConstraintKind::Contact,
    ];

    /// Appends this kind's rows at the state `at`.
    fn append<T: Real>(self, at: &At<T>, rows: &mut Rows<T>) {
        match self {
            ConstraintKind::Equality => equality::append(at, rows),
            ConstraintKind::DofFriction => friction::append(at, rows),
            ConstraintKind::TendonFriction => tendon::append_friction(at, rows),
            ConstraintKind::JointLimit => limit::append(at, rows),
            ConstraintKind::TendonLimit => tendon::append_limits(at, rows),
            ConstraintKind::Contact => contact::append(at, rows),
        }
    }
}

/// What a row is, for the solver's cost.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum RowKind {
    /// Bilateral (equalities): f = -D jar on both sides.
    Equality,
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
    /// Per row, the constraint it belongs to.
    pub origin: Vec<Origin>,
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
            origin: vec![],
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
        self.origin.clear();
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

    /// Appends the row J = sign e_i (moving dof i alone).
    fn unit(&mut self, i: usize, sign: T) {
        let n = self.nv;
        self.j
            .extend((0..n).map(|k| if k == i { sign } else { T::zero() }));
        self.moving(1, [i]);
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

    /// The rows by constraint: each run of consecutive rows of one origin
    /// (a contact's rows; a dof's limit rows, both sides) and its range.
    pub fn by_origin(&self) -> impl Iterator<Item = (Origin, Range<usize>)> + '_ {
        let mut start = 0;
        std::iter::from_fn(move || {
            let origin = *self.origin.get(start)?;
            let count = self.origin[start..]
                .iter()
                .take_while(|o| **o == origin)
                .count();
            start += count;
            Some((origin, start - count..start))
        })
    }
}

/// What the row builders read: the tree, its frames at (q, v) (`data.x_up`
/// and [`world_frames`](super::world_frames)) and the state's contacts.
struct At<'a, T: Real> {
    tree: &'a Tree<T>,
    data: &'a Data<T>,
    q: &'a [T],
    v: &'a [T],
    contacts: &'a [ConstraintContact<T>],
}

/// The contacts and rows at (q, v) into `contacts` and `rows`: `data.x_up`
/// at q and [`world_frames`](super::world_frames) filled (`pre`: the colliders' scratch).
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
    contacts(tree, data, (&mut *contacts_out, pre));
    contacts_out.retain(|c| c.dist < lift(c.params.margin));
    rows.clear(tree.nv());
    let at = At {
        tree,
        data,
        q,
        v,
        contacts: contacts_out,
    };
    for kind in ConstraintKind::ORDER {
        kind.append(&at, rows);
    }
}
