//! `DiffOsi`: identification of named parameters from a window of
//! transitions, by Levenberg-Marquardt or Adam on exact Jacobians.

use engine::osi::{Adam, Identifier, Lm, LmOptions, Loss, HUBER_THRESHOLD};
use numpy::PyArray1;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::identification::{loss_name, robust_loss, with_constraints, DEFAULT_MARGIN};
use crate::model::PyModel;
use crate::osi::Osi;

/// Which solver a `DiffOsi` runs.
#[derive(Clone, Copy, Debug)]
enum Method {
    Lm,
    Adam,
}

/// Online system identification (DiffOSI): the named parameters that make
/// the model reproduce a window of observed transitions.
///
/// `DiffOsi(model, params, lower, upper, method="lm", scale=None,
/// loss="squared", huber=1.345, constraints="modelled", margin=0.02,
/// force_scale=None, impulses="model")`:
/// - `params`: parameter names (see `Model.param_names()`); mu is their
///   values flattened in that order (a 3-vector such as `body/pole/com` takes
///   three components), and `lower`/`upper` hold one finite bound per
///   component, lower < upper.
/// - `method`: "lm" (bounded Levenberg-Marquardt on exact Jacobians) or
///   "adam" (the paper's first-order variant; many more iterations).
/// - `scale`: 2 nv positive values (q then v) dividing the residuals; best
///   set to each component's measurement noise. Default: 1e-3 for every v
///   and `timestep * 1e-3` for every q (under semi-implicit Euler a position
///   residual is dt times the velocity residual that caused it, so both
///   weigh alike).
/// - `loss`: "squared" (sum of squared scaled residuals, the default) or
///   "huber" (method "lm" only): quadratic for scaled residuals up to `huber`,
///   linear beyond, so a few corrupted transitions cannot drag the estimate.
///   `huber` is in units of the residual scale (1.345, the default, keeps 95%
///   of least squares' efficiency when `scale` is the noise level).
/// - `constraints`: "modelled" (the default: the residuals are the paper's,
///   through our contact and limits) or "unknown" (the target's contact law,
///   limits and dry friction are not ours: each transition's residual is the
///   generalized force our smooth dynamics leaves unexplained at the observed
///   acceleration, less any impulse on a body within `margin` (m) of touching
///   something or on a joint within `margin` of its range's ends or with dry
///   friction; nv values per transition divided by `force_scale`, nv values in
///   N or N m, default 1; `scale` is then unused; the model must integrate
///   with Euler). `impulses`: how the target applies those impulses, "model"
///   (through M + E, E the model's implicit passive diagonal: MuJoCo's and
///   our Euler step) or "mass" (through M alone, the implicit spring and
///   damper terms taken before them: DART's).
///
/// The model is copied: later changes to it do not reach this object. The
/// default start is the model's current parameter values clamped into the
/// bounds (`prior`).
#[pyclass(name = "DiffOsi", module = "diffosi")]
pub(crate) struct PyDiffOsi {
    osi: Osi,
    method: Method,
    loss: Loss,
}

#[pymethods]
impl PyDiffOsi {
    #[new]
    #[pyo3(signature = (model, params, lower, upper, method = "lm", scale = None, loss = "squared", huber = HUBER_THRESHOLD, constraints = "modelled", margin = DEFAULT_MARGIN, force_scale = None, impulses = "model"))]
    // The constants' values spelled out for help() (pyo3 shows a named default as "...").
    #[pyo3(
        text_signature = "(model, params, lower, upper, method='lm', scale=None, loss='squared', huber=1.345, constraints='modelled', margin=0.02, force_scale=None, impulses='model')"
    )]
    #[allow(clippy::too_many_arguments)]
    fn new(
        model: &Bound<'_, PyModel>,
        params: Vec<String>,
        lower: &Bound<'_, PyAny>,
        upper: &Bound<'_, PyAny>,
        method: &str,
        scale: Option<&Bound<'_, PyAny>>,
        loss: &str,
        huber: f64,
        constraints: &str,
        margin: f64,
        force_scale: Option<&Bound<'_, PyAny>>,
        impulses: &str,
    ) -> PyResult<Self> {
        let method = match method {
            "lm" => Method::Lm,
            "adam" => Method::Adam,
            other => {
                return Err(PyValueError::new_err(format!(
                    "method must be 'lm' or 'adam', got '{other}'"
                )))
            }
        };
        let loss = robust_loss(loss, huber, matches!(method, Method::Lm))?;
        let mut osi = Osi::new(model, params, lower, upper, scale, "DiffOsi")?;
        let unknown = (margin, force_scale, impulses);
        osi.problem = with_constraints(osi.problem, constraints, unknown, "DiffOsi")?;
        Ok(PyDiffOsi { osi, method, loss })
    }

    /// Estimates the parameters from a window of W transitions: q, v, tau,
    /// q_next, v_next of shapes (W, nq), (W, nv), (W, nv), (W, nq), (W, nv),
    /// starting from `init` (default: `prior`). Returns a dict: "params" and
    /// "std" (float64 arrays of length nmu; an unexcited direction keeps its
    /// start value and reports the uniform prior's std, never NaN), "loss"
    /// (the scaled sum of squares, or the Huber loss with loss="huber"),
    /// "iterations", "evaluations" and "flags" (a list drawn from
    /// "unexcited", "at_bound", "not_converged", "misfit": loss per
    /// residual above 4, i.e. residuals larger than `scale`; with `scale` at
    /// the measurement noise, the model does not explain the data).
    #[pyo3(signature = (q, v, tau, q_next, v_next, init = None))]
    #[allow(clippy::too_many_arguments)]
    fn identify<'py>(
        &mut self,
        py: Python<'py>,
        q: &Bound<'py, PyAny>,
        v: &Bound<'py, PyAny>,
        tau: &Bound<'py, PyAny>,
        q_next: &Bound<'py, PyAny>,
        v_next: &Bound<'py, PyAny>,
        init: Option<&Bound<'py, PyAny>>,
    ) -> PyResult<Bound<'py, PyDict>> {
        let mut lm = Lm {
            options: LmOptions {
                loss: self.loss,
                ..LmOptions::default()
            },
        };
        let mut adam = Adam::default();
        let identifier: &mut (dyn Identifier + Send) = match self.method {
            Method::Lm => &mut lm,
            Method::Adam => &mut adam,
        };
        self.osi
            .identify(py, identifier, q, v, tau, q_next, v_next, init)
    }

    /// Parameter names, in the order of mu.
    #[getter]
    fn params(&self) -> Vec<String> {
        self.osi.names.clone()
    }

    /// The solver: "lm" or "adam".
    #[getter]
    fn method(&self) -> &'static str {
        match self.method {
            Method::Lm => "lm",
            Method::Adam => "adam",
        }
    }

    /// "squared" or "huber".
    #[getter]
    fn loss(&self) -> &'static str {
        loss_name(self.loss)
    }

    /// The Huber threshold in units of the residual scale (None for "squared").
    #[getter]
    fn huber(&self) -> Option<f64> {
        match self.loss {
            Loss::Huber { threshold } => Some(threshold),
            _ => None,
        }
    }

    /// The lower bound of each mu component (float64, length nmu).
    #[getter]
    fn lower<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        PyArray1::from_slice(py, self.osi.problem.lower())
    }

    /// The upper bound of each mu component (float64, length nmu).
    #[getter]
    fn upper<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        PyArray1::from_slice(py, self.osi.problem.upper())
    }

    /// The default start: the model's values clamped into the bounds.
    #[getter]
    fn prior<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        PyArray1::from_slice(py, self.osi.problem.prior())
    }

    fn __repr__(&self) -> String {
        format!(
            "<diffosi.DiffOsi method='{}' loss='{}' params={:?} nmu={}>",
            self.method(),
            self.loss(),
            self.osi.names,
            self.osi.problem.nmu()
        )
    }
}
