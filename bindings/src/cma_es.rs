//! `CmaEs`: the derivative-free baseline of `DiffOsi`.

use engine::osi::{CmaEs, CmaEsOptions};
use numpy::PyArray1;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::model::PyModel;
use crate::osi::Osi;

/// The CMA-ES baseline behind the same interface as `DiffOsi`:
/// `CmaEs(model, params, lower, upper, scale=None, seed=0,
/// max_evaluations=20000)`. Derivative-free and seeded (the same window,
/// start and seed give the same bits); it needs many more loss evaluations
/// than DiffOsi's "lm" for the same answer. `identify` and its result are
/// those of `DiffOsi` ("iterations" counts generations; hitting
/// `max_evaluations` sets "not_converged").
#[pyclass(name = "CmaEs", module = "diffosi")]
pub(crate) struct PyCmaEs {
    osi: Osi,
    options: CmaEsOptions,
}

#[pymethods]
impl PyCmaEs {
    #[new]
    #[pyo3(signature = (model, params, lower, upper, scale = None, seed = None, max_evaluations = None))]
    // The defaults CmaEsOptions gives (None reads them), spelled out for help().
    #[pyo3(
        text_signature = "(model, params, lower, upper, scale=None, seed=0, max_evaluations=20000)"
    )]
    #[allow(clippy::too_many_arguments)]
    fn new(
        model: &Bound<'_, PyModel>,
        params: Vec<String>,
        lower: &Bound<'_, PyAny>,
        upper: &Bound<'_, PyAny>,
        scale: Option<&Bound<'_, PyAny>>,
        seed: Option<&Bound<'_, PyAny>>,
        max_evaluations: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<Self> {
        let defaults = CmaEsOptions::default();
        let seed: u64 = match seed {
            None => defaults.seed,
            Some(seed) => seed.extract().map_err(|_| {
                PyValueError::new_err(format!("seed must be an integer in [0, 2^64), got {seed}"))
            })?,
        };
        let max_evaluations: usize = match max_evaluations.map(|m| (m, m.extract::<usize>())) {
            None => defaults.max_evaluations,
            Some((_, Ok(n))) if n >= 1 => n,
            Some((m, _)) => {
                return Err(PyValueError::new_err(format!(
                    "max_evaluations must be a positive integer, got {m}"
                )))
            }
        };
        let osi = Osi::new(model, params, lower, upper, scale, "CmaEs")?;
        let options = CmaEsOptions {
            seed,
            max_evaluations,
            ..defaults
        };
        Ok(PyCmaEs { osi, options })
    }

    /// As `DiffOsi.identify`.
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
        let mut cmaes = CmaEs {
            options: self.options,
        };
        self.osi
            .identify(py, &mut cmaes, q, v, tau, q_next, v_next, init)
    }

    /// Parameter names, in the order of mu.
    #[getter]
    fn params(&self) -> Vec<String> {
        self.osi.names.clone()
    }

    #[getter]
    fn seed(&self) -> u64 {
        self.options.seed
    }

    #[getter]
    fn max_evaluations(&self) -> usize {
        self.options.max_evaluations
    }

    #[getter]
    fn lower<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        PyArray1::from_slice(py, self.osi.problem.lower())
    }

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
            "<diffosi.CmaEs seed={} params={:?} nmu={}>",
            self.options.seed,
            self.osi.names,
            self.osi.problem.nmu()
        )
    }
}
