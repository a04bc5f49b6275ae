//! What the MJCF and URDF formats share: reading the document, errors that
//! point at an element, and lists of numbers.

use roxmltree::{Document, Node};

use super::ModelError;

/// Deepest element nesting a document may have: MuJoCo's XML reader (tinyxml2)
/// accepts a chain of 496 bodies, whose geoms sit 499 elements deep, and
/// refuses one of 497.
pub const MAX_DEPTH: usize = 499;

/// Parses XML text; `file` names it in errors. Documents nested deeper than
/// [`MAX_DEPTH`] elements are refused, as MuJoCo refuses them, before anything
/// walks them recursively.
pub(super) fn document<'i>(text: &'i str, file: &str) -> Result<Document<'i>, ModelError> {
    let error = |message: String| ModelError::Xml {
        file: file.to_string(),
        message,
    };
    let doc = Document::parse(text).map_err(|e| error(e.to_string()))?;
    let mut stack = vec![(doc.root_element(), 1)];
    while let Some((node, depth)) = stack.pop() {
        if depth > MAX_DEPTH {
            let line = doc.text_pos_at(node.range().start).row;
            return Err(error(format!(
                "element nesting is too deep: <{}> at line {line} is {depth} elements deep \
                 (at most {MAX_DEPTH}, as in MuJoCo)",
                node.tag_name().name()
            )));
        }
        stack.extend(
            node.children()
                .filter(|c| c.is_element())
                .map(|c| (c, depth + 1)),
        );
    }
    Ok(doc)
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
