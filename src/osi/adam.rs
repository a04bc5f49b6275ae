//! The paper's first-order DiffOSI: Adam on the loss gradient dL/dmu,
//! projected onto the bounds after every step. Kept for comparison with
//! [`super::Lm`]: same loss, same interface, many more evaluations.

use nalgebra::DVector;

use super::{Estimate, Excitation, Identifier, OsiError, Problem};
use crate::derivatives::Transition;

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AdamOptions {
    /// Step size, as a fraction of each component's bound width.
    pub learning_rate: f64,
    pub beta1: f64,
    pub beta2: f64,
    pub epsilon: f64,
    pub max_iterations: usize,
    /// Stop when no component moves by more than this fraction of its bound
    /// width.
    pub step_tol: f64,
    /// Only used to flag unexcited directions and compute standard errors.
    pub excitation: Excitation,
}

impl Default for AdamOptions {
    fn default() -> Self {
        AdamOptions {
            learning_rate: 1e-2,
            beta1: 0.9,
            beta2: 0.999,
            epsilon: 1e-8,
            max_iterations: 2000,
            step_tol: 1e-7,
            excitation: Excitation::default(),
        }
    }
}

#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Adam {
    pub options: AdamOptions,
}

impl Identifier for Adam {
    fn identify(
        &mut self,
        problem: &mut Problem,
        window: &[Transition],
        start: &[f64],
    ) -> Result<Estimate, OsiError> {
        problem.check_window(window)?;
        problem.check_mu("start", start)?;
        let opt = self.options;
        let n = problem.nmu();
        let width: Vec<f64> = (0..n)
            .map(|i| problem.upper()[i] - problem.lower()[i])
            .collect();
        let mut mu = DVector::from_column_slice(start);
        problem.project(&mut mu);
        let mut fit = problem.fit(mu.as_slice(), window)?;
        let (mut m, mut v) = (DVector::zeros(n), DVector::zeros(n));
        let (mut iterations, mut evaluations) = (0, 1);
        let mut converged = false;
        while iterations < opt.max_iterations {
            iterations += 1;
            let g = &fit.gradient;
            m = &m * opt.beta1 + g * (1.0 - opt.beta1);
            v = &v * opt.beta2 + g.component_mul(g) * (1.0 - opt.beta2);
            let m_hat = &m / (1.0 - opt.beta1.powi(iterations as i32));
            let v_hat = &v / (1.0 - opt.beta2.powi(iterations as i32));
            let mut next = mu.clone();
            for i in 0..n {
                next[i] -=
                    opt.learning_rate * width[i] * m_hat[i] / (v_hat[i].sqrt() + opt.epsilon);
            }
            problem.project(&mut next);
            let moved = (0..n)
                .map(|i| (next[i] - mu[i]).abs() / width[i])
                .fold(0.0, f64::max);
            if moved <= opt.step_tol {
                converged = true;
                break;
            }
            mu = next;
            problem.fit_into(mu.as_slice(), window, &mut fit)?;
            evaluations += 1;
        }
        let work = (iterations, evaluations);
        Ok(Estimate::at(
            problem,
            (&mu, &fit),
            opt.excitation,
            converged,
            work,
        ))
    }
}
