//! diffosi: differentiable rigid-body dynamics with online system identification.
//!
//! Layout follows the math: [`spatial`] algebra, the [`model`] (bodies, joints,
//! loaders), and the [`dynamics`] algorithms that run on it.

pub mod dynamics;
pub mod model;
pub mod spatial;

pub use model::{Model, ModelError};
