//! `WipingRun`: one episode of the wiping task driven a control step at a
//! time (`Wiping.run(mu)`), so that another engine's controller loop can
//! follow ours step by step.

use engine::control::admittance::Admittance;
use engine::dynamics::Data;
use engine::model::State;
use engine::tasks::wiping::{closed_loop_step, LoopState, APPROACH, STEPS};
use engine::Model;
use numpy::PyArray1;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;

use crate::wiping::gains_of;

/// One closed-loop episode of the wiping task at a fixed mu
/// (`Wiping.run(mu)`): `step(gains)` runs the admittance controller with
/// `gains` (k_tau, k_xi) for one control step (1 ms) from the current state
/// and returns the sensed normal force over it (N); `q`, `v`, `xi` (the
/// admittance offset, m), `force` (the last sensed force) and `k` (steps
/// done; step k starts at t = k h) describe where the episode is. The
/// episode `Wiping.episode` runs is these steps with fixed gains.
#[pyclass(name = "WipingRun", module = "diffosi")]
pub(crate) struct PyWipingRun {
    model: Model,
    data: Data<f64>,
    ctrl: Admittance<f64>,
    k: usize,
    state: State,
    next: State,
    tau: Vec<f64>,
    carry: LoopState<f64>,
}

impl PyWipingRun {
    /// The episode of `model` under `ctrl` from `state`, before its first step.
    pub(crate) fn start(model: Model, ctrl: Admittance<f64>, state: State) -> Self {
        PyWipingRun {
            data: model.data(),
            ctrl,
            next: State::new(vec![0.0; model.nv()], vec![0.0; model.nv()]),
            tau: vec![0.0; model.nv()],
            model,
            k: 0,
            state,
            carry: LoopState {
                xi: 0.0,
                force: 0.0,
            },
        }
    }
}

#[pymethods]
impl PyWipingRun {
    /// One control step under `gains`; ValueError for gains outside
    /// (0, inf) or a step that fails (the state is then unchanged).
    fn step(&mut self, gains: &Bound<'_, PyAny>) -> PyResult<f64> {
        self.ctrl.gains = gains_of(Some(gains))?;
        let (q, v) = (&self.state.q, &self.state.v);
        let (q1, v1) = (&mut self.next.q, &mut self.next.v);
        let step = (self.k, q.as_slice(), v.as_slice(), self.carry);
        self.carry = closed_loop_step(
            self.model.tree(),
            &mut self.data,
            &mut self.ctrl,
            step,
            &mut self.tau,
            (q1, v1),
        )
        .map_err(|e| PyValueError::new_err(format!("step {}: {e}", self.k)))?;
        std::mem::swap(&mut self.state, &mut self.next);
        self.k += 1;
        Ok(self.carry.force)
    }

    #[getter]
    fn q<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        PyArray1::from_slice(py, &self.state.q)
    }

    #[getter]
    fn v<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        PyArray1::from_slice(py, &self.state.v)
    }

    #[getter]
    fn xi(&self) -> f64 {
        self.carry.xi
    }

    #[getter]
    fn force(&self) -> f64 {
        self.carry.force
    }

    #[getter]
    fn k(&self) -> usize {
        self.k
    }

    /// The steps of the task's episode (3000: 3 s).
    #[getter]
    fn steps(&self) -> usize {
        STEPS
    }

    /// The time step (s).
    #[getter]
    fn timestep(&self) -> f64 {
        self.model.opt.timestep
    }

    /// Whether step k is in the strokes (t >= 0.5 s), past the approach.
    #[getter]
    fn stroking(&self) -> bool {
        self.k as f64 * self.model.opt.timestep >= APPROACH
    }

    fn __repr__(&self) -> String {
        format!("<diffosi.WipingRun step {} of {STEPS}>", self.k)
    }
}
