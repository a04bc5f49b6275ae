//! `<include file="...">`, expanded as MuJoCo's XML reader expands it before
//! anything else reads the document: the child elements of the included
//! file's root element take the place of the `<include>`, wherever it sits,
//! and included files may include others.
//!
//! Paths: MuJoCo first looks for the file relative to the directory of the
//! main (top-level) file, then relative to the directory of the including
//! file (an absolute path is used as it is). The issue asked for "relative to
//! the including file"; that is MuJoCo's second choice, taken when the first
//! does not exist.
//!
//! A file is included at most once, as in MuJoCo ("already included"), so an
//! include cycle (a file including itself, directly or not) is refused too.
//!
//! The expansion is textual: the included text is spliced in, each splice
//! starting on a line of its own, and a [`SourceMap`] remembers where every
//! line of the expanded text came from, so an error found later names the
//! file and line the element was written at.

use std::collections::HashSet;
use std::ops::Range;
use std::path::{Path, PathBuf};

use super::schema::check_attributes;
use super::{tag, xml, Node, Result};
use crate::model::ModelError;

/// The text of a model with its includes expanded.
pub struct Expanded {
    pub text: String,
    /// The name of the main file, as errors in `text` give it.
    file: String,
    map: SourceMap,
}

/// Where each line of the expanded text came from: runs of consecutive
/// lines, each starting at `line` of the expanded text and at `orig` of
/// `file`.
#[derive(Default)]
struct SourceMap {
    runs: Vec<Run>,
}

struct Run {
    line: u32,
    file: String,
    orig: u32,
}

/// The main file's text with every `<include>` expanded; `file` is its path
/// (includes are looked up next to it).
pub fn expand(text: &str, file: &str) -> Result<Expanded> {
    let main_dir = Path::new(file)
        .parent()
        .unwrap_or(Path::new(""))
        .to_path_buf();
    let mut expander = Expander {
        main_dir,
        included: HashSet::from([canonical(Path::new(file))]),
        chain: vec![(canonical(Path::new(file)), file.to_string())],
        out: Expanded {
            text: String::new(),
            file: file.to_string(),
            map: SourceMap::default(),
        },
    };
    let doc = xml::document(text, file)?;
    expander.splice(&doc, text, file, 0..text.len())?;
    Ok(expander.out)
}

impl Expanded {
    /// `error` with the file and line it points at in the expanded text
    /// replaced by where that line was written.
    pub fn locate(&self, error: ModelError) -> ModelError {
        match error {
            ModelError::Invalid {
                file,
                line,
                element,
                message,
            } if file == self.file => {
                let (file, line) = self.map.origin(line).unwrap_or((file, line));
                ModelError::Invalid {
                    file,
                    line,
                    element,
                    message,
                }
            }
            other => other,
        }
    }
}

impl SourceMap {
    fn origin(&self, line: u32) -> Option<(String, u32)> {
        let run = self.runs.iter().rev().find(|r| r.line <= line)?;
        Some((run.file.clone(), run.orig + (line - run.line)))
    }
}

struct Expander {
    main_dir: PathBuf,
    /// Files included so far (canonical paths), with the main file.
    included: HashSet<PathBuf>,
    /// The files being expanded, outermost first: canonical path, and name
    /// as shown.
    chain: Vec<(PathBuf, String)>,
    out: Expanded,
}

impl Expander {
    /// Appends `text[range]` of `doc` (read from `file`) with its includes
    /// expanded.
    fn splice(
        &mut self,
        doc: &roxmltree::Document,
        text: &str,
        file: &str,
        range: Range<usize>,
    ) -> Result<()> {
        let mut cursor = range.start;
        let includes = doc
            .root_element()
            .descendants()
            .skip(1)
            .filter(|n| n.has_tag_name("include"));
        for include in includes {
            self.push(doc, text, file, cursor..include.range().start);
            self.include(include, file)?;
            cursor = include.range().end;
        }
        self.push(doc, text, file, cursor..range.end);
        Ok(())
    }

    /// Appends `text[range]`, starting on a new line.
    fn push(&mut self, doc: &roxmltree::Document, text: &str, file: &str, range: Range<usize>) {
        if range.is_empty() {
            return;
        }
        let out = &mut self.out;
        if !out.text.is_empty() && !out.text.ends_with('\n') {
            out.text.push('\n');
        }
        out.map.runs.push(Run {
            line: out.text.matches('\n').count() as u32 + 1,
            file: file.to_string(),
            orig: doc.text_pos_at(range.start).row,
        });
        out.text.push_str(&text[range]);
    }

    /// Appends the child elements of the file an `<include>` names.
    fn include(&mut self, include: Node, file: &str) -> Result<()> {
        check_attributes(file, include, &["file"])?;
        if let Some(child) = include.children().find(|n| n.is_element()) {
            let msg = format!("an <include> cannot have children (<{}>)", tag(child));
            return Err(xml::invalid(file, include, msg));
        }
        let name = include
            .attribute("file")
            .ok_or_else(|| xml::invalid(file, include, "<include> needs a file attribute"))?;
        let path = self.resolve(name, file);
        let shown = path.display().to_string();
        let cannot = |why: String| {
            let msg = format!("cannot read included file '{shown}': {why}");
            xml::invalid(file, include, msg)
        };
        // Only regular files: a device (/dev/zero, a pipe) would never end.
        match std::fs::metadata(&path) {
            Ok(meta) if !meta.is_file() => return Err(cannot("not a regular file".into())),
            Err(e) => return Err(cannot(e.to_string())),
            Ok(_) => {}
        }
        let text = std::fs::read_to_string(&path).map_err(|e| cannot(e.to_string()))?;
        let id = canonical(&path);
        if !self.included.insert(id.clone()) {
            let msg = if self.chain.iter().any(|(c, _)| *c == id) {
                let names: Vec<&str> = self.chain.iter().map(|(_, s)| s.as_str()).collect();
                format!("include cycle: {} -> {shown}", names.join(" -> "))
            } else {
                format!("file '{shown}' is already included (MuJoCo includes a file once)")
            };
            return Err(xml::invalid(file, include, msg));
        }
        let doc = xml::document(&text, &shown)?;
        let root = doc.root_element();
        let (Some(first), Some(last)) = (root.first_element_child(), root.last_element_child())
        else {
            let msg = format!(
                "included file '{shown}' has no elements inside its <{}>",
                tag(root)
            );
            return Err(xml::invalid(file, include, msg));
        };
        self.chain.push((id, shown.clone()));
        self.splice(&doc, &text, &shown, first.range().start..last.range().end)?;
        self.chain.pop();
        Ok(())
    }

    /// MuJoCo's lookup: next to the main file, else next to the including
    /// one.
    fn resolve(&self, name: &str, including: &str) -> PathBuf {
        let first = self.main_dir.join(name);
        if first.exists() {
            return first;
        }
        let including_dir = Path::new(including).parent().unwrap_or(Path::new(""));
        including_dir.join(name)
    }
}

/// A file's identity: its canonical path, else the path as given.
fn canonical(path: &Path) -> PathBuf {
    std::fs::canonicalize(path).unwrap_or_else(|_| path.to_path_buf())
}

#[cfg(test)]
mod tests {
    use std::path::{Path, PathBuf};

    use crate::model::ModelError;
    use crate::Model;

    /// A fresh directory holding `files` (path, text).
    fn files(test: &str, files: &[(&str, &str)]) -> PathBuf {
        let dir =
            std::env::temp_dir().join(format!("diffosi-include-{}-{test}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        for (path, text) in files {
            let path = dir.join(path);
            std::fs::create_dir_all(path.parent().unwrap()).unwrap();
            std::fs::write(path, text).unwrap();
        }
        dir
    }

    /// The file (relative to `dir`), line and message of the error loading
    /// `dir/main.xml` gives.
    fn error(dir: &Path) -> (String, u32, String) {
        match Model::load(dir.join("main.xml")) {
            Err(ModelError::Invalid {
                file,
                line,
                message,
                ..
            }) => {
                let file = Path::new(&file)
                    .strip_prefix(dir)
                    .unwrap()
                    .display()
                    .to_string();
                (file, line, message)
            }
            other => panic!("expected an Invalid error, got {other:?}"),
        }
    }

    const MAIN: &str =
        "<mujoco>\n  <worldbody>\n    <include file=\"sub/a.xml\"/>\n  </worldbody>\n</mujoco>\n";

    /// A body file that includes `b.xml`, which MuJoCo looks for next to
    /// the main file first, then next to `sub/a.xml`.
    const A: &str = "<mujoco>\n  <body name=\"a\"><joint/><geom size=\"0.1\"/>\n    <include file=\"b.xml\"/>\n  </body>\n</mujoco>\n";

    #[test]
    fn nested_includes_are_found_where_mujoco_looks() {
        let b = r#"<mujoco><geom name="bg" size="0.2" pos="0 0 1"/></mujoco>"#;
        let dir = files(
            "nested",
            &[("main.xml", MAIN), ("sub/a.xml", A), ("sub/b.xml", b)],
        );
        let m = Model::load(dir.join("main.xml")).unwrap();
        let names: Vec<&str> = m.geoms.iter().map(|g| g.name.as_str()).collect();
        assert_eq!(names, ["geom0", "bg"]);
        assert_eq!((m.geoms[1].body, m.bodies[1].name.as_str()), (1, "a"));
        // MuJoCo 4.0.0 takes a b.xml next to the main file over sub/b.xml.
        let top = r#"<mujoco><geom name="top_b" size="0.3"/></mujoco>"#;
        std::fs::write(dir.join("b.xml"), top).unwrap();
        let m = Model::load(dir.join("main.xml")).unwrap();
        assert_eq!(m.geoms[1].name, "top_b");
    }

    #[test]
    fn errors_name_the_file_and_line_they_are_in() {
        let b = "<mujoco>\n\n  <geom size=\"0.2 x\"/>\n</mujoco>";
        let dir = files(
            "where",
            &[("main.xml", MAIN), ("sub/a.xml", A), ("sub/b.xml", b)],
        );
        let (file, line, message) = error(&dir);
        assert_eq!((file.as_str(), line), ("sub/b.xml", 3), "{message}");
        // After the splice, the main file's own lines are its own again.
        let main = MAIN.replace("</worldbody>", "  <body pos=\"1\"/>\n  </worldbody>");
        let b = "<mujoco><geom size=\"0.2\"/></mujoco>";
        let dir = files(
            "after",
            &[("main.xml", &main), ("sub/a.xml", A), ("sub/b.xml", b)],
        );
        let (file, line, message) = error(&dir);
        assert_eq!((file.as_str(), line), ("main.xml", 4), "{message}");
        assert!(message.contains("'pos' needs 3 numbers"), "{message}");
    }

    #[test]
    fn bad_includes_are_refused_at_the_include() {
        let dir = files("missing", &[("main.xml", MAIN), ("sub/a.xml", A)]);
        let (file, line, message) = error(&dir);
        assert_eq!((file.as_str(), line), ("sub/a.xml", 3));
        assert!(message.contains("cannot read included file") && message.contains("b.xml"));
        std::fs::create_dir(dir.join("sub/b.xml")).unwrap();
        assert!(error(&dir).2.contains("not a regular file"));

        let cycle = "<mujoco>\n<include file=\"a.xml\"/></mujoco>";
        let dir = files(
            "cycle",
            &[("main.xml", MAIN), ("sub/a.xml", A), ("sub/b.xml", cycle)],
        );
        let (file, line, message) = error(&dir);
        assert_eq!((file.as_str(), line), ("sub/b.xml", 2));
        assert!(
            message.contains("include cycle") && message.contains("sub/a.xml"),
            "{message}"
        );

        let twice = "<mujoco><include file=\"sub/b.xml\"/><include file=\"sub/b.xml\"/></mujoco>";
        let dir = files(
            "twice",
            &[
                ("main.xml", twice),
                ("sub/b.xml", "<mujoco><size/></mujoco>"),
            ],
        );
        assert!(error(&dir).2.contains("already included"));

        let children = "<mujoco><include file=\"sub/b.xml\"><size/></include></mujoco>";
        let dir = files(
            "children",
            &[
                ("main.xml", children),
                ("sub/b.xml", "<mujoco><size/></mujoco>"),
            ],
        );
        assert!(error(&dir).2.contains("cannot have children"));

        let empty = "<mujoco><include file=\"sub/b.xml\"/></mujoco>";
        let dir = files("empty", &[("main.xml", empty), ("sub/b.xml", "<mujoco/>")]);
        assert!(error(&dir).2.contains("has no elements"));

        let dir = files(
            "syntax",
            &[("main.xml", empty), ("sub/b.xml", "<mujoco><size>")],
        );
        match Model::load(dir.join("main.xml")) {
            Err(ModelError::Xml { file, .. }) => assert!(file.ends_with("b.xml")),
            other => panic!("expected an XML error, got {other:?}"),
        }
    }
}
