//! Closed-loop segments of a wiping episode, the observations the paper
//! identifies the compliance from: a recorded episode (run with the
//! canonical gains at the unknown mu) is cut into segments, and a candidate
//! mu is scored by re-simulating each segment in our engine, controller and
//! contact included, from its recorded start.
//!
//! Conventions:
//! - A segment starts at step k with the recorded (q_k, v_k) and admittance
//!   offset xi_k (the controller's own state, known to it), and holds the
//!   `length` recorded states after it, (q, v) at k + 1 .. k + length. The
//!   paper's segment (q_t, q_t+1, q_t^traj) is length 1; with length 1 the
//!   torque of the step does not depend on mu (the sensed force is a function
//!   of the state), so longer segments are what lets mu act through the
//!   controller and the contact, and they average out more.
//! - Residuals: per segment and step, (q_pred - q_obs, v_pred - v_obs)
//!   divided by the problem's `scale` (q then v), in segment order.
//! - Jacobian: exact, by forward-mode dual numbers (one direction per mu
//!   component) pushed through the whole closed loop: the tree is built
//!   with each mapped parameter seeded by its row of the map's gain, so the
//!   controller's sensing, gravity compensation and inverse kinematics,
//!   the contact forces and the step all carry d/dmu.

use nalgebra::SVector;
use num_dual::{Derivative, DualSVec64};
use rand::rngs::StdRng;
use rand::RngExt;

use super::{closed_loop_step, Episode, Wiping};
use crate::control::admittance::Gains;
use crate::derivatives::WindowFit;
use crate::dynamics::{Data, Tree};
use crate::model::{Model, Param, State};
use crate::osi::{Observations, OsiError, Problem};
use crate::spatial::Real;

/// The largest mu the dual-number Jacobian supports.
pub const MAX_NMU: usize = 6;

/// One closed-loop segment (see the module docs).
#[derive(Clone, Debug, PartialEq)]
pub struct Segment {
    /// The step it starts at.
    pub start: usize,
    pub q: Vec<f64>,
    pub v: Vec<f64>,
    pub xi: f64,
    /// The recorded states after the start, in order.
    pub observed: Vec<State>,
}

/// Segments of one episode and the controller that produced it.
#[derive(Clone, Debug)]
pub struct Segments {
    task: Wiping,
    gains: Gains,
    pub segments: Vec<Segment>,
}

impl Segments {
    /// `count` segments of `length` steps with starts drawn uniformly from
    /// the episode's steps (with replacement, in draw order).
    pub fn sample(
        task: &Wiping,
        (episode, gains): (&Episode, Gains),
        (count, length): (usize, usize),
        rng: &mut StdRng,
    ) -> Result<Segments, String> {
        let steps = episode.states.len().saturating_sub(1);
        if length == 0 || length > steps {
            return Err(format!(
                "segment length {length} must be between 1 and the episode's {steps} steps"
            ));
        }
        let segments = (0..count)
            .map(|_| {
                let k = rng.random_range(0..=steps - length);
                let (q, v) = episode.states[k].clone();
                Segment {
                    start: k,
                    q,
                    v,
                    xi: episode.xi[k],
                    observed: episode.states[k + 1..=k + length].to_vec(),
                }
            })
            .collect();
        Ok(Segments {
            task: task.clone(),
            gains,
            segments,
        })
    }

    /// Simulates every segment at the tree's parameters, handing each step's
    /// predicted state to `out(row, q, v)`, row counting steps over all
    /// segments.
    fn simulate<T: Real>(
        &self,
        (tree, model): (&Tree<T>, &Model),
        lift: impl Fn(f64) -> T,
        mut out: impl FnMut(usize, &[T], &[T]),
    ) -> Result<(), OsiError> {
        let nv = model.nv();
        let mut data = Data::new(tree);
        let mut ctrl = self.task.controller::<T>(self.gains);
        let mut tau = vec![T::zero(); nv];
        let (mut q1, mut v1) = (vec![T::zero(); nv], vec![T::zero(); nv]);
        let mut row = 0;
        for s in &self.segments {
            let mut q: Vec<T> = s.q.iter().map(|x| lift(*x)).collect();
            let mut v: Vec<T> = s.v.iter().map(|x| lift(*x)).collect();
            let mut xi = lift(s.xi);
            for k in s.start..s.start + s.observed.len() {
                let at = (k, q.as_slice(), v.as_slice(), xi);
                let action = closed_loop_step(
                    (tree, model),
                    &mut data,
                    &mut ctrl,
                    at,
                    &mut tau,
                    (&mut q1, &mut v1),
                )
                .map_err(|e| OsiError::Segment(format!("segment at step {}: {e}", s.start)))?;
                std::mem::swap(&mut q, &mut q1);
                std::mem::swap(&mut v, &mut v1);
                xi = action.xi_next;
                out(row, &q, &v);
                row += 1;
            }
        }
        Ok(())
    }

    /// Residuals and their Jacobian by dual numbers with N directions.
    fn dual_residuals<const N: usize>(
        &self,
        model: &Model,
        (seeds, scale): (&Seeds<N>, &[f64]),
        fit: &mut WindowFit,
    ) -> Result<(), OsiError> {
        let tree = Tree::<DualSVec64<N>>::build_with(model, |p, c, x| {
            match seeds.iter().find(|(q, _)| *q == p) {
                Some((_, rows)) => DualSVec64::new(x, Derivative::some(rows[c])),
                None => DualSVec64::from_re(x),
            }
        });
        let observed = self.observed_rows();
        let nv = model.nv();
        self.simulate((&tree, model), DualSVec64::from_re, |row, q, v| {
            for (i, x) in q.iter().chain(v).enumerate() {
                let r = 2 * nv * row + i;
                fit.residuals[r] = (x.re - observed_at(&observed[row], i, nv)) / scale[i];
                let eps = x.eps.0.unwrap_or_else(SVector::zeros);
                for j in 0..N {
                    fit.jacobian[(r, j)] = eps[j] / scale[i];
                }
            }
        })
    }

    /// Each simulated step's recorded (q, v), in row order.
    fn observed_rows(&self) -> Vec<(&[f64], &[f64])> {
        self.segments
            .iter()
            .flat_map(|s| s.observed.iter().map(|(q, v)| (q.as_slice(), v.as_slice())))
            .collect()
    }

    fn rows(&self) -> usize {
        self.segments.iter().map(|s| s.observed.len()).sum()
    }
}

/// Component i of a recorded state stacked as (q, v).
fn observed_at((q, v): &(&[f64], &[f64]), i: usize, nv: usize) -> f64 {
    if i < nv {
        q[i]
    } else {
        v[i - nv]
    }
}

/// Seeds: per mapped parameter, one derivative vector per scalar (its row
/// of the map's gain).
fn seeds<const N: usize>(problem: &Problem) -> Box<Seeds<N>> {
    problem
        .map()
        .targets
        .iter()
        .map(|(p, _, gain)| {
            let rows = (0..gain.nrows())
                .map(|r| SVector::from_fn(|j, _| gain[(r, j)]))
                .collect();
            (*p, rows)
        })
        .collect()
}

/// Per mapped parameter, the derivative seed of each of its scalars.
type Seeds<const N: usize> = [(Param, Vec<SVector<f64, N>>)];

impl Observations for Segments {
    fn check(&self, problem: &Problem) -> Result<(), OsiError> {
        if self.segments.is_empty() {
            return Err(OsiError::EmptyWindow);
        }
        if problem.nmu() > MAX_NMU {
            return Err(OsiError::Segment(format!(
                "{} unknowns: closed-loop segments differentiate at most {MAX_NMU}",
                problem.nmu()
            )));
        }
        let nv = problem.nv();
        for (t, s) in self.segments.iter().enumerate() {
            let states =
                std::iter::once((&s.q, &s.v)).chain(s.observed.iter().map(|(q, v)| (q, v)));
            for (q, v) in states {
                for (what, x) in [("q", q), ("v", v)] {
                    if x.len() != nv {
                        return Err(OsiError::Length {
                            what,
                            got: x.len(),
                            expected: nv,
                        });
                    }
                    if let Some((i, &value)) = x.iter().enumerate().find(|(_, x)| !x.is_finite()) {
                        return Err(OsiError::NotFinite { t, what, i, value });
                    }
                }
            }
            if !s.xi.is_finite() {
                return Err(OsiError::NotFinite {
                    t,
                    what: "xi",
                    i: 0,
                    value: s.xi,
                });
            }
        }
        Ok(())
    }

    fn residual_count(&self, problem: &Problem) -> usize {
        self.rows() * 2 * problem.nv()
    }

    fn residuals_into(
        &self,
        problem: &mut Problem,
        mu: &[f64],
        jacobian: bool,
        fit: &mut WindowFit,
    ) -> Result<(), OsiError> {
        let (m, nmu) = (self.residual_count(problem), problem.nmu());
        let scale = problem.scale().to_vec();
        let cols = if jacobian { nmu } else { 0 };
        fit.residuals.resize_vertically_mut(m, 0.0);
        if fit.jacobian.shape() != (m, cols) {
            fit.jacobian = nalgebra::DMatrix::zeros(m, cols);
        }
        if jacobian {
            macro_rules! dual {
                ($($n:literal)*) => {
                    match nmu {
                        $($n => {
                            let seeds = seeds::<$n>(problem);
                            let model = problem.model_at(mu)?;
                            self.dual_residuals::<$n>(model, (&seeds, &scale), fit)?
                        })*
                        _ => return Err(OsiError::Segment(format!("{nmu} unknowns: at most {MAX_NMU}"))),
                    }
                };
            }
            dual!(1 2 3 4 5 6);
        } else {
            let model = problem.model_at(mu)?;
            let observed = self.observed_rows();
            let nv = model.nv();
            self.simulate(
                (model.tree(), model),
                |x| x,
                |row, q, v| {
                    for (i, x) in q.iter().chain(v).enumerate() {
                        let target = observed_at(&observed[row], i, nv);
                        fit.residuals[2 * nv * row + i] = (x - target) / scale[i];
                    }
                },
            )?;
        }
        fit.loss = fit.residuals.norm_squared();
        fit.gradient = if jacobian {
            fit.jacobian.tr_mul(&fit.residuals) * 2.0
        } else {
            nalgebra::DVector::zeros(0)
        };
        Ok(())
    }
}
