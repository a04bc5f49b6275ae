//! Baselines behind the same interface, for experiments: Random (uniform in
//! the bounds, seeded), Average (the middle of each range) and Oracle (the
//! true mu). Each evaluates the loss once at its answer, so its estimate is
//! comparable with a solver's. Random and Average report the prior's standard
//! deviation, Oracle zero.

use rand::rngs::StdRng;
use rand::{RngExt, SeedableRng};

use super::{Estimate, Flags, Identifier, OsiError, Problem};
use crate::derivatives::Transition;

/// The estimate that answers `mu` without solving.
fn answer(
    problem: &mut Problem,
    window: &[Transition],
    mu: Vec<f64>,
    std: Vec<f64>,
) -> Result<Estimate, OsiError> {
    problem.check_window(window)?;
    problem.check_mu("mu", &mu)?;
    let loss = problem.loss(&mu, window)?;
    Ok(Estimate {
        flags: Flags {
            at_bound: problem.at_bound(&mu),
            ..Flags::default()
        },
        mu,
        std,
        loss,
        iterations: 0,
        evaluations: 1,
    })
}

#[derive(Debug)]
pub struct Random {
    rng: StdRng,
}

impl Random {
    pub fn new(seed: u64) -> Random {
        Random {
            rng: StdRng::seed_from_u64(seed),
        }
    }
}

impl Identifier for Random {
    fn identify(
        &mut self,
        problem: &mut Problem,
        window: &[Transition],
        _start: &[f64],
    ) -> Result<Estimate, OsiError> {
        let mu = (0..problem.nmu())
            .map(|i| {
                let (lo, hi) = (problem.lower()[i], problem.upper()[i]);
                lo + (hi - lo) * self.rng.random::<f64>()
            })
            .collect();
        let std = problem.prior_std();
        answer(problem, window, mu, std)
    }
}

#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Average;

impl Identifier for Average {
    fn identify(
        &mut self,
        problem: &mut Problem,
        window: &[Transition],
        _start: &[f64],
    ) -> Result<Estimate, OsiError> {
        let mu = (0..problem.nmu())
            .map(|i| 0.5 * (problem.lower()[i] + problem.upper()[i]))
            .collect();
        let std = problem.prior_std();
        answer(problem, window, mu, std)
    }
}

#[derive(Clone, Debug, PartialEq)]
pub struct Oracle {
    pub mu: Vec<f64>,
}

impl Identifier for Oracle {
    fn identify(
        &mut self,
        problem: &mut Problem,
        window: &[Transition],
        _start: &[f64],
    ) -> Result<Estimate, OsiError> {
        let std = vec![0.0; self.mu.len()];
        answer(problem, window, self.mu.clone(), std)
    }
}
