//! URDF loader (stub, being written).
use super::{Model, ModelError};

pub fn parse(_text: &str, file: &str) -> Result<Model, ModelError> {
    Err(ModelError::UnknownFormat(file.to_string()))
}
