//! The constraint solver: MuJoCo's primal problem, solved by Newton's method
//! with an exact line search until the answer is exact.
//!
//! The constrained acceleration a minimises
//!   c(a) = 1/2 (a - a0)^T M (a - a0) + sum_rows s(J a - aref),
//! with a0 = M^-1 (forces without constraints) and, for jar = J a - aref:
//! - dry friction (bound F, D = 1/R): 1/2 D jar^2 while |jar| < R F, else the
//!   linear continuation F |jar| - 1/2 R F^2;
//! - equality rows: 1/2 D jar^2 on both sides;
//! - unilateral rows (limits, pyramid edges, frictionless contacts): 1/2 D
//!   jar^2 while jar < 0, else 0;
//! - elliptic cones: MuJoCo's three zones (inside the dual cone: nothing;
//!   below it: 1/2 sum D jar^2; between: 1/2 D0 / (mu^2 (1 + mu^2)) (N - mu
//!   T)^2 in the scaled coordinates N = mu jar_0, T = |friction_k jar_k|).
//!
//! The cost is strictly convex (M positive definite), so its minimiser is
//! unique: the answer depends on nothing but the problem (not on the start,
//! not on the row order), to rounding. The constraint forces are f = -ds/djar
//! and M (a - a0) = J^T f.
//!
//! Newton's method: H = M + J^T (d^2 s) J built on the zones at the current
//! point, direction -H^-1 grad. The full step minimises the cost with those
//! zones; where no cone is in its middle zone and the zones are the same at
//! the full step, the cost's gradient vanishes there: it is the exact
//! minimiser, and the solver stops. Otherwise the step length minimises c
//! along the direction (its derivative is monotone; safeguarded Newton inside
//! a bracket). With a cone in the middle zone the iteration stops when a step
//! changes nothing.

use nalgebra::DMatrix;

use super::{RowKind, Rows};
use crate::dynamics::cholesky;
use crate::spatial::{lift, Real};

/// Where a row (or a cone) is on its cost.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Zone {
    /// No force.
    Free,
    /// Quadratic: f = -D jar.
    Quadratic,
    /// Dry friction at its bound, below (-) or above (+).
    LinearNeg,
    LinearPos,
    /// An elliptic cone between its free and quadratic zones.
    Cone,
}

/// The solver's answer. Its buffers are reused by the next solve.
#[derive(Clone, Debug)]
pub struct Solution<T: Real> {
    pub qacc: Vec<T>,
    /// Per row: its force and zone.
    pub force: Vec<T>,
    pub zone: Vec<Zone>,
    pub iterations: usize,
    /// False if the iteration limit stopped the solver first.
    pub converged: bool,
    /// The Cholesky factor ([`cholesky`], nv x nv) of the cost's Hessian
    /// M + J^T D J over the quadratic rows of `zone`, valid when `factored`:
    /// the solver's last factor was on the final zones, no cone in its middle.
    pub hessian: Vec<T>,
    pub factored: bool,
    /// Whether the noslip sweeps ([`super::noslip`]) then moved frictional
    /// forces: `force` and `qacc` are theirs, `zone` the solver's.
    pub noslip: bool,
}

impl<T: Real> Default for Solution<T> {
    fn default() -> Self {
        Solution {
            qacc: vec![],
            force: vec![],
            zone: vec![],
            iterations: 0,
            converged: false,
            hessian: vec![],
            factored: false,
            noslip: false,
        }
    }
}

/// An elliptic cone in its middle zone: its first row, its dimension and
/// its Hessian (the first `dim` rows and columns).
type ConeHessian<T> = (usize, usize, [[T; 6]; 6]);

/// Forces, zones and (optionally) the cones' Hessians of the row costs at
/// one residual.
#[derive(Clone, Debug)]
struct Eval<T: Real> {
    force: Vec<T>,
    zone: Vec<Zone>,
    cones: Vec<ConeHessian<T>>,
}

impl<T: Real> Default for Eval<T> {
    fn default() -> Self {
        Eval {
            force: vec![],
            zone: vec![],
            cones: vec![],
        }
    }
}

/// The solver's buffers, kept across solves so that solving allocates nothing.
#[derive(Clone, Debug)]
pub struct Scratch<T: Real> {
    /// At the current point, and at a trial point or along the line search.
    eval: Eval<T>,
    trial_eval: Eval<T>,
    /// Residuals J a - aref at the current point and J dir (or a trial's).
    jar: Vec<T>,
    jd: Vec<T>,
    grad: Vec<T>,
    dir: Vec<T>,
    trial: Vec<T>,
    md: Vec<T>,
}

impl<T: Real> Default for Scratch<T> {
    fn default() -> Self {
        Scratch {
            eval: Eval::default(),
            trial_eval: Eval::default(),
            jar: vec![],
            jd: vec![],
            grad: vec![],
            dir: vec![],
            trial: vec![],
            md: vec![],
        }
    }
}

/// The forces and zones at residual `jar` into `force` and `zone`, and the
/// Hessians of the cones in their middle zone into `cones` when given.
fn evaluate<T: Real>(
    rows: &Rows<T>,
    jar: &[T],
    (force, zone): (&mut Vec<T>, &mut Vec<Zone>),
    mut cones: Option<&mut Vec<ConeHessian<T>>>,
) {
    let n = rows.len();
    force.clear();
    force.resize(n, T::zero());
    zone.clear();
    zone.resize(n, Zone::Free);
    if let Some(cones) = cones.as_mut() {
        cones.clear();
    }
    let mut i = 0;
    while i < n {
        let d = T::one() / rows.r[i];
        match rows.kind[i] {
            RowKind::Friction => {
                let bound = rows.r[i] * rows.floss[i];
                (force[i], zone[i]) = if jar[i] <= -bound {
                    (rows.floss[i], Zone::LinearNeg)
                } else if jar[i] >= bound {
                    (-rows.floss[i], Zone::LinearPos)
                } else {
                    (-d * jar[i], Zone::Quadratic)
                };
            }
            RowKind::Equality => {
                (force[i], zone[i]) = (-d * jar[i], Zone::Quadratic);
            }
            RowKind::Unilateral => {
                if jar[i] < T::zero() {
                    (force[i], zone[i]) = (-d * jar[i], Zone::Quadratic);
                }
            }
            RowKind::Cone { dim, cone } => {
                let (mu, friction) = rows.cone[cone];
                let hessian = cones.is_some();
                let (z, h) = cone_zone(rows, i, dim, (mu, &friction), jar, force, hessian);
                if let (Some(cones), Some(h)) = (cones.as_mut(), h) {
                    cones.push((i, dim, h));
                }
                zone[i..i + dim].fill(z);
                i += dim;
                continue;
            }
            RowKind::ConeRest => unreachable!("cone rows follow their first row"),
        }
        i += 1;
    }
}

/// An elliptic cone's zone and forces (MuJoCo's formulas), with its
/// Hessian in the middle zone when asked.
fn cone_zone<T: Real>(
    rows: &Rows<T>,
    i: usize,
    dim: usize,
    (mu, friction): (T, &[T; 5]),
    jar: &[T],
    force: &mut [T],
    hessian: bool,
) -> (Zone, Option<[[T; 6]; 6]>) {
    let scale = |k: usize| if k == 0 { mu } else { friction[k - 1] };
    let mut u = [T::zero(); 6];
    for k in 0..dim {
        u[k] = jar[i + k] * scale(k);
    }
    let normal = u[0];
    let tangent = u[1..dim].iter().fold(T::zero(), |s, x| s + *x * *x).sqrt();
    let zero = T::zero();
    if normal >= mu * tangent || (tangent <= zero && normal >= zero) {
        return (Zone::Free, None);
    }
    if mu * normal + tangent <= zero || (tangent <= zero && normal < zero) {
        for k in 0..dim {
            force[i + k] = -jar[i + k] / rows.r[i + k];
        }
        return (Zone::Quadratic, None);
    }
    let d0 = T::one() / rows.r[i];
    let dm = d0 / (mu * mu * (T::one() + mu * mu));
    let nmt = normal - mu * tangent;
    force[i] = -dm * nmt * mu;
    for k in 1..dim {
        force[i + k] = -force[i] / tangent * u[k] * friction[k - 1];
    }
    if !hessian {
        return (Zone::Cone, None);
    }
    let mut h = [[T::zero(); 6]; 6];
    h[0][0] = T::one();
    for k in 1..dim {
        h[0][k] = -mu / tangent * u[k];
        h[k][0] = h[0][k];
        for j in 1..dim {
            h[k][j] = mu * normal / (tangent * tangent * tangent) * u[j] * u[k];
        }
        h[k][k] += mu * mu - mu * normal / tangent;
    }
    for k in 0..dim {
        for j in 0..dim {
            h[k][j] *= dm * scale(k) * scale(j);
        }
    }
    (Zone::Cone, Some(h))
}

fn dot<T: Real>(a: &[T], b: &[T]) -> T {
    a.iter().zip(b).fold(T::zero(), |s, (x, y)| s + *x * *y)
}

/// J x - offset into `out` (offset: aref for the residual, none for J dir).
fn apply_rows<T: Real>(rows: &Rows<T>, x: &[T], offset: Option<&[T]>, out: &mut Vec<T>) {
    out.clear();
    out.extend((0..rows.len()).map(|i| {
        let jx = rows.dot(i, x);
        offset.map_or(jx, |o| jx - o[i])
    }));
}

/// out = M x (M symmetric, column-major).
fn mass_product<T: Real>(m: &DMatrix<T>, x: &[T], out: &mut Vec<T>) {
    let n = x.len();
    out.clear();
    out.resize(n, T::zero());
    for (column, &xj) in m.as_slice().chunks_exact(n).zip(x) {
        out.iter_mut()
            .zip(column)
            .for_each(|(o, mij)| *o += *mij * xj);
    }
}

/// Where Newton's method starts.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Start {
    /// At a0, the acceleration without constraints.
    Unconstrained,
    /// At the solution `out` holds, of a problem close to this one (the
    /// previous stage of an RK4 step).
    Previous,
}

/// Minimises the constrained cost (see the module documentation) for the
/// mass matrix `m`, the unconstrained acceleration `a0` and the rows into
/// `out`, from `start`; `iterations` bounds the Newton steps.
pub fn solve<T: Real>(
    m: &DMatrix<T>,
    a0: &[T],
    rows: &Rows<T>,
    (iterations, start): (usize, Start),
    (out, s): (&mut Solution<T>, &mut Scratch<T>),
) {
    let n = a0.len();
    let a = &mut out.qacc;
    if start == Start::Unconstrained || a.len() != n {
        a.clear();
        a.extend_from_slice(a0);
    }
    out.hessian.resize(n * n, T::zero());
    out.converged = false;
    out.noslip = false;
    let mut factored = false;
    let mut iteration = 0;
    while iteration < iterations {
        iteration += 1;
        apply_rows(rows, a, Some(&rows.aref), &mut s.jar);
        evaluate(
            rows,
            &s.jar,
            (&mut s.eval.force, &mut s.eval.zone),
            Some(&mut s.eval.cones),
        );
        gradient(m, a0, rows, (a, &s.eval.force), (&mut s.grad, &mut s.md));
        hessian(m, rows, &s.eval, &mut out.hessian);
        factored = cholesky::factor(&mut out.hessian, n);
        if !factored {
            break;
        }
        s.dir.clone_from(&s.grad);
        cholesky::solve(&out.hessian, n, &mut s.dir);
        s.dir.iter_mut().for_each(|d| *d = -*d);
        if s.eval.cones.is_empty() {
            // The full step minimises the cost with these zones; if the zones hold
            // there, the cost's gradient vanishes there too: it is the minimiser.
            s.trial.clear();
            s.trial.extend(a.iter().zip(&s.dir).map(|(x, d)| *x + *d));
            let again = &mut s.trial_eval;
            apply_rows(rows, &s.trial, Some(&rows.aref), &mut s.jd);
            evaluate(rows, &s.jd, (&mut again.force, &mut again.zone), None);
            if again.zone == s.eval.zone {
                // One more step from there on the same factor: its gradient is at
                // rounding level, so the correction removes the rounding the large
                // first step left (ill-conditioned H, many stiff rows).
                gradient(
                    m,
                    a0,
                    rows,
                    (&s.trial, &again.force),
                    (&mut s.grad, &mut s.md),
                );
                cholesky::solve(&out.hessian, n, &mut s.grad);
                a.clear();
                a.extend(s.trial.iter().zip(&s.grad).map(|(x, d)| *x - *d));
                out.converged = true;
                break;
            }
        }
        if s.dir.iter().all(|d| *d == T::zero()) {
            out.converged = true;
            break;
        }
        let alpha = line_search(m, a0, rows, a, s);
        let mut moved = false;
        for (x, d) in a.iter_mut().zip(&s.dir) {
            let next = *x + alpha * *d;
            moved |= next != *x;
            *x = next;
        }
        if !moved {
            out.converged = true;
            break;
        }
    }
    apply_rows(rows, a, Some(&rows.aref), &mut s.jar);
    evaluate(rows, &s.jar, (&mut out.force, &mut out.zone), None);
    out.iterations = iteration;
    out.factored = factored && s.eval.cones.is_empty() && s.eval.zone == out.zone;
}

/// The cost's gradient M (a - a0) - J^T f into `grad` (`delta`: scratch).
fn gradient<T: Real>(
    m: &DMatrix<T>,
    a0: &[T],
    rows: &Rows<T>,
    (a, force): (&[T], &[T]),
    (grad, delta): (&mut Vec<T>, &mut Vec<T>),
) {
    delta.clear();
    delta.extend(a.iter().zip(a0).map(|(x, y)| *x - *y));
    mass_product(m, delta, grad);
    for (k, &f) in force.iter().enumerate() {
        rows.sub_transposed(k, f, grad);
    }
}

/// The cost's Hessian M + J^T (d^2 s) J at `eval` into `h` (column-major).
fn hessian<T: Real>(m: &DMatrix<T>, rows: &Rows<T>, eval: &Eval<T>, h: &mut [T]) {
    let n = m.nrows();
    h.copy_from_slice(m.as_slice());
    add_quadratic_rows(h, rows, &eval.zone);
    for (first, dim, hc) in &eval.cones {
        for p in 0..*dim {
            for q in 0..*dim {
                let (jp, jq) = (rows.row(first + p), rows.row(first + q));
                for j in 0..n {
                    for i in 0..n {
                        h[j * n + i] += hc[p][q] * jp[i] * jq[j];
                    }
                }
            }
        }
    }
}

/// Adds J^T D J over the rows in their quadratic zone to `h` (nv x nv,
/// column-major): from h = M, the cost's Hessian when no elliptic cone is
/// in its middle zone.
pub fn add_quadratic_rows<T: Real>(h: &mut [T], rows: &Rows<T>, zone: &[Zone]) {
    for k in (0..rows.len()).filter(|&k| zone[k] == Zone::Quadratic) {
        rows.add_outer(h, T::one() / rows.r[k], k);
    }
}

/// The cost along a + t dir: its Gauss part's slope at t = 0 and curvature
/// ((a - a0)^T M dir, dir^T M dir), with the residual at t = 0 and its rate
/// J dir in the scratch's `jar` and `jd`.
fn slope<T: Real>(rows: &Rows<T>, gauss: (T, T), s: &mut Scratch<T>, t: T) -> (T, T) {
    s.trial.clear();
    s.trial
        .extend(s.jar.iter().zip(&s.jd).map(|(r, d)| *r + t * *d));
    let eval = &mut s.trial_eval;
    evaluate(
        rows,
        &s.trial,
        (&mut eval.force, &mut eval.zone),
        Some(&mut eval.cones),
    );
    let (g1, g2) = gauss;
    let jd = &s.jd;
    let first = g1 + t * g2 - dot(&eval.force, jd);
    let mut second = g2;
    for (k, z) in eval.zone.iter().enumerate() {
        if *z == Zone::Quadratic {
            second += jd[k] * jd[k] / rows.r[k];
        }
    }
    for (i, dim, hc) in &eval.cones {
        for p in 0..*dim {
            for q in 0..*dim {
                second += hc[p][q] * jd[i + p] * jd[i + q];
            }
        }
    }
    (first, second)
}

/// The step t > 0 where the cost's derivative along `s.dir` vanishes: a
/// bracket from t = 0 (a descent direction) to the first doubling of t = 1
/// with a non-negative derivative, then Newton steps kept inside the bracket
/// (bisection otherwise) until t stops changing. `s.jar` holds the residual at a.
fn line_search<T: Real>(
    m: &DMatrix<T>,
    a0: &[T],
    rows: &Rows<T>,
    a: &[T],
    s: &mut Scratch<T>,
) -> T {
    mass_product(m, &s.dir, &mut s.md);
    let gauss = (
        a.iter()
            .zip(a0)
            .zip(&s.md)
            .fold(T::zero(), |acc, ((x, y), md)| acc + *md * (*x - *y)),
        dot(&s.md, &s.dir),
    );
    let dir = std::mem::take(&mut s.dir);
    apply_rows(rows, &dir, None, &mut s.jd);
    s.dir = dir;
    let mut at = |t: T| slope(rows, gauss, s, t);
    let (mut lo, mut hi) = (T::zero(), T::one());
    let two: T = lift(2.0);
    for _ in 0..60 {
        if at(hi).0 >= T::zero() {
            break;
        }
        lo = hi;
        hi *= two;
    }
    let mut t = hi;
    for _ in 0..100 {
        let (g, h) = at(t);
        if g == T::zero() {
            return t;
        }
        if g < T::zero() {
            lo = t;
        } else {
            hi = t;
        }
        let newton = t - g / h;
        let next = if h > T::zero() && newton > lo && newton < hi {
            newton
        } else {
            (lo + hi) / two
        };
        if next == t || hi - lo <= lift::<T>(f64::EPSILON) * hi {
            return next;
        }
        t = next;
    }
    t
}

#[cfg(test)]
mod tests {
    use super::*;

    fn solve(m: &DMatrix<f64>, a0: &[f64], rows: &Rows<f64>, iterations: usize) -> Solution<f64> {
        let mut out = Solution::default();
        super::solve(
            m,
            a0,
            rows,
            (iterations, Start::Unconstrained),
            (&mut out, &mut Scratch::default()),
        );
        out
    }

    /// One dof of mass m with one row J = 1 of regulariser R: a unilateral row
    /// is active when a0 - aref < 0, and then a = (m a0 + aref / R) / (m + 1 / R).
    fn one_row(kind: RowKind, aref: f64, r: f64, floss: f64) -> Rows<f64> {
        Rows {
            j: vec![1.0],
            nv: 1,
            kind: vec![kind],
            aref: vec![aref],
            r: vec![r],
            floss: vec![floss],
            dofs: vec![0],
            span: vec![(0, 1)],
            ..Rows::default()
        }
    }

    #[test]
    fn a_unilateral_row_pushes_only_when_violated() {
        let m = DMatrix::from_element(1, 1, 2.0);
        let rows = one_row(RowKind::Unilateral, 1.0, 0.01, 0.0);
        let s = solve(&m, &[-3.0], &rows, 100);
        let expected = (2.0 * -3.0 + 1.0 / 0.01) / (2.0 + 1.0 / 0.01);
        assert!(s.converged && (s.qacc[0] - expected).abs() < 1e-14);
        assert_eq!(s.zone, vec![Zone::Quadratic]);
        assert!((s.force[0] - 2.0 * (s.qacc[0] + 3.0)).abs() < 1e-12); // M (a - a0) = J^T f
        let free = solve(&m, &[3.0], &rows, 100);
        assert_eq!(
            (free.qacc[0], free.force[0], free.zone[0]),
            (3.0, 0.0, Zone::Free)
        );
    }

    #[test]
    fn dry_friction_saturates_at_its_bound() {
        // A large push: the friction force is the bound F, opposing.
        let m = DMatrix::from_element(1, 1, 1.0);
        let rows = one_row(RowKind::Friction, 0.0, 1e-4, 0.5);
        let s = solve(&m, &[10.0], &rows, 100);
        assert_eq!((s.zone[0], s.force[0]), (Zone::LinearPos, -0.5));
        assert!((s.qacc[0] - 9.5).abs() < 1e-14);
        // A small one: stuck (quadratic zone), almost no motion.
        let s = solve(&m, &[1e-6], &rows, 100);
        assert_eq!(s.zone[0], Zone::Quadratic);
        assert!(s.qacc[0].abs() < 1e-9 && s.force[0] < 0.0);
    }

    #[test]
    fn the_answer_does_not_depend_on_row_order() {
        // Two dofs, three rows in two orders: the same acceleration, bit for bit.
        let m = DMatrix::from_row_slice(2, 2, &[2.0, 0.3, 0.3, 1.0]);
        let rows = |order: [usize; 3]| {
            let all = [([1.0, 0.0], 0.5), ([0.3, 1.0], -0.2), ([1.0, -1.0], 0.1)];
            let mut r = Rows {
                nv: 2,
                ..Rows::default()
            };
            for k in order {
                r.span.push((r.dofs.len(), r.dofs.len() + 2));
                r.dofs.extend([0, 1]);
                r.j.extend(all[k].0);
                r.kind.push(RowKind::Unilateral);
                r.aref.push(all[k].1);
                r.r.push(0.01 * (k + 1) as f64);
                r.floss.push(0.0);
            }
            r
        };
        let a = solve(&m, &[-1.0, -2.0], &rows([0, 1, 2]), 100);
        let b = solve(&m, &[-1.0, -2.0], &rows([2, 0, 1]), 100);
        assert!(a.converged && b.converged);
        assert!((a.qacc[0] - b.qacc[0]).abs() < 1e-15 && (a.qacc[1] - b.qacc[1]).abs() < 1e-15);
        // Nor on where Newton's method starts.
        for guess in [
            [30.0, -40.0],
            [0.0, 0.0],
            b.qacc.clone().try_into().unwrap(),
        ] {
            let mut c = Solution {
                qacc: guess.to_vec(),
                ..Solution::default()
            };
            let start = (100, Start::Previous);
            super::solve(
                &m,
                &[-1.0, -2.0],
                &rows([0, 1, 2]),
                start,
                (&mut c, &mut Scratch::default()),
            );
            assert!(c.converged && c.zone == a.zone, "from {guess:?}");
            assert!((c.qacc[0] - a.qacc[0]).abs() < 1e-15 && (c.qacc[1] - a.qacc[1]).abs() < 1e-15);
        }
    }
}
