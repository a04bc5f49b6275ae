//! The Python module `diffosi` (DESIGN.md, "Python contract"): a thin layer
//! over the engine crate that converts arrays and errors, and nothing else.
//!
//! Every argument goes through `numpy.asarray(x, dtype=float64)`, so lists,
//! tuples and arrays of any real dtype work; shapes and finiteness are checked
//! here so that the messages name the Python argument. Every engine error maps
//! to a Python exception (`OSError` for files, `ValueError` for everything
//! else); nothing the caller passes can reach a panic.
//!
//! One Python class a file: `Model` in model.rs, `DiffOsi` in diff_osi.rs,
//! `CmaEs` in cma_es.rs (both on osi.rs's windows), `OnlineOsi` in
//! online_osi.rs, `Task` in task.rs, `Policy` in policy.rs, `Wiping` in
//! wiping.rs and `WipingRun` in wiping_run.rs. The conversions of arguments
//! are in convert.rs, those of errors in errors.rs, and what the
//! identification classes share (scales, losses, constraints, the result
//! dict) in identification.rs.

mod cma_es;
mod convert;
mod diff_osi;
mod errors;
mod identification;
mod model;
mod online_osi;
mod osi;
mod policy;
mod task;
mod wiping;
mod wiping_run;

use pyo3::prelude::*;

/// Differentiable rigid-body dynamics with online system identification.
#[pymodule]
fn diffosi(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<model::PyModel>()?;
    m.add_class::<diff_osi::PyDiffOsi>()?;
    m.add_class::<cma_es::PyCmaEs>()?;
    m.add_class::<task::PyTask>()?;
    m.add_class::<policy::PyPolicy>()?;
    m.add_class::<wiping::PyWiping>()?;
    m.add_class::<wiping_run::PyWipingRun>()?;
    m.add_class::<online_osi::PyOnlineOsi>()?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
