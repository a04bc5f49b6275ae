//! What the identification classes (`DiffOsi`, `CmaEs`, `OnlineOsi`,
//! `Wiping.identify`) share: the residual scale, the robust loss, the
//! `constraints` arguments and the result dict.

use engine::derivatives::Impulses;
use engine::osi::{default_scale, Estimate, Loss, Problem};
use engine::Model;
use numpy::PyArray1;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};

use crate::convert::vector;
use crate::errors::osi_error;

/// The margin (m or rad) within which a body or joint counts as possibly
/// constrained when constraints are unknown.
pub(crate) const DEFAULT_MARGIN: f64 = 0.02;

/// Applies the `constraints`, `margin`, `force_scale` and `impulses` arguments
/// of `DiffOsi` and `OnlineOsi`: "modelled" keeps `problem`; "unknown"
/// eliminates the target's constraint impulses
/// (`Problem::with_unknown_constraints`), `force_scale` nv positive values
/// (default 1 N or N m each), `impulses` "model" or "mass".
pub(crate) fn with_constraints(
    problem: Problem,
    constraints: &str,
    (margin, force_scale, impulses): (f64, Option<&Bound<'_, PyAny>>, &str),
    class: &str,
) -> PyResult<Problem> {
    let nv = problem.nv();
    let impulses = match impulses {
        "model" => Impulses::Model,
        "mass" => Impulses::Mass,
        other => {
            return Err(PyValueError::new_err(format!(
                "impulses must be 'model' or 'mass', got '{other}'"
            )))
        }
    };
    match constraints {
        "modelled" if force_scale.is_some() || impulses != Impulses::Model => Err(
            PyValueError::new_err("force_scale and impulses apply to constraints='unknown' only"),
        ),
        "modelled" => Ok(problem),
        "unknown" => {
            let scale = match force_scale {
                Some(s) => vector(s, "force_scale", nv, "nv")?,
                None => vec![1.0; nv],
            };
            problem
                .with_unknown_constraints(margin, &scale, impulses)
                .map_err(|e| osi_error(class, e))
        }
        other => Err(PyValueError::new_err(format!(
            "constraints must be 'modelled' or 'unknown', got '{other}'"
        ))),
    }
}

/// The `scale` argument: 2 nv positive values (q then v), or `default_scale`.
pub(crate) fn residual_scale(
    scale: Option<&Bound<'_, PyAny>>,
    model: &Model,
) -> PyResult<Vec<f64>> {
    match scale {
        Some(s) => {
            let s = vector(s, "scale", 2 * model.nv(), "2 nv")?;
            if let Some(i) = s.iter().position(|x| *x <= 0.0) {
                return Err(PyValueError::new_err(format!(
                    "scale[{i}] = {} must be positive",
                    s[i]
                )));
            }
            Ok(s)
        }
        None => Ok(default_scale(model)),
    }
}

/// The LM loss from its Python spelling: "squared", or "huber" with
/// `threshold` (finite, positive; only where the solver is LM).
pub(crate) fn robust_loss(loss: &str, threshold: f64, lm: bool) -> PyResult<Loss> {
    match loss {
        "squared" => Ok(Loss::Squared),
        "huber" if !lm => Err(PyValueError::new_err(
            "loss='huber' needs method='lm' (the other methods minimise the squared loss)",
        )),
        "huber" if !(threshold.is_finite() && threshold > 0.0) => {
            Err(PyValueError::new_err(format!(
                "huber = {threshold} must be finite and positive (in units of the residual scale)"
            )))
        }
        "huber" => Ok(Loss::Huber { threshold }),
        other => Err(PyValueError::new_err(format!(
            "loss must be 'squared' or 'huber', got '{other}'"
        ))),
    }
}

pub(crate) fn loss_name(loss: Loss) -> &'static str {
    match loss {
        Loss::Huber { .. } => "huber",
        _ => "squared",
    }
}

/// An `Estimate` as the contract's dict, the estimate under the key `key`
/// ("params" for `DiffOsi` and `CmaEs`, "mu" for `OnlineOsi`).
pub(crate) fn estimate_dict<'py>(
    py: Python<'py>,
    e: Estimate,
    key: &str,
) -> PyResult<Bound<'py, PyDict>> {
    let out = PyDict::new(py);
    out.set_item(key, PyArray1::from_vec(py, e.mu))?;
    out.set_item("std", PyArray1::from_vec(py, e.std))?;
    out.set_item("loss", e.loss)?;
    out.set_item("iterations", e.iterations)?;
    out.set_item("evaluations", e.evaluations)?;
    out.set_item("flags", PyList::new(py, e.flags.names())?)?;
    Ok(out)
}
