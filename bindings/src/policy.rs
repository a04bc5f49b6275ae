//! `Policy`: a trained controller of a task (`rl::Policy`), loaded, trained
//! or saved as `diffosi train` and `diffosi eval` do.

use engine::rl::{self as rl, Policy, PolicyKind, PpoConfig};
use numpy::PyArray1;
use pyo3::exceptions::{PyOSError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};

use crate::convert::vector;
use crate::task::PyTask;

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
