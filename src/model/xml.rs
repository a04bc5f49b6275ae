//! What the MJCF and URDF formats share: reading the document, errors that
//! point at an element, and lists of numbers.

use std::borrow::Cow;

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

/// `text` as tinyxml2 (the XML reader of PyBullet and MuJoCo) reads it, where
/// it accepts what [`document`] refuses, and a note (1-based line, what was
/// assumed) for each departure:
/// - NUL bytes ending the file, perhaps with whitespace: tinyxml2 reads the
///   text as a C string and stops at the first (a NUL followed by anything
///   else is left for [`document`] to refuse);
/// - an XML declaration after leading whitespace, which tinyxml2 reads as one
///   at the start: it is blanked, so that every line keeps its number.
pub(super) fn as_tinyxml2_reads(text: &str) -> (Cow<'_, str>, Vec<(usize, String)>) {
    let line = |at: usize| text[..at].matches('\n').count() + 1;
    let mut notes = vec![];
    let mut text_end = text.len();
    if let Some(nul) = text.find('\0') {
        if text[nul..].chars().all(|c| c == '\0' || c.is_whitespace()) {
            notes.push((
                line(nul),
                "NUL bytes end the file: ignored from the first on, as tinyxml2 \
                 (PyBullet's and MuJoCo's XML reader) stops there"
                    .to_string(),
            ));
            text_end = nul;
        }
    }
    let kept = &text[..text_end];
    let start = kept.len() - kept.trim_start().len();
    let declaration = kept[start..]
        .strip_prefix("<?xml")
        .filter(|rest| rest.starts_with(char::is_whitespace) || rest.starts_with("?>"))
        .and_then(|_| kept[start..].find("?>"));
    let Some(length) = declaration.filter(|_| start > 0).map(|end| end + 2) else {
        return (Cow::Borrowed(kept), notes);
    };
    notes.push((
        line(start),
        "an XML declaration after leading blank space, read as tinyxml2 reads it \
         (XML allows it only at the start)"
            .to_string(),
    ));
    let blank: String = kept[start..start + length]
        .chars()
        .map(|c| if c == '\n' { '\n' } else { ' ' })
        .collect();
    let fixed = format!("{}{blank}{}", &kept[..start], &kept[start + length..]);
    (Cow::Owned(fixed), notes)
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn late_declarations_and_trailing_nuls_are_read_as_tinyxml2_reads_them() {
        let late = "\n\n<?xml version=\"1.0\"?>\n<robot>\n<bad/></robot>\0\0\r\n";
        let (text, notes) = as_tinyxml2_reads(late);
        let lines: Vec<usize> = notes.iter().map(|(line, _)| *line).collect();
        assert_eq!(lines, [5, 3]);
        let doc = document(&text, "f").unwrap();
        let bad = doc.descendants().find(|n| n.has_tag_name("bad")).unwrap();
        assert_eq!(doc.text_pos_at(bad.range().start).row, 5);

        // Well-formed text is left alone, and what follows a NUL is not dropped.
        let plain = "<?xml version=\"1.0\"?>\n<robot/>\n";
        assert_eq!(as_tinyxml2_reads(plain), (Cow::Borrowed(plain), vec![]));
        let (text, notes) = as_tinyxml2_reads("<robot/>\0<more/>");
        assert!(notes.is_empty() && document(&text, "f").is_err());
        let (_, notes) = as_tinyxml2_reads("  <?xml-stylesheet href=\"a\"?><robot/>");
        assert!(notes.is_empty());
    }
}
