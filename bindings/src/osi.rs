//! The core of `DiffOsi` and `CmaEs`: an identification problem over named
//! parameters with an identity map, and the checks of a window of transitions.

use engine::derivatives::Transition;
use engine::model::{ParamMap, State};
use engine::osi::{Identifier, Problem};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::convert::{matrix, vector};
use crate::errors::{osi_error, param_error};
use crate::identification::{estimate_dict, residual_scale};
use crate::model::PyModel;

/// What `DiffOsi` and `CmaEs` share: the problem (model copy, identity map,
/// bounds, default start, scale) and the conversion of windows.
pub(crate) struct Osi {
    pub(crate) problem: Problem,
    pub(crate) names: Vec<String>,
}

impl Osi {
    pub(crate) fn new(
        model: &Bound<'_, PyModel>,
        params: Vec<String>,
        lower: &Bound<'_, PyAny>,
        upper: &Bound<'_, PyAny>,
        scale: Option<&Bound<'_, PyAny>>,
        class: &str,
    ) -> PyResult<Osi> {
        let model = model.borrow().model.clone();
        if params.is_empty() {
            return Err(PyValueError::new_err(
                "params must name at least one parameter",
            ));
        }
        for (i, name) in params.iter().enumerate() {
            if params[..i].contains(name) {
                return Err(PyValueError::new_err(format!(
                    "params: parameter '{name}' is named twice"
                )));
            }
        }
        let sizes: Vec<usize> = params
            .iter()
            .map(|name| model.param(name).map(|p| p.size()).map_err(param_error))
            .collect::<PyResult<_>>()?;
        let nmu: usize = sizes.iter().sum();
        let what = "nmu (the flattened length of params)";
        let lower = vector(lower, "lower", nmu, what)?;
        let upper = vector(upper, "upper", nmu, what)?;
        if let Some(i) = (0..nmu).find(|&i| lower[i] >= upper[i]) {
            return Err(PyValueError::new_err(format!(
                "bounds: lower[{i}] = {} must be below upper[{i}] = {}",
                lower[i], upper[i]
            )));
        }
        let scale = residual_scale(scale, &model)?;
        // Identity map: mu component k is the k-th flattened parameter scalar.
        let mut prior = Vec::with_capacity(nmu);
        for name in &params {
            prior.extend(model.get_param(name).map_err(param_error)?);
        }
        for (i, p) in prior.iter_mut().enumerate() {
            *p = p.clamp(lower[i], upper[i]);
        }
        let map = ParamMap::identity(&model, &params).map_err(param_error)?;
        let problem = Problem::new(&model, map, &lower, &upper, &prior, &scale)
            .map_err(|e| osi_error(class, e))?;
        Ok(Osi {
            problem,
            names: params,
        })
    }

    /// Checks the window and `init`, then runs `identifier`.
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn identify<'py>(
        &mut self,
        py: Python<'py>,
        identifier: &mut (dyn Identifier + Send),
        q: &Bound<'py, PyAny>,
        v: &Bound<'py, PyAny>,
        tau: &Bound<'py, PyAny>,
        q_next: &Bound<'py, PyAny>,
        v_next: &Bound<'py, PyAny>,
        init: Option<&Bound<'py, PyAny>>,
    ) -> PyResult<Bound<'py, PyDict>> {
        let (nq, nv) = (self.problem.nq(), self.problem.nv());
        let arrays = [
            matrix(q, "q", nq, "nq")?,
            matrix(v, "v", nv, "nv")?,
            matrix(tau, "tau", nv, "nv")?,
            matrix(q_next, "q_next", nq, "nq")?,
            matrix(v_next, "v_next", nv, "nv")?,
        ];
        let w = arrays[0].nrows();
        if w == 0 {
            return Err(PyValueError::new_err(
                "q: the window holds no transitions (W = 0)",
            ));
        }
        let names = ["q", "v", "tau", "q_next", "v_next"];
        if let Some(k) = arrays.iter().position(|a| a.nrows() != w) {
            return Err(PyValueError::new_err(format!(
                "{} has {} rows, but q has W = {w}: every array needs one row per transition",
                names[k],
                arrays[k].nrows()
            )));
        }
        let row = |k: usize, t: usize| arrays[k].row(t).to_vec();
        let window: Vec<Transition> = (0..w)
            .map(|t| Transition {
                start: State::new(row(0, t), row(1, t)),
                tau: row(2, t),
                next: State::new(row(3, t), row(4, t)),
            })
            .collect();
        let nmu = self.problem.nmu();
        let start = match init {
            Some(init) => {
                let init = vector(init, "init", nmu, "nmu")?;
                let (lo, hi) = (self.problem.lower(), self.problem.upper());
                if let Some(i) = (0..nmu).find(|&i| !(lo[i]..=hi[i]).contains(&init[i])) {
                    return Err(PyValueError::new_err(format!(
                        "init[{i}] = {} lies outside its bounds [{}, {}]",
                        init[i], lo[i], hi[i]
                    )));
                }
                init
            }
            None => self.problem.prior().to_vec(),
        };
        let problem = &mut self.problem;
        let estimate = py
            .detach(|| identifier.identify(problem, &window, &start))
            .map_err(|e| osi_error("identify", e))?;
        estimate_dict(py, estimate, "params")
    }
}
