//! Online system identification (DiffOSI, the paper's eq. 1-3): find the task
//! parameters mu that make our step reproduce a window of observed transitions.
//!
//! Conventions, stated once:
//! - mu is the task's parameter vector; a [`ParamMap`] turns it into named
//!   physical parameters. Every mu component has finite bounds
//!   `lower < upper` and a prior (the cold-start value) inside them.
//! - The loss is L(mu) = sum over the window of ||(g_mu(x_t, tau_t) - x_{t+1}) / scale||^2
//!   ([`window_residuals`](crate::derivatives::window_residuals)); `scale` holds 2 nv positive values, q then v,
//!   best set to each component's measurement noise (then J^T J is the
//!   Fisher information). [`Lm`] can minimise a Huber loss of the same
//!   scaled residuals instead ([`Loss`]). When the target's contact law is
//!   not ours, [`Problem::with_unknown_constraints`] replaces them by nv
//!   generalized-force residuals per transition with the constraint
//!   impulses eliminated (module `derivatives::eliminated`).
//! - The prior is uniform on the bounds: its standard deviation is
//!   (upper - lower) / sqrt(12). A direction of mu the window does not excite
//!   keeps its start value and reports that prior standard deviation, so an
//!   [`Estimate`] never holds NaN.
//! - Iterations count solver steps; evaluations count calls of
//!   [`window_residuals`](crate::derivatives::window_residuals) (residuals and Jacobian together).

mod adam;
mod change;
mod cmaes;
mod lm;
pub mod mlp;
mod online;
mod trivial;

use nalgebra::{DMatrix, DVector};

pub use adam::{Adam, AdamOptions};
pub use change::ChangeDetection;
pub use cmaes::{CmaEs, CmaEsOptions, Search};
pub use lm::{Lm, LmOptions, Loss, HUBER_THRESHOLD};
pub use online::{Online, Sampling};
pub use trivial::{Average, Oracle, Random};

use crate::derivatives::{
    check_transition, eliminated_residuals_into, one_dof_joints, window_residuals_into,
    Elimination, Impulses, Transition, WindowError, WindowFit, Workspace,
};
use crate::dynamics::StepError;
use crate::model::{ParamError, ParamMap};
use crate::Model;

#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum OsiError {
    #[error("{what} has {got} values, expected {expected}")]
    Length {
        what: &'static str,
        got: usize,
        expected: usize,
    },
    #[error(
        "bounds of mu[{i}]: lower {lower} and upper {upper} must be finite with lower < upper"
    )]
    Bounds { i: usize, lower: f64, upper: f64 },
    #[error("prior mu[{i}] = {value} lies outside its bounds [{lower}, {upper}]")]
    PriorOutside {
        i: usize,
        value: f64,
        lower: f64,
        upper: f64,
    },
    #[error("the window holds no transitions")]
    EmptyWindow,
    #[error("window size {window} must be at least 1 and at most the history {history}")]
    WindowSize { window: usize, history: usize },
    #[error("transition {t}: {what}[{i}] = {value} is not finite")]
    NotFinite {
        t: usize,
        what: &'static str,
        i: usize,
        value: f64,
    },
    #[error("change detection: threshold {threshold} must be finite and above 1, min_window {min_window} and memory {memory} at least 1")]
    ChangeDetection {
        threshold: f64,
        min_window: usize,
        memory: usize,
    },
    #[error(
        "Huber threshold {threshold} must be finite and positive (in units of the residual scale)"
    )]
    Huber { threshold: f64 },
    /// Closed-loop segments that cannot be simulated or differentiated.
    #[error("{0}")]
    Segment(String),
    /// A model whose identification residuals are not written yet.
    #[error(transparent)]
    Unsupported(StepError),
    #[error(transparent)]
    Param(#[from] ParamError),
    #[error(transparent)]
    Window(#[from] WindowError),
}

/// What to identify: the model, the map from mu, the box, the prior and the
/// residual scale. Holds the working copy of the model and the derivative
/// buffers, so evaluating the loss takes `&mut self`.
#[derive(Clone, Debug)]
pub struct Problem {
    model: Model,
    ws: Workspace,
    /// The residuals of [`Problem::loss`].
    scratch: WindowFit,
    map: ParamMap,
    lower: Vec<f64>,
    upper: Vec<f64>,
    prior: Vec<f64>,
    scale: Vec<f64>,
    /// Set when the target's constraint impulses are unknown (another
    /// engine's contact law): the residuals are then
    /// [`eliminated_residuals_into`]'s, nv per transition.
    elimination: Option<Elimination>,
}

/// The velocity residual scale when none is given: a measurement noise of
/// 1e-3 (m/s or rad/s), the level the misfit test, the Huber threshold and
/// the excitation floor are stated in units of. Noise-free data fits as well
/// under it (the minimiser does not depend on a common factor); a problem
/// that wants rounding-level misfit detection sets its own (the tasks'
/// [`task_problem`](crate::control::task_problem) uses 1e-6).
pub const DEFAULT_NOISE: f64 = 1e-3;

/// The default residual scale of a model's transitions: [`DEFAULT_NOISE`] on
/// every v and `timestep` times it on every q (under semi-implicit Euler a
/// position residual is dt times the velocity residual that caused it, so
/// both weigh alike). The CLI's `identify` and the Python classes use it.
pub fn default_scale(model: &Model) -> Vec<f64> {
    let nv = model.nv();
    let mut scale = vec![model.opt.timestep * DEFAULT_NOISE; nv];
    scale.extend(std::iter::repeat_n(DEFAULT_NOISE, nv));
    scale
}

impl Problem {
    /// Checks the bounds, the prior (inside the bounds, mapping onto a
    /// physical model) and the scale.
    pub fn new(
        model: &Model,
        map: ParamMap,
        lower: &[f64],
        upper: &[f64],
        prior: &[f64],
        scale: &[f64],
    ) -> Result<Problem, OsiError> {
        let nmu = map.nmu;
        for (what, x, expected) in [
            ("lower", lower, nmu),
            ("upper", upper, nmu),
            ("prior", prior, nmu),
            ("scale", scale, 2 * model.nv()),
        ] {
            if x.len() != expected {
                return Err(OsiError::Length {
                    what,
                    got: x.len(),
                    expected,
                });
            }
        }
        for i in 0..nmu {
            let (lo, hi, p) = (lower[i], upper[i], prior[i]);
            if !(lo.is_finite() && hi.is_finite() && lo < hi) {
                return Err(OsiError::Bounds {
                    i,
                    lower: lo,
                    upper: hi,
                });
            }
            if !(lo..=hi).contains(&p) {
                return Err(OsiError::PriorOutside {
                    i,
                    value: p,
                    lower: lo,
                    upper: hi,
                });
            }
        }
        if scale.iter().any(|s| !(s.is_finite() && *s > 0.0)) {
            return Err(WindowError::Scale {
                expected: 2 * model.nv(),
            }
            .into());
        }
        let mut model = model.clone();
        map.apply(&mut model, prior)?;
        Ok(Problem {
            ws: Workspace::new(&model),
            scratch: WindowFit::empty(),
            model,
            map,
            lower: lower.to_vec(),
            upper: upper.to_vec(),
            prior: prior.to_vec(),
            scale: scale.to_vec(),
            elimination: None,
        })
    }

    /// The same problem with the target's constraint impulses unknown: any
    /// wrench on a body within `margin` of touching, any force on a joint
    /// within `margin` of its range's ends or with dry friction, eliminated
    /// from each transition's residual (module `derivatives::eliminated`),
    /// whose nv values are generalized forces divided by `force_scale`
    /// (N or N m), `impulses` the target's convention. Refuses a bad margin
    /// or scale, a model that does not integrate with Euler, and one with
    /// ball or free joints or fluid forces.
    pub fn with_unknown_constraints(
        mut self,
        margin: f64,
        force_scale: &[f64],
        impulses: Impulses,
    ) -> Result<Problem, OsiError> {
        one_dof_joints(&self.model).map_err(OsiError::Unsupported)?;
        let elimination = Elimination::new(&self.model, margin, force_scale, impulses)?;
        self.elimination = Some(elimination);
        Ok(self)
    }

    /// Residuals per transition: 2 nv (q then v), or nv forces when the
    /// constraints are unknown.
    pub fn rows_per_transition(&self) -> usize {
        match self.elimination {
            Some(_) => self.nv(),
            None => 2 * self.nv(),
        }
    }

    pub fn nmu(&self) -> usize {
        self.map.nmu
    }

    pub fn nv(&self) -> usize {
        self.model.nv()
    }

    pub fn nq(&self) -> usize {
        self.model.nq()
    }

    pub fn lower(&self) -> &[f64] {
        &self.lower
    }

    pub fn upper(&self) -> &[f64] {
        &self.upper
    }

    pub fn prior(&self) -> &[f64] {
        &self.prior
    }

    /// Standard deviation of the uniform prior on the bounds.
    pub fn prior_std(&self) -> Vec<f64> {
        let width = self.upper.iter().zip(&self.lower).map(|(u, l)| u - l);
        width.map(|w| w / 12f64.sqrt()).collect()
    }

    /// The scaled residuals, their Jacobian, the loss and its gradient at mu.
    pub fn fit<O: Observations + ?Sized>(
        &mut self,
        mu: &[f64],
        observed: &O,
    ) -> Result<WindowFit, OsiError> {
        let mut fit = WindowFit::empty();
        self.fit_into(mu, observed, &mut fit)?;
        Ok(fit)
    }

    /// [`Problem::fit`] into the buffers of `fit` (reused while the number
    /// of residuals stays the same).
    pub fn fit_into<O: Observations + ?Sized>(
        &mut self,
        mu: &[f64],
        observed: &O,
        fit: &mut WindowFit,
    ) -> Result<(), OsiError> {
        observed.residuals_into(self, mu, true, fit)
    }

    /// The loss at mu alone: residuals without their Jacobian, what a
    /// derivative-free search or a one-step prediction needs.
    pub fn loss<O: Observations + ?Sized>(
        &mut self,
        mu: &[f64],
        observed: &O,
    ) -> Result<f64, OsiError> {
        let mut scratch = std::mem::replace(&mut self.scratch, WindowFit::empty());
        let result = observed.residuals_into(self, mu, false, &mut scratch);
        let loss = scratch.loss;
        self.scratch = scratch;
        result.map(|()| loss)
    }

    /// The map from mu onto the model's parameters.
    pub fn map(&self) -> &ParamMap {
        &self.map
    }

    /// The residual scale (2 nv values: q then v).
    pub fn scale(&self) -> &[f64] {
        &self.scale
    }

    /// The working model with mu's parameters set.
    pub fn model_at(&mut self, mu: &[f64]) -> Result<&Model, OsiError> {
        self.check_mu("mu", mu)?;
        self.map.apply(&mut self.model, mu)?;
        Ok(&self.model)
    }

    /// Rejects an empty window and names any wrong length or non-finite value.
    pub fn check_window(&self, window: &[Transition]) -> Result<(), OsiError> {
        if window.is_empty() {
            return Err(OsiError::EmptyWindow);
        }
        let sizes = (self.nq(), self.nv());
        window
            .iter()
            .enumerate()
            .try_for_each(|(t, tr)| check_transition(t, tr, sizes).map_err(OsiError::from))
    }

    fn check_mu(&self, what: &'static str, mu: &[f64]) -> Result<(), OsiError> {
        if mu.len() != self.nmu() {
            return Err(OsiError::Length {
                what,
                got: mu.len(),
                expected: self.nmu(),
            });
        }
        Ok(())
    }

    /// mu clamped into the bounds.
    fn project(&self, mu: &mut DVector<f64>) {
        for (i, m) in mu.iter_mut().enumerate() {
            *m = m.clamp(self.lower[i], self.upper[i]);
        }
    }

    fn at_bound(&self, mu: &[f64]) -> bool {
        mu.iter()
            .enumerate()
            .any(|(i, m)| *m <= self.lower[i] || *m >= self.upper[i])
    }
}

/// What a [`Problem`] fits: observations our model predicts from mu (a
/// window of transitions, or closed-loop segments of a task).
pub trait Observations {
    /// Rejects empty or malformed observations, naming what is wrong.
    fn check(&self, problem: &Problem) -> Result<(), OsiError>;
    /// How many residuals [`Observations::residuals_into`] writes.
    fn residual_count(&self, problem: &Problem) -> usize;
    /// The scaled residuals at mu, the loss, and with `jacobian` their
    /// Jacobian d r / d mu and the gradient, into `fit` (sized here).
    fn residuals_into(
        &self,
        problem: &mut Problem,
        mu: &[f64],
        jacobian: bool,
        fit: &mut WindowFit,
    ) -> Result<(), OsiError>;
}

/// The paper's observations: a window of transitions under recorded forces.
impl Observations for [Transition] {
    fn check(&self, problem: &Problem) -> Result<(), OsiError> {
        problem.check_window(self)
    }

    fn residual_count(&self, problem: &Problem) -> usize {
        self.len() * problem.rows_per_transition()
    }

    fn residuals_into(
        &self,
        problem: &mut Problem,
        mu: &[f64],
        jacobian: bool,
        fit: &mut WindowFit,
    ) -> Result<(), OsiError> {
        let (model, ws) = (&mut problem.model, &mut problem.ws);
        let at = (&problem.map, mu);
        match &mut problem.elimination {
            Some(e) => eliminated_residuals_into(model, ws, at, (self, e), jacobian, fit)?,
            None => window_residuals_into(model, ws, at, (self, &problem.scale), jacobian, fit)?,
        }
        Ok(())
    }
}

/// Conditions attached to an estimate; all false is a clean result.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Flags {
    /// Some direction of mu was not excited by the window (J^T J rank
    /// deficient or ill-conditioned): it kept its start value (the prior on a
    /// cold start) and reports the prior's standard deviation.
    pub unexcited: bool,
    /// Some component ended on a bound.
    pub at_bound: bool,
    /// The iteration limit stopped the solver before a tolerance did.
    pub not_converged: bool,
    /// The best fit leaves the loss per degree of freedom, loss / max(1, m -
    /// nmu), above [`LmOptions::misfit`]: the
    /// residuals are larger than `scale` says the noise is. Either the scale
    /// is too small for the data, or the model does not explain them (an
    /// unmodelled effect, a delay, mu changing inside the window), and mu
    /// may be biased. Set by LM.
    pub misfit: bool,
    /// [`Online`]'s change detection judged the last pushed transition a
    /// change of mu: the window held only transitions from it on.
    pub changed: bool,
}

impl Flags {
    /// The names of the flags that are set, in declaration order (the
    /// Python result's `flags` list and the CLI's).
    pub fn names(&self) -> Vec<&'static str> {
        [
            (self.unexcited, "unexcited"),
            (self.at_bound, "at_bound"),
            (self.not_converged, "not_converged"),
            (self.misfit, "misfit"),
            (self.changed, "changed"),
        ]
        .into_iter()
        .filter_map(|(on, name)| on.then_some(name))
        .collect()
    }
}

/// An identifier's answer.
#[derive(Clone, Debug, PartialEq)]
pub struct Estimate {
    pub mu: Vec<f64>,
    /// Standard errors of mu, finite (see the module conventions).
    pub std: Vec<f64>,
    pub loss: f64,
    pub iterations: usize,
    pub evaluations: usize,
    pub flags: Flags,
}

impl Estimate {
    /// Where a solver ended: mu with its last fit, standard errors and flags
    /// from that fit, and the work it took.
    fn at(
        problem: &Problem,
        (mu, fit): (&DVector<f64>, &WindowFit),
        excitation: Excitation,
        converged: bool,
        (iterations, evaluations): (usize, usize),
    ) -> Estimate {
        let (std, unexcited) = standard_errors(problem, fit, excitation);
        Estimate {
            flags: Flags {
                unexcited,
                at_bound: problem.at_bound(mu.as_slice()),
                not_converged: !converged,
                ..Flags::default()
            },
            mu: mu.as_slice().to_vec(),
            std,
            loss: fit.loss,
            iterations,
            evaluations,
        }
    }
}

/// Anything that estimates mu from a window of transitions.
pub trait Identifier {
    /// Estimates mu, starting from `start` (the prior on a cold start, the
    /// previous estimate on a warm one).
    fn identify(
        &mut self,
        problem: &mut Problem,
        window: &[Transition],
        start: &[f64],
    ) -> Result<Estimate, OsiError>;
}

/// A boxed identifier is one, so a solver chosen at run time
/// (`Box<dyn Identifier + Send>`) drives [`Online`] like a concrete one.
impl<I: Identifier + ?Sized> Identifier for Box<I> {
    fn identify(
        &mut self,
        problem: &mut Problem,
        window: &[Transition],
        start: &[f64],
    ) -> Result<Estimate, OsiError> {
        (**self).identify(problem, window, start)
    }
}

/// Thresholds on the eigenvalues of J^T J that decide which directions of mu
/// a window excites.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Excitation {
    /// A direction is unexcited below `relative` times the largest eigenvalue
    /// (condition number above 1 / relative).
    pub relative: f64,
    /// ... or below `absolute` (in the units of the scaled residuals: the
    /// window then pins that direction no better than 1/sqrt(absolute)).
    pub absolute: f64,
}

impl Default for Excitation {
    fn default() -> Self {
        Excitation {
            relative: 1e-10,
            absolute: 1e-12,
        }
    }
}

/// The eigen-decomposition of a symmetric J^T J split into its excited and
/// unexcited directions.
struct Subspace {
    /// Eigenvectors, one per column.
    vectors: DMatrix<f64>,
    values: DVector<f64>,
    excited: Vec<bool>,
}

impl Subspace {
    fn new(jtj: &DMatrix<f64>, thresholds: Excitation) -> Subspace {
        // One parameter (the common case) needs no eigen-solver.
        let (vectors, values) = if jtj.nrows() == 1 {
            (
                DMatrix::identity(1, 1),
                DVector::from_element(1, jtj[(0, 0)]),
            )
        } else {
            let eigen = jtj.clone().symmetric_eigen();
            (eigen.eigenvectors, eigen.eigenvalues)
        };
        let max = values.max().max(0.0);
        let floor = (thresholds.relative * max).max(thresholds.absolute);
        Subspace {
            excited: values.iter().map(|l| *l > floor).collect(),
            vectors,
            values,
        }
    }

    fn all_excited(&self) -> bool {
        self.excited.iter().all(|e| *e)
    }

    /// `mu` with its components along the unexcited directions taken from
    /// `start`: what the window cannot tell stays where it began.
    fn keep_unexcited(&self, mu: &DVector<f64>, start: &DVector<f64>) -> DVector<f64> {
        let mut kept = mu.clone();
        for (k, v) in self.vectors.column_iter().enumerate() {
            if !self.excited[k] {
                kept -= v * v.dot(&(mu - start));
            }
        }
        kept
    }

    /// Solves (J^T J + damping I) x = b within the excited directions; x has
    /// no component along the others.
    fn solve(&self, b: &DVector<f64>, damping: f64) -> DVector<f64> {
        let mut x = DVector::zeros(b.len());
        for (k, v) in self.vectors.column_iter().enumerate() {
            if self.excited[k] {
                x += v * (v.dot(b) / (self.values[k] + damping));
            }
        }
        x
    }
}

/// Standard errors at the end of a fit: sigma^2 (J^T J)^-1 restricted to the
/// excited directions, sigma^2 = loss / max(1, m - p) with p the number of
/// excited directions; plus the prior's variance projected onto the
/// unexcited ones. Returns them with whether any direction was unexcited.
fn standard_errors(problem: &Problem, fit: &WindowFit, thresholds: Excitation) -> (Vec<f64>, bool) {
    let sub = Subspace::new(&fit.jacobian.tr_mul(&fit.jacobian), thresholds);
    let p = sub.excited.iter().filter(|e| **e).count();
    let m = fit.residuals.len();
    let sigma2 = fit.loss / (m.saturating_sub(p).max(1) as f64);
    let n = problem.nmu();
    // The diagonal of sum over excited k of v_k v_k^T sigma^2 / lambda_k.
    let mut var: Vec<f64> = (0..n)
        .map(|i| {
            (0..n)
                .filter(|k| sub.excited[*k])
                .map(|k| sub.vectors[(i, k)].powi(2) * sigma2 / sub.values[k])
                .sum()
        })
        .collect();
    if !sub.all_excited() {
        // P D P, P the projector onto the unexcited directions, D the prior
        // variances.
        let mut unexcited = DMatrix::zeros(n, n);
        for (k, v) in sub.vectors.column_iter().enumerate() {
            if !sub.excited[k] {
                unexcited += v * v.transpose();
            }
        }
        let prior = problem.prior_std();
        for (i, var) in var.iter_mut().enumerate() {
            *var += (0..n)
                .map(|l| (unexcited[(i, l)] * prior[l]).powi(2))
                .sum::<f64>();
        }
    }
    let std = var.iter().map(|c| c.max(0.0).sqrt()).collect();
    (std, !sub.all_excited())
}
