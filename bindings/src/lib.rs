//! The Python module `diffosi` (DESIGN.md, "Python contract"): a thin layer
//! over the engine crate that converts arrays and errors, and nothing else.
//!
//! Every argument goes through `numpy.asarray(x, dtype=float64)`, so lists,
//! tuples and arrays of any real dtype work; shapes and finiteness are checked
//! here so that the messages name the Python argument. Every engine error maps
//! to a Python exception (`OSError` for files, `ValueError` for everything
//! else); nothing the caller passes can reach a panic.
//!
//! The tasks, trained policies and online identification (`Task`, `Policy`,
//! `OnlineOsi`) live in `task.rs`.

mod task;
mod wiping;

use engine::derivatives::{
    step_jacobians, transition_jacobians, Impulses, Transition, TransitionJacobians, Workspace, Wrt,
};
use engine::dynamics::{body_contact_forces, Contact, Data};
use engine::model::{ContactModel, Integrator, Param, ParamError, ParamMap, PassiveMode};
use engine::osi::{
    Adam, CmaEs, CmaEsOptions, Estimate, Identifier, Lm, LmOptions, Loss, OsiError, Problem,
    HUBER_THRESHOLD,
};
use engine::{Model, ModelError};
use numpy::ndarray::{Array2, ArrayView2, ShapeBuilder};
use numpy::{PyArray1, PyArray2, PyArrayDyn, PyArrayMethods, PyUntypedArrayMethods, ToPyArray};
use pyo3::exceptions::{PyFileNotFoundError, PyOSError, PyValueError};
use pyo3::intern;
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList, PyTuple};

/// A rigid-body model with its simulation buffers.
///
/// `Model.load(path)` reads MJCF (`.xml`) or URDF (`.urdf`). States are
/// (q, v) with q of length nq and v of length nv (MuJoCo's qpos and qvel);
/// tau are generalized forces of length nv. nq > nv with ball joints (a
/// quaternion w, x, y, z for 3 dofs: body-frame angular velocity) and free
/// joints (world position and quaternion for 6 dofs: world linear, then
/// body-frame angular velocity). Parameters are named as in `param_names()`.
#[pyclass(name = "Model", module = "diffosi")]
pub(crate) struct PyModel {
    pub(crate) model: Model,
    /// Scratch for `step`; rebuilt whenever the model changes.
    data: Data<f64>,
    /// Scratch for `step_jacobians`; rebuilt whenever the model changes.
    ws: Workspace,
    /// `transition_jacobians`' result, reused.
    transition: TransitionJacobians,
}

impl PyModel {
    pub(crate) fn new(model: Model) -> Self {
        let data = model.data();
        let ws = Workspace::new(&model);
        let transition = TransitionJacobians::new(model.nq(), model.nv());
        PyModel {
            model,
            data,
            ws,
            transition,
        }
    }

    /// Resolves parameter names, failing on the first unknown one.
    fn params(&self, names: &[String]) -> PyResult<Vec<Param>> {
        names
            .iter()
            .map(|name| self.model.param(name).map_err(param_error))
            .collect()
    }
}

#[pymethods]
impl PyModel {
    /// Loads a model: `.xml` as MJCF, `.urdf` as URDF. A missing or unreadable
    /// file raises OSError; a file we cannot accept raises ValueError naming
    /// the element and line.
    #[staticmethod]
    fn load(path: std::path::PathBuf) -> PyResult<Self> {
        Model::load(&path).map(PyModel::new).map_err(model_error)
    }

    /// Number of generalized positions.
    #[getter]
    fn nq(&self) -> usize {
        self.model.nq()
    }

    /// Number of generalized velocities (the length of tau).
    #[getter]
    fn nv(&self) -> usize {
        self.model.nv()
    }

    /// The configuration (length nq) at which every body sits at its
    /// modelled pose: MuJoCo's qpos0 (a free joint's body position and
    /// quaternion, a ball's identity quaternion).
    fn reference_q<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        PyArray1::from_vec(py, self.model.reference_q())
    }

    /// Number of actuators.
    #[getter]
    fn nu(&self) -> usize {
        self.model.nu()
    }

    /// Integration timestep in seconds.
    #[getter]
    fn timestep(&self) -> f64 {
        self.model.opt.timestep
    }

    /// Gravity (x, y, z) in m/s^2, in the world frame.
    #[getter]
    fn gravity<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        PyArray1::from_slice(py, self.model.opt.gravity.as_slice())
    }

    /// "Euler" (semi-implicit) or "RK4".
    #[getter]
    fn integrator(&self) -> &'static str {
        name_of(&Integrator::NAMES, self.model.opt.integrator)
    }

    /// How joint damping and stiffness enter an Euler step: "explicit"
    /// (PyBullet), "implicit_damping" (MuJoCo) or "implicit_damping_stiffness"
    /// (DART).
    #[getter]
    fn passive(&self) -> &'static str {
        name_of(&PassiveMode::NAMES, self.model.opt.passive)
    }

    /// The law contacts, limits and dry friction follow: "constraint" (MuJoCo's
    /// soft constraints, the default for MJCF files) or "smooth" (the penalty
    /// model, the default for URDF files).
    #[getter]
    fn contact_model(&self) -> &'static str {
        name_of(&ContactModel::NAMES, self.model.opt.contact_model)
    }

    /// A copy run with other options, e.g. the conventions of the engine it is
    /// compared with: `m.with_options(passive="implicit_damping_stiffness",
    /// timestep=0.005)`; `contact=False` / `limits=False` switch off the
    /// contacts and joint limits; `contact_model` is "constraint" (MuJoCo's
    /// soft constraints, the default for MJCF files) or "smooth" (the penalty
    /// model, the default for URDF files); `density` (kg/m^3), `viscosity`
    /// (Pa s) and `wind` (3, m/s) set the fluid (MuJoCo's inertia-box model).
    /// Options not given keep their value.
    #[pyo3(signature = (*, timestep = None, gravity = None, integrator = None, passive = None, contact = None, limits = None, contact_model = None, density = None, viscosity = None, wind = None))]
    #[allow(clippy::too_many_arguments)]
    fn with_options(
        &self,
        timestep: Option<f64>,
        gravity: Option<&Bound<'_, PyAny>>,
        integrator: Option<&str>,
        passive: Option<&str>,
        contact: Option<bool>,
        limits: Option<bool>,
        contact_model: Option<&str>,
        density: Option<f64>,
        viscosity: Option<f64>,
        wind: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<Self> {
        let wind = wind.map(|w| vector(w, "wind", 3, "3")).transpose()?;
        let contact_model = contact_model
            .map(|c| keyword("contact_model", c, &ContactModel::NAMES))
            .transpose()?;
        let gravity = gravity.map(|g| vector(g, "gravity", 3, "3")).transpose()?;
        let integrator = integrator
            .map(|i| keyword("integrator", i, &Integrator::NAMES))
            .transpose()?;
        let passive = passive
            .map(|p| keyword("passive", p, &PassiveMode::NAMES))
            .transpose()?;
        let model = self
            .model
            .edited(|s| {
                s.opt.timestep = timestep.unwrap_or(s.opt.timestep);
                if let Some(g) = gravity {
                    s.opt.gravity.copy_from_slice(&g);
                }
                s.opt.integrator = integrator.unwrap_or(s.opt.integrator);
                s.opt.passive = passive.unwrap_or(s.opt.passive);
                s.opt.contact = contact.unwrap_or(s.opt.contact);
                s.opt.limits = limits.unwrap_or(s.opt.limits);
                s.opt.contact_model = contact_model.unwrap_or(s.opt.contact_model);
                let fluid = &mut s.opt.fluid;
                fluid.density = density.unwrap_or(fluid.density);
                fluid.viscosity = viscosity.unwrap_or(fluid.viscosity);
                if let Some(w) = wind {
                    fluid.wind.copy_from_slice(&w);
                }
            })
            .map_err(model_error)?;
        Ok(PyModel::new(model))
    }

    /// The model's name (from the file).
    #[getter]
    fn name(&self) -> String {
        self.model.name.clone()
    }

    /// Joint names, in the order of q and v (one each for hinges and
    /// slides; see `coordinate_names` for ball and free joints).
    #[getter]
    fn joint_names(&self) -> Vec<String> {
        self.model.joints.iter().map(|j| j.name.clone()).collect()
    }

    /// (names of q's nq coordinates, names of the nv dofs): a hinge's or
    /// slide's joint name; a ball's or free joint's with a suffix (`root:qw`,
    /// `root:x`, `root:vx`, `root:wx`, ...).
    fn coordinate_names(&self) -> (Vec<String>, Vec<String>) {
        self.model.coordinate_names()
    }

    /// Body names, the world body first.
    #[getter]
    fn body_names(&self) -> Vec<String> {
        self.model.bodies.iter().map(|b| b.name.clone()).collect()
    }

    /// Names of every identifiable parameter.
    fn param_names(&self) -> Vec<String> {
        self.model.param_names()
    }

    /// The current value of a parameter as a 1-D float64 array.
    fn get_param<'py>(&self, py: Python<'py>, name: &str) -> PyResult<Bound<'py, PyArray1<f64>>> {
        let value = self.model.get_param(name).map_err(param_error)?;
        Ok(PyArray1::from_vec(py, value))
    }

    /// Sets a parameter from a number or array-like. Unknown names, wrong
    /// lengths and non-physical values raise ValueError and leave the model
    /// unchanged.
    fn set_param(&mut self, name: &str, value: &Bound<'_, PyAny>) -> PyResult<()> {
        let value = float_array(value, "value")?;
        if value.ndim() > 1 {
            return Err(PyValueError::new_err(format!(
                "value for parameter '{name}' must be a number or 1-D, got shape {}",
                shape(value.shape())
            )));
        }
        let value = entries(&value);
        self.model.set_param(name, &value).map_err(param_error)?;
        self.data = self.model.data();
        self.ws = Workspace::new(&self.model);
        Ok(())
    }

    /// One step from (q, v) under generalized forces tau; returns (q1, v1).
    fn step<'py>(
        &mut self,
        py: Python<'py>,
        q: &Bound<'py, PyAny>,
        v: &Bound<'py, PyAny>,
        tau: &Bound<'py, PyAny>,
    ) -> PyResult<Bound<'py, PyTuple>> {
        let (q, v, tau) = self.state(q, v, tau)?;
        let (q1, v1) = self
            .model
            .step(&mut self.data, &q, &v, &tau)
            .map_err(|e| PyValueError::new_err(format!("step: {e}")))?;
        PyTuple::new(py, [PyArray1::from_vec(py, q1), PyArray1::from_vec(py, v1)])
    }

    /// Steps from (q0, v0) under each row of taus (shape (T, nv)); returns the
    /// visited states as arrays of shapes (T+1, nq) and (T+1, nv).
    fn rollout<'py>(
        &mut self,
        py: Python<'py>,
        q0: &Bound<'py, PyAny>,
        v0: &Bound<'py, PyAny>,
        taus: &Bound<'py, PyAny>,
    ) -> PyResult<Bound<'py, PyTuple>> {
        let q0 = vector(q0, "q0", self.model.nq(), "nq")?;
        let v0 = vector(v0, "v0", self.model.nv(), "nv")?;
        let taus = matrix(taus, "taus", self.model.nv(), "nv")?;
        let (nq, nv) = (self.model.nq(), self.model.nv());
        let steps = taus.nrows();
        let (mut qs, mut vs) = (
            Array2::zeros((steps + 1, nq)),
            Array2::zeros((steps + 1, nv)),
        );
        let (model, data) = (&self.model, &mut self.data);
        // Other Python threads run while this one steps.
        py.detach(|| {
            let (mut q, mut v) = (q0, v0);
            for t in 0..=steps {
                qs.row_mut(t).assign(&numpy::ndarray::ArrayView1::from(&q));
                vs.row_mut(t).assign(&numpy::ndarray::ArrayView1::from(&v));
                if t == steps {
                    break;
                }
                let tau = taus.row(t);
                let tau = tau.as_slice().expect("rows of a standard-layout array");
                (q, v) = model
                    .step(data, &q, &v, tau)
                    .map_err(|e| format!("rollout step {t}: {e}"))?;
            }
            Ok::<(), String>(())
        })
        .map_err(PyValueError::new_err)?;
        let qs = PyArray2::from_owned_array(py, qs);
        let vs = PyArray2::from_owned_array(py, vs);
        PyTuple::new(py, [qs, vs])
    }

    /// One step with its exact Jacobians: a dict of 2-D float64 arrays
    /// dq_dq, dq_dv, dv_dq, dv_dv (n x n), dq_dtau, dv_dtau (n x n) and
    /// dq_dp, dv_dp (n x total length of `params`, columns in the order of
    /// the flattened parameters); n = nv, positions in the tangent space
    /// (see `transition_jacobians`).
    #[pyo3(signature = (q, v, tau, params = None))]
    fn step_jacobians<'py>(
        &mut self,
        py: Python<'py>,
        q: &Bound<'py, PyAny>,
        v: &Bound<'py, PyAny>,
        tau: &Bound<'py, PyAny>,
        params: Option<Vec<String>>,
    ) -> PyResult<Bound<'py, PyDict>> {
        let params = self.params(params.as_deref().unwrap_or_default())?;
        let (q, v, tau) = self.state(q, v, tau)?;
        let wrt = Wrt {
            state: true,
            control: true,
            params: &params,
        };
        let (model, ws) = (&self.model, &mut self.ws);
        let j = py
            .detach(|| step_jacobians(model, ws, (&q, &v, &tau), &wrt))
            .map_err(|e| PyValueError::new_err(format!("step_jacobians: {e}")))?;
        let out = PyDict::new(py);
        // Interned keys: a hot call, and the eight strings are the same every time.
        for (key, m) in [
            (intern!(py, "dq_dq"), j.dq_dq()),
            (intern!(py, "dq_dv"), j.dq_dv()),
            (intern!(py, "dq_dtau"), j.dq_dtau()),
            (intern!(py, "dv_dq"), j.dv_dq()),
            (intern!(py, "dv_dv"), j.dv_dv()),
            (intern!(py, "dv_dtau"), j.dv_dtau()),
            (intern!(py, "dq_dp"), j.dq_dp()),
            (intern!(py, "dv_dp"), j.dv_dp()),
        ] {
            let m = m.into_owned();
            out.set_item(key, to_numpy(py, m.shape(), m.as_slice()))?;
        }
        Ok(out)
    }

    /// One step's Jacobians in MuJoCo's layout (mjd_transitionFD's A and B,
    /// here exact): A = d(q', v')/d(q, v), 2 nv x 2 nv, rows q' then v',
    /// columns q then v; B = d(q', v')/d tau, 2 nv x nv. Two float64 arrays.
    /// Positions in the tangent space, as mjd_transitionFD has them: a ball's
    /// or free joint's rotation as its body-frame rotation vector.
    fn transition_jacobians<'py>(
        &mut self,
        py: Python<'py>,
        q: &Bound<'py, PyAny>,
        v: &Bound<'py, PyAny>,
        tau: &Bound<'py, PyAny>,
    ) -> PyResult<MatrixPair<'py>> {
        let (q, v, tau) = self.state(q, v, tau)?;
        let x = (&q[..], &v[..], &tau[..]);
        let (model, ws, out) = (&self.model, &mut self.ws, &mut self.transition);
        py.detach(|| transition_jacobians(model, ws, x, out))
            .map_err(|e| PyValueError::new_err(format!("transition_jacobians: {e}")))?;
        let (a, b) = (&self.transition.a, &self.transition.b);
        Ok((
            to_numpy(py, a.shape(), a.as_slice()),
            to_numpy(py, b.shape(), b.as_slice()),
        ))
    }

    /// The contacts at (q, v), with the forces a step from (q, v) under the
    /// generalized forces `tau` (default zero) applies: a list of dicts, one
    /// per contact point. Under the smooth model (forces independent of tau)
    /// every geom pair within reach (depth > -30 activation widths; `depth`
    /// < 0 is a separation, whose force is tiny but not zero); under the
    /// constraint model MuJoCo's contacts within their margin, with the
    /// solver's forces (mj_contactForce in world coordinates, torsional and
    /// rolling moments left out). World frame, SI units. Keys: `geoms` and
    /// `bodies` (names of a and b; b is the plane when there is one, else the
    /// geom first in MuJoCo's shape order), `point` (halfway between the
    /// surfaces), `normal` (unit, from b into a: the direction of the normal
    /// force on a), `depth` (m, > 0 overlapping), `normal_force` (N along
    /// `normal` on a; negative only while separating fast under the smooth
    /// model), `friction` (3-vector, N, tangential force on a) and `force`
    /// (the total force on a, normal_force * normal + friction), `torque`
    /// (3-vector, N m: torsional and rolling friction moments on a, condim 4
    /// and 6), `frame` (3 x 3, rows: the normal and two tangents, MuJoCo's
    /// contact frame) and `frame_force` (6: normal, tangential, torsional and
    /// rolling components in that frame, mj_contactForce's); b feels the
    /// opposite. Empty when contacts are off. NaN or infinite input raises
    /// ValueError.
    #[pyo3(signature = (q, v, tau = None))]
    fn contacts<'py>(
        &mut self,
        py: Python<'py>,
        q: &Bound<'py, PyAny>,
        v: &Bound<'py, PyAny>,
        tau: Option<&Bound<'py, PyAny>>,
    ) -> PyResult<Bound<'py, PyList>> {
        let contacts = self.contact_list(q, v, tau)?;
        let out = PyList::empty(py);
        for c in contacts {
            let d = PyDict::new(py);
            let geoms = c.geoms.map(|g| self.model.geoms[g].name.clone());
            let bodies = c.bodies.map(|b| self.model.bodies[b].name.clone());
            d.set_item("geoms", PyTuple::new(py, geoms)?)?;
            d.set_item("bodies", PyTuple::new(py, bodies)?)?;
            d.set_item("point", PyArray1::from_slice(py, c.point.as_slice()))?;
            d.set_item("normal", PyArray1::from_slice(py, c.normal.as_slice()))?;
            d.set_item("depth", c.depth)?;
            d.set_item("normal_force", c.normal_force)?;
            d.set_item("friction", PyArray1::from_slice(py, c.friction.as_slice()))?;
            d.set_item("force", PyArray1::from_slice(py, c.force().as_slice()))?;
            d.set_item("torque", PyArray1::from_slice(py, c.torque.as_slice()))?;
            let frame = Array2::from_shape_fn((3, 3), |(r, k)| c.frame[(r, k)]);
            d.set_item("frame", PyArray2::from_owned_array(py, frame))?;
            d.set_item("frame_force", PyArray1::from_slice(py, &c.in_frame()))?;
            out.append(d)?;
        }
        Ok(out)
    }

    /// The net contact force on each body at (q, v) under `tau` (default
    /// zero): an array of shape (number of bodies, 3), rows in `body_names`
    /// order (the world first), world frame, N: the sum of the forces of
    /// `contacts(q, v, tau)` on the body (no moments). The rows sum to zero.
    #[pyo3(signature = (q, v, tau = None))]
    fn body_contact_forces<'py>(
        &mut self,
        py: Python<'py>,
        q: &Bound<'py, PyAny>,
        v: &Bound<'py, PyAny>,
        tau: Option<&Bound<'py, PyAny>>,
    ) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let contacts = self.contact_list(q, v, tau)?;
        let forces = body_contact_forces(&contacts, self.model.bodies.len());
        let a = Array2::from_shape_fn((forces.len(), 3), |(b, k)| forces[b][k]);
        Ok(PyArray2::from_owned_array(py, a))
    }

    fn __repr__(&self) -> String {
        format!(
            "<diffosi.Model '{}' nq={} nv={} nu={}>",
            self.model.name,
            self.model.nq(),
            self.model.nv(),
            self.model.nu()
        )
    }
}

impl PyModel {
    /// The contacts at (q, v), checked: ValueError if a force overflows.
    fn contact_list(
        &mut self,
        q: &Bound<'_, PyAny>,
        v: &Bound<'_, PyAny>,
        tau: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<Vec<Contact<f64>>> {
        let q = vector(q, "q", self.model.nq(), "nq")?;
        let v = vector(v, "v", self.model.nv(), "nv")?;
        let tau = match tau {
            Some(t) => vector(t, "tau", self.model.nv(), "nv")?,
            None => vec![0.0; self.model.nv()],
        };
        let contacts = self
            .model
            .contacts(&mut self.data, &q, &v, &tau)
            .map_err(|e| PyValueError::new_err(format!("contacts: {e}")))?;
        let finite = |c: &Contact<f64>| {
            c.point.iter().chain(&c.force()).all(|x| x.is_finite()) && c.depth.is_finite()
        };
        if !contacts.iter().all(finite) {
            return Err(PyValueError::new_err(
                "contacts: a contact force is not finite (state too large)",
            ));
        }
        Ok(contacts)
    }

    /// Converts and checks (q, v, tau).
    fn state(
        &self,
        q: &Bound<'_, PyAny>,
        v: &Bound<'_, PyAny>,
        tau: &Bound<'_, PyAny>,
    ) -> PyResult<(Vec<f64>, Vec<f64>, Vec<f64>)> {
        let (nq, nv) = (self.model.nq(), self.model.nv());
        Ok((
            vector(q, "q", nq, "nq")?,
            vector(v, "v", nv, "nv")?,
            vector(tau, "tau", nv, "nv")?,
        ))
    }
}

/// The residual scale on velocities when `scale` is not given; positions get
/// `timestep` times this (see `DiffOsi`).
const DEFAULT_V_SCALE: f64 = 1e-3;

/// The default residual scale: `DEFAULT_V_SCALE` on every v and `timestep`
/// times it on every q (see `DiffOsi`).
pub(crate) fn default_scale(model: &Model) -> Vec<f64> {
    let nv = model.nv();
    let mut s = vec![model.opt.timestep * DEFAULT_V_SCALE; nv];
    s.extend(std::iter::repeat_n(DEFAULT_V_SCALE, nv));
    s
}

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
struct PyDiffOsi {
    osi: Osi,
    method: Method,
    loss: Loss,
}

#[pymethods]
impl PyDiffOsi {
    #[new]
    #[pyo3(signature = (model, params, lower, upper, method = "lm", scale = None, loss = "squared", huber = HUBER_THRESHOLD, constraints = "modelled", margin = DEFAULT_MARGIN, force_scale = None, impulses = "model"))]
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
            "<diffosi.DiffOsi method='{}' loss='{}' params={:?} nmu={}>",
            self.method(),
            self.loss(),
            self.osi.names,
            self.osi.problem.nmu()
        )
    }
}

/// The LM loss from its Python spelling: "squared", or "huber" with
/// `threshold` (finite, positive; only where the solver is LM).
pub(crate) fn robust_loss(loss: &str, threshold: f64, lm: bool) -> PyResult<Loss> {
    match loss {
        "squared" => Ok(Loss::Squared),
        "huber" if !lm => Err(PyValueError::new_err(
            "loss='huber' needs method='lm' (Adam minimises the squared loss)",
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

/// The CMA-ES baseline behind the same interface as `DiffOsi`:
/// `CmaEs(model, params, lower, upper, scale=None, seed=0,
/// max_evaluations=20000)`. Derivative-free and seeded (the same window,
/// start and seed give the same bits); it needs many more loss evaluations
/// than DiffOsi's "lm" for the same answer. `identify` and its result are
/// those of `DiffOsi` ("iterations" counts generations; hitting
/// `max_evaluations` sets "not_converged").
#[pyclass(name = "CmaEs", module = "diffosi")]
struct PyCmaEs {
    osi: Osi,
    options: CmaEsOptions,
}

#[pymethods]
impl PyCmaEs {
    #[new]
    #[pyo3(signature = (model, params, lower, upper, scale = None, seed = None, max_evaluations = None))]
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

/// What `DiffOsi` and `CmaEs` share: the problem (model copy, identity map,
/// bounds, default start, scale) and the conversion of windows.
struct Osi {
    problem: Problem,
    names: Vec<String>,
}

impl Osi {
    fn new(
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
        let nv = model.nv();
        let scale = match scale {
            Some(s) => {
                let s = vector(s, "scale", 2 * nv, "2 nv")?;
                if let Some(i) = s.iter().position(|x| *x <= 0.0) {
                    return Err(PyValueError::new_err(format!(
                        "scale[{i}] = {} must be positive",
                        s[i]
                    )));
                }
                s
            }
            None => default_scale(&model),
        };
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
    fn identify<'py>(
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
                q: row(0, t),
                v: row(1, t),
                tau: row(2, t),
                q_next: row(3, t),
                v_next: row(4, t),
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
    let flags: Vec<&str> = [
        (e.flags.unexcited, "unexcited"),
        (e.flags.at_bound, "at_bound"),
        (e.flags.not_converged, "not_converged"),
        (e.flags.misfit, "misfit"),
        (e.flags.changed, "changed"),
    ]
    .into_iter()
    .filter_map(|(on, name)| on.then_some(name))
    .collect();
    out.set_item("flags", PyList::new(py, flags)?)?;
    Ok(out)
}

pub(crate) fn osi_error(context: &str, e: OsiError) -> PyErr {
    PyValueError::new_err(format!("{context}: {e}"))
}

/// `numpy.asarray(obj, dtype=float64)`, with a ValueError naming `name` if
/// the object does not convert.
pub(crate) fn float_array<'py>(
    obj: &Bound<'py, PyAny>,
    name: &str,
) -> PyResult<Bound<'py, PyArrayDyn<f64>>> {
    // A float64 array passes as it is; only other inputs pay for numpy.asarray.
    if let Ok(array) = obj.cast::<PyArrayDyn<f64>>() {
        return Ok(array.clone());
    }
    let py = obj.py();
    let fail = |why: String| PyValueError::new_err(format!("{name}: {why}"));
    let kwargs = PyDict::new(py);
    kwargs.set_item("dtype", "float64")?;
    let array = py
        .import("numpy")?
        .call_method("asarray", (obj,), Some(&kwargs))
        .map_err(|e| fail(format!("cannot convert to a float64 array ({e})")))?;
    array
        .cast_into::<PyArrayDyn<f64>>()
        .map_err(|e| fail(format!("cannot convert to a float64 array ({e})")))
}

/// The entries of `array` in logical (row-major) order: copied straight
/// from a C-contiguous buffer (no borrow bookkeeping), else read through a
/// borrow of the array.
fn entries(array: &Bound<'_, PyArrayDyn<f64>>) -> Vec<f64> {
    if array.is_c_contiguous() {
        if let Ok(values) = array.to_vec() {
            return values;
        }
    }
    array.readonly().as_array().iter().copied().collect()
}

/// A numpy array of a matrix's `shape` from its column-major entries, copied
/// in one block into a Fortran-ordered array.
fn to_numpy<'py>(
    py: Python<'py>,
    shape: (usize, usize),
    entries: &[f64],
) -> Bound<'py, PyArray2<f64>> {
    let view = ArrayView2::from_shape(shape.f(), entries).expect("shape matches the entries");
    view.to_pyarray(py)
}

/// Two matrices returned together, as a tuple.
type MatrixPair<'py> = (Bound<'py, PyArray2<f64>>, Bound<'py, PyArray2<f64>>);

/// A 1-D array of length `n` with finite entries.
pub(crate) fn vector(
    obj: &Bound<'_, PyAny>,
    name: &str,
    n: usize,
    what: &str,
) -> PyResult<Vec<f64>> {
    let array = float_array(obj, name)?;
    if array.ndim() != 1 || array.len() != n {
        return Err(PyValueError::new_err(format!(
            "{name} must be 1-D of length {what} = {n}, got shape {}",
            shape(array.shape())
        )));
    }
    let values = entries(&array);
    check_finite(name, &values, |i| format!("[{i}]"))?;
    Ok(values)
}

/// A 2-D array with `n` columns and finite entries, in standard layout.
pub(crate) fn matrix(
    obj: &Bound<'_, PyAny>,
    name: &str,
    n: usize,
    what: &str,
) -> PyResult<Array2<f64>> {
    let array = float_array(obj, name)?;
    let dims = array.shape().to_vec();
    if dims.len() != 2 || dims[1] != n {
        return Err(PyValueError::new_err(format!(
            "{name} must be 2-D of shape (T, {what} = {n}), got shape {}",
            shape(&dims)
        )));
    }
    let values = entries(&array);
    check_finite(name, &values, |i| format!("[{}, {}]", i / n, i % n))?;
    Ok(Array2::from_shape_vec((dims[0], n), values).expect("shape checked above"))
}

/// A shape as Python prints it: (3,), (2, 4), ().
pub(crate) fn shape(dims: &[usize]) -> String {
    match dims {
        [n] => format!("({n},)"),
        _ => format!(
            "({})",
            dims.iter()
                .map(|d| d.to_string())
                .collect::<Vec<_>>()
                .join(", ")
        ),
    }
}

pub(crate) fn check_finite(
    name: &str,
    values: &[f64],
    index: impl Fn(usize) -> String,
) -> PyResult<()> {
    match values.iter().position(|x| !x.is_finite()) {
        Some(i) => Err(PyValueError::new_err(format!(
            "{name}{} is not finite ({})",
            index(i),
            values[i]
        ))),
        None => Ok(()),
    }
}

/// The spelling of an option value.
fn name_of<T: PartialEq>(names: &[(&'static str, T)], value: T) -> &'static str {
    names
        .iter()
        .find(|(_, v)| *v == value)
        .map(|(n, _)| *n)
        .expect("every option value has a name")
}

/// An option value from its spelling; ValueError lists the choices.
pub(crate) fn keyword<T: Copy>(what: &str, text: &str, names: &[(&str, T)]) -> PyResult<T> {
    names
        .iter()
        .find(|(n, _)| *n == text)
        .map(|(_, v)| *v)
        .ok_or_else(|| {
            let choices: Vec<&str> = names.iter().map(|(n, _)| *n).collect();
            PyValueError::new_err(format!(
                "{what} must be one of {}, got '{text}'",
                choices.join(", ")
            ))
        })
}

fn model_error(e: ModelError) -> PyErr {
    match &e {
        ModelError::Io { source, .. } if source.kind() == std::io::ErrorKind::NotFound => {
            PyFileNotFoundError::new_err(e.to_string())
        }
        ModelError::Io { .. } => PyOSError::new_err(e.to_string()),
        _ => PyValueError::new_err(e.to_string()),
    }
}

pub(crate) fn param_error(e: ParamError) -> PyErr {
    PyValueError::new_err(e.to_string())
}

/// Differentiable rigid-body dynamics with online system identification.
#[pymodule]
fn diffosi(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<PyModel>()?;
    m.add_class::<PyDiffOsi>()?;
    m.add_class::<PyCmaEs>()?;
    m.add_class::<task::PyTask>()?;
    m.add_class::<task::PyPolicy>()?;
    m.add_class::<wiping::PyWiping>()?;
    m.add_class::<wiping::PyWipingRun>()?;
    m.add_class::<task::PyOnlineOsi>()?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
