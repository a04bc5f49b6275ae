//! diffosi: differentiable rigid-body dynamics with online system identification.
//!
//! A model is read from MJCF or URDF as MuJoCo 4 reads it, stepped as
//! `mj_step` steps it (MuJoCo's soft contact constraints, actuators,
//! sensors), and differentiated exactly: a step's Jacobians in the state,
//! the inputs and the named physical parameters. DiffOSI identifies those
//! parameters from windows of observed transitions. The user guide
//! (`docs/`, built by `make docs`) has the long form; the Python module
//! wraps this crate (`bindings/`).
//!
//! The modules follow the math, in MuJoCo's spec -> compiler -> model ->
//! data order:
//!
//! - [`model`]: what a file says ([`model::Spec`]), the MJCF and URDF
//!   readers, named parameters, [`model::State`] and [`model::Inputs`];
//! - [`compile`]: the [`Model`] compiled from a spec, its step and rollouts;
//! - [`dynamics`]: the algorithms on a [`Model`]'s tree (kinematics, RNEA,
//!   CRBA, ABA, collision, the constraint solver, integrators), in a
//!   [`dynamics::Data`] workspace;
//! - [`derivatives`]: exact step and transition Jacobians;
//! - [`osi`]: the identifiers (Levenberg-Marquardt, Adam, CMA-ES) and the
//!   online loop;
//! - [`spatial`]: spatial vectors and inertias, generic over the scalar
//!   (f64 or dual numbers);
//! - [`tasks`], [`control`], [`nn`], [`rl`], [`experiments`]: the paper's
//!   tasks, controllers, networks, training and experiments.
//!
//! Units are SI; q has nq entries and v, tau nv (MuJoCo's qpos, qvel).
//!
//! ```
//! use diffosi::derivatives::{step_jacobians, Workspace, Wrt};
//! use diffosi::model::{Inputs, State};
//!
//! # fn main() -> Result<(), Box<dyn std::error::Error>> {
//! let model = diffosi::Model::load(concat!(env!("CARGO_MANIFEST_DIR"), "/reference_models/cartpole.xml"))?;
//! let mut data = model.data();
//! // State (q, v) = ((cart x, pole angle), their rates); tau = generalized forces.
//! let x = State::new(vec![0.0, 0.1], vec![0.0, 0.0]);
//! let u = Inputs { tau: vec![0.0, 0.0], ..Inputs::default() };
//! let next = model.step(&mut data, &x, &u)?;
//! assert!(next.v[1] > 0.0, "the tilted pole falls further");
//! assert_eq!(next.q[1], 0.1 + model.opt.timestep * next.v[1]);
//!
//! // d(q', v')/d(q, v), d(q', v')/d tau and d(q', v')/d(pole mass), exact.
//! let mass = model.param("body/pole/mass")?;
//! let wrt = Wrt { state: true, control: true, params: &[mass] };
//! let j = step_jacobians(&model, &mut Workspace::new(&model), (&x.q, &x.v, &u.tau), &wrt)?;
//! assert_eq!(j.dv_dp().shape(), (2, 1));
//! # Ok(())
//! # }
//! ```

pub mod compile;
pub mod control;
pub mod derivatives;
pub mod dynamics;
pub mod experiments;
pub mod model;
pub mod nn;
pub mod osi;
pub mod rl;
pub mod spatial;
pub mod tasks;

pub use compile::Model;
pub use model::ModelError;

/// The user guide's Rust examples, run by `cargo test` as doctests (the
/// chapters of docs/src/ that hold ```rust blocks; harness/tests/test_docs.py
/// checks that each such chapter is listed here).
#[cfg(doctest)]
#[doc = include_str!("../docs/src/getting-started.md")]
mod guide_getting_started {}
