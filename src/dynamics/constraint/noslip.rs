//! MuJoCo's noslip post-processing (mj_solNoSlip): after the main solver,
//! projected Gauss-Seidel sweeps over the frictional rows with the
//! regulariser R removed, so that what the soft model lets slip sticks.
//!
//! With A = J M^-1 J^T and the residual r = J qacc - aref, qacc = a0 +
//! M^-1 J^T f, each sweep minimises 1/2 f^T A f + f^T (J a0 - aref) block by
//! block, the normal forces, limits and equalities held:
//! - dry friction, one row at a time: f_i -= r_i / A_ii, clamped to the
//!   bound (A_ii at least MINVAL);
//! - a pyramid's opposing edges in pairs (f_0 + f_1 held, the split
//!   between them free, each non-negative);
//! - an elliptic cone's frictional rows together: the QCQP of minimising
//!   over the ellipsoid sum (f_k / friction_k)^2 <= f_n^2 (none with f_n <
//!   MINVAL), its answer moved onto the ellipsoid when the bound is active.
//!
//! The blocks' diagonals are clamped at 1e-10; a block step that raises the
//! cost by more than 1e-10 is undone. Islands (dofs linked through rows,
//! by the trees they belong to) sweep on their own: each stops after
//! `iterations` sweeps, or after the first whose improvement, scaled by
//! 1 / (mean inertia max(1, nv)), is below `tolerance` (the first sweep's
//! counts 1/2 sum R f^2 over the island's rows in addition), as MuJoCo
//! 4 runs islands. The acceleration is then a0 + M^-1 J^T f.
//!
//! The sweeps are a fixed sequence of operations once their branches are
//! taken: through dual numbers the step's derivative is that sequence's, the
//! one finite differences see where no branch switches.

use super::{ConstraintKind, RowKind, Rows};
use crate::dynamics::constraint::solver::Solution;
use crate::model::{NoSlip, MINVAL};
use crate::spatial::{lift, Real};

/// A diagonal block of A (at most the five frictional rows of a cone).
type Block<T> = [[T; 5]; 5];

/// The sweeps' buffers, kept across steps.
#[derive(Clone, Debug)]
pub struct Scratch<T: Real> {
    /// Per row, M^-1 J_i^T (nv each).
    w: Vec<T>,
    /// Per row, its island's label.
    island: Vec<usize>,
}

impl<T: Real> Default for Scratch<T> {
    fn default() -> Self {
        Scratch {
            w: vec![],
            island: vec![],
        }
    }
}

/// One block swept: its rows from `start`, and how.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Sweep {
    /// A dry friction row.
    Friction,
    /// Two opposing pyramid edges.
    Edges,
    /// An elliptic cone from its normal row: its dimension and its entry
    /// in [`Rows::cone`].
    Ellipse(usize, usize),
}

/// Runs the noslip sweeps on the solution `out` (its forces; its
/// acceleration recomputed from them) of the rows `rows`, with `a0` the
/// unconstrained acceleration, `minv` applying M^-1 in place, `parent` the
/// tree's parent nodes (the islands) and `mean_inertia` MuJoCo's. Zones in
/// `out` stay the main solver's; `out.noslip` says whether any row was swept.
pub fn noslip<T: Real>(
    rows: &Rows<T>,
    a0: &[T],
    minv: impl Fn(&mut [T]),
    (parent, mean_inertia): (&[Option<usize>], T),
    settings: NoSlip,
    (out, s): (&mut Solution<T>, &mut Scratch<T>),
) {
    let (n, m) = (rows.nv, rows.len());
    out.noslip = false;
    if settings.iterations == 0 || m == 0 {
        return;
    }
    s.w.clear();
    for i in 0..m {
        let start = s.w.len();
        s.w.extend_from_slice(rows.row(i));
        minv(&mut s.w[start..]);
    }
    islands(rows, parent, &mut s.island);
    let blocks = blocks(rows);
    let (force, qacc) = (&mut out.force, &mut out.qacc);
    accelerate(qacc, a0, force, &s.w);
    let scale = T::one() / (mean_inertia * lift(n.max(1) as f64));
    let tolerance: T = lift(settings.tolerance);
    let mut labels = s.island.clone();
    labels.sort_unstable();
    labels.dedup();
    out.noslip = !blocks.is_empty();
    for label in labels.into_iter().filter(|l| *l != usize::MAX) {
        let of_island = |i: &usize| s.island[*i] == label;
        for sweep in 0..settings.iterations {
            let mut improvement = T::zero();
            if sweep == 0 {
                for i in (0..m).filter(of_island) {
                    improvement += lift::<T>(0.5) * force[i] * force[i] * rows.r[i];
                }
            }
            for &(start, how) in blocks.iter().filter(|(i, _)| of_island(i)) {
                let change = match how {
                    Sweep::Friction => {
                        dry_friction(rows, &s.w, start, (&mut force[..], &mut qacc[..]))
                    }
                    Sweep::Edges => edges(rows, &s.w, start, (&mut force[..], &mut qacc[..])),
                    Sweep::Ellipse(dim, cone) => ellipse(
                        rows,
                        &s.w,
                        (start, dim, cone),
                        (&mut force[..], &mut qacc[..]),
                    ),
                };
                improvement -= change;
            }
            if improvement * scale < tolerance {
                break;
            }
        }
    }
    accelerate(qacc, a0, force, &s.w);
}

/// qacc = a0 + sum_i f_i w_i (w_i = M^-1 J_i^T, in rows of a0's length).
fn accelerate<T: Real>(qacc: &mut Vec<T>, a0: &[T], force: &[T], w: &[T]) {
    qacc.clear();
    qacc.extend_from_slice(a0);
    for (f, w) in force.iter().zip(w.chunks_exact(a0.len().max(1))) {
        axpy(qacc, *f, w);
    }
}

/// The blocks a sweep visits in order: the dry friction rows, then each
/// contact's frictional rows (MuJoCo's order: rows of kind friction first).
fn blocks<T: Real>(rows: &Rows<T>) -> Vec<(usize, Sweep)> {
    let mut blocks: Vec<(usize, Sweep)> = (0..rows.len())
        .filter(|&i| rows.kind[i] == RowKind::Friction)
        .map(|i| (i, Sweep::Friction))
        .collect();
    for (origin, range) in rows.by_origin() {
        if origin.kind != ConstraintKind::Contact {
            continue;
        }
        match rows.kind[range.start] {
            RowKind::Cone { dim, cone } if dim > 1 => {
                blocks.push((range.start, Sweep::Ellipse(dim, cone)));
            }
            RowKind::Unilateral if range.len() >= 2 => {
                blocks.extend(range.step_by(2).map(|i| (i, Sweep::Edges)));
            }
            _ => {}
        }
    }
    blocks
}

/// Per row, a label of its island: rows that move dofs of one tree (a
/// root node's descendants) share it, and so do the trees a row links.
fn islands<T: Real>(rows: &Rows<T>, parent: &[Option<usize>], out: &mut Vec<usize>) {
    let root = |mut k: usize| {
        while let Some(p) = parent[k] {
            k = p;
        }
        k
    };
    let mut link: Vec<usize> = (0..parent.len()).collect();
    fn find(link: &mut [usize], mut k: usize) -> usize {
        while link[k] != k {
            link[k] = link[link[k]];
            k = link[k];
        }
        k
    }
    for i in 0..rows.len() {
        let mut dofs = rows.support(i).iter().map(|&k| root(k));
        if let Some(first) = dofs.next() {
            for other in dofs {
                let (a, b) = (find(&mut link, first), find(&mut link, other));
                link[a.max(b)] = a.min(b);
            }
        }
    }
    out.clear();
    for i in 0..rows.len() {
        let label = rows.support(i).first().map_or(usize::MAX, |&k| root(k));
        out.push(if label == usize::MAX {
            label
        } else {
            find(&mut link, label)
        });
    }
}

/// x += a y.
fn axpy<T: Real>(x: &mut [T], a: T, y: &[T]) {
    x.iter_mut().zip(y).for_each(|(x, y)| *x += a * *y);
}

/// Residuals J_i qacc - aref_i of rows start..start + len.
fn residual<T: Real>(rows: &Rows<T>, qacc: &[T], start: usize, len: usize) -> [T; 5] {
    let mut res = [T::zero(); 5];
    for (k, r) in res.iter_mut().enumerate().take(len) {
        *r = rows.dot(start + k, qacc) - rows.aref[start + k];
    }
    res
}

/// A's block of rows start..start + len, its diagonal at least 1e-10.
fn block<T: Real>(rows: &Rows<T>, w: &[T], start: usize, len: usize) -> Block<T> {
    let n = rows.nv;
    let mut a = [[T::zero(); 5]; 5];
    for j in 0..len {
        for k in 0..len {
            a[j][k] = rows.dot(start + j, &w[(start + k) * n..(start + k + 1) * n]);
        }
        a[j][j] = a[j][j].max(lift(1e-10));
    }
    a
}

/// Moves the forces of rows start..start + len from `old` to their values
/// in `force` unless that raises the cost by more than 1e-10 (then they are
/// restored); returns the cost's change, updating qacc.
fn settle<T: Real>(
    (rows, w, a): (&Rows<T>, &[T], &Block<T>),
    (start, len): (usize, usize),
    (old, res): (&[T; 5], &[T; 5]),
    (force, qacc): (&mut [T], &mut [T]),
) -> T {
    let mut delta = [T::zero(); 5];
    for k in 0..len {
        delta[k] = force[start + k] - old[k];
    }
    let mut change = T::zero();
    for j in 0..len {
        let row: T = (0..len).fold(T::zero(), |s, k| s + a[j][k] * delta[k]);
        change += lift::<T>(0.5) * delta[j] * row + delta[j] * res[j];
    }
    if change > lift(1e-10) {
        force[start..start + len].copy_from_slice(&old[..len]);
        return T::zero();
    }
    let n = rows.nv;
    for k in 0..len {
        axpy(qacc, delta[k], &w[(start + k) * n..(start + k + 1) * n]);
    }
    change
}

/// A dry friction row's step; returns its cost change.
fn dry_friction<T: Real>(
    rows: &Rows<T>,
    w: &[T],
    i: usize,
    (force, qacc): (&mut [T], &mut [T]),
) -> T {
    let n = rows.nv;
    let res = rows.dot(i, qacc) - rows.aref[i];
    let a = rows.dot(i, &w[i * n..(i + 1) * n]).max(lift(MINVAL));
    let old = force[i];
    let bound = rows.floss[i];
    force[i] = (old - res / a).max(-bound).min(bound);
    let delta = force[i] - old;
    axpy(qacc, delta, &w[i * n..(i + 1) * n]);
    lift::<T>(0.5) * delta * delta * a + delta * res
}

/// Two opposing pyramid edges from row j: their sum held, its split
/// minimising the cost with both non-negative.
fn edges<T: Real>(rows: &Rows<T>, w: &[T], j: usize, (force, qacc): (&mut [T], &mut [T])) -> T {
    let res = residual(rows, qacc, j, 2);
    let a = block(rows, w, j, 2);
    let mut old = [T::zero(); 5];
    old[..2].copy_from_slice(&force[j..j + 2]);
    let b: [T; 2] = std::array::from_fn(|k| res[k] - a[k][0] * old[0] - a[k][1] * old[1]);
    let half: T = lift(0.5);
    let mid = half * (old[0] + old[1]);
    let k1 = a[0][0] + a[1][1] - a[0][1] - a[1][0];
    let k0 = mid * (a[0][0] - a[1][1]) + b[0] - b[1];
    let (f0, f1) = if k1 < lift(MINVAL) {
        (mid, mid)
    } else {
        let y = -k0 / k1;
        if y < -mid {
            (T::zero(), mid + mid)
        } else if y > mid {
            (mid + mid, T::zero())
        } else {
            (mid + y, mid - y)
        }
    };
    (force[j], force[j + 1]) = (f0, f1);
    settle((rows, w, &a), (j, 2), (&old, &res), (force, qacc))
}

/// An elliptic cone's frictional rows (its normal row at `i`, `dim` rows in
/// all): the QCQP over the friction ellipsoid of the normal force.
fn ellipse<T: Real>(
    rows: &Rows<T>,
    w: &[T],
    (i, dim, cone): (usize, usize, usize),
    (force, qacc): (&mut [T], &mut [T]),
) -> T {
    let (start, len) = (i + 1, dim - 1);
    let res = residual(rows, qacc, start, len);
    let a = block(rows, w, start, len);
    let mut old = [T::zero(); 5];
    old[..len].copy_from_slice(&force[start..start + len]);
    let mut b = [T::zero(); 5];
    for j in 0..len {
        b[j] = (0..len).fold(res[j], |s, k| s - a[j][k] * old[k]);
    }
    let normal = force[i];
    let friction = &rows.cone[cone].1[..len];
    if normal < lift(MINVAL) {
        force[start..start + len].fill(T::zero());
    } else {
        let (mut x, active) = qcqp(&a, &b, friction, normal, len);
        if active {
            let s = (0..len).fold(T::zero(), |s, k| {
                s + x[k] * x[k] / (friction[k] * friction[k])
            });
            let scale = (normal * normal / s.max(lift(MINVAL))).sqrt();
            x.iter_mut().for_each(|x| *x *= scale);
        }
        force[start..start + len].copy_from_slice(&x[..len]);
    }
    settle((rows, w, &a), (start, len), (&old, &res), (force, qacc))
}

/// min 1/2 x^T A x + x^T b subject to sum (x_k / d_k)^2 <= r^2 (n <= 5),
/// MuJoCo's mju_QCQP: in the scaled x_k / d_k, Newton's method on the
/// multiplier la of (A + la) x = -b, at most 20 steps; zero where A + la
/// is singular (n <= 3: its determinant below 1e-10; else a Cholesky pivot
/// below 1e-10). Returns x and whether the bound is active (la != 0).
fn qcqp<T: Real>(a: &Block<T>, b: &[T; 5], d: &[T], r: T, n: usize) -> ([T; 5], bool) {
    let mut scaled = [[T::zero(); 5]; 5];
    let mut bs = [T::zero(); 5];
    for i in 0..n {
        bs[i] = b[i] * d[i];
        for j in 0..n {
            scaled[i][j] = a[i][j] * d[i] * d[j];
        }
    }
    let tiny: T = lift(1e-10);
    let mut la = T::zero();
    let mut x = [T::zero(); 5];
    for _ in 0..20 {
        let mut l = scaled;
        (0..n).for_each(|k| l[k][k] += la);
        let Some(l) = cholesky(l, n, tiny) else {
            return ([T::zero(); 5], false);
        };
        x = bs.map(|v| -v);
        chol_solve(&l, n, &mut x);
        let val = (0..n).fold(-r * r, |s, k| s + x[k] * x[k]);
        if val < tiny {
            break;
        }
        let mut px = x;
        chol_solve(&l, n, &mut px);
        let deriv = (0..n).fold(T::zero(), |s, k| s + x[k] * px[k]) * lift(-2.0);
        let delta = -val / deriv;
        if delta < tiny {
            break;
        }
        la += delta;
    }
    for k in 0..n {
        x[k] *= d[k];
    }
    (x, la != T::zero())
}

/// The lower Cholesky factor of the leading n x n of `a`, or none where
/// MuJoCo's QCQP calls it singular (see [`qcqp`]).
fn cholesky<T: Real>(mut a: Block<T>, n: usize, tiny: T) -> Option<Block<T>> {
    let mut det = T::one();
    for j in 0..n {
        let pivot = (0..j).fold(a[j][j], |s, k| s - a[j][k] * a[j][k]);
        if pivot <= T::zero() || (n > 3 && pivot < tiny) {
            return None;
        }
        det *= pivot;
        a[j][j] = pivot.sqrt();
        for i in j + 1..n {
            a[i][j] = (0..j).fold(a[i][j], |s, k| s - a[i][k] * a[j][k]) / a[j][j];
        }
    }
    (n > 3 || det >= tiny).then_some(a)
}

/// x <- (L L^T)^-1 x.
fn chol_solve<T: Real>(l: &Block<T>, n: usize, x: &mut [T; 5]) {
    for i in 0..n {
        x[i] = (0..i).fold(x[i], |s, k| s - l[i][k] * x[k]) / l[i][i];
    }
    for i in (0..n).rev() {
        x[i] = (i + 1..n).fold(x[i], |s, k| s - l[k][i] * x[k]) / l[i][i];
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dynamics::constraint::Origin;

    /// One dof of mass 2 with a dry friction row J = 1 (bound 1, R = 0.1),
    /// at rest, pushed by a0: the soft solver's force, then the sweeps.
    fn friction_row(a0: f64) -> Solution<f64> {
        let rows = Rows {
            j: vec![1.0],
            nv: 1,
            dofs: vec![0],
            span: vec![(0, 1)],
            kind: vec![RowKind::Friction],
            origin: vec![Origin {
                kind: ConstraintKind::DofFriction,
                id: 0,
            }],
            aref: vec![0.0],
            r: vec![0.1],
            floss: vec![1.0],
            ..Rows::default()
        };
        let mass = 2.0;
        // The soft optimum: f = -(a0) / (1 / m + R), clamped to the bound.
        let force = (-a0 / (1.0 / mass + 0.1)).clamp(-1.0, 1.0);
        let mut out = Solution {
            force: vec![force],
            qacc: vec![a0 + force / mass],
            ..Solution::default()
        };
        let settings = NoSlip {
            iterations: 5,
            tolerance: 1e-6,
        };
        noslip(
            &rows,
            &[a0],
            |x: &mut [f64]| x[0] /= mass,
            (&[None], mass),
            settings,
            (&mut out, &mut Scratch::default()),
        );
        out
    }

    #[test]
    fn dry_friction_sticks_below_its_bound_and_slides_at_it() {
        // Below the bound (m a0 = 0.6 < 1): the soft solution creeps, the sweeps stop it.
        let stuck = friction_row(0.3);
        assert!(stuck.noslip);
        assert!(stuck.qacc[0].abs() < 1e-15 && (stuck.force[0] + 0.6).abs() < 1e-15);
        // Above it: the force is the bound either way.
        let sliding = friction_row(3.0);
        assert_eq!(sliding.force[0], -1.0);
        assert!((sliding.qacc[0] - 2.5).abs() < 1e-15);
    }

    /// The QCQP's answer satisfies its optimality conditions: inside the
    /// ellipsoid the unconstrained minimiser; on it, A x + b = -la D^-2 x
    /// with la > 0.
    #[test]
    fn qcqp_answers_satisfy_the_optimality_conditions() {
        let mut a = [[0.0; 5]; 5];
        let full = [
            [2.0, 0.3, -0.1, 0.2, 0.0],
            [0.3, 1.5, 0.2, 0.0, 0.1],
            [-0.1, 0.2, 1.2, 0.1, 0.0],
            [0.2, 0.0, 0.1, 1.8, 0.3],
            [0.0, 0.1, 0.0, 0.3, 1.1],
        ];
        let d = [0.9, 0.6, 0.5, 0.4, 0.7];
        for n in [2, 3, 5] {
            for i in 0..n {
                a[i][..n].copy_from_slice(&full[i][..n]);
            }
            let b = [0.4, -0.7, 0.01, 0.02, -0.01];
            for (r, active) in [(0.1, true), (100.0, false)] {
                let (x, on) = qcqp(&a, &b, &d, r, n);
                assert_eq!(on, active, "n = {n}, r = {r}");
                let g: Vec<f64> = (0..n)
                    .map(|i| (0..n).map(|k| a[i][k] * x[k]).sum::<f64>() + b[i])
                    .collect();
                if !active {
                    assert!(g.iter().all(|g| g.abs() < 1e-12), "{g:?}");
                    continue;
                }
                let norm: f64 = (0..n).map(|k| (x[k] / d[k]).powi(2)).sum();
                assert!((norm - r * r).abs() < 1e-9);
                let la = -g[0] * d[0] * d[0] / x[0];
                assert!(la > 0.0);
                for k in 0..n {
                    assert!((g[k] + la * x[k] / (d[k] * d[k])).abs() < 1e-7, "n = {n}");
                }
            }
        }
    }
}
