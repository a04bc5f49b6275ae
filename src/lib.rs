//! diffosi: differentiable rigid-body dynamics with online system identification.
//!
//! Layout follows the math: [`spatial`] algebra, the [`model`] (bodies, joints,
//! the MJCF and URDF loaders), and the [`dynamics`] algorithms that run on it.
//!
//! ```
//! # fn main() -> Result<(), Box<dyn std::error::Error>> {
//! let model = diffosi::Model::load(concat!(env!("CARGO_MANIFEST_DIR"), "/reference_models/cartpole.xml"))?;
//! let mut data = model.data();
//! // State (q, v) = ((cart x, pole angle), their rates); tau = generalized forces.
//! let x = diffosi::model::State::new(vec![0.0, 0.1], vec![0.0, 0.0]);
//! let next = model.step(&mut data, &x, &diffosi::model::Inputs::tau(&[0.0, 0.0]))?;
//! assert!(next.v[1] > 0.0, "the tilted pole falls further");
//! assert_eq!(next.q[1], 0.1 + model.opt.timestep * next.v[1]);
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
