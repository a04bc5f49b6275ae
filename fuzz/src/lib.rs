//! Fuzz checks of diffosi's model loaders and step, shared by the cargo-fuzz
//! targets (`fuzz/fuzz_targets/`) and the stable smoke test
//! (`tests/fuzz_smoke.rs`, which includes this file as a module).
//!
//! Each `check_*` takes arbitrary bytes and panics only when diffosi breaks a
//! promise of issue 10: a loader or the step panics, a success carries a
//! non-finite number or a model that does not load again, or bad input is
//! accepted, or refused with an error that does not name it. An `Err` with a
//! message is the right answer to bad input.
//!
//! The step input is decoded by [`Bytes`]: one byte picks a reference model
//! (MJCF or URDF twin), one its integrator and passive mode, then up to three
//! parameter edits, then q, v and tau; each number is a small, large, tiny,
//! special (NaN, infinities, extremes) or raw 64-bit float, so finite and
//! non-finite inputs both reach every boundary.

use diffosi::derivatives::{step_jacobians, StepJacobians, Workspace, Wrt};
use diffosi::dynamics::StepError;
use diffosi::model::mesh::{self, MeshSettings};
use diffosi::model::{mjcf, Inputs, Integrator, Param, PassiveMode, State};
use diffosi::Model;

/// The reference models, MJCF and URDF twins, as the step check loads them.
pub const REFERENCE_MODELS: [(&str, &str); 8] = [
    (
        "cartpole.xml",
        include_str!("../../reference_models/cartpole.xml"),
    ),
    (
        "cartpole.urdf",
        include_str!("../../reference_models/cartpole.urdf"),
    ),
    (
        "pendulum.xml",
        include_str!("../../reference_models/pendulum.xml"),
    ),
    (
        "pendulum.urdf",
        include_str!("../../reference_models/pendulum.urdf"),
    ),
    (
        "double_pendulum.xml",
        include_str!("../../reference_models/double_pendulum.xml"),
    ),
    (
        "double_pendulum.urdf",
        include_str!("../../reference_models/double_pendulum.urdf"),
    ),
    (
        "half_cheetah.xml",
        include_str!("../../reference_models/half_cheetah.xml"),
    ),
    (
        "half_cheetah.urdf",
        include_str!("../../reference_models/half_cheetah.urdf"),
    ),
];

/// Loads MJCF (`.xml`) or URDF text by the file name's extension.
pub fn parse(name: &str, text: &str) -> Result<Model, diffosi::ModelError> {
    if name.ends_with(".urdf") {
        Model::from_urdf(text, name)
    } else {
        Model::from_mjcf(text, name)
    }
}

/// MJCF loader: any text loads or is refused with a message; a loaded model
/// passes [`check_loaded`].
pub fn check_mjcf(data: &[u8]) {
    check_loader("fuzz.xml", data);
}

/// URDF loader: as [`check_mjcf`].
pub fn check_urdf(data: &[u8]) {
    check_loader("fuzz.urdf", data);
}

/// Mesh readers: the bytes read as STL, OBJ, MSH and COLLADA each either give a
/// mesh or a message; a mesh read compiles (with its hull) or is refused
/// with a message, and a compiled mesh has finite numbers and a hull whose
/// faces index its vertices.
pub fn check_mesh(data: &[u8]) {
    for ext in ["stl", "obj", "msh", "dae"] {
        let raw = match mesh::read_bytes(ext, data) {
            Ok(raw) => raw,
            Err(e) => {
                assert!(!e.is_empty(), "an empty {ext} error message");
                continue;
            }
        };
        let settings = MeshSettings {
            needs_hull: true,
            max_hull_vertices: data.len().is_multiple_of(3).then_some(8),
            ..Default::default()
        };
        match mesh::compile("fuzz", &raw, &settings) {
            Ok(m) => {
                let numbers = m.vertices.iter().flat_map(|v| v.iter()).chain(m.pos.iter());
                assert!(numbers.chain(m.inertia_box.iter()).all(|x| x.is_finite()));
                assert!(m.volume.is_finite() && m.volume > 0.0);
                let hull = m.hull.expect("a hull was asked for");
                assert!(hull.faces.iter().flatten().all(|&i| i < m.vertices.len()));
                assert!(settings
                    .max_hull_vertices
                    .is_none_or(|k| hull.vertices.len() <= k));
            }
            Err(e) => assert!(!e.is_empty(), "an empty compile error message"),
        }
    }
}

fn check_loader(name: &str, data: &[u8]) {
    let text = String::from_utf8_lossy(data);
    match parse(name, &text) {
        Ok(model) => check_loaded(&model),
        Err(e) => assert!(!e.to_string().is_empty(), "an empty error message"),
    }
}

/// What every loaded model satisfies: all its numbers are finite, it steps
/// (or reports divergence) from its reference state, its step Jacobians exist
/// wherever its step does, and if MJCF can express it, the written MJCF loads
/// again with the same tree.
pub fn check_loaded(model: &Model) {
    assert_finite_model(model);
    let n = model.nv();
    let (q, zero) = (model.reference_q(), vec![0.0; n]);
    let params: Vec<Param> = model
        .param_names()
        .iter()
        .map(|name| model.param(name).expect("listed names resolve"))
        .collect();
    check_step_and_jacobians(model, (&q, &zero, &zero), &params);
    if let Ok(text) = mjcf::write(model) {
        let again = Model::from_mjcf(&text, "written.xml")
            .unwrap_or_else(|e| panic!("written MJCF does not load: {e}\n{text}"));
        assert_eq!(again.nv(), n, "written MJCF changed nv\n{text}");
        assert_eq!(again.bodies.len(), model.bodies.len(), "{text}");
    }
}

/// Every number of a loaded model is finite: a file never smuggles an
/// overflowed `1e999` into the dynamics.
fn assert_finite_model(model: &Model) {
    let finite = |what: &str, xs: &mut dyn Iterator<Item = f64>| {
        let xs: Vec<f64> = xs.collect();
        assert!(
            xs.iter().all(|x| x.is_finite()),
            "{what} not finite: {xs:?}"
        );
    };
    let o = &model.opt;
    finite(
        "options",
        &mut [o.timestep].into_iter().chain(o.gravity.iter().copied()),
    );
    for b in &model.bodies {
        let mut numbers = b
            .pos
            .iter()
            .chain(b.rot.matrix().iter())
            .chain(b.com.iter())
            .chain(b.inertia.iter())
            .copied()
            .chain([b.mass]);
        finite(&format!("body '{}'", b.name), &mut numbers);
    }
    for j in &model.joints {
        let range = j.range.map_or([0.0, 0.0], |(lo, hi)| [lo, hi]);
        let mut numbers = j.axis.iter().chain(j.anchor.iter()).copied().chain(
            [
                j.reference,
                j.damping,
                j.stiffness,
                j.springref,
                j.armature,
                j.frictionloss,
            ]
            .into_iter()
            .chain(range),
        );
        finite(&format!("joint '{}'", j.name), &mut numbers);
    }
    for a in &model.actuators {
        let range = a.ctrl_range.map_or([0.0, 0.0], |(lo, hi)| [lo, hi]);
        finite(
            &format!("actuator '{}'", a.name),
            &mut a.gear.into_iter().chain(range),
        );
    }
    for g in &model.geoms {
        let mut numbers = g
            .pos
            .iter()
            .chain(g.rot.matrix().iter())
            .chain(g.friction.iter())
            .copied();
        finite(&format!("geom '{}'", g.name), &mut numbers);
    }
}

/// Reads fuzz bytes as choices and numbers; past the end every read is 0.
pub struct Bytes<'a>(&'a [u8]);

impl<'a> Bytes<'a> {
    pub fn new(data: &'a [u8]) -> Self {
        Bytes(data)
    }

    pub fn byte(&mut self) -> u8 {
        match self.0.split_first() {
            Some((b, rest)) => {
                self.0 = rest;
                *b
            }
            None => 0,
        }
    }

    fn array<const N: usize>(&mut self) -> [u8; N] {
        std::array::from_fn(|_| self.byte())
    }

    /// One of `n` choices.
    pub fn choice(&mut self, n: usize) -> usize {
        self.byte() as usize % n
    }

    /// A number: small (|x| < 33), large (up to 3e7), tiny (down to 1e-6),
    /// special, or any 64-bit pattern.
    pub fn number(&mut self) -> f64 {
        const SPECIAL: [f64; 10] = [
            f64::NAN,
            f64::INFINITY,
            f64::NEG_INFINITY,
            0.0,
            -0.0,
            1e300,
            -1e300,
            1e-300,
            f64::MAX,
            f64::MIN_POSITIVE,
        ];
        let tag = self.byte();
        let short = f64::from(i16::from_le_bytes(self.array()));
        match tag % 8 {
            0..=3 => short / 1000.0,
            4 => short * 1e3,
            5 => short * 1e-6,
            6 => SPECIAL[(short.abs() as usize) % SPECIAL.len()],
            _ => f64::from_le_bytes(self.array()),
        }
    }

    pub fn numbers(&mut self, n: usize) -> Vec<f64> {
        (0..n).map(|_| self.number()).collect()
    }
}

/// The reference models, loaded once.
pub fn reference_models() -> &'static [Model] {
    static MODELS: std::sync::OnceLock<Vec<Model>> = std::sync::OnceLock::new();
    MODELS.get_or_init(|| {
        REFERENCE_MODELS
            .iter()
            .map(|(name, text)| parse(name, text).expect("reference models load"))
            .collect()
    })
}

/// Step and step Jacobians of a reference model under decoded options,
/// parameter edits and state (see the module documentation).
pub fn check_step(data: &[u8]) {
    let mut bytes = Bytes::new(data);
    let models = reference_models();
    let mut model = models[bytes.choice(models.len())].clone();
    let settings = bytes.byte();
    let integrator = Integrator::NAMES[settings as usize % 2].1;
    let passive = PassiveMode::NAMES[(settings as usize / 2) % 3].1;
    let timestep = if settings & 0x80 != 0 {
        bytes.number()
    } else {
        model.opt.timestep
    };
    match model.edited(|s| {
        s.opt.integrator = integrator;
        s.opt.passive = passive;
        s.opt.timestep = timestep;
    }) {
        Ok(edited) => model = edited,
        Err(e) => {
            assert!(!(timestep.is_finite() && timestep > 0.0), "{e}");
            assert!(e.to_string().contains(&timestep.to_string()), "{e}");
        }
    }
    let names = model.param_names();
    for _ in 0..bytes.choice(4) {
        let name = &names[bytes.choice(names.len())];
        let size = model.param(name).expect("listed").size();
        // Mostly the right length, sometimes one short or one long.
        let len = match bytes.choice(8) {
            0 => size - 1,
            1 => size + 1,
            _ => size,
        };
        let value = bytes.numbers(len);
        check_set_param(&mut model, name, &value);
    }
    let n = model.nv();
    let (q, v, tau) = (bytes.numbers(n), bytes.numbers(n), bytes.numbers(n));
    let params: Vec<Param> = (0..bytes.choice(3))
        .map(|_| model.param(&names[bytes.choice(names.len())]).unwrap())
        .collect();
    check_step_and_jacobians(&model, (&q, &v, &tau), &params);
}

/// `set_param` keeps what it accepts exactly and leaves the model as it was
/// when it refuses, with an error naming the parameter.
pub fn check_set_param(model: &mut Model, name: &str, value: &[f64]) {
    let before = model.clone();
    match model.set_param(name, value) {
        Ok(()) => {
            assert!(value.iter().all(|x| x.is_finite()), "{name} = {value:?}");
            assert_eq!(model.get_param(name).unwrap(), value, "{name}");
            let rebuilt = Model::from_spec((**model).clone())
                .unwrap_or_else(|e| panic!("{name} = {value:?} made the model invalid: {e}"));
            assert_eq!(
                rebuilt.tree(),
                model.tree(),
                "{name}: the tree was not patched"
            );
        }
        Err(e) => {
            assert!(e.to_string().contains(name), "{e}");
            assert_eq!(**model, *before, "a refused {name} changed the model");
            assert_eq!(model.tree(), before.tree());
        }
    }
}

/// The step at (q, v, tau) either succeeds with a finite next state or names
/// the first bad input (or reports divergence); the step Jacobians agree with
/// it and are finite whenever they succeed.
pub fn check_step_and_jacobians(
    model: &Model,
    (q, v, tau): (&[f64], &[f64], &[f64]),
    params: &[Param],
) {
    let x = State::new(q.to_vec(), v.to_vec());
    let stepped = model.step(&mut model.data(), &x, &Inputs::tau(tau));
    let first_bad = [("q", q), ("v", v), ("tau", tau)]
        .into_iter()
        .find_map(|(name, x)| x.iter().position(|x| !x.is_finite()).map(|i| (name, i)));
    match (&stepped, first_bad) {
        (Err(StepError::NotFinite { name, index }), Some((want, i))) => {
            assert_eq!((*name, *index), (want, i));
        }
        (_, Some(bad)) => panic!("non-finite {bad:?} not refused: {stepped:?}"),
        (Ok(next), None) => {
            assert!(next.q.iter().chain(&next.v).all(|x| x.is_finite()));
        }
        (Err(StepError::DivergedAt { .. }), None) => {}
        // A documented refusal: geoms within reach that the constraint model
        // (URDF's default too) has no collider for.
        (Err(StepError::NoCollider(_)), None) => {}
        (Err(e), None) => panic!("finite input refused: {e}"),
    }
    let wrt = Wrt {
        state: true,
        control: true,
        params,
    };
    let jacobians = step_jacobians(model, &mut Workspace::new(model), (q, v, tau), &wrt);
    match (&stepped, &jacobians) {
        (Ok(_), Ok(j)) => assert_finite_jacobians(j),
        // Model::step names the cause of a divergence; the Jacobians do not.
        (Err(StepError::DivergedAt { .. }), Err(StepError::Diverged)) => {}
        (Err(a), Err(b)) => assert_eq!(a, b),
        // Jacobians may overflow where the state does not.
        (Ok(_), Err(StepError::JacobianNotFinite { .. })) => {}
        _ => panic!("step {stepped:?} but step_jacobians {jacobians:?}"),
    }
}

fn assert_finite_jacobians(j: &StepJacobians) {
    let blocks = [
        ("dq_dq", j.dq_dq()),
        ("dq_dv", j.dq_dv()),
        ("dq_dtau", j.dq_dtau()),
        ("dq_dp", j.dq_dp()),
        ("dv_dq", j.dv_dq()),
        ("dv_dv", j.dv_dv()),
        ("dv_dtau", j.dv_dtau()),
        ("dv_dp", j.dv_dp()),
    ];
    for (name, m) in blocks {
        assert!(m.iter().all(|x| x.is_finite()), "{name} not finite: {m}");
    }
    assert!(j.q_next.iter().chain(&j.v_next).all(|x| x.is_finite()));
}
