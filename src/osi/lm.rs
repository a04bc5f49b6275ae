//! DiffOSI with a bounded Levenberg-Marquardt (Gauss-Newton when undamped) on
//! the stacked scaled residuals and their exact Jacobian.
//!
//! Bounds: an active-set step followed by a projection. Components sitting on
//! a bound whose descent direction points outside are frozen for the step;
//! the step is solved in the remaining excited subspace and the trial point
//! clamped into the box. A trial is accepted only if it lowers the loss
//! (else the damping grows tenfold; a trial the model rejects as unphysical
//! counts as a failed one).
//!
//! Local minima: with few transitions the loss can have a second basin (the
//! cartpole COM from two random transitions: about 6% of windows trap a
//! solve started at 0). A fit that leaves loss / (m - nmu) above
//! [`LmOptions::misfit`] (with `scale` set to the noise, about 1 at the truth)
//! is retried from up to [`LmOptions::restarts`] other starts; the lowest loss
//! wins. Iterations and evaluations count every solve.
//!
//! Identifiability: each step eigen-decomposes J^T J (nmu is small) and solves
//! only along the excited eigenvectors ([`Excitation`]), so an unexcited
//! direction keeps its start value instead of becoming NaN.

use nalgebra::{DMatrix, DVector};
use rand::rngs::StdRng;
use rand::seq::SliceRandom;
use rand::SeedableRng;

use super::{Estimate, Excitation, Identifier, OsiError, Problem, Subspace};
use crate::derivatives::{Transition, WindowError, WindowFit};

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LmOptions {
    pub max_iterations: usize,
    /// Stop when no component moves by more than this fraction of its bound
    /// width.
    pub step_tol: f64,
    /// Stop when |dL/dmu_i| (upper_i - lower_i) / 2, the first-order loss
    /// change of crossing the box, is below this for every free component.
    pub gradient_tol: f64,
    /// Stop when an accepted step lowers the loss by less than this fraction.
    pub loss_tol: f64,
    /// Initial damping, as a fraction of the largest eigenvalue of J^T J.
    pub damping: f64,
    pub excitation: Excitation,
    /// A fit whose loss per degree of freedom, loss / max(1, m - nmu), stays
    /// above this (residuals larger than their scale says the noise is) is
    /// retried from other starts.
    pub misfit: f64,
    /// How many other starts: a Latin hypercube in the box, seeded by `seed`.
    pub restarts: usize,
    pub seed: u64,
}

impl Default for LmOptions {
    fn default() -> Self {
        LmOptions {
            max_iterations: 50,
            step_tol: 1e-12,
            gradient_tol: 1e-14,
            loss_tol: 1e-12,
            damping: 1e-6,
            excitation: Excitation::default(),
            misfit: 4.0,
            restarts: 8,
            seed: 0,
        }
    }
}

#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Lm {
    pub options: LmOptions,
}

impl Identifier for Lm {
    fn identify(
        &mut self,
        problem: &mut Problem,
        window: &[Transition],
        start: &[f64],
    ) -> Result<Estimate, OsiError> {
        problem.check_window(window)?;
        problem.check_mu("start", start)?;
        let opt = self.options;
        let dof = (window.len() * 2 * problem.nv()).saturating_sub(problem.nmu());
        let misfit = |run: &Run| run.fit.loss / dof.max(1) as f64;
        let mut best = self.solve(problem, window, start)?;
        let (mut iterations, mut evaluations) = (best.iterations, best.evaluations);
        if misfit(&best) > opt.misfit {
            for start in latin_hypercube(problem, opt.restarts, opt.seed) {
                let run = self.solve(problem, window, &start)?;
                iterations += run.iterations;
                evaluations += run.evaluations;
                if run.fit.loss < best.fit.loss {
                    best = run;
                }
                if misfit(&best) <= opt.misfit {
                    break;
                }
            }
        }
        let end = (&best.mu, &best.fit);
        let work = (iterations, evaluations);
        Ok(Estimate::at(
            problem,
            end,
            opt.excitation,
            best.converged,
            work,
        ))
    }
}

/// One local solve.
struct Run {
    mu: DVector<f64>,
    fit: WindowFit,
    iterations: usize,
    evaluations: usize,
    converged: bool,
}

impl Lm {
    fn solve(
        &self,
        problem: &mut Problem,
        window: &[Transition],
        start: &[f64],
    ) -> Result<Run, OsiError> {
        let opt = self.options;
        let width: Vec<f64> = (0..problem.nmu())
            .map(|i| problem.upper()[i] - problem.lower()[i])
            .collect();
        let mut mu = DVector::from_column_slice(start);
        problem.project(&mut mu);
        let mut fit = WindowFit::empty();
        problem.fit_into(mu.as_slice(), window, &mut fit)?;
        let mut next = WindowFit::empty();
        let (mut iterations, mut evaluations) = (0, 1);
        let mut damping = opt.damping;
        let mut converged = false;
        let n = problem.nmu();
        let mut jtj = DMatrix::zeros(n, n);
        'outer: while iterations < opt.max_iterations {
            // The gradient of the loss is 2 J^T r.
            let g = &fit.gradient;
            let free: Vec<bool> = (0..n)
                .map(|i| {
                    let outward_low = mu[i] <= problem.lower()[i] && g[i] > 0.0;
                    let outward_high = mu[i] >= problem.upper()[i] && g[i] < 0.0;
                    !(outward_low || outward_high)
                })
                .collect();
            let stationary =
                (0..n).all(|i| !free[i] || 0.5 * g[i].abs() * width[i] <= opt.gradient_tol);
            if stationary {
                converged = true;
                break;
            }
            fit.jacobian.tr_mul_to(&fit.jacobian, &mut jtj);
            for i in (0..n).filter(|i| !free[*i]) {
                jtj.row_mut(i).fill(0.0);
                jtj.column_mut(i).fill(0.0);
            }
            let sub = Subspace::new(&jtj, opt.excitation);
            let largest = sub.values.max().max(0.0);
            iterations += 1;
            loop {
                // The step solves (J^T J + damping) step = -J^T r = -g / 2.
                let mut trial = sub.solve(g, damping * largest);
                trial.axpy(1.0, &mu, -0.5);
                problem.project(&mut trial);
                let moved = (0..n)
                    .map(|i| (trial[i] - mu[i]).abs() / width[i])
                    .fold(0.0, f64::max);
                if moved <= opt.step_tol {
                    converged = true;
                    break 'outer;
                }
                evaluations += 1;
                match problem.fit_into(trial.as_slice(), window, &mut next) {
                    Ok(()) if next.loss < fit.loss => {
                        let decrease = (fit.loss - next.loss) / fit.loss;
                        mu = trial;
                        std::mem::swap(&mut fit, &mut next);
                        damping /= 10.0;
                        if decrease <= opt.loss_tol {
                            converged = true;
                            break 'outer;
                        }
                        break;
                    }
                    Ok(()) | Err(OsiError::Window(WindowError::Param(_))) => damping *= 10.0,
                    Err(e) => return Err(e),
                }
            }
        }
        Ok(Run {
            mu,
            fit,
            iterations,
            evaluations,
            converged,
        })
    }
}

/// `count` points of a Latin hypercube in the box: along every component the
/// points sit at the centres of `count` equal strata, in a seeded order.
fn latin_hypercube(problem: &Problem, count: usize, seed: u64) -> Vec<Vec<f64>> {
    let mut rng = StdRng::seed_from_u64(seed);
    let mut points = vec![vec![0.0; problem.nmu()]; count];
    for i in 0..problem.nmu() {
        let mut strata: Vec<usize> = (0..count).collect();
        strata.shuffle(&mut rng);
        let (lo, hi) = (problem.lower()[i], problem.upper()[i]);
        for (point, s) in points.iter_mut().zip(strata) {
            point[i] = lo + (hi - lo) * (s as f64 + 0.5) / count as f64;
        }
    }
    points
}
