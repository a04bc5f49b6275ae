//! The wiping task for Python: episodes of the admittance-controlled arm
//! and identification of the tool's compliance from closed-loop segments,
//! as `diffosi wipe` and Table 3 run them (src/tasks/wiping/).
//!
//! Conventions are the engine's: q = (a1 .. a7, tool), SI units, 1 ms
//! steps; mu = (tool k_p in N/cm, k_d in N s/m, then the study's extra
//! unknowns), each in [1, 100]; gains = (k_tau in 1/s^2, k_xi in m/(N s)).

use engine::control::admittance::{Gains, F_GOAL};
use engine::experiments::wiping::Uc;
use engine::model::State;
use engine::osi::{CmaEs, CmaEsOptions, Lm, LmOptions, HUBER_THRESHOLD};
use engine::tasks::wiping::{
    tip_target, Segments, Unknown, Wiping, CANONICAL, CONTACT_FORCE, GAINS_LOWER, GAINS_UPPER,
};
use numpy::ndarray::Array2;
use numpy::{PyArray1, PyArray2};
use pyo3::exceptions::{PyOSError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use rand::rngs::StdRng;
use rand::SeedableRng;

use crate::convert::{matrix, vector};
use crate::errors::osi_error;
use crate::identification::{estimate_dict, robust_loss};
use crate::wiping_run::PyWipingRun;

/// The wiping task: `Wiping(unknowns=2)` (2 to 6 unknowns: the tool's k_p and
/// k_d, then a6's damping and stiffness, then a4's).
///
/// `episode(mu, gains=None, steps=3000)` runs the controller (canonical gains
/// by default) and returns a dict of arrays `q`, `v`, `tau` (T+1 rows: the
/// torques the step from each row applies), `force` (sensed normal force,
/// N), `xi` (admittance offset, m) and the float `metric` (N^2).
/// `identify(q, v, xi, force, gains=None, segments=50, length=5, seed=0,
/// method="lm", max_evaluations=300, loss="squared", huber=1.345)`
/// identifies mu from segments of a record made with `gains` (from our
/// engine or any other; `force` is what the controller sensed at each row,
/// the normal force over the step into it): a dict with `mu`, `std`,
/// `loss`, `iterations`, `evaluations`, `flags`. `act(k, q, v, xi, force, gains=None)` is one step of the
/// controller on a force sensed elsewhere (to run it on another engine),
/// returning the torques and the next xi; `uc_gains(path, mu)` the
/// Universal Controller's gains; `run(mu)` an episode driven step by step
/// (`WipingRun`).
#[pyclass(name = "Wiping", module = "diffosi", frozen)]
pub(crate) struct PyWiping {
    task: Wiping,
}

pub(crate) fn gains_of(gains: Option<&Bound<'_, PyAny>>) -> PyResult<Gains> {
    let Some(g) = gains else {
        return Ok(CANONICAL);
    };
    let g = vector(g, "gains", 2, "2")?;
    Gains {
        k_tau: g[0],
        k_xi: g[1],
    }
    .check()
    .map_err(PyValueError::new_err)
}

fn rows(a: &Array2<f64>) -> Vec<Vec<f64>> {
    a.outer_iter().map(|r| r.to_vec()).collect()
}

#[pymethods]
impl PyWiping {
    #[new]
    #[pyo3(signature = (unknowns = 2))]
    fn new(unknowns: usize) -> PyResult<Self> {
        let list = Unknown::first(unknowns).map_err(PyValueError::new_err)?;
        let task =
            Wiping::with_unknowns(&list).map_err(|e| PyValueError::new_err(e.to_string()))?;
        Ok(PyWiping { task })
    }

    #[getter]
    fn nmu(&self) -> usize {
        self.task.unknowns().len()
    }

    /// The unknowns' labels, with the unit of their mu.
    #[getter]
    fn unknowns(&self) -> Vec<String> {
        self.task.unknowns().iter().map(|u| u.label()).collect()
    }

    #[getter]
    fn mu_range<'py>(
        &self,
        py: Python<'py>,
    ) -> (Bound<'py, PyArray1<f64>>, Bound<'py, PyArray1<f64>>) {
        let (lo, hi) = self.task.mu_range();
        (PyArray1::from_vec(py, lo), PyArray1::from_vec(py, hi))
    }

    /// The canonical gains (k_tau, k_xi) that collect identification data.
    #[getter]
    fn canonical_gains(&self) -> (f64, f64) {
        (CANONICAL.k_tau, CANONICAL.k_xi)
    }

    /// The box the gains are searched in, ((k_tau, k_xi) lower, upper).
    #[getter]
    fn gains_range(&self) -> ((f64, f64), (f64, f64)) {
        let pair = |g: Gains| (g.k_tau, g.k_xi);
        (pair(GAINS_LOWER), pair(GAINS_UPPER))
    }

    /// The normal force the controller holds the tool to (N).
    #[getter]
    fn force_goal(&self) -> f64 {
        F_GOAL
    }

    /// A sensed force above this is contact (N); the task metric counts those steps.
    #[getter]
    fn contact_force(&self) -> f64 {
        CONTACT_FORCE
    }

    /// One episode of `steps` control steps (1 ms each) at mu (length nmu)
    /// under `gains` (k_tau in 1/s^2, k_xi in m/(N s); default the canonical
    /// gains): a dict of float64 arrays "q" (T+1, nq), "v" (T+1, nv), "tau"
    /// (T+1, nv: the torques the step from each row applies, N m), "force"
    /// (T+1: the normal force sensed over the step into each row, N), "xi"
    /// (T+1: the admittance offset, m), and the float "metric" (the MSE of
    /// the force against `force_goal` over the steps in contact, N^2).
    #[pyo3(signature = (mu, gains = None, steps = 3000))]
    fn episode<'py>(
        &self,
        py: Python<'py>,
        mu: &Bound<'py, PyAny>,
        gains: Option<&Bound<'py, PyAny>>,
        steps: usize,
    ) -> PyResult<Bound<'py, PyDict>> {
        let mu = vector(mu, "mu", self.nmu(), "nmu")?;
        let gains = gains_of(gains)?;
        let task = &self.task;
        let e = py
            .detach(|| task.episode(&mu, gains, steps))
            .map_err(|e| PyValueError::new_err(e.to_string()))?;
        let out = PyDict::new(py);
        let table = |x: Vec<Vec<f64>>| PyArray2::from_vec2(py, &x);
        out.set_item("q", table(e.states.iter().map(|s| s.q.clone()).collect())?)?;
        out.set_item("v", table(e.states.iter().map(|s| s.v.clone()).collect())?)?;
        out.set_item("tau", table(e.taus)?)?;
        out.set_item("force", PyArray1::from_vec(py, e.forces))?;
        out.set_item("xi", PyArray1::from_vec(py, e.xi))?;
        out.set_item("metric", e.metric)?;
        Ok(out)
    }

    /// Identifies mu from `segments` closed-loop segments of `length` steps
    /// drawn (seeded by `seed`) from a record of T rows: q (T, nq), v (T,
    /// nv), xi (T,) and force (T,) as `episode` returns them, made with
    /// `gains` (default the canonical gains). `method` "lm" (DiffOSI: exact
    /// Jacobians through the closed loop) or "cmaes" (at most
    /// `max_evaluations` episodes' worth of evaluations). Returns a dict:
    /// "mu", "std" (float64, length nmu), "loss", "iterations",
    /// "evaluations", "flags" (as `DiffOsi.identify`'s). `loss` "squared"
    /// or, with "lm", "huber": the Huber loss of the scaled residuals with
    /// threshold `huber` (in units of the task's residual scale, 1 um and
    /// 1 mm/s), so steps our model cannot explain (another engine's contact
    /// dropouts) pull mu with a bounded force; "loss" is then that loss.
    #[allow(clippy::too_many_arguments)]
    #[pyo3(signature = (q, v, xi, force, gains = None, segments = 50, length = 5, seed = 0, method = "lm", max_evaluations = 300, loss = "squared", huber = HUBER_THRESHOLD))]
    #[pyo3(
        text_signature = "($self, q, v, xi, force, gains=None, segments=50, length=5, seed=0, method='lm', max_evaluations=300, loss='squared', huber=1.345)"
    )]
    fn identify<'py>(
        &self,
        py: Python<'py>,
        q: &Bound<'py, PyAny>,
        v: &Bound<'py, PyAny>,
        xi: &Bound<'py, PyAny>,
        force: &Bound<'py, PyAny>,
        gains: Option<&Bound<'py, PyAny>>,
        segments: usize,
        length: usize,
        seed: u64,
        method: &str,
        max_evaluations: usize,
        loss: &str,
        huber: f64,
    ) -> PyResult<Bound<'py, PyDict>> {
        let loss = robust_loss(loss, huber, method == "lm")?;
        let model = self.task.model();
        let q = matrix(q, "q", model.nq(), "nq")?;
        let v = matrix(v, "v", model.nv(), "nv")?;
        if q.nrows() != v.nrows() {
            return Err(PyValueError::new_err(format!(
                "q and v must have as many rows: {} and {}",
                q.nrows(),
                v.nrows()
            )));
        }
        let xi = vector(xi, "xi", q.nrows(), "rows of q")?;
        let force = vector(force, "force", q.nrows(), "rows of q")?;
        let states: Vec<State> = rows(&q)
            .into_iter()
            .zip(rows(&v))
            .map(|(q, v)| State::new(q, v))
            .collect();
        let gains = gains_of(gains)?;
        let mut rng = StdRng::seed_from_u64(seed);
        let record = (states.as_slice(), xi.as_slice(), force.as_slice(), gains);
        let segments = Segments::sample(&self.task, record, (segments, length), &mut rng)
            .map_err(PyValueError::new_err)?;
        let mut problem = self.task.problem();
        let prior = self.task.prior();
        let mut cmaes = CmaEs {
            options: CmaEsOptions {
                max_evaluations,
                seed,
                ..CmaEsOptions::default()
            },
        };
        let estimate = match method {
            "lm" => {
                let mut lm = Lm {
                    options: LmOptions {
                        loss,
                        ..LmOptions::default()
                    },
                };
                py.detach(|| lm.identify_on(&mut problem, &segments, &prior))
            }
            "cmaes" => py.detach(|| cmaes.identify_on(&mut problem, &segments, &prior)),
            other => {
                return Err(PyValueError::new_err(format!(
                    "method '{other}': expected 'lm' or 'cmaes'"
                )))
            }
        }
        .map_err(|e| osi_error("identify", e))?;
        estimate_dict(py, estimate, "mu")
    }

    /// One control step of the admittance controller at step index `k`
    /// (time k h), state (q, v), offset xi and the normal force sensed by
    /// whatever runs the arm (N): the generalized forces (length nv) and the
    /// next offset. What `episode` does each step, with our own sensing.
    #[pyo3(signature = (k, q, v, xi, force, gains = None))]
    #[allow(clippy::too_many_arguments)]
    fn act<'py>(
        &self,
        py: Python<'py>,
        k: usize,
        q: &Bound<'py, PyAny>,
        v: &Bound<'py, PyAny>,
        xi: f64,
        force: f64,
        gains: Option<&Bound<'py, PyAny>>,
    ) -> PyResult<(Bound<'py, PyArray1<f64>>, f64)> {
        let model = self.task.model();
        let q = vector(q, "q", model.nq(), "nq")?;
        let v = vector(v, "v", model.nv(), "nv")?;
        if !(xi.is_finite() && force.is_finite()) {
            return Err(PyValueError::new_err(format!(
                "xi = {xi} and force = {force} must be finite"
            )));
        }
        let mut ctrl = self.task.controller::<f64>(gains_of(gains)?);
        let mut data = model.data();
        let mut tau = vec![0.0; model.nv()];
        let h = model.opt.timestep;
        let target = (tip_target(k as f64 * h), h);
        let xi_next = ctrl.act(
            model.tree(),
            &mut data,
            (&q, &v, force),
            xi,
            target,
            &mut tau,
        );
        Ok((PyArray1::from_vec(py, tau), xi_next))
    }

    /// The Universal Controller's gains (k_tau, k_xi) for mu, from a weights
    /// file written by `diffosi train-wiping` (policies/wiping/uc.json).
    fn uc_gains(&self, path: std::path::PathBuf, mu: &Bound<'_, PyAny>) -> PyResult<(f64, f64)> {
        let mu = vector(mu, "mu", self.nmu(), "nmu")?;
        let uc = Uc::load(&path).map_err(PyOSError::new_err)?;
        if uc.mu_lower.len() != mu.len() {
            return Err(PyValueError::new_err(format!(
                "{} maps {} unknowns, the task has {}",
                path.display(),
                uc.mu_lower.len(),
                mu.len()
            )));
        }
        let g = uc.gains(&mu);
        Ok((g.k_tau, g.k_xi))
    }

    /// An episode at mu from the task's start state, driven one control
    /// step at a time with gains of the caller's choosing (`WipingRun`).
    fn run(&self, mu: &Bound<'_, PyAny>) -> PyResult<PyWipingRun> {
        let mu = vector(mu, "mu", self.nmu(), "nmu")?;
        let model = self
            .task
            .model_at(&mu)
            .map_err(|e| PyValueError::new_err(e.to_string()))?;
        let ctrl = self.task.controller(CANONICAL);
        Ok(PyWipingRun::start(model, ctrl, self.task.start()))
    }

    fn __repr__(&self) -> String {
        format!("Wiping(unknowns={}: {:?})", self.nmu(), self.unknowns())
    }
}
