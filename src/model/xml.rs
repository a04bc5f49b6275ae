//! What the MJCF and URDF formats share: reading the document, errors that
//! point at an element, and lists of numbers.

use roxmltree::{Document, Node};

use super::ModelError;

/// Parses XML text; `file` names it in errors.
pub(super) fn document<'i>(text: &'i str, file: &str) -> Result<Document<'i>, ModelError> {
    Document::parse(text).map_err(|e| ModelError::Xml {
        file: file.to_string(),
        message: e.to_string(),
    })
}

/// An error in `file` at `node`: its 1-based line and its tag name.
pub(super) fn invalid(file: &str, node: Node, message: impl Into<String>) -> ModelError {
    ModelError::Invalid {
        file: file.to_string(),
        line: node.document().text_pos_at(node.range().start).row,
        element: node.tag_name().name().to_string(),
        message: message.into(),
    }
}

/// Whitespace-separated finite numbers; `None` if any word is not one.
pub(super) fn numbers(text: &str) -> Option<Vec<f64>> {
    text.split_whitespace()
        .map(|word| word.parse::<f64>().ok().filter(|x| x.is_finite()))
        .collect()
}
