//! The regulariser R and reference acceleration aref of a block of rows
//! sharing one distance, from its solver parameters (solref, solimp) as
//! MuJoCo computes them (its Computation chapter):
//! - Impedance d = imp(|dist - margin|) in (0, 1) from solimp (clamped as
//!   MuJoCo clamps it); R = max(1e-15, (1 - d) / d * A_ii) with A_ii the
//!   diagonal approximation of J M^-1 J^T from the invweight0 constants;
//!   D = 1 / R. (A contact adjusts its frictional rows' R afterwards, see
//!   [`super::contact`].)
//! - aref = -B (J v) - K d (dist - margin), with from solref (timeconst,
//!   dampratio) K = 1 / (dmax^2 timeconst^2 dampratio^2) and B = 2 / (dmax
//!   timeconst), or from the direct form (-k, -b) K = k / dmax^2 and B = b /
//!   dmax; timeconst is at least 2 timesteps (`refsafe`); friction rows (dry
//!   friction, an elliptic cone's tangents) have K = 0.

use super::{Origin, RowKind, Rows};
use crate::dynamics::collision::MINVAL;
use crate::model::{Options, SolParams, SolverOptions};
use crate::spatial::{lift, Real};

/// MuJoCo's bounds on impedance.
const MIN_IMP: f64 = 0.0001;
const MAX_IMP: f64 = 0.9999;

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
pub(super) struct Block<'a, T: Real> {
    pub origin: Origin,
    pub kind: &'a [RowKind],
    /// A_ii per row.
    pub diag: &'a [T],
    pub dist: T,
    /// Per row, the distance its aref reads (an equality's error
    /// components, MuJoCo's efc_pos); None: `dist` for every row.
    pub pos: Option<&'a [T]>,
    pub margin: f64,
    pub sol: SolParams<T>,
    pub floss: T,
}

impl<T: Real> Rows<T> {
    /// Appends a block whose rows of J were just appended to `j`:
    /// impedance, R (before a contact's adjustment), aref.
    pub(super) fn push(
        &mut self,
        block: Block<T>,
        v: &[T],
        opt: &Options,
        friction_ref: Option<[T; 2]>,
    ) {
        let sol = effective(&block.sol, &opt.solver, opt.timestep);
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
                    effective(&SolParams { solref: r, ..sol }, &opt.solver, opt.timestep).solref
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
            let x_row = block.pos.map_or(x, |p| p[k] - lift::<T>(block.margin));
            self.aref.push(-vel * damp - x_row * imp * stiff);
            self.damping.push(damp);
            self.daref_ddist.push(-stiff * (slope * x + imp));
            self.dlog_r_ddist.push(if clamped {
                T::zero()
            } else {
                -slope / (imp * (T::one() - imp))
            });
            self.floss.push(block.floss);
            self.kind.push(kind);
            self.origin.push(block.origin);
        }
    }
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
