//! `Task`: a control task of the engine (`tasks::Task`), so that the harness
//! runs the same task as `diffosi eval`.
//!
//! Conventions are the engine's (src/tasks/mod.rs): a state is (q, v) in SI
//! units; an action has `act_dim` components meaningful in [-1, 1];
//! `forces(action)` gives the generalized forces (length nv) one control step
//! holds for `substeps` physics steps; mu is the task's parameter vector,
//! mapped affinely onto named physical parameters (`mu_params`), drawn
//! uniformly in `mu_range`.

use engine::model::State;
use engine::tasks::{self, Task};
use numpy::ndarray::Array2;
use numpy::PyArray1;
use numpy::PyArray2;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyTuple};
use rand::rngs::StdRng;
use rand::SeedableRng;

use crate::convert::vector;
use crate::errors::param_error;
use crate::model::PyModel;

/// A control task by name: `Task("cartpole")`.
///
/// `model(mu)` is the task's model with mu applied (a `diffosi.Model`);
/// `mu_params(mu)` the physical parameters mu sets; `episodes(n, seed)` the
/// seeded (mu, initial state) pairs that `diffosi eval --seed` meets;
/// `observe`, `forces`, `inputs`, `terminated` and `metric` are the task's own.
#[pyclass(name = "Task", module = "diffosi", frozen)]
pub(crate) struct PyTask {
    pub(crate) task: Box<dyn Task>,
}

impl PyTask {
    /// Converts and checks a state of the task's model.
    pub(crate) fn state(&self, q: &Bound<'_, PyAny>, v: &Bound<'_, PyAny>) -> PyResult<State> {
        let m = self.task.model();
        Ok(State::new(
            vector(q, "q", m.nq(), "nq")?,
            vector(v, "v", m.nv(), "nv")?,
        ))
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
    pub(crate) fn nmu(&self) -> usize {
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
        let State { q, v, .. } = self.task.reset(&mut StdRng::seed_from_u64(seed));
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
            let State { q, v, .. } = task.reset(&mut rng);
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

    /// The step's inputs (tau, ctrl) for an action, held over the control
    /// step: ctrl is empty unless the task's actions drive actuators.
    fn inputs<'py>(
        &self,
        py: Python<'py>,
        action: &Bound<'py, PyAny>,
    ) -> PyResult<Bound<'py, PyTuple>> {
        let u = self.task.inputs(&self.action(action)?);
        PyTuple::new(py, [u.tau, u.ctrl].map(|a| PyArray1::from_vec(py, a)))
    }

    /// The generalized forces an identifier is given for a physics step from
    /// (q, v) under `action`: the inputs' tau plus the actuators' forces at
    /// their ctrl minus theirs at zero ctrl, at (q, v); under them with zero
    /// ctrl the step is the same (Model::held_forces).
    fn held_forces<'py>(
        &self,
        py: Python<'py>,
        q: &Bound<'py, PyAny>,
        v: &Bound<'py, PyAny>,
        action: &Bound<'py, PyAny>,
    ) -> PyResult<Bound<'py, PyArray1<f64>>> {
        let state = self.state(q, v)?;
        let u = self.task.inputs(&self.action(action)?);
        Ok(PyArray1::from_vec(
            py,
            self.task.model().held_forces(&state, &u),
        ))
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
