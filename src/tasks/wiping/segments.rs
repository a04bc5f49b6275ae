//! Closed-loop segments of a wiping episode, the observations the paper
//! identifies the compliance from: a recorded episode (run with the
//! canonical gains at the unknown mu) is cut into segments, and a candidate
//! mu is scored by re-simulating each segment in our engine, controller and
//! contact included, from its recorded start.
//!
//! Conventions:
//! - A segment starts at step k with the recorded (q_k, v_k), admittance
//!   offset xi_k and sensed force F_k (the controller's own state and
//!   reading, known to it), and holds the
//!   `length` recorded states after it, (q, v) at k + 1 .. k + length. The
//!   paper's segment (q_t, q_t+1, q_t^traj) is length 1; with length 1 the
//!   torque of the step does not depend on mu (the sensed force is the
//!   recorded one), so longer segments are what lets mu act through the
//!   controller and the contact, and they average out more.
//! - Residuals: per segment and step, (q_pred - q_obs, v_pred - v_obs)
//!   divided by the problem's `scale` (q then v), in segment order.
//! - Jacobian: exact, by forward-mode dual numbers pushed through the whole
//!   closed loop, one pass per mu component: the tree is built with each
//!   mapped parameter seeded by its gain on that component, so the
//!   controller's sensing, gravity compensation and inverse kinematics, the
//!   contact forces and the step all carry d/dmu_j. (One single-direction
//!   pass costs about 3 plain ones; num-dual's multi-direction numbers cost
//!   more per direction here, 7.4 against 4.1 ms for two.)

use num_dual::Dual64;
use rand::rngs::StdRng;
use rand::RngExt;

#[cfg(doc)]
use super::Episode;
use super::{closed_loop_step, LoopState, Wiping};
use crate::control::admittance::Gains;
use crate::derivatives::WindowFit;
use crate::dynamics::{Data, Tree};
use crate::model::{ParamMap, State};
use crate::osi::{Observations, OsiError, Problem};
use crate::spatial::Real;
use crate::Model;

/// One closed-loop segment (see the module docs).
#[derive(Clone, Debug, PartialEq)]
pub struct Segment {
    /// The step it starts at.
    pub start: usize,
    pub q: Vec<f64>,
    pub v: Vec<f64>,
    pub xi: f64,
    pub force: f64,
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
    /// `count` segments of `length` steps with starts drawn uniformly from a
    /// record of an episode run with `gains` (its states and the
    /// controller's offset xi and sensed force at each, as [`Episode`]
    /// holds them), with replacement, in draw order.
    pub fn sample(
        task: &Wiping,
        (states, xi, forces, gains): (&[State], &[f64], &[f64], Gains),
        (count, length): (usize, usize),
        rng: &mut StdRng,
    ) -> Result<Segments, String> {
        for (what, len) in [("offsets xi", xi.len()), ("forces", forces.len())] {
            if len != states.len() {
                return Err(format!(
                    "the record holds {} states but {len} {what}",
                    states.len()
                ));
            }
        }
        let steps = states.len().saturating_sub(1);
        if length == 0 || length > steps {
            return Err(format!(
                "segment length {length} must be between 1 and the episode's {steps} steps"
            ));
        }
        let segments = (0..count)
            .map(|_| {
                let k = rng.random_range(0..=steps - length);
                let State { q, v, .. } = states[k].clone();
                Segment {
                    start: k,
                    q,
                    v,
                    xi: xi[k],
                    force: forces[k],
                    observed: states[k + 1..=k + length].to_vec(),
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
            let mut carry = LoopState {
                xi: lift(s.xi),
                force: lift(s.force),
            };
            for k in s.start..s.start + s.observed.len() {
                let at = (k, q.as_slice(), v.as_slice(), carry);
                carry =
                    closed_loop_step(tree, &mut data, &mut ctrl, at, &mut tau, (&mut q1, &mut v1))
                        .map_err(|e| {
                            OsiError::Segment(format!("segment at step {}: {e}", s.start))
                        })?;
                std::mem::swap(&mut q, &mut q1);
                std::mem::swap(&mut v, &mut v1);
                out(row, &q, &v);
                row += 1;
            }
        }
        Ok(())
    }

    /// The residuals and column j of their Jacobian, by one pass in dual
    /// numbers with mu_j's direction seeded (each mapped parameter's scalar
    /// carries its gain on mu_j).
    fn dual_column(
        &self,
        model: &Model,
        (map, scale, j): (&ParamMap, &[f64], usize),
        fit: &mut WindowFit,
    ) -> Result<(), OsiError> {
        let tree = Tree::<Dual64>::build_with(model, |p, c, x| {
            match map.targets.iter().find(|(q, ..)| *q == p) {
                Some((_, _, gain)) => Dual64::new(x, gain[(c, j)]),
                None => Dual64::from(x),
            }
        });
        let observed = self.observed_rows();
        let nv = model.nv();
        self.simulate((&tree, model), Dual64::from, |row, q, v| {
            for (i, x) in q.iter().chain(v).enumerate() {
                let r = 2 * nv * row + i;
                fit.residuals[r] = (x.re - observed_at(&observed[row], i, nv)) / scale[i];
                fit.jacobian[(r, j)] = x.eps / scale[i];
            }
        })
    }

    /// Each simulated step's recorded (q, v), in row order.
    fn observed_rows(&self) -> Vec<(&[f64], &[f64])> {
        self.segments
            .iter()
            .flat_map(|s| s.observed.iter().map(|x| (x.q.as_slice(), x.v.as_slice())))
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

impl Observations for Segments {
    fn check(&self, problem: &Problem) -> Result<(), OsiError> {
        if self.segments.is_empty() {
            return Err(OsiError::EmptyWindow);
        }
        let nv = problem.nv();
        for (t, s) in self.segments.iter().enumerate() {
            let states =
                std::iter::once((&s.q, &s.v)).chain(s.observed.iter().map(|x| (&x.q, &x.v)));
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
            for (what, value) in [("xi", s.xi), ("force", s.force)] {
                if !value.is_finite() {
                    return Err(OsiError::NotFinite {
                        t,
                        what,
                        i: 0,
                        value,
                    });
                }
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
        if jacobian && nmu > 0 {
            let map = problem.map().clone();
            let model = problem.model_at(mu)?;
            for j in 0..nmu {
                self.dual_column(model, (&map, &scale, j), fit)?;
            }
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
