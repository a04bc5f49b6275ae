//! CMA-ES baseline: a derivative-free (mu/mu_w, lambda)-CMA-ES on the window
//! loss, with the default parameters of Hansen's tutorial ("The CMA Evolution
//! Strategy: A Tutorial", 2016), seeded.
//!
//! - Search space: each component normalised to [0, 1] over its bounds; the
//!   initial mean is the start, the initial step `sigma0` a fraction of the
//!   box width, the initial covariance the identity.
//! - Bounds: a sample x outside the box is evaluated at its clamp x_c and
//!   scored f(x_c) (1 + d^2) + d^2, d = ||x - x_c|| (normalised), so it ranks
//!   behind its clamp; the loss is a sum of squares, so this is >= f(x_c).
//! - A sample the model rejects as unphysical scores +infinity and ranks
//!   last; no score is ever NaN.
//! - Stopping: sigma times the largest axis of the covariance below `x_tol`
//!   (normalised units), or the range of the generation's scores together
//!   with the best scores of the last 10 + ceil(30 n / lambda) generations
//!   below `f_tol` (loss units), both counted as converged; or
//!   `max_evaluations` (flagged not converged).
//! - The answer is the best sample evaluated. Its standard errors are the
//!   Gauss-Newton ones at that point (as for LM, from one evaluation with
//!   the Jacobian there; samples are scored on residuals alone): the final sigma^2 C describes the search
//!   distribution, which shrinks to the stopping tolerance, not the
//!   uncertainty of mu. Unexcited directions report the prior's standard
//!   deviation as everywhere else.
//! - Iterations count generations, evaluations loss evaluations (lambda per
//!   generation, residuals only) plus the Jacobian evaluation at the answer.

use nalgebra::{DMatrix, DVector};
use rand::rngs::StdRng;
use rand::SeedableRng;
use rand_distr::{Distribution, StandardNormal};

use super::{Estimate, Excitation, Identifier, Observations, OsiError, Problem, Subspace};
use crate::derivatives::{Transition, WindowError};

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CmaEsOptions {
    /// Initial step size as a fraction of each component's bound width.
    pub sigma0: f64,
    /// Population size lambda; 0 picks the default 4 + floor(3 ln n).
    pub population: usize,
    pub max_evaluations: usize,
    /// Stop when sigma times the largest standard deviation of the search
    /// distribution, in fractions of the bound widths, falls below this.
    pub x_tol: f64,
    /// Stop when the recent scores span less than this (loss units).
    pub f_tol: f64,
    pub excitation: Excitation,
    pub seed: u64,
}

impl Default for CmaEsOptions {
    fn default() -> Self {
        CmaEsOptions {
            sigma0: 0.3,
            population: 0,
            max_evaluations: 20_000,
            x_tol: 1e-12,
            f_tol: 1e-12,
            excitation: Excitation::default(),
            seed: 0,
        }
    }
}

/// CMA-ES behind the [`Identifier`] interface. Every call reseeds its
/// generator from `options.seed`: the same window and start give the same
/// bits.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct CmaEs {
    pub options: CmaEsOptions,
}

impl Identifier for CmaEs {
    fn identify(
        &mut self,
        problem: &mut Problem,
        window: &[Transition],
        start: &[f64],
    ) -> Result<Estimate, OsiError> {
        self.identify_on(problem, window, start)
    }
}

impl CmaEs {
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
        let bounds = (problem.lower().to_vec(), problem.upper().to_vec());
        let search = self.minimize((&bounds.0, &bounds.1), start, |mu| {
            match problem.loss(mu, window) {
                Ok(loss) => Ok(Some(loss)),
                Err(OsiError::Window(WindowError::Param(_))) => Ok(None),
                Err(e) => Err(e),
            }
        })?;
        let Search {
            best,
            generations,
            mut evaluations,
            converged,
        } = search;

        // The best sample with its Jacobian; nothing physical sampled (or no
        // budget): the start.
        let mut mu = match best {
            Some((mu, _)) => mu,
            None => {
                let mut mu = DVector::from_column_slice(start);
                problem.project(&mut mu);
                mu
            }
        };
        evaluations += 1;
        let mut fit = problem.fit(mu.as_slice(), window)?;
        // Where the loss is flat the search stopped anywhere: those directions
        // keep the start, as in Levenberg-Marquardt.
        let sub = Subspace::new(&fit.jacobian.tr_mul(&fit.jacobian), opt.excitation);
        if !sub.all_excited() {
            mu = sub.keep_unexcited(&mu, &DVector::from_column_slice(start));
            problem.project(&mut mu);
            evaluations += 1;
            fit = problem.fit(mu.as_slice(), window)?;
        }
        let work = (generations, evaluations);
        Ok(Estimate::at(
            problem,
            (&mu, &fit),
            opt.excitation,
            converged,
            work,
        ))
    }

    /// Minimises `loss` over the box [lower, upper] from `start` with the
    /// strategy of the module docs (any function, not only a window loss).
    /// `loss` answers None for a point it rejects (scored +infinity).
    pub fn minimize<E>(
        &self,
        (lower, upper): (&[f64], &[f64]),
        start: &[f64],
        mut loss: impl FnMut(&[f64]) -> Result<Option<f64>, E>,
    ) -> Result<Search, E> {
        let opt = self.options;
        let mut rng = StdRng::seed_from_u64(opt.seed);
        let n = lower.len();
        let lower = DVector::from_column_slice(lower);
        let width = DVector::from_column_slice(upper) - &lower;
        let to_mu = |y: &DVector<f64>| lower.clone() + y.component_mul(&width);

        // Strategy parameters (Hansen's tutorial, table 1).
        let nf = n as f64;
        let lambda = if opt.population > 0 {
            opt.population.max(2)
        } else {
            4 + (3.0 * nf.ln()).floor() as usize
        };
        let parents = lambda / 2;
        let raw: Vec<f64> = (1..=parents)
            .map(|i| ((lambda as f64 + 1.0) / 2.0).ln() - (i as f64).ln())
            .collect();
        let total: f64 = raw.iter().sum();
        let weights: Vec<f64> = raw.iter().map(|w| w / total).collect();
        let mueff = 1.0 / weights.iter().map(|w| w * w).sum::<f64>();
        let cc = (4.0 + mueff / nf) / (nf + 4.0 + 2.0 * mueff / nf);
        let cs = (mueff + 2.0) / (nf + mueff + 5.0);
        let c1 = 2.0 / ((nf + 1.3).powi(2) + mueff);
        let cmu = (1.0 - c1).min(2.0 * (mueff - 2.0 + 1.0 / mueff) / ((nf + 2.0).powi(2) + mueff));
        let damps = 1.0 + 2.0 * (((mueff - 1.0) / (nf + 1.0)).sqrt() - 1.0).max(0.0) + cs;
        let chi_n = nf.sqrt() * (1.0 - 1.0 / (4.0 * nf) + 1.0 / (21.0 * nf * nf));
        let history = 10 + (30.0 * nf / lambda as f64).ceil() as usize;

        // State.
        let mut mean =
            DVector::from_fn(n, |i, _| ((start[i] - lower[i]) / width[i]).clamp(0.0, 1.0));
        let mut sigma = opt.sigma0;
        let mut cov = DMatrix::<f64>::identity(n, n);
        let mut axes = DMatrix::<f64>::identity(n, n);
        let mut lengths = DVector::from_element(n, 1.0);
        let (mut pc, mut ps) = (DVector::zeros(n), DVector::zeros(n));
        let mut best: Option<(DVector<f64>, f64)> = None;
        let mut bests: Vec<f64> = vec![];
        let (mut generations, mut evaluations) = (0, 0);
        let mut converged = false;

        while evaluations + lambda <= opt.max_evaluations {
            generations += 1;
            let mut steps = Vec::with_capacity(lambda);
            let mut scores = Vec::with_capacity(lambda);
            for _ in 0..lambda {
                let z = DVector::from_fn(n, |_, _| StandardNormal.sample(&mut rng));
                let y = &axes * lengths.component_mul(&z);
                let x = &mean + &y * sigma;
                let clamped = x.map(|xi| xi.clamp(0.0, 1.0));
                let d2 = (&x - &clamped).norm_squared();
                let mu = to_mu(&clamped);
                evaluations += 1;
                let score = match loss(mu.as_slice())? {
                    Some(loss) => {
                        let score = loss * (1.0 + d2) + d2;
                        if best.as_ref().is_none_or(|(_, b)| loss < *b) {
                            best = Some((mu, loss));
                        }
                        if score.is_nan() {
                            f64::INFINITY
                        } else {
                            score
                        }
                    }
                    None => f64::INFINITY,
                };
                steps.push(y);
                scores.push(score);
            }
            let mut order: Vec<usize> = (0..lambda).collect();
            order.sort_by(|a, b| scores[*a].total_cmp(&scores[*b]));

            // Mean, evolution paths, covariance, step size.
            let mut yw = DVector::zeros(n);
            for (w, k) in weights.iter().zip(&order) {
                yw += &steps[*k] * *w;
            }
            mean += &yw * sigma;
            let inv_sqrt =
                &axes * DMatrix::from_diagonal(&lengths.map(|l| 1.0 / l)) * axes.transpose();
            ps = ps * (1.0 - cs) + &inv_sqrt * &yw * (cs * (2.0 - cs) * mueff).sqrt();
            let decay = 1.0 - (1.0 - cs).powi(2 * generations as i32);
            let hsig = ps.norm() / decay.sqrt() / chi_n < 1.4 + 2.0 / (nf + 1.0);
            let h = if hsig { 1.0 } else { 0.0 };
            pc = pc * (1.0 - cc) + &yw * (h * (cc * (2.0 - cc) * mueff).sqrt());
            let delta_h = (1.0 - h) * cc * (2.0 - cc);
            let mut rank_mu = DMatrix::zeros(n, n);
            for (w, k) in weights.iter().zip(&order) {
                rank_mu += &steps[*k] * steps[*k].transpose() * *w;
            }
            cov =
                &cov * (1.0 - c1 - cmu + c1 * delta_h) + &pc * pc.transpose() * c1 + rank_mu * cmu;
            cov = (&cov + cov.transpose()) * 0.5;
            sigma *= ((cs / damps) * (ps.norm() / chi_n - 1.0)).exp();
            let eigen = cov.clone().symmetric_eigen();
            axes = eigen.eigenvectors;
            lengths = eigen.eigenvalues.map(|e| e.max(1e-300).sqrt());

            // Stopping.
            if sigma * lengths.max() < opt.x_tol {
                converged = true;
                break;
            }
            bests.push(scores[order[0]]);
            if bests.len() >= history {
                let recent = bests[bests.len() - history..].iter().chain(&scores);
                let (lo, hi) = recent.fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), s| {
                    (lo.min(*s), hi.max(*s))
                });
                if hi - lo < opt.f_tol {
                    converged = true;
                    break;
                }
            }
        }

        Ok(Search {
            best,
            generations,
            evaluations,
            converged,
        })
    }
}

/// Where a [`CmaEs::minimize`] ended.
#[derive(Clone, Debug, PartialEq)]
pub struct Search {
    /// The best point evaluated and its loss; None if no point was accepted.
    pub best: Option<(DVector<f64>, f64)>,
    pub generations: usize,
    pub evaluations: usize,
    /// A tolerance stopped it (not the evaluation budget).
    pub converged: bool,
}
