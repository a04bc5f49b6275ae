//! Builders shared by the tests of every part of the loader.

use nalgebra::Matrix3;

use super::{LoadOptions, NAMESPACE};
use crate::model::ModelError;
use crate::Model;

pub fn load(body: &str) -> Result<Model, ModelError> {
    Model::from_urdf(&urdf(body), "test.urdf")
}

/// `body` loaded with `options`.
pub fn load_with(body: &str, options: &LoadOptions) -> Result<Model, ModelError> {
    Model::from_urdf_with(&urdf(body), "test.urdf", options)
}

/// A robot holding `body`, with our namespace declared.
pub fn urdf(body: &str) -> String {
    format!("<robot name=\"r\" xmlns:diffosi=\"{NAMESPACE}\">\n{body}\n</robot>")
}

/// A link with a unit mass and inertia.
pub fn link(name: &str) -> String {
    format!(
        "<link name=\"{name}\"><inertial><mass value=\"1\"/>\
         <inertia ixx=\"1\" iyy=\"1\" izz=\"1\" ixy=\"0\" ixz=\"0\" iyz=\"0\"/></inertial></link>"
    )
}

pub fn joint(name: &str, kind: &str, parent: &str, child: &str, extra: &str) -> String {
    format!(
        "<joint name=\"{name}\" type=\"{kind}\"><parent link=\"{parent}\"/>\
         <child link=\"{child}\"/>{extra}</joint>"
    )
}

pub fn close(a: &Matrix3<f64>, b: &Matrix3<f64>) -> bool {
    (a - b).abs().max() < 1e-15
}
