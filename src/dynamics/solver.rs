//! The constraint solver: MuJoCo's primal problem, solved by Newton's method
//! with an exact line search until the answer is exact.
//!
//! The constrained acceleration a minimises
//!   c(a) = 1/2 (a - a0)^T M (a - a0) + sum_rows s(J a - aref),
//! with a0 = M^-1 (forces without constraints) and, for jar = J a - aref:
//! - dry friction (bound F, D = 1/R): 1/2 D jar^2 while |jar| < R F, else the
//!   linear continuation F |jar| - 1/2 R F^2;
//! - unilateral rows (limits, pyramid edges, frictionless contacts): 1/2 D
//!   jar^2 while jar < 0, else 0;
//! - elliptic cones: MuJoCo's three zones (inside the dual cone: nothing;
//!   below it: 1/2 sum D jar^2; between: 1/2 D0 / (mu^2 (1 + mu^2)) (N - mu
//!   T)^2 in the scaled coordinates N = mu jar_0, T = |friction_k jar_k|).
//!
//! The cost is strictly convex (M positive definite), so its minimiser is
//! unique: the answer depends on nothing but the problem (no warm start, no
//! row order). The constraint forces are f = -ds/djar and M (a - a0) = J^T f.
//!
//! Newton's method: H = M + J^T (d^2 s) J built on the zones at the current
//! point, direction -H^-1 grad. The full step minimises the cost with those
//! zones; where no cone is in its middle zone and the zones are the same at
//! the full step, the cost's gradient vanishes there: it is the exact
//! minimiser, and the solver stops. Otherwise the step length minimises c
//! along the direction (its derivative is monotone; safeguarded Newton inside
//! a bracket). With a cone in the middle zone the iteration stops when a step
//! changes nothing.

use nalgebra::{Cholesky, DMatrix, DMatrixViewMut, DVector};

use super::constraint::{RowKind, Rows};
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

/// The solver's answer.
#[derive(Clone, Debug)]
pub struct Solution<T: Real> {
    pub qacc: Vec<T>,
    /// Per row: its force and zone.
    pub force: Vec<T>,
    pub zone: Vec<Zone>,
    pub iterations: usize,
    /// False if the iteration limit stopped the solver first.
    pub converged: bool,
}

/// Forces, zones and (optionally) the Hessian of the row costs at jar.
struct Eval<T: Real> {
    force: Vec<T>,
    zone: Vec<Zone>,
    /// Per elliptic cone in its middle zone: first row and its Hessian.
    cone_hessians: Vec<(usize, DMatrix<T>)>,
}

fn evaluate<T: Real>(rows: &Rows<T>, jar: &[T], hessians: bool) -> Eval<T> {
    let n = rows.len();
    let mut force = vec![T::zero(); n];
    let mut zone = vec![Zone::Free; n];
    let mut cone_hessians = vec![];
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
            RowKind::Unilateral => {
                if jar[i] < T::zero() {
                    (force[i], zone[i]) = (-d * jar[i], Zone::Quadratic);
                }
            }
            RowKind::Cone { dim, cone } => {
                let (mu, friction) = rows.cone[cone];
                let z = cone_zone(rows, i, dim, (mu, &friction), jar, &mut force, hessians);
                if let Some(h) = z.1 {
                    cone_hessians.push((i, h));
                }
                zone[i..i + dim].fill(z.0);
                i += dim;
                continue;
            }
            RowKind::ConeRest => unreachable!("cone rows follow their first row"),
        }
        i += 1;
    }
    Eval {
        force,
        zone,
        cone_hessians,
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
    hessians: bool,
) -> (Zone, Option<DMatrix<T>>) {
    let scale = |k: usize| if k == 0 { mu } else { friction[k - 1] };
    let u: Vec<T> = (0..dim).map(|k| jar[i + k] * scale(k)).collect();
    let normal = u[0];
    let tangent = u[1..].iter().fold(T::zero(), |s, x| s + *x * *x).sqrt();
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
    if !hessians {
        return (Zone::Cone, None);
    }
    let mut h = DMatrix::zeros(dim, dim);
    h[(0, 0)] = T::one();
    for k in 1..dim {
        h[(0, k)] = -mu / tangent * u[k];
        h[(k, 0)] = h[(0, k)];
        for j in 1..dim {
            h[(k, j)] = mu * normal / (tangent * tangent * tangent) * u[j] * u[k];
        }
        h[(k, k)] += mu * mu - mu * normal / tangent;
    }
    for k in 0..dim {
        for j in 0..dim {
            h[(k, j)] *= dm * scale(k) * scale(j);
        }
    }
    (Zone::Cone, Some(h))
}

fn dot<T: Real>(a: &[T], b: &[T]) -> T {
    a.iter().zip(b).fold(T::zero(), |s, (x, y)| s + *x * *y)
}

/// J a - aref.
fn residual<T: Real>(rows: &Rows<T>, a: &[T]) -> Vec<T> {
    (0..rows.len())
        .map(|i| dot(rows.row(i), a) - rows.aref[i])
        .collect()
}

/// Minimises the constrained cost (see the module documentation) for the
/// mass matrix `m`, the unconstrained acceleration `a0` and the rows;
/// `iterations` bounds the Newton steps.
pub fn solve<T: Real>(m: &DMatrix<T>, a0: &[T], rows: &Rows<T>, iterations: usize) -> Solution<T> {
    let mut a = a0.to_vec();
    let mut converged = false;
    let mut iteration = 0;
    while iteration < iterations {
        iteration += 1;
        let jar = residual(rows, &a);
        let eval = evaluate(rows, &jar, true);
        let (grad, hessian) = gradient_hessian(m, a0, rows, &a, &eval);
        let Some(chol) = Cholesky::new(hessian) else {
            break;
        };
        let dir = -chol.solve(&DVector::from_column_slice(&grad));
        let dir = dir.as_slice();
        if eval.cone_hessians.is_empty() {
            // The full step minimises the cost with these zones; if the zones hold
            // there, the cost's gradient vanishes there too: it is the minimiser.
            let trial: Vec<T> = a.iter().zip(dir).map(|(x, d)| *x + *d).collect();
            let again = evaluate(rows, &residual(rows, &trial), false);
            if again.zone == eval.zone {
                // One more step from there on the same factor: its gradient is at
                // rounding level, so the correction removes the rounding the large
                // first step left (ill-conditioned H, many stiff rows).
                let grad = gradient(m, a0, rows, &trial, &again);
                let fix = chol.solve(&DVector::from_column_slice(&grad));
                a = trial.iter().zip(fix.iter()).map(|(x, d)| *x - *d).collect();
                converged = true;
                break;
            }
        }
        if dir.iter().all(|d| *d == T::zero()) {
            converged = true;
            break;
        }
        let alpha = line_search(m, a0, rows, &a, dir);
        let before = a.clone();
        for (x, d) in a.iter_mut().zip(dir) {
            *x += alpha * *d;
        }
        if a == before {
            converged = true;
            break;
        }
    }
    let jar = residual(rows, &a);
    let eval = evaluate(rows, &jar, false);
    Solution {
        qacc: a,
        force: eval.force,
        zone: eval.zone,
        iterations: iteration,
        converged,
    }
}

/// The cost's gradient M (a - a0) - J^T f.
fn gradient<T: Real>(m: &DMatrix<T>, a0: &[T], rows: &Rows<T>, a: &[T], eval: &Eval<T>) -> Vec<T> {
    let delta: Vec<T> = a.iter().zip(a0).map(|(x, y)| *x - *y).collect();
    let mut grad: Vec<T> = (m * DVector::from_column_slice(&delta)).data.into();
    for k in 0..rows.len() {
        for (g, j) in grad.iter_mut().zip(rows.row(k)) {
            *g -= *j * eval.force[k];
        }
    }
    grad
}

/// The cost's gradient and Hessian M + J^T (d^2 s) J.
fn gradient_hessian<T: Real>(
    m: &DMatrix<T>,
    a0: &[T],
    rows: &Rows<T>,
    a: &[T],
    eval: &Eval<T>,
) -> (Vec<T>, DMatrix<T>) {
    let n = a.len();
    let grad = gradient(m, a0, rows, a, eval);
    let mut h = m.clone();
    add_quadratic_rows(&mut h, rows, &eval.zone);
    for (first, hc) in &eval.cone_hessians {
        let dim = hc.nrows();
        for p in 0..dim {
            for q in 0..dim {
                let (jp, jq) = (rows.row(first + p), rows.row(first + q));
                for i in 0..n {
                    for j in 0..n {
                        h[(i, j)] += hc[(p, q)] * jp[i] * jq[j];
                    }
                }
            }
        }
    }
    (grad, h)
}

/// Adds J^T D J over the rows in their quadratic zone to `h` (n x n): from
/// h = M, the cost's Hessian when no elliptic cone is in its middle zone.
pub fn add_quadratic_rows<T: Real>(h: &mut DMatrix<T>, rows: &Rows<T>, zone: &[Zone]) {
    for k in (0..rows.len()).filter(|&k| zone[k] == Zone::Quadratic) {
        add_outer(h.as_view_mut(), T::one() / rows.r[k], rows.row(k));
    }
}

/// h += w row^T row over row's nonzero entries, column by column (h is
/// column-major); entry (i, j) adds (w row_i) row_j.
pub fn add_outer<T: Real>(mut h: DMatrixViewMut<T>, w: T, row: &[T]) {
    let nonzero = row.iter().enumerate().filter(|(_, x)| **x != T::zero());
    for (j, &x) in nonzero.clone() {
        let mut column = h.column_mut(j);
        let column = column.as_mut_slice();
        for (i, &y) in nonzero.clone() {
            column[i] += w * y * x;
        }
    }
}

/// The cost along a + t dir: its Gauss part's slope at t = 0 and curvature
/// ((a - a0)^T M dir, dir^T M dir), the residual at t = 0 and its rate J dir.
struct Line<T: Real> {
    gauss: (T, T),
    jar: Vec<T>,
    jd: Vec<T>,
}

impl<T: Real> Line<T> {
    fn new(m: &DMatrix<T>, a0: &[T], rows: &Rows<T>, (a, dir): (&[T], &[T])) -> Self {
        let md: Vec<T> = (m * DVector::from_column_slice(dir)).data.into();
        let delta: Vec<T> = a.iter().zip(a0).map(|(x, y)| *x - *y).collect();
        Line {
            gauss: (dot(&md, &delta), dot(&md, dir)),
            jar: residual(rows, a),
            jd: (0..rows.len()).map(|i| dot(rows.row(i), dir)).collect(),
        }
    }

    /// The cost's first and second derivatives in t at t.
    fn slope(&self, rows: &Rows<T>, t: T) -> (T, T) {
        let jar: Vec<T> = self
            .jar
            .iter()
            .zip(&self.jd)
            .map(|(r, d)| *r + t * *d)
            .collect();
        let eval = evaluate(rows, &jar, true);
        let (g1, g2) = self.gauss;
        let jd = &self.jd;
        let first = g1 + t * g2 - dot(&eval.force, jd);
        let mut second = g2;
        for (k, z) in eval.zone.iter().enumerate() {
            if *z == Zone::Quadratic {
                second += jd[k] * jd[k] / rows.r[k];
            }
        }
        for (i, hc) in &eval.cone_hessians {
            let dim = hc.nrows();
            for p in 0..dim {
                for q in 0..dim {
                    second += hc[(p, q)] * jd[i + p] * jd[i + q];
                }
            }
        }
        (first, second)
    }
}

/// The step t > 0 where the cost's derivative along `dir` vanishes: a
/// bracket from t = 0 (a descent direction) to the first doubling of t = 1
/// with a non-negative derivative, then Newton steps kept inside the bracket
/// (bisection otherwise) until t stops changing.
fn line_search<T: Real>(m: &DMatrix<T>, a0: &[T], rows: &Rows<T>, a: &[T], dir: &[T]) -> T {
    let line = Line::new(m, a0, rows, (a, dir));
    let slope = |t: T| line.slope(rows, t);
    let (mut lo, mut hi) = (T::zero(), T::one());
    let two: T = lift(2.0);
    for _ in 0..60 {
        if slope(hi).0 >= T::zero() {
            break;
        }
        lo = hi;
        hi *= two;
    }
    let mut t = hi;
    for _ in 0..100 {
        let (g, h) = slope(t);
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
    }
}
