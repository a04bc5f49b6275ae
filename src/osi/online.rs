//! Online use: a ring buffer of recent transitions; each pushed transition
//! triggers an update on a window sampled from it, warm-started from the
//! previous estimate (the prior before the first). Optionally, a change
//! detection ([`ChangeDetection`], off by default; the rule is in its module)
//! empties the buffer when a new transition no longer fits the estimate.

use std::collections::VecDeque;

use rand::rngs::StdRng;
use rand::seq::index::sample;
use rand::SeedableRng;

use super::change::{ChangeDetection, Detector};
use super::{Estimate, Identifier, OsiError, Problem};
use crate::derivatives::Transition;

/// Which transitions of the buffer form the window.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Sampling {
    /// The W most recent transitions.
    Recent,
    /// W distinct transitions drawn uniformly from the `history` most recent
    /// (the paper's wiping task), kept in time order.
    Uniform { history: usize },
}

#[derive(Debug)]
pub struct Online<I> {
    pub identifier: I,
    problem: Problem,
    window: usize,
    history: usize,
    sampling: Sampling,
    buffer: VecDeque<Transition>,
    rng: StdRng,
    estimate: Option<Estimate>,
    detector: Option<Detector>,
    residual: Option<f64>,
}

impl<I: Identifier> Online<I> {
    /// A window of `window` >= 1 transitions; with uniform sampling the
    /// history must hold at least as many. `seed` drives the sampling.
    pub fn new(
        problem: Problem,
        identifier: I,
        window: usize,
        sampling: Sampling,
        seed: u64,
    ) -> Result<Online<I>, OsiError> {
        let history = match sampling {
            Sampling::Recent => window,
            Sampling::Uniform { history } => history,
        };
        if window == 0 || history < window {
            return Err(OsiError::WindowSize { window, history });
        }
        Ok(Online {
            identifier,
            problem,
            window,
            history,
            sampling,
            buffer: VecDeque::with_capacity(history),
            rng: StdRng::seed_from_u64(seed),
            estimate: None,
            detector: None,
            residual: None,
        })
    }

    /// Turns on change detection (off by default). Refuses a threshold that
    /// is not finite and above 1, or a zero `min_window` or `memory`.
    pub fn with_change_detection(
        mut self,
        options: ChangeDetection,
    ) -> Result<Online<I>, OsiError> {
        if !options.is_valid() {
            return Err(OsiError::ChangeDetection {
                threshold: options.threshold,
                min_window: options.min_window,
                memory: options.memory,
            });
        }
        self.detector = Some(Detector::new(options));
        Ok(self)
    }

    /// The change detection's options, if it is on.
    pub fn change_detection(&self) -> Option<ChangeDetection> {
        self.detector.as_ref().map(|d| d.options)
    }

    /// The scaled one-step prediction residual of the last pushed transition
    /// under the estimate before it (None before a first estimate, or with
    /// change detection off).
    pub fn residual(&self) -> Option<f64> {
        self.residual
    }

    /// Stores a transition (checked first: a bad one leaves the buffer as it
    /// was) and updates the estimate from a freshly sampled window. With
    /// change detection on, a transition judged a change first empties the
    /// buffer, and the estimate says so in `flags.changed`.
    pub fn push(&mut self, transition: Transition) -> Result<&Estimate, OsiError> {
        let one = std::slice::from_ref(&transition);
        self.problem.check_window(one)?;
        let mut changed = false;
        if let Some(detector) = &mut self.detector {
            self.residual = match &self.estimate {
                Some(e) => Some(self.problem.loss(&e.mu, one)?),
                None => None,
            };
            changed = detector.judge(self.residual, self.problem.rows_per_transition());
        }
        if changed {
            self.buffer.clear();
        }
        if self.buffer.len() == self.history {
            self.buffer.pop_front();
        }
        self.buffer.push_back(transition);
        let start = match &self.estimate {
            Some(e) => e.mu.clone(),
            None => self.problem.prior().to_vec(),
        };
        // The most recent transitions are a slice of the buffer; a uniform
        // sample is gathered (in time order) into its own window.
        let w = self.window.min(self.buffer.len());
        let sampled: Vec<Transition>;
        let window: &[Transition] = match self.sampling {
            Sampling::Recent => {
                let all = self.buffer.make_contiguous();
                &all[all.len() - w..]
            }
            Sampling::Uniform { .. } => {
                let mut picked = sample(&mut self.rng, self.buffer.len(), w).into_vec();
                picked.sort_unstable();
                sampled = picked.iter().map(|&i| self.buffer[i].clone()).collect();
                &sampled
            }
        };
        let mut estimate = self
            .identifier
            .identify(&mut self.problem, window, &start)?;
        estimate.flags.changed = changed;
        Ok(self.estimate.insert(estimate))
    }

    /// The latest estimate, if any transition was pushed.
    pub fn estimate(&self) -> Option<&Estimate> {
        self.estimate.as_ref()
    }

    pub fn problem(&self) -> &Problem {
        &self.problem
    }
}
