//! Derivatives of the soft contact and joint-limit forces tau_soft(q, v; k, c, f)
//! (see [`crate::dynamics::contact`]), from the evaluation at (q, v) that
//! [`crate::dynamics::acceleration`] leaves in [`Data`].
//!
//! - A joint limit acts on its own dof: d tau_i / d(q_i, v_i) in closed form,
//!   with the softplus s'' = s' (1 - s') / w.
//! - Contacts, in world coordinates: with S_i node i's motion axis and F_i the
//!   contact force on node i's subtree (about the world origin),
//!   tau_i = S_i . F_i, so d tau_i = dS_i . F_i + S_i . dF_i, where
//!   dS_i / dq_j = S_j x S_i for j a strict ancestor of i (S_i does not
//!   depend on v or the parameters), and dF_i sums the pairs below node i.
//! - A pair's forces are a function of its two geoms' world poses and their
//!   nodes' world velocities V ([`pair_contacts`]). A change of q_j moves
//!   every node below j by the twist S_j (a point x by S_j.lin + S_j.ang x x,
//!   a direction e by S_j.ang x e) and changes its velocity by S_j x (V - V_j);
//!   a change of v_j changes its velocity by S_j. One dual-number evaluation
//!   of the pair's forces per direction that reaches one of its geoms (and per
//!   contact parameter) gives the pair's dF exactly; pairs without contacts
//!   at (q, v) contribute nothing.
//!
//! The other parameters (inertial, joint) do not enter tau_soft.

use nalgebra::{DMatrix, Matrix3};
use num_dual::Dual64;

use crate::dynamics::collision::Contact;
use crate::dynamics::contact::{pair_contacts, softplus, Pair, Soft, CUTOFF_WIDTHS};
use crate::dynamics::{Data, Tree};
use crate::model::Param;
use crate::spatial::{Force, Motion, Transform};
use crate::Model;

/// Where the columns of a residual Jacobian live: q and v (each nv wide, at
/// 0 and `v_start`) if the state is asked for, and the first column of each
/// parameter in `params`.
pub(super) struct Columns<'a> {
    pub state: bool,
    pub v_start: usize,
    pub params: &'a [(Param, usize)],
}

/// Subtracts d tau_soft / d(column) from each column of `r` (the residual R
/// holds -tau_soft); `data` holds the soft forces' evaluation at (q, v).
pub(super) fn subtract_soft_derivatives(
    model: &Model,
    data: &Data<f64>,
    (q, v): (&[f64], &[f64]),
    columns: &Columns,
    r: &mut DMatrix<f64>,
) {
    let tree = model.tree();
    if columns.state {
        subtract_limit_derivatives(tree, (q, v), columns.v_start, r);
    }
    if data.contacts.is_empty() {
        return;
    }
    let (n, width) = (tree.nv(), r.ncols());
    // dF per node and column, world coordinates.
    let mut df = vec![Force::zero(); n * width];
    let mut scratch = vec![];
    let mut next = 0;
    for pair in &tree.pairs {
        let geoms = pair.geoms.map(|g| &tree.geoms[g]);
        let ids = [geoms[1].geom, geoms[0].geom];
        let count = data.contacts[next..]
            .iter()
            .take_while(|c| c.geoms == ids)
            .count();
        next += count;
        if count > 0 {
            let mut add = |col: usize, contacts: &[Contact<Dual64>]| {
                for c in contacts {
                    let f = c.force();
                    let d = Force::new(c.pos.cross(&f).map(|x| x.eps), f.map(|x| x.eps));
                    if let Some(k) = geoms[0].node {
                        df[k * width + col] += d;
                    }
                    if let Some(k) = geoms[1].node {
                        df[k * width + col] += -d;
                    }
                }
            };
            pair_derivatives(tree, data, pair, columns, &mut scratch, &mut add);
        }
    }
    for i in (0..n).rev() {
        let s = data.world_axis[i];
        for col in 0..width {
            let d = df[i * width + col];
            r[(i, col)] -= s.dot(&d);
            if let Some(p) = tree.parent[i] {
                df[p * width + col] += d;
            }
        }
        if columns.state {
            let mut ancestor = tree.parent[i];
            while let Some(j) = ancestor {
                r[(i, j)] -= data.world_axis[j]
                    .cross_motion(&s)
                    .dot(&data.world_force[i]);
                ancestor = tree.parent[j];
            }
        }
    }
}

/// Evaluates one pair's contacts in dual numbers once per direction that
/// reaches it (see the module documentation), handing each column's
/// contacts to `add`.
fn pair_derivatives(
    tree: &Tree<f64>,
    data: &Data<f64>,
    pair: &Pair,
    columns: &Columns,
    contacts: &mut Vec<Contact<Dual64>>,
    add: &mut impl FnMut(usize, &[Contact<Dual64>]),
) {
    let geoms = pair.geoms.map(|g| &tree.geoms[g]);
    let poses = geoms.map(|g| g.pose(data));
    let vels = geoms.map(|g| g.node.map_or(Motion::zero(), |k| data.world_vel[k]));
    let constant = |x: f64| Dual64::from(x);
    let plain_poses = poses.map(|x| moved(&x, None));
    let plain_vels = vels.map(|m| dual_motion(&m, &Motion::zero()));
    let soft = Soft {
        stiffness: constant(tree.soft.stiffness),
        damping: constant(tree.soft.damping),
        friction: constant(tree.soft.friction),
        width: tree.soft.width,
        slip: tree.soft.slip,
        limit_stiffness: tree.soft.limit_stiffness,
        limit_damping: tree.soft.limit_damping,
        limit_width: tree.soft.limit_width,
    };
    let mut run = |col, soft: &Soft<Dual64>, state| {
        contacts.clear();
        pair_contacts(soft, pair, geoms, state, contacts);
        add(col, contacts);
    };
    if columns.state {
        for j in 0..tree.nv() {
            let reached = geoms.map(|g| below(tree, g.node, j));
            if reached == [false, false] {
                continue;
            }
            let (s, vj) = (data.world_axis[j], data.world_vel[j]);
            let pick = |k: usize, on: Transform<Dual64>, off| if reached[k] { on } else { off };
            let q_poses = [0, 1].map(|k| pick(k, moved(&poses[k], Some(&s)), plain_poses[k]));
            let q_vels = [0, 1].map(|k| {
                let dv = s.cross_motion(&(vels[k] - vj));
                let m = dual_motion(&vels[k], &dv);
                if reached[k] {
                    m
                } else {
                    plain_vels[k]
                }
            });
            run(j, &soft, (q_poses, q_vels));
            let v_vels = [0, 1].map(|k| {
                if reached[k] {
                    dual_motion(&vels[k], &s)
                } else {
                    plain_vels[k]
                }
            });
            run(columns.v_start + j, &soft, (plain_poses, v_vels));
        }
    }
    for &(param, col) in columns.params {
        let mut seeded = soft;
        let target = match param {
            Param::ContactStiffness => &mut seeded.stiffness,
            Param::ContactDamping => &mut seeded.damping,
            Param::ContactFriction => &mut seeded.friction,
            _ => continue,
        };
        target.eps = 1.0;
        run(col, &seeded, (plain_poses, plain_vels));
    }
}

/// Whether node `j` is on the path from `node` to the world (node included).
fn below(tree: &Tree<f64>, node: Option<usize>, j: usize) -> bool {
    let mut k = node;
    while let Some(i) = k {
        if i == j {
            return true;
        }
        k = tree.parent[i];
    }
    false
}

/// The pose x as dual numbers, its derivative that of moving it by the
/// world-frame `twist` (none: constant): the origin by twist.lin + w x origin,
/// the axes (columns of rot^T) by w x axis, so rot by -rot [w]x.
fn moved(x: &Transform<f64>, twist: Option<&Motion<f64>>) -> Transform<Dual64> {
    let (d_rot, d_trans) = match twist {
        Some(t) => (-x.rot * t.ang.cross_matrix(), t.lin + t.ang.cross(&x.trans)),
        None => (Matrix3::zeros(), nalgebra::Vector3::zeros()),
    };
    Transform {
        rot: x.rot.zip_map(&d_rot, Dual64::new),
        trans: x.trans.zip_map(&d_trans, Dual64::new),
    }
}

/// A motion with value `m` and derivative `dm`.
fn dual_motion(m: &Motion<f64>, dm: &Motion<f64>) -> Motion<Dual64> {
    Motion::new(
        m.ang.zip_map(&dm.ang, Dual64::new),
        m.lin.zip_map(&dm.lin, Dual64::new),
    )
}

/// Subtracts the joint limits' d tau_i / dq_i and d tau_i / dv_i (columns i
/// and `v_start + i`) from `r`.
fn subtract_limit_derivatives(
    tree: &Tree<f64>,
    (q, v): (&[f64], &[f64]),
    v_start: usize,
    r: &mut DMatrix<f64>,
) {
    let soft = &tree.soft;
    let (k, c, w) = (soft.limit_stiffness, soft.limit_damping, soft.limit_width);
    for (i, range) in tree.limits.iter().enumerate() {
        let Some((lo, hi)) = *range else { continue };
        // Below: tau = k s(d) - c s'(d) v with d = lo - q (sign +1); above:
        // tau = -k s(d) - c s'(d) v with d = q - hi (sign -1).
        for (d, sign) in [(lo - q[i], 1.0), (q[i] - hi, -1.0)] {
            if d > -CUTOFF_WIDTHS * w {
                let (_, ds) = softplus(d, w);
                let dds = ds * (1.0 - ds) / w;
                r[(i, i)] -= -k * ds + sign * c * dds * v[i];
                r[(i, v_start + i)] -= -c * ds;
            }
        }
    }
}
