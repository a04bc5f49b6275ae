//! Tasks, trained policies and online identification for Python: the engine's
//! `tasks::Task`, `rl::Policy` and `osi::Online`, so that the harness runs the
//! same task, controllers and identifier as `diffosi eval`.
//!
//! Conventions are the engine's (src/tasks/mod.rs): a state is (q, v) in SI
//! units; an action has `act_dim` components meaningful in [-1, 1];
//! `forces(action)` gives the generalized forces (length nv) one control step
//! holds for `substeps` physics steps; mu is the task's parameter vector,
//! mapped affinely onto named physical parameters (`mu_params`), drawn
//! uniformly in `mu_range`.

use engine::derivatives::Transition;
use engine::model::State;
use engine::osi::{
    Adam, ChangeDetection, Identifier, Lm, LmOptions, Loss, Online, Problem, Sampling,
    HUBER_THRESHOLD,
};
use engine::rl::{self as rl, Policy, PolicyKind, PpoConfig};
use engine::tasks::{self, Task};
use numpy::ndarray::Array2;
use numpy::PyArray1;
use numpy::PyArray2;
use pyo3::exceptions::{PyOSError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList, PyTuple};
use rand::rngs::StdRng;
use rand::SeedableRng;

use crate::{
    default_scale, estimate_dict, loss_name, osi_error, param_error, robust_loss, vector,
    with_constraints, PyModel, DEFAULT_MARGIN,
};

/// A control task by name: `Task("cartpole")`.
///
/// `model(mu)` is the task's model with mu applied (a `diffosi.Model`);
/// `mu_params(mu)` the physical parameters mu sets; `episodes(n, seed)` the
/// seeded (mu, initial state) pairs that `diffosi eval --seed` meets;
/// `observe`, `forces`, `terminated` and `metric` are the task's own.
#[pyclass(name = "Task", module = "diffosi", frozen)]
pub(crate) struct PyTask {
    task: Box<dyn Task>,
}

impl PyTask {
    /// Converts and checks a state of the task's model.
    fn state(&self, q: &Bound<'_, PyAny>, v: &Bound<'_, PyAny>) -> PyResult<State> {
        let m = self.task.model();
        Ok((vector(q, "q", m.nq(), "nq")?, vector(v, "v", m.nv(), "nv")?))
    }

    /// Converts mu and checks that it lies in the task's range.
    fn mu(&self, mu: &Bound<'_, PyAny>) -> PyResult<Vec<f64>> {
        let mu = vector(mu, "mu", self.nmu(), "nmu")?;
        let (lo, hi) = self.task.mu_range();
        if let Some(i) = (0..mu.len()).find(|&i| !(lo[i]..=hi[i]).contains(&mu[i])) {
            return Err(PyValueError::new_err(format!(
                "mu[{i}] = {} lies outside the task's range [{}, {}]",
                mu[i], lo[i], hi[i]
            )));
        }
        Ok(mu)
    }

    fn action(&self, action: &Bound<'_, PyAny>) -> PyResult<Vec<f64>> {
        vector(action, "action", self.task.act_dim(), "act_dim")
    }
}

#[pymethods]
impl PyTask {
    #[new]
    fn new(name: &str) -> PyResult<Self> {
        let task = tasks::by_name(name).map_err(PyValueError::new_err)?;
        Ok(PyTask { task })
    }

    #[getter]
    fn name(&self) -> &'static str {
        self.task.name()
    }

    /// Control steps of a full episode.
    #[getter]
    fn horizon(&self) -> usize {
        self.task.horizon()
    }

    /// Physics steps of the model's timestep per control step.
    #[getter]
    fn substeps(&self) -> usize {
        self.task.substeps()
    }

    #[getter]
    fn obs_dim(&self) -> usize {
        self.task.obs_dim()
    }

    #[getter]
    fn act_dim(&self) -> usize {
        self.task.act_dim()
    }

    /// Components of mu.
    #[getter]
    fn nmu(&self) -> usize {
        self.task.mu_map().nmu
    }

    /// (lower, upper): the bounds of each mu component.
    #[getter]
    fn mu_range<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyTuple>> {
        let (lo, hi) = self.task.mu_range();
        PyTuple::new(
            py,
            [PyArray1::from_slice(py, lo), PyArray1::from_slice(py, hi)],
        )
    }

    /// The task's model with mu applied (the nominal model if mu is None).
    #[pyo3(signature = (mu = None))]
    fn model(&self, mu: Option<&Bound<'_, PyAny>>) -> PyResult<PyModel> {
        let mut model = self.task.model().clone();
        if let Some(mu) = mu {
            let mu = self.mu(mu)?;
            self.task
                .mu_map()
                .apply(&mut model, &mu)
                .map_err(param_error)?;
        }
        Ok(PyModel::new(model))
    }

    /// The physical parameters mu sets: {name: float64 array}, e.g. for the
    /// cartpole {"body/pole/com": [mu, 0, 0.5 + 0.2 mu]}.
    fn mu_params<'py>(
        &self,
        py: Python<'py>,
        mu: &Bound<'py, PyAny>,
    ) -> PyResult<Bound<'py, PyDict>> {
        let mu = self.mu(mu)?;
        let map = self.task.mu_map();
        let model = self.task.model();
        let out = PyDict::new(py);
        for ((param, _, _), value) in map.targets.iter().zip(map.values(&mu)) {
            out.set_item(
                param.name(model),
                PyArray1::from_slice(py, value.as_slice()),
            )?;
        }
        Ok(out)
    }

    /// An initial state (q, v) from the task's reset distribution, drawn from
    /// a generator seeded with `seed`.
    fn reset<'py>(&self, py: Python<'py>, seed: u64) -> PyResult<Bound<'py, PyTuple>> {
        let (q, v) = self.task.reset(&mut StdRng::seed_from_u64(seed));
        PyTuple::new(py, [PyArray1::from_vec(py, q), PyArray1::from_vec(py, v)])
    }

    /// `count` episodes' true mu and initial states as arrays (mu (count,
    /// nmu), q0 (count, nq), v0 (count, nv)): the ones `diffosi eval --seed
    /// seed` runs (one generator: mu drawn, then the reset, per episode).
    fn episodes<'py>(
        &self,
        py: Python<'py>,
        count: usize,
        seed: u64,
    ) -> PyResult<Bound<'py, PyTuple>> {
        let task = self.task.as_ref();
        let mut rng = StdRng::seed_from_u64(seed);
        let (nq, nv) = (task.model().nq(), task.model().nv());
        let mut mus = Array2::zeros((count, self.nmu()));
        let (mut q0, mut v0) = (Array2::zeros((count, nq)), Array2::zeros((count, nv)));
        for k in 0..count {
            let mu = tasks::sample_mu(task, &mut rng);
            let (q, v) = task.reset(&mut rng);
            mus.row_mut(k)
                .iter_mut()
                .zip(&mu)
                .for_each(|(a, b)| *a = *b);
            q0.row_mut(k).iter_mut().zip(&q).for_each(|(a, b)| *a = *b);
            v0.row_mut(k).iter_mut().zip(&v).for_each(|(a, b)| *a = *b);
        }
        PyTuple::new(py, [mus, q0, v0].map(|a| PyArray2::from_owned_array(py, a)))
    }

    /// The controller's observation of a state (without mu).
    fn observe<'py>(
        &self,
        py: Python<'py>,
        q: &Bound<'py, PyAny>,
        v: &Bound<'py, PyAny>,
    ) -> PyResult<Bound<'py, PyArray1<f64>>> {
        let state = self.state(q, v)?;
        let mut out = Vec::with_capacity(self.task.obs_dim());
        self.task.observe(&state, &mut out);
        Ok(PyArray1::from_vec(py, out))
    }

    /// Generalized forces (length nv) for an action (clamped by the task).
    fn forces<'py>(
        &self,
        py: Python<'py>,
        action: &Bound<'py, PyAny>,
    ) -> PyResult<Bound<'py, PyArray1<f64>>> {
        let action = self.action(action)?;
        Ok(PyArray1::from_vec(py, self.task.forces(&action)))
    }

    /// Whether an episode ends at (q, v).
    fn terminated(&self, q: &Bound<'_, PyAny>, v: &Bound<'_, PyAny>) -> PyResult<bool> {
        Ok(self.task.terminated(&self.state(q, v)?))
    }

    /// One control step's contribution to the task metric, from (q, v) under
    /// `action` to (q_next, v_next).
    fn metric(
        &self,
        q: &Bound<'_, PyAny>,
        v: &Bound<'_, PyAny>,
        action: &Bound<'_, PyAny>,
        q_next: &Bound<'_, PyAny>,
        v_next: &Bound<'_, PyAny>,
    ) -> PyResult<f64> {
        let state = self.state(q, v)?;
        let next = self.state(q_next, v_next)?;
        Ok(self.task.metric(&state, &self.action(action)?, &next))
    }

    fn __repr__(&self) -> String {
        format!(
            "<diffosi.Task '{}' horizon={} nmu={}>",
            self.task.name(),
            self.task.horizon(),
            self.nmu()
        )
    }
}

/// A trained policy: `Policy.load(path)` reads a `diffosi-policy/1` JSON file
/// (src/rl/policy.rs). `kind` is "uc" (Universal Controller: it is fed mu)
/// or "dr" (domain-randomised: mu is ignored). `act(task, q, v, mu)` gives
/// the deterministic action (the Gaussian's mean, clamped to [-1, 1]).
#[pyclass(name = "Policy", module = "diffosi", frozen)]
pub(crate) struct PyPolicy {
    policy: Policy,
}

#[pymethods]
impl PyPolicy {
    /// A missing or unreadable file raises OSError; a file that is not a
    /// policy raises ValueError.
    #[staticmethod]
    fn load(path: std::path::PathBuf) -> PyResult<Self> {
        if let Err(e) = std::fs::metadata(&path) {
            return Err(PyOSError::new_err(format!(
                "cannot read {}: {e}",
                path.display()
            )));
        }
        let policy = Policy::load(&path).map_err(PyValueError::new_err)?;
        Ok(PyPolicy { policy })
    }

    /// Trains a policy of `kind` ("uc" or "dr") on `task` with PPO, from a
    /// network initialised from `seed`, for `steps` environment steps
    /// (default: the budget of the shipped policies, `diffosi train`'s).
    /// Other Python threads run meanwhile (the GIL is released). Returns
    /// (policy, curve): curve one dict per PPO iteration with "iteration",
    /// "env_steps", "episodes", "mean_return" and "mean_metric" (of the last
    /// finished training episodes; NaN before the first ends). The same task,
    /// kind, seed and steps give the same policy, bit for bit.
    #[staticmethod]
    #[pyo3(signature = (task, kind, seed = 0, steps = None))]
    fn train<'py>(
        py: Python<'py>,
        task: &PyTask,
        kind: &str,
        seed: u64,
        steps: Option<usize>,
    ) -> PyResult<(Self, Bound<'py, PyList>)> {
        let kind = match kind {
            "uc" => PolicyKind::Uc,
            "dr" => PolicyKind::Dr,
            other => {
                return Err(PyValueError::new_err(format!(
                    "kind '{other}': expected 'uc' or 'dr'"
                )))
            }
        };
        let t = task.task.as_ref();
        let mut config = PpoConfig {
            seed,
            ..PpoConfig::for_task(t.name())
        };
        if let Some(steps) = steps {
            if steps == 0 {
                return Err(PyValueError::new_err("steps must be at least 1"));
            }
            config.total_steps = steps;
        }
        let trained = py
            .detach(|| rl::train(t, kind, &config, |_| {}))
            .map_err(|e| PyValueError::new_err(format!("train: {e}")))?;
        let curve = PyList::empty(py);
        for row in &trained.curve {
            let d = PyDict::new(py);
            d.set_item("iteration", row.iteration)?;
            d.set_item("env_steps", row.env_steps)?;
            d.set_item("episodes", row.episodes)?;
            d.set_item("mean_return", row.mean_return)?;
            d.set_item("mean_metric", row.mean_metric)?;
            curve.append(d)?;
        }
        let policy = PyPolicy {
            policy: trained.policy,
        };
        Ok((policy, curve))
    }

    /// Writes the policy as `diffosi train` does (a `diffosi-policy/1` JSON
    /// file that `Policy.load` reads back); OSError if it cannot.
    fn save(&self, path: std::path::PathBuf) -> PyResult<()> {
        self.policy.save(&path).map_err(PyOSError::new_err)
    }

    /// The actor network's weights and biases, layer by layer, as float32.
    fn parameters<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f32>> {
        PyArray1::from_slice(py, self.policy.actor.params())
    }

    #[getter]
    fn kind(&self) -> &'static str {
        match self.policy.kind {
            PolicyKind::Uc => "uc",
            PolicyKind::Dr => "dr",
        }
    }

    /// The task the policy was trained on.
    #[getter]
    fn task(&self) -> String {
        self.policy.task.clone()
    }

    /// The action at (q, v); a "uc" policy needs mu (length nmu), a "dr"
    /// policy ignores it.
    #[pyo3(signature = (task, q, v, mu = None))]
    fn act<'py>(
        &self,
        py: Python<'py>,
        task: &PyTask,
        q: &Bound<'py, PyAny>,
        v: &Bound<'py, PyAny>,
        mu: Option<&Bound<'py, PyAny>>,
    ) -> PyResult<Bound<'py, PyArray1<f64>>> {
        let t = task.task.as_ref();
        if self.policy.task != t.name() {
            return Err(PyValueError::new_err(format!(
                "the policy was trained on task '{}', not '{}'",
                self.policy.task,
                t.name()
            )));
        }
        let state = task.state(q, v)?;
        let mu = match (self.policy.kind, mu) {
            (PolicyKind::Dr, _) => vec![],
            (PolicyKind::Uc, Some(mu)) => vector(mu, "mu", task.nmu(), "nmu")?,
            (PolicyKind::Uc, None) => {
                return Err(PyValueError::new_err("a 'uc' policy needs mu"));
            }
        };
        let input = self.policy.observation(t, &state, &mu);
        if input.len() != self.policy.actor.inputs() {
            return Err(PyValueError::new_err(format!(
                "the policy takes {} inputs, the task gives {}",
                self.policy.actor.inputs(),
                input.len()
            )));
        }
        Ok(PyArray1::from_vec(py, self.policy.act(&input)))
    }

    fn __repr__(&self) -> String {
        format!(
            "<diffosi.Policy kind='{}' task='{}'>",
            self.kind(),
            self.policy.task
        )
    }
}

/// The solver behind an `OnlineOsi`, chosen at run time.
type Solver = Box<dyn Identifier + Send + Sync>;

/// Online DiffOSI of a task's mu (src/osi/online.rs):
/// `OnlineOsi(task, window=1, method="lm", change_detection=False, seed=0,
/// scale=None, loss="squared", huber=1.345, constraints="modelled",
/// margin=0.02, force_scale=None, impulses="model", restarts=8)`.
///
/// Each `push(q, v, tau, q_next, v_next)` of one observed transition (tau the
/// generalized forces, length nv) re-identifies mu on the `window` most recent
/// transitions, warm-started from the last estimate (the middle of the task's
/// mu range before the first), within the task's mu range, on the task's
/// nominal model. `method` "lm" (bounded Levenberg-Marquardt; `seed` seeds
/// its restarts) or "adam"; `change_detection=True` empties the window when a
/// transition no longer fits (the engine's default rule); `scale`, `loss`,
/// `huber`, `constraints`, `margin`, `force_scale` and `impulses` as in `DiffOsi`
/// (constraints="unknown": the target's contact law is not ours); `restarts`:
/// how many other starts "lm" tries when a fit leaves a misfit (useless
/// when mu enters the residuals linearly, as masses and armatures do with
/// constraints="unknown"). Returns a dict: "mu", "std", "loss", "iterations",
/// "evaluations", "flags" (a list drawn from "unexcited", "at_bound",
/// "not_converged", "misfit", "changed").
#[pyclass(name = "OnlineOsi", module = "diffosi")]
pub(crate) struct PyOnlineOsi {
    online: Online<Solver>,
    method: &'static str,
    window: usize,
    loss: Loss,
}

#[pymethods]
impl PyOnlineOsi {
    #[new]
    #[pyo3(signature = (task, window = 1, method = "lm", change_detection = false, seed = 0, scale = None, loss = "squared", huber = HUBER_THRESHOLD, constraints = "modelled", margin = DEFAULT_MARGIN, force_scale = None, impulses = "model", restarts = LmOptions::default().restarts))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        task: &PyTask,
        window: usize,
        method: &str,
        change_detection: bool,
        seed: u64,
        scale: Option<&Bound<'_, PyAny>>,
        loss: &str,
        huber: f64,
        constraints: &str,
        margin: f64,
        force_scale: Option<&Bound<'_, PyAny>>,
        impulses: &str,
        restarts: usize,
    ) -> PyResult<Self> {
        let t = task.task.as_ref();
        let loss = robust_loss(loss, huber, method == "lm")?;
        let (solver, method): (Solver, &'static str) = match method {
            "lm" => {
                let options = LmOptions {
                    seed,
                    loss,
                    restarts,
                    ..LmOptions::default()
                };
                (Box::new(Lm { options }), "lm")
            }
            "adam" => (Box::new(Adam::default()), "adam"),
            other => {
                return Err(PyValueError::new_err(format!(
                    "method must be 'lm' or 'adam', got '{other}'"
                )))
            }
        };
        let model = t.model();
        let scale = match scale {
            Some(s) => {
                let s = vector(s, "scale", 2 * model.nv(), "2 nv")?;
                if let Some(i) = s.iter().position(|x| *x <= 0.0) {
                    return Err(PyValueError::new_err(format!(
                        "scale[{i}] = {} must be positive",
                        s[i]
                    )));
                }
                s
            }
            None => default_scale(model),
        };
        let (lo, hi) = t.mu_range();
        let prior = tasks::average_mu(t);
        let problem = Problem::new(model, t.mu_map().clone(), lo, hi, &prior, &scale)
            .map_err(|e| osi_error("OnlineOsi", e))?;
        let unknown = (margin, force_scale, impulses);
        let problem = with_constraints(problem, constraints, unknown, "OnlineOsi")?;
        let mut online = Online::new(problem, solver, window, Sampling::Recent, seed)
            .map_err(|e| osi_error("OnlineOsi", e))?;
        if change_detection {
            online = online
                .with_change_detection(ChangeDetection::default())
                .map_err(|e| osi_error("OnlineOsi", e))?;
        }
        Ok(PyOnlineOsi {
            online,
            method,
            window,
            loss,
        })
    }

    /// Adds one observed transition and returns the new estimate (see the
    /// class docs). A bad transition raises ValueError and changes nothing.
    fn push<'py>(
        &mut self,
        py: Python<'py>,
        q: &Bound<'py, PyAny>,
        v: &Bound<'py, PyAny>,
        tau: &Bound<'py, PyAny>,
        q_next: &Bound<'py, PyAny>,
        v_next: &Bound<'py, PyAny>,
    ) -> PyResult<Bound<'py, PyDict>> {
        let (nq, nv) = (self.online.problem().nq(), self.online.problem().nv());
        let transition = Transition {
            q: vector(q, "q", nq, "nq")?,
            v: vector(v, "v", nv, "nv")?,
            tau: vector(tau, "tau", nv, "nv")?,
            q_next: vector(q_next, "q_next", nq, "nq")?,
            v_next: vector(v_next, "v_next", nv, "nv")?,
        };
        let online = &mut self.online;
        let estimate = py
            .detach(|| online.push(transition).cloned())
            .map_err(|e| osi_error("push", e))?;
        estimate_dict(py, estimate, "mu")
    }

    /// The current mu estimate: the prior (the middle of the range) before
    /// the first push.
    #[getter]
    fn mu<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        let mu = match self.online.estimate() {
            Some(e) => e.mu.as_slice(),
            None => self.online.problem().prior(),
        };
        PyArray1::from_slice(py, mu)
    }

    #[getter]
    fn window(&self) -> usize {
        self.window
    }

    #[getter]
    fn method(&self) -> &'static str {
        self.method
    }

    /// "squared" or "huber" (see `DiffOsi`).
    #[getter]
    fn loss(&self) -> &'static str {
        loss_name(self.loss)
    }

    #[getter]
    fn change_detection(&self) -> bool {
        self.online.change_detection().is_some()
    }

    fn __repr__(&self) -> String {
        format!(
            "<diffosi.OnlineOsi method='{}' window={} change_detection={}>",
            self.method,
            self.window,
            self.change_detection()
        )
    }
}
