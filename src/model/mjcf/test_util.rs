//! Builders and checks shared by the tests of every part of the loader.

use nalgebra::{Rotation3, UnitQuaternion};

use super::parse;
use crate::model::ModelError;
use crate::Model;

pub fn load(xml: &str) -> Model {
    compile(xml).unwrap_or_else(|e| panic!("{e}"))
}

/// `xml` read and compiled, as [`Model::load`] does.
pub fn compile(xml: &str) -> Result<Model, ModelError> {
    Model::from_spec(parse(xml, "test.xml")?)
}

/// The line, element and message of the error `xml` must give.
pub fn error(xml: &str) -> (u32, String, String) {
    match compile(xml) {
        Err(ModelError::Invalid {
            file,
            line,
            element,
            message,
        }) => {
            assert_eq!(file, "test.xml");
            (line, element, message)
        }
        other => panic!("expected an Invalid error, got {other:?}"),
    }
}

/// Asserts `xml` is rejected with a message containing `expected`.
pub fn assert_rejects(xml: &str, expected: &str) {
    let (line, element, message) = error(xml);
    assert!(line >= 1 && !element.is_empty());
    let context = format!("{xml}\n  gave: {message}\n  expected: {expected}");
    assert!(message.contains(expected), "{context}");
}

/// A model whose worldbody holds `bodies`, with `head` before it and
/// `tail` after it.
pub fn model(head: &str, bodies: &str, tail: &str) -> String {
    format!("<mujoco>{head}<worldbody>{bodies}</worldbody>{tail}</mujoco>")
}

/// A body with a joint and a 0.1 m ball, holding `inner` too.
pub fn body(inner: &str) -> String {
    format!(r#"<body><joint/><geom size="0.1"/>{inner}</body>"#)
}

/// The (w, x, y, z) quaternion of a rotation, with w >= 0 as MuJoCo has it.
pub fn quat_of(rot: &Rotation3<f64>) -> [f64; 4] {
    let q = UnitQuaternion::from_rotation_matrix(rot).into_inner();
    let q = if q.w < 0.0 { -q } else { q };
    [q.w, q.i, q.j, q.k]
}

pub fn assert_close(ours: &[f64], theirs: &[f64], tol: f64) {
    assert_eq!(ours.len(), theirs.len());
    for (a, b) in ours.iter().zip(theirs) {
        assert!((a - b).abs() <= tol, "{ours:?} vs {theirs:?}");
    }
}
