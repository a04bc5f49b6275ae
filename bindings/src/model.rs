//! `Model`: a loaded model, its options and parameters, and its step,
//! rollouts, step Jacobians and contacts, for Python.

use engine::derivatives::{
    input_jacobians, step_jacobians, transition_jacobians, TransitionJacobians, Workspace, Wrt,
};
use engine::dynamics::{body_contact_forces, Contact, Data};
use engine::model::urdf::LoadOptions;
use engine::model::{ContactModel, Inputs, Integrator, JointKind, Param, PassiveMode, State};
use engine::Model;
use nalgebra::DMatrix;
use numpy::ndarray::Array2;
use numpy::{PyArray1, PyArray2, PyUntypedArrayMethods};
use pyo3::exceptions::{PyKeyError, PyUserWarning, PyValueError};
use pyo3::intern;
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList, PyTuple};

use crate::convert::{
    check_finite, entries, float_array, keyword, matrix, name_of, shape, to_numpy, vector,
    MatrixPair,
};
use crate::errors::{model_error, param_error};

/// The optional mocap_pos and mocap_quat arguments of a Python call.
type MocapArgs<'a, 'py> = (Option<&'a Bound<'py, PyAny>>, Option<&'a Bound<'py, PyAny>>);

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
    /// the element and line. URDF only: `floating_base=True` gives the root
    /// link a free joint `root_joint` (PyBullet's loadURDF default; by
    /// default it is welded to the world, as MuJoCo's importer and Pinocchio
    /// read it); `package_dirs` are searched first for `package://` paths;
    /// `inertial` is whose reading of `<inertial>`: "pinocchio" (as written,
    /// a link without one massless; the default) or "pybullet" (PyBullet's
    /// importer with URDF_USE_INERTIA_FROM_FILE: 1 kg and unit inertia where
    /// there is none, principal axes by Bullet's iteration, unphysical
    /// moments zeroed). What the loader took as written or ignored comes as
    /// UserWarnings.
    #[staticmethod]
    #[pyo3(signature = (path, floating_base=false, package_dirs=None, inertial="pinocchio"))]
    fn load(
        py: Python<'_>,
        path: std::path::PathBuf,
        floating_base: bool,
        package_dirs: Option<Vec<std::path::PathBuf>>,
        inertial: &str,
    ) -> PyResult<Self> {
        let options = LoadOptions {
            floating_base,
            package_dirs: package_dirs.unwrap_or_default(),
            inertials: inertial.parse().map_err(PyValueError::new_err)?,
        };
        let model = Model::load_with(&path, &options).map_err(model_error)?;
        let category = py.get_type::<PyUserWarning>();
        for warning in model.warnings() {
            let text = std::ffi::CString::new(warning.replace('\0', " ")).expect("no NUL left");
            PyErr::warn(py, &category, &text, 1)?;
        }
        Ok(PyModel::new(model))
    }

    /// (index of the joint's first coordinate in q, of its first dof in v)
    /// for the joint named `name` (MuJoCo's jnt_qposadr, jnt_dofadr).
    fn joint_address(&self, name: &str) -> PyResult<(usize, usize)> {
        self.model.joint_address_of(name).ok_or_else(|| {
            PyValueError::new_err(format!("no joint named '{name}' (see joint_names)"))
        })
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

    /// Number of mocap bodies (MJCF `mocap="true"`), whose poses are
    /// inputs of `step` (mocap_pos, mocap_quat).
    #[getter]
    fn nmocap(&self) -> usize {
        self.model.tree().nmocap()
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
    /// soft constraints, the default for MJCF and URDF files) or "smooth" (the
    /// penalty model).
    #[getter]
    fn contact_model(&self) -> &'static str {
        name_of(&ContactModel::NAMES, self.model.opt.contact_model)
    }

    /// A copy run with other options, e.g. the conventions of the engine it is
    /// compared with: `m.with_options(passive="implicit_damping_stiffness",
    /// timestep=0.005)`; `contact=False` / `limits=False` switch off the
    /// contacts and joint limits; `contact_model` is "constraint" (MuJoCo's
    /// soft constraints, the default for MJCF and URDF files) or "smooth" (the
    /// penalty model); `density` (kg/m^3), `viscosity`
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

    /// Names of the file's keyframes (MJCF `<key>`), in file order; an
    /// unnamed key is `key<i>` after its index.
    #[getter]
    fn keyframe_names(&self) -> Vec<String> {
        self.model
            .keyframes
            .iter()
            .map(|k| k.name.clone())
            .collect()
    }

    /// The keyframe `name` as a dict: "q" (nq), "v" (nv), "ctrl" (nu) and
    /// "act" (na) float64 arrays, "mocap_pos" (nmocap, 3) and "mocap_quat"
    /// (nmocap, 4; MuJoCo's key_mpos, key_mquat), and "time" (s), MuJoCo's
    /// defaults where the file leaves them out (q: `reference_q()`, the
    /// mocap bodies' compiled poses, the rest zeros). KeyError for an
    /// unknown name.
    fn keyframe<'py>(&self, py: Python<'py>, name: &str) -> PyResult<Bound<'py, PyDict>> {
        let key = self.model.keyframe(name).ok_or_else(|| {
            let names = self.keyframe_names().join(", ");
            PyKeyError::new_err(format!("no keyframe '{name}' (the model has: {names})"))
        })?;
        let dict = PyDict::new(py);
        dict.set_item("q", PyArray1::from_slice(py, &key.q))?;
        dict.set_item("v", PyArray1::from_slice(py, &key.v))?;
        dict.set_item("ctrl", PyArray1::from_slice(py, &key.ctrl))?;
        dict.set_item("act", PyArray1::from_slice(py, &key.act))?;
        for (name, x, width) in [("mocap_pos", &key.mpos, 3), ("mocap_quat", &key.mquat, 4)] {
            let rows = Array2::from_shape_vec((x.len() / width, width), x.clone())
                .expect("a keyframe holds whole poses");
            dict.set_item(name, PyArray2::from_owned_array(py, rows))?;
        }
        dict.set_item("time", key.time)?;
        Ok(dict)
    }

    /// The compiled model, for comparing it with another engine's: a dict
    /// with "bodies" (one dict per body, the world first: "name", "parent"
    /// (the parent's name; the world's is None), "mass" (kg), "com" (m, body
    /// frame), "inertia" (3x3 about the COM, body axes, kg m^2)) and "joints"
    /// (one per joint: "name", "type" (hinge, slide, ball, free), "body",
    /// "axis" (unit, body frame), "range" ((lo, hi) or None), "damping",
    /// "armature", "stiffness", "frictionloss").
    fn compiled<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let m = &self.model;
        let bodies = PyList::empty(py);
        for (i, b) in m.bodies.iter().enumerate() {
            let body = PyDict::new(py);
            body.set_item("name", &b.name)?;
            body.set_item("parent", (i > 0).then(|| m.bodies[b.parent].name.clone()))?;
            body.set_item("mass", b.mass)?;
            body.set_item("com", PyArray1::from_slice(py, b.com.as_slice()))?;
            let inertia = DMatrix::from_column_slice(3, 3, b.inertia.as_slice());
            body.set_item("inertia", to_numpy(py, inertia.as_view()))?;
            bodies.append(body)?;
        }
        let joints = PyList::empty(py);
        for j in &m.joints {
            let joint = PyDict::new(py);
            let kind = match j.kind {
                JointKind::Hinge => "hinge",
                JointKind::Slide => "slide",
                JointKind::Ball => "ball",
                JointKind::Free => "free",
            };
            joint.set_item("name", &j.name)?;
            joint.set_item("type", kind)?;
            joint.set_item("body", &m.bodies[j.body].name)?;
            joint.set_item("axis", PyArray1::from_slice(py, j.axis.as_slice()))?;
            joint.set_item("range", j.range)?;
            joint.set_item("damping", j.damping)?;
            joint.set_item("armature", j.armature)?;
            joint.set_item("stiffness", j.stiffness)?;
            joint.set_item("frictionloss", j.frictionloss)?;
            joints.append(joint)?;
        }
        let dict = PyDict::new(py);
        dict.set_item("bodies", bodies)?;
        dict.set_item("joints", joints)?;
        Ok(dict)
    }

    /// Site names (MJCF `<site>`), in MuJoCo's order.
    #[getter]
    fn site_names(&self) -> Vec<String> {
        self.model.sites.iter().map(|s| s.name.clone()).collect()
    }

    /// Sensor names, in the order of their readings (see `sensors`).
    #[getter]
    fn sensor_names(&self) -> Vec<String> {
        self.model.sensors.iter().map(|s| s.name.clone()).collect()
    }

    /// Each sensor's first index in the readings (MuJoCo's sensor_adr).
    #[getter]
    fn sensor_adr(&self) -> Vec<usize> {
        self.model.sensor_layout().iter().map(|l| l.0).collect()
    }

    /// Each sensor's number of readings (MuJoCo's sensor_dim).
    #[getter]
    fn sensor_dim(&self) -> Vec<usize> {
        self.model.sensor_layout().iter().map(|l| l.1).collect()
    }

    /// Every sensor's readings at (q, v) under generalized forces tau, as
    /// MuJoCo's sensordata after mj_forward: a 1-D array laid out by
    /// `sensor_adr` and `sensor_dim`. ctrl (nu) and act (na) set the
    /// actuators (None: zero), mocap_pos and mocap_quat the mocap bodies as
    /// `step` places them. A sensor type that is read but not computed
    /// raises ValueError naming it.
    #[pyo3(signature = (q, v, tau, ctrl = None, act = None, mocap_pos = None, mocap_quat = None))]
    #[allow(clippy::too_many_arguments)]
    fn sensors<'py>(
        &mut self,
        py: Python<'py>,
        q: &Bound<'py, PyAny>,
        v: &Bound<'py, PyAny>,
        tau: &Bound<'py, PyAny>,
        ctrl: Option<&Bound<'py, PyAny>>,
        act: Option<&Bound<'py, PyAny>>,
        mocap_pos: Option<&Bound<'py, PyAny>>,
        mocap_quat: Option<&Bound<'py, PyAny>>,
    ) -> PyResult<Bound<'py, PyArray1<f64>>> {
        let (x, u) = self.actuated((q, v, tau), (ctrl, act), (mocap_pos, mocap_quat))?;
        let readings = self
            .model
            .sensor_readings(&mut self.data, &x, &u)
            .map_err(|e| PyValueError::new_err(format!("sensors: {e}")))?;
        Ok(PyArray1::from_vec(py, readings))
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

    /// One step as MuJoCo's mj_step: from (q, v) and activations act
    /// (length na; zeros if None) under generalized forces tau, actuator
    /// controls ctrl (length nu; zeros if None) and the mocap bodies' poses
    /// mocap_pos (nmocap, 3) and mocap_quat (nmocap, 4, w x y z; MuJoCo's
    /// d.mocap_pos, d.mocap_quat; the compiled poses if None). Returns
    /// (q1, v1), and (q1, v1, act1) for a model with activations (na > 0).
    #[pyo3(signature = (q, v, tau, ctrl = None, act = None, mocap_pos = None, mocap_quat = None))]
    #[allow(clippy::too_many_arguments)]
    fn step<'py>(
        &mut self,
        py: Python<'py>,
        q: &Bound<'py, PyAny>,
        v: &Bound<'py, PyAny>,
        tau: &Bound<'py, PyAny>,
        ctrl: Option<&Bound<'py, PyAny>>,
        act: Option<&Bound<'py, PyAny>>,
        mocap_pos: Option<&Bound<'py, PyAny>>,
        mocap_quat: Option<&Bound<'py, PyAny>>,
    ) -> PyResult<Bound<'py, PyTuple>> {
        let (x, u) = self.actuated((q, v, tau), (ctrl, act), (mocap_pos, mocap_quat))?;
        let next = self
            .model
            .step(&mut self.data, &x, &u)
            .map_err(|e| PyValueError::new_err(format!("step: {e}")))?;
        let mut out = vec![
            PyArray1::from_vec(py, next.q),
            PyArray1::from_vec(py, next.v),
        ];
        if self.model.na() > 0 {
            out.push(PyArray1::from_vec(py, next.act));
        }
        PyTuple::new(py, out)
    }

    /// Number of activation states (actuators with dynamics).
    #[getter]
    fn na(&self) -> usize {
        self.model.na()
    }

    /// Actuator names, in the order of ctrl.
    #[getter]
    fn actuator_names(&self) -> Vec<String> {
        self.model
            .actuators
            .iter()
            .map(|a| a.name.clone())
            .collect()
    }

    /// Steps from (q0, v0) under each row of taus (shape (T, nv)) and of
    /// ctrls (shape (T, nu); zeros if None), from activations act0 (na;
    /// zeros if None), the mocap bodies at mocap_pos and mocap_quat (per
    /// step, shapes (T, nmocap, 3) and (T, nmocap, 4), or one pose for every
    /// step, (nmocap, 3) and (nmocap, 4); the compiled poses if None);
    /// returns the visited states as arrays of shapes (T+1, nq) and
    /// (T+1, nv), and (T+1, na) for a model with activations.
    #[pyo3(signature = (q0, v0, taus, ctrls = None, act0 = None, mocap_pos = None, mocap_quat = None))]
    #[allow(clippy::too_many_arguments)]
    fn rollout<'py>(
        &mut self,
        py: Python<'py>,
        q0: &Bound<'py, PyAny>,
        v0: &Bound<'py, PyAny>,
        taus: &Bound<'py, PyAny>,
        ctrls: Option<&Bound<'py, PyAny>>,
        act0: Option<&Bound<'py, PyAny>>,
        mocap_pos: Option<&Bound<'py, PyAny>>,
        mocap_quat: Option<&Bound<'py, PyAny>>,
    ) -> PyResult<Bound<'py, PyTuple>> {
        let q0 = vector(q0, "q0", self.model.nq(), "nq")?;
        let v0 = vector(v0, "v0", self.model.nv(), "nv")?;
        let taus = matrix(taus, "taus", self.model.nv(), "nv")?;
        let (nq, nv, nu, na) = (
            self.model.nq(),
            self.model.nv(),
            self.model.nu(),
            self.model.na(),
        );
        let steps = taus.nrows();
        // No ctrls: empty rows, zero controls.
        let ctrls = match ctrls {
            Some(c) => matrix(c, "ctrls", nu, "nu")?,
            None => Array2::zeros((steps, 0)),
        };
        if ctrls.nrows() != steps {
            return Err(PyValueError::new_err(format!(
                "ctrls has {} rows and taus {steps}: one each per step",
                ctrls.nrows()
            )));
        }
        let act0 = match act0 {
            Some(a) => vector(a, "act0", na, "na")?,
            None => vec![0.0; na],
        };
        let poses = self.mocap_steps(mocap_pos, "mocap_pos", 3, steps)?;
        let turns = self.mocap_steps(mocap_quat, "mocap_quat", 4, steps)?;
        let (mut qs, mut vs, mut acts) = (
            Array2::zeros((steps + 1, nq)),
            Array2::zeros((steps + 1, nv)),
            Array2::zeros((steps + 1, na)),
        );
        let (model, data) = (&self.model, &mut self.data);
        // Other Python threads run while this one steps.
        py.detach(|| {
            let mut x = State {
                q: q0,
                v: v0,
                act: act0,
            };
            for t in 0..=steps {
                qs.row_mut(t)
                    .assign(&numpy::ndarray::ArrayView1::from(&x.q));
                vs.row_mut(t)
                    .assign(&numpy::ndarray::ArrayView1::from(&x.v));
                acts.row_mut(t)
                    .assign(&numpy::ndarray::ArrayView1::from(&x.act));
                if t == steps {
                    break;
                }
                let row = |m: &Array2<f64>| m.row(t).to_vec();
                let u = Inputs {
                    ctrl: row(&ctrls),
                    tau: row(&taus),
                    mocap_pos: poses[t].clone(),
                    mocap_quat: turns[t].clone(),
                };
                x = model
                    .step(data, &x, &u)
                    .map_err(|e| format!("rollout step {t}: {e}"))?;
            }
            Ok::<(), String>(())
        })
        .map_err(PyValueError::new_err)?;
        let mut out = vec![
            PyArray2::from_owned_array(py, qs),
            PyArray2::from_owned_array(py, vs),
        ];
        if na > 0 {
            out.push(PyArray2::from_owned_array(py, acts));
        }
        PyTuple::new(py, out)
    }

    /// One step with its exact Jacobians: a dict of 2-D float64 arrays
    /// dq_dq, dq_dv, dv_dq, dv_dv (n x n), dq_dtau, dv_dtau (n x n) and
    /// dq_dp, dv_dp (n x total length of `params`, columns in the order of
    /// the flattened parameters); n = nv, positions in the tangent space
    /// (see `transition_jacobians`), at ctrl = 0 and act = 0 as `step`. Given
    /// controls ctrl (nu) or activations act (na; the other zeros), at those,
    /// and also dq_dctrl, dv_dctrl (n x nu), dq_dact, dv_dact (n x na),
    /// dact_dq, dact_dv (na x n, zero), dact_dact (na x na) and dact_dctrl
    /// (na x nu): mjd_transitionFD's A and B in blocks. The mocap bodies at
    /// mocap_pos, mocap_quat as `step` places them (no columns in them).
    #[pyo3(signature = (q, v, tau, params = None, ctrl = None, act = None, mocap_pos = None, mocap_quat = None))]
    #[allow(clippy::too_many_arguments)]
    fn step_jacobians<'py>(
        &mut self,
        py: Python<'py>,
        q: &Bound<'py, PyAny>,
        v: &Bound<'py, PyAny>,
        tau: &Bound<'py, PyAny>,
        params: Option<Vec<String>>,
        ctrl: Option<&Bound<'py, PyAny>>,
        act: Option<&Bound<'py, PyAny>>,
        mocap_pos: Option<&Bound<'py, PyAny>>,
        mocap_quat: Option<&Bound<'py, PyAny>>,
    ) -> PyResult<Bound<'py, PyDict>> {
        let params = self.params(params.as_deref().unwrap_or_default())?;
        let (q, v, tau) = self.state(q, v, tau)?;
        let with_inputs = ctrl.is_some() || act.is_some();
        let (ctrl, act) = self.actuation(ctrl, act)?;
        let (pos, quat) = self.mocap(mocap_pos, mocap_quat)?;
        self.ws
            .set_mocap(&self.model, (&pos, &quat))
            .map_err(|e| PyValueError::new_err(format!("step_jacobians: {e}")))?;
        let wrt = Wrt {
            state: true,
            control: true,
            params: &params,
        };
        let (model, ws) = (&self.model, &mut self.ws);
        let error = |e| PyValueError::new_err(format!("step_jacobians: {e}"));
        let (j, actuated) = if !with_inputs {
            let j = py.detach(|| step_jacobians(model, ws, (&q, &v, &tau), &wrt));
            (j.map_err(error)?, None)
        } else {
            let state = (&q[..], &v[..], &act[..]);
            let j = py.detach(|| input_jacobians(model, ws, state, (&ctrl, &tau), &wrt));
            let j = j.map_err(error)?;
            (j.step.clone(), Some(j))
        };
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
            out.set_item(key, to_numpy(py, m))?;
        }
        if let Some(a) = actuated {
            let n = model.nv();
            let zero = DMatrix::<f64>::zeros(model.na(), n);
            for (key, m) in [
                ("dq_dctrl", a.dx_dctrl.rows(0, n)),
                ("dv_dctrl", a.dx_dctrl.rows(n, n)),
                ("dq_dact", a.dx_dact.rows(0, n)),
                ("dv_dact", a.dx_dact.rows(n, n)),
                ("dact_dq", zero.rows(0, zero.nrows())),
                ("dact_dv", zero.rows(0, zero.nrows())),
                ("dact_dact", a.dact_dact.rows(0, a.dact_dact.nrows())),
                ("dact_dctrl", a.dact_dctrl.rows(0, a.dact_dctrl.nrows())),
            ] {
                out.set_item(key, to_numpy(py, m))?;
            }
        }
        Ok(out)
    }

    /// One step's Jacobians in MuJoCo's layout (mjd_transitionFD's A and B,
    /// here exact): A = d(q', v')/d(q, v), 2 nv x 2 nv, rows q' then v',
    /// columns q then v; B = d(q', v')/d tau, 2 nv x nv. Two float64 arrays.
    /// Positions in the tangent space, as mjd_transitionFD has them: a ball's
    /// or free joint's rotation as its body-frame rotation vector. The mocap
    /// bodies at their compiled poses.
    fn transition_jacobians<'py>(
        &mut self,
        py: Python<'py>,
        q: &Bound<'py, PyAny>,
        v: &Bound<'py, PyAny>,
        tau: &Bound<'py, PyAny>,
    ) -> PyResult<MatrixPair<'py>> {
        let (q, v, tau) = self.state(q, v, tau)?;
        let x = (&q[..], &v[..], &tau[..]);
        let error = |e| PyValueError::new_err(format!("transition_jacobians: {e}"));
        // The mocap bodies at their compiled poses.
        self.ws.set_mocap(&self.model, (&[], &[])).map_err(error)?;
        let (model, ws, out) = (&self.model, &mut self.ws, &mut self.transition);
        py.detach(|| transition_jacobians(model, ws, x, out))
            .map_err(error)?;
        let (a, b) = (&self.transition.a, &self.transition.b);
        Ok((to_numpy(py, a.as_view()), to_numpy(py, b.as_view())))
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
    /// opposite. Empty when contacts are off. The mocap bodies at mocap_pos,
    /// mocap_quat as `step` places them (the compiled poses if None). NaN or
    /// infinite input raises ValueError.
    #[pyo3(signature = (q, v, tau = None, mocap_pos = None, mocap_quat = None))]
    fn contacts<'py>(
        &mut self,
        py: Python<'py>,
        q: &Bound<'py, PyAny>,
        v: &Bound<'py, PyAny>,
        tau: Option<&Bound<'py, PyAny>>,
        mocap_pos: Option<&Bound<'py, PyAny>>,
        mocap_quat: Option<&Bound<'py, PyAny>>,
    ) -> PyResult<Bound<'py, PyList>> {
        let contacts = self.contact_list(q, v, tau, (mocap_pos, mocap_quat))?;
        let out = PyList::empty(py);
        for c in contacts {
            let d = PyDict::new(py);
            // Python's a and b are geoms 2 and 1, its depth -dist.
            let [g1, g2] = c.geoms.map(|g| self.model.geoms[g].name.clone());
            let [b1, b2] = c.bodies.map(|b| self.model.bodies[b].name.clone());
            let (geoms, bodies) = ([g2, g1], [b2, b1]);
            d.set_item("geoms", PyTuple::new(py, geoms)?)?;
            d.set_item("bodies", PyTuple::new(py, bodies)?)?;
            d.set_item("point", PyArray1::from_slice(py, c.pos.as_slice()))?;
            d.set_item("normal", PyArray1::from_slice(py, c.normal.as_slice()))?;
            d.set_item("depth", -c.dist)?;
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
    /// `contacts(q, v, tau, mocap_pos, mocap_quat)` on the body (no
    /// moments). The rows sum to zero.
    #[pyo3(signature = (q, v, tau = None, mocap_pos = None, mocap_quat = None))]
    fn body_contact_forces<'py>(
        &mut self,
        py: Python<'py>,
        q: &Bound<'py, PyAny>,
        v: &Bound<'py, PyAny>,
        tau: Option<&Bound<'py, PyAny>>,
        mocap_pos: Option<&Bound<'py, PyAny>>,
        mocap_quat: Option<&Bound<'py, PyAny>>,
    ) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let contacts = self.contact_list(q, v, tau, (mocap_pos, mocap_quat))?;
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
        mocap: MocapArgs<'_, '_>,
    ) -> PyResult<Vec<Contact<f64>>> {
        let (x, u) = self.unactuated(q, v, tau, mocap)?;
        let contacts = self
            .model
            .contacts(&mut self.data, &x, &u)
            .map_err(|e| PyValueError::new_err(format!("contacts: {e}")))?;
        let finite = |c: &Contact<f64>| {
            c.pos.iter().chain(&c.force()).all(|x| x.is_finite()) && c.dist.is_finite()
        };
        if !contacts.iter().all(finite) {
            return Err(PyValueError::new_err(
                "contacts: a contact force is not finite (state too large)",
            ));
        }
        Ok(contacts)
    }

    /// Converts and checks (q, v, tau).
    /// ctrl (nu) and act (na); empty where None, which the engine reads as
    /// zeros (a step without them is the plain step, bit for bit).
    fn actuation(
        &self,
        ctrl: Option<&Bound<'_, PyAny>>,
        act: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<(Vec<f64>, Vec<f64>)> {
        let (nu, na) = (self.model.nu(), self.model.na());
        let read = |x: Option<&Bound<'_, PyAny>>, name, n, what| match x {
            Some(x) => vector(x, name, n, what),
            None => Ok(vec![]),
        };
        Ok((read(ctrl, "ctrl", nu, "nu")?, read(act, "act", na, "na")?))
    }

    /// The mocap poses, (nmocap, 3) and (nmocap, 4) arrays flattened (empty
    /// if None: the compiled poses).
    fn mocap(
        &self,
        pos: Option<&Bound<'_, PyAny>>,
        quat: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<(Vec<f64>, Vec<f64>)> {
        let n = self.model.tree().nmocap();
        let read = |x: Option<&Bound<'_, PyAny>>, name: &str, width: usize| match x {
            Some(x) => {
                let rows = matrix(x, name, width, &width.to_string())?;
                if rows.nrows() != n {
                    let msg = format!(
                        "{name} has {} rows, the model has nmocap = {n}",
                        rows.nrows()
                    );
                    return Err(PyValueError::new_err(msg));
                }
                Ok(rows.into_iter().collect())
            }
            None => Ok(vec![]),
        };
        Ok((read(pos, "mocap_pos", 3)?, read(quat, "mocap_quat", 4)?))
    }

    /// A rollout's mocap poses (`width` 3: positions, 4: quaternions), one
    /// list per step: None gives empty lists (the compiled poses), a 2-D
    /// (nmocap, width) array the same pose for every step, a 3-D (T, nmocap,
    /// width) array one per step.
    fn mocap_steps(
        &self,
        given: Option<&Bound<'_, PyAny>>,
        name: &str,
        width: usize,
        steps: usize,
    ) -> PyResult<Vec<Vec<f64>>> {
        let Some(given) = given else {
            return Ok(vec![vec![]; steps]);
        };
        let n = self.model.tree().nmocap();
        let array = float_array(given, name)?;
        let dims = array.shape().to_vec();
        let per_step = match dims[..] {
            [rows, w] if (rows, w) == (n, width) => false,
            [t, rows, w] if (t, rows, w) == (steps, n, width) => true,
            _ => {
                return Err(PyValueError::new_err(format!(
                    "{name} must be ({n}, {width}) (nmocap = {n}, one pose for every step) or \
                     ({steps}, {n}, {width}) (T = {steps} steps), got shape {}",
                    shape(&dims)
                )))
            }
        };
        let values = entries(&array);
        check_finite(name, &values, |i| format!("[{i}] (flattened)"))?;
        let pose = n * width;
        Ok(if per_step {
            (0..steps)
                .map(|t| values[t * pose..(t + 1) * pose].to_vec())
                .collect()
        } else {
            vec![values; steps]
        })
    }

    /// The state (q, v) and inputs (tau, zero if None; the mocap poses, the
    /// compiled ones if None) of an evaluation without actuators (contacts,
    /// sensors), converted and checked.
    /// The state (q, v, act) and inputs (ctrl, tau, mocap poses) of a step
    /// or an evaluation that reads the actuators, each checked and named.
    fn actuated(
        &self,
        (q, v, tau): (&Bound<'_, PyAny>, &Bound<'_, PyAny>, &Bound<'_, PyAny>),
        (ctrl, act): (Option<&Bound<'_, PyAny>>, Option<&Bound<'_, PyAny>>),
        mocap: MocapArgs<'_, '_>,
    ) -> PyResult<(State, Inputs)> {
        let (q, v, tau) = self.state(q, v, tau)?;
        let (ctrl, act) = self.actuation(ctrl, act)?;
        let (mocap_pos, mocap_quat) = self.mocap(mocap.0, mocap.1)?;
        let u = Inputs {
            ctrl,
            tau,
            mocap_pos,
            mocap_quat,
        };
        Ok((State { q, v, act }, u))
    }

    fn unactuated(
        &self,
        q: &Bound<'_, PyAny>,
        v: &Bound<'_, PyAny>,
        tau: Option<&Bound<'_, PyAny>>,
        (pos, quat): MocapArgs<'_, '_>,
    ) -> PyResult<(State, Inputs)> {
        let nv = self.model.nv();
        let q = vector(q, "q", self.model.nq(), "nq")?;
        let v = vector(v, "v", nv, "nv")?;
        let tau = match tau {
            Some(t) => vector(t, "tau", nv, "nv")?,
            None => vec![0.0; nv],
        };
        let (mocap_pos, mocap_quat) = self.mocap(pos, quat)?;
        let u = Inputs {
            tau,
            mocap_pos,
            mocap_quat,
            ..Inputs::default()
        };
        Ok((State::new(q, v), u))
    }

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
