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
//!
//! Robust loss: with [`Loss::Huber`] the solver minimises a Huber loss of the
//! scaled residuals by iteratively reweighted least squares: every evaluation
//! scales each residual and its Jacobian row by sqrt(w), w = min(1, c / |r|),
//! so J^T J is the IRLS curvature J^T W J, the gradient 2 J^T W r is the
//! Huber loss's exact gradient, and a trial is accepted on the Huber loss.
//! The estimate then reports that loss, and its standard errors come from the
//! reweighted J.

use nalgebra::{DMatrix, DVector};
use rand::rngs::StdRng;
use rand::seq::SliceRandom;
use rand::SeedableRng;

use super::{Estimate, Excitation, Identifier, Observations, OsiError, Problem, Subspace};
use crate::derivatives::{Transition, WindowError, WindowFit};

/// The loss over the scaled residuals r (residual / `scale`, see the module
/// `osi`) that [`Lm`] minimises.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub enum Loss {
    /// sum r^2, the paper's loss (the default).
    #[default]
    Squared,
    /// sum rho(r), rho(r) = r^2 for |r| <= threshold and
    /// 2 threshold |r| - threshold^2 beyond: quadratic near zero, linear in
    /// the tails, so one corrupted transition pulls the estimate with a
    /// bounded force. `threshold` is in units of the scaled residuals, i.e.
    /// of `scale`; with `scale` set to the measurement noise, 1.345 keeps
    /// 95% of least squares' efficiency on Gaussian noise ([`HUBER_THRESHOLD`]).
    Huber { threshold: f64 },
}

/// The classical Huber threshold, in units of the residual scale.
pub const HUBER_THRESHOLD: f64 = 1.345;

impl Loss {
    fn check(self) -> Result<(), OsiError> {
        match self {
            Loss::Huber { threshold } if !(threshold.is_finite() && threshold > 0.0) => {
                Err(OsiError::Huber { threshold })
            }
            _ => Ok(()),
        }
    }

    /// Turns a least-squares fit into this loss's IRLS fit (see the module
    /// docs): residuals and Jacobian rows scaled by sqrt(w), the gradient
    /// 2 J^T W r and the loss itself.
    fn reweight(self, fit: &mut WindowFit) {
        let Loss::Huber { threshold: c } = self else {
            return;
        };
        let mut loss = 0.0;
        for (i, r) in fit.residuals.iter_mut().enumerate() {
            let a = r.abs();
            if a <= c {
                loss += a * a;
                continue;
            }
            loss += 2.0 * c * a - c * c;
            let root = (c / a).sqrt();
            *r *= root;
            if fit.jacobian.ncols() > 0 {
                fit.jacobian.row_mut(i).scale_mut(root);
            }
        }
        fit.loss = loss;
        if fit.jacobian.ncols() > 0 {
            fit.jacobian.tr_mul_to(&fit.residuals, &mut fit.gradient);
            fit.gradient *= 2.0;
        }
    }
}

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
    pub loss: Loss,
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
            loss: Loss::Squared,
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
        self.identify_on(problem, window, start)
    }
}

impl Lm {
    /// [`Identifier::identify`] on any [`Observations`].
    pub fn identify_on<O: Observations + ?Sized>(
        &mut self,
        problem: &mut Problem,
        window: &O,
        start: &[f64],
    ) -> Result<Estimate, OsiError> {
        window.check(problem)?;
        problem.check_mu("start", start)?;
        let opt = self.options;
        opt.loss.check()?;
        let dof = window.residual_count(problem).saturating_sub(problem.nmu());
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
        let mut estimate = Estimate::at(problem, end, opt.excitation, best.converged, work);
        estimate.flags.misfit = misfit(&best) > opt.misfit;
        Ok(estimate)
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
    /// The residuals, Jacobian, loss and gradient of the chosen loss at mu.
    fn fit_into<O: Observations + ?Sized>(
        &self,
        problem: &mut Problem,
        mu: &[f64],
        window: &O,
        fit: &mut WindowFit,
    ) -> Result<(), OsiError> {
        problem.fit_into(mu, window, fit)?;
        self.options.loss.reweight(fit);
        Ok(())
    }

    fn solve<O: Observations + ?Sized>(
        &self,
        problem: &mut Problem,
        window: &O,
        start: &[f64],
    ) -> Result<Run, OsiError> {
        let opt = self.options;
        let width: Vec<f64> = (0..problem.nmu())
            .map(|i| problem.upper()[i] - problem.lower()[i])
            .collect();
        let mut mu = DVector::from_column_slice(start);
        problem.project(&mut mu);
        let mut fit = WindowFit::empty();
        self.fit_into(problem, mu.as_slice(), window, &mut fit)?;
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
                match self.fit_into(problem, trial.as_slice(), window, &mut next) {
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::State;
    use crate::tasks::{by_name, Task};

    /// The cartpole's mu problem at rounding-level scale (q then v).
    fn cartpole_problem() -> (Problem, Box<dyn Task>) {
        let task = by_name("cartpole").unwrap();
        let scale = [2e-8, 2e-8, 1e-6, 1e-6];
        let problem = Problem::new(
            task.model(),
            task.mu_map().clone(),
            &[-0.6],
            &[0.6],
            &[0.0],
            &scale,
        )
        .unwrap();
        (problem, task)
    }

    /// `len` transitions of the cartpole at mu = 0.3 from a fixed spread of
    /// states and forces, every `corrupt`-th next velocity pushed by 0.5 rad/s.
    fn window(task: &dyn Task, len: usize, corrupt: usize) -> Vec<Transition> {
        let mut truth = task.model().clone();
        task.mu_map().apply(&mut truth, &[0.3]).unwrap();
        (0..len)
            .map(|t| {
                let s = (t as f64 * 0.7).sin();
                let (q, v, tau) = (vec![0.1 * s, 0.4 * s], vec![s, -s], vec![8.0 * s, 0.0]);
                let start = State::new(q, v);
                let mut seen =
                    Transition::simulated(&truth, &mut truth.data(), start, tau).unwrap();
                if t % corrupt == corrupt - 1 {
                    seen.next.v[1] += 0.5;
                }
                seen
            })
            .collect()
    }

    #[test]
    fn huber_gradient_matches_finite_differences_of_its_loss() {
        let (mut problem, task) = cartpole_problem();
        let window = window(task.as_ref(), 20, 5);
        let lm = Lm {
            options: LmOptions {
                loss: Loss::Huber { threshold: 1.345 },
                ..LmOptions::default()
            },
        };
        let mut fit = WindowFit::empty();
        let (mu, h) = (0.1, 1e-7);
        lm.fit_into(&mut problem, &[mu], &window[..], &mut fit)
            .unwrap();
        let mut at = |m: f64| {
            let mut f = WindowFit::empty();
            lm.fit_into(&mut problem, &[m], &window[..], &mut f)
                .unwrap();
            f.loss
        };
        let fd = (at(mu + h) - at(mu - h)) / (2.0 * h);
        assert!(
            (fit.gradient[0] - fd).abs() <= 1e-5 * fd.abs(),
            "{} vs {fd}",
            fit.gradient[0]
        );
        // Some residuals are beyond the threshold, so the loss is not sum r^2.
        assert!(fit.loss < fit.residuals.norm_squared() * 2.0);
    }

    #[test]
    fn huber_resists_an_outlier_that_moves_least_squares() {
        let (mut problem, task) = cartpole_problem();
        let window = window(task.as_ref(), 20, 20);
        let squared = Lm::default()
            .identify(&mut problem, &window, &[0.0])
            .unwrap();
        let mut huber = Lm {
            options: LmOptions {
                loss: Loss::Huber { threshold: 1.345 },
                ..LmOptions::default()
            },
        };
        let robust = huber.identify(&mut problem, &window, &[0.0]).unwrap();
        let (e_sq, e_hu) = ((squared.mu[0] - 0.3).abs(), (robust.mu[0] - 0.3).abs());
        assert!(e_sq > 1e-3, "squared loss error {e_sq}");
        assert!(e_hu < 1e-6 && e_hu < e_sq / 100.0, "Huber error {e_hu}");
        assert!(robust.std.iter().all(|s| s.is_finite()) && robust.loss.is_finite());
    }

    #[test]
    fn data_the_model_cannot_explain_is_flagged_as_misfit() {
        let (mut problem, task) = cartpole_problem();
        let clean = window(task.as_ref(), 20, usize::MAX);
        let e = Lm::default()
            .identify(&mut problem, &clean, &[0.0])
            .unwrap();
        assert!(!e.flags.misfit && (e.mu[0] - 0.3).abs() < 1e-9, "{e:?}");
        // One next velocity in five pushed by 0.5 rad/s: no mu explains it.
        let corrupted = window(task.as_ref(), 20, 5);
        let e = Lm::default()
            .identify(&mut problem, &corrupted, &[0.0])
            .unwrap();
        assert!(e.flags.misfit, "{e:?}");
    }

    #[test]
    fn a_bad_threshold_is_an_error_naming_it() {
        let (mut problem, task) = cartpole_problem();
        for threshold in [0.0, -1.0, f64::NAN, f64::INFINITY] {
            let mut lm = Lm {
                options: LmOptions {
                    loss: Loss::Huber { threshold },
                    ..LmOptions::default()
                },
            };
            let e = lm.identify(&mut problem, &window(task.as_ref(), 2, 20), &[0.0]);
            let message = e.unwrap_err().to_string();
            assert!(message.contains(&threshold.to_string()), "{message}");
        }
    }

    #[test]
    fn the_default_loss_is_squared_and_leaves_the_fit_alone() {
        assert_eq!(LmOptions::default().loss, Loss::Squared);
        let (mut problem, task) = cartpole_problem();
        let window = window(task.as_ref(), 5, 20);
        let mut fit = WindowFit::empty();
        Lm::default()
            .fit_into(&mut problem, &[0.1], &window[..], &mut fit)
            .unwrap();
        assert_eq!(fit, problem.fit(&[0.1], &window[..]).unwrap());
    }
}
