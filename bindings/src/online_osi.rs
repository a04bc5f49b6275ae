//! `OnlineOsi`: online identification of a task's mu (`osi::Online`), as
//! `diffosi eval` runs it.

use engine::derivatives::Transition;
use engine::model::State;
use engine::osi::{
    Adam, ChangeDetection, Identifier, Lm, LmOptions, Loss, Online, Problem, Sampling,
    HUBER_THRESHOLD,
};
use engine::tasks;
use numpy::PyArray1;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::convert::vector;
use crate::errors::osi_error;
use crate::identification::{
    estimate_dict, loss_name, residual_scale, robust_loss, with_constraints, DEFAULT_MARGIN,
};
use crate::task::PyTask;

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
    // The constants' values spelled out for help() (pyo3 shows a named default as "...").
    #[pyo3(
        text_signature = "(task, window=1, method='lm', change_detection=False, seed=0, scale=None, loss='squared', huber=1.345, constraints='modelled', margin=0.02, force_scale=None, impulses='model', restarts=8)"
    )]
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
        let scale = residual_scale(scale, model)?;
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
            start: State::new(vector(q, "q", nq, "nq")?, vector(v, "v", nv, "nv")?),
            tau: vector(tau, "tau", nv, "nv")?,
            next: State::new(
                vector(q_next, "q_next", nq, "nq")?,
                vector(v_next, "v_next", nv, "nv")?,
            ),
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
