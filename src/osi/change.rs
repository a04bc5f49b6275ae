//! Change detection for [`Online`](super::Online): notice an abrupt change of
//! the true mu (the paper's Table 4 weakness) from the one-step prediction
//! residual of each new transition, and drop the stale part of the window.
//!
//! The rule. Before a pushed transition joins the buffer, its residual under
//! the current estimate is computed, scaled like the loss:
//! r = ||(g_mu_hat(x_t, tau_t) - x_{t+1}) / scale||^2. With `scale` at the
//! noise level (the module convention) r is about chi-square with 2 nv
//! degrees of freedom, so its typical level is at least 2 nv; if the data are
//! noisier than `scale` says (or the model misfits), the median of the recent
//! accepted residuals is larger and takes over. A change is declared when
//!
//! r > threshold * max(2 nv, median of the last `memory` accepted residuals).
//!
//! At the default threshold 10 (nv = 2: r > 40 at least), a chi-square(4)
//! draw crosses it with probability 4e-8, about one false alarm in 25
//! million transitions; for larger nv the false-alarm rate only falls. A
//! change in mu that moves the prediction by a few noise levels crosses it
//! at once. The test is armed only once `min_window` transitions have been
//! accepted since the start or the last change, so an estimate from too few
//! transitions (a poor one) does not raise alarms.
//!
//! On a change the buffer is emptied and the new transition alone forms the
//! window; the estimate is re-identified warm-started from the previous
//! estimate and carries [`Flags::changed`](super::Flags::changed). The
//! residual memory is cleared (the floor 2 nv applies until it refills).

use std::collections::VecDeque;

/// Options of the change detection (off unless given to
/// [`Online::with_change_detection`](super::Online::with_change_detection)).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ChangeDetection {
    /// A residual above `threshold` times its typical level is a change;
    /// finite and above 1.
    pub threshold: f64,
    /// Transitions accepted since the start or the last change before the
    /// test is armed; at least 1.
    pub min_window: usize,
    /// How many recent accepted residuals the median runs over; at least 1.
    pub memory: usize,
}

impl Default for ChangeDetection {
    fn default() -> Self {
        ChangeDetection {
            threshold: 10.0,
            min_window: 3,
            memory: 20,
        }
    }
}

impl ChangeDetection {
    pub(super) fn is_valid(&self) -> bool {
        self.threshold.is_finite()
            && self.threshold > 1.0
            && self.min_window >= 1
            && self.memory >= 1
    }
}

/// The state of the test: recent accepted residuals and the count since the
/// last change.
#[derive(Clone, Debug)]
pub(super) struct Detector {
    pub(super) options: ChangeDetection,
    recent: VecDeque<f64>,
    accepted: usize,
}

impl Detector {
    pub(super) fn new(options: ChangeDetection) -> Detector {
        Detector {
            options,
            recent: VecDeque::with_capacity(options.memory),
            accepted: 0,
        }
    }

    /// The residual level above which a transition is a change, if armed.
    pub(super) fn limit(&self, dof: usize) -> Option<f64> {
        if self.accepted < self.options.min_window {
            return None;
        }
        let mut sorted: Vec<f64> = self.recent.iter().copied().collect();
        sorted.sort_unstable_by(f64::total_cmp);
        let median = match sorted.len() {
            0 => 0.0,
            n if n % 2 == 1 => sorted[n / 2],
            n => 0.5 * (sorted[n / 2 - 1] + sorted[n / 2]),
        };
        Some(self.options.threshold * median.max(dof as f64))
    }

    /// Judges a transition whose prediction residual is `residual` (None
    /// before any estimate exists); true means a change.
    pub(super) fn judge(&mut self, residual: Option<f64>, dof: usize) -> bool {
        let Some(r) = residual else {
            self.accepted += 1;
            return false;
        };
        match self.limit(dof) {
            // A non-finite residual counts as a change too.
            Some(limit) if r.is_nan() || r > limit => {
                self.recent.clear();
                self.accepted = 1;
                true
            }
            armed => {
                if armed.is_some() {
                    if self.recent.len() == self.options.memory {
                        self.recent.pop_front();
                    }
                    self.recent.push_back(r);
                }
                self.accepted += 1;
                false
            }
        }
    }
}
