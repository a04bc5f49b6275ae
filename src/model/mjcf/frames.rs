//! `<frame>` and `<replicate>`, unfolded as MuJoCo's compiler unfolds them:
//! neither makes a body. Everything inside belongs to the enclosing body (or
//! the world), in document order, placed by the frames around it.
//!
//! A frame sits at `pos` with its orientation (any of `orientation.rs`'s
//! forms) in its parent frame; an element inside it is moved into the
//! body's frame by every enclosing frame, innermost first: a body's, geom's
//! (after `fromto`) or site's position and orientation, a joint's anchor and
//! (hinge, slide) axis. A frame's or replicate's `childclass` is the default
//! class of what it holds, as a body's is.
//!
//! `<replicate count offset euler sep>` makes `count` copies of its contents.
//! Copy i sits in a frame rotated by `euler` times i (angles and sequence as
//! in `compiler.rs`) at p_i, with p_0 = 0 and p_{i+1} = p_i + R(i euler)
//! offset. Every name inside copy i gets `sep` and i, zero-padded to the
//! digits of `count`, appended (unnamed elements stay unnamed); names inside
//! nested replicates get the inner suffix first.

use nalgebra::{Rotation3, Vector3};

use super::attributes::Attrs;
use super::schema::{check_attributes, FRAME_ATTRS, REPLICATE_ATTRS};
use super::{elements, tag, Node, Reader, Result};

/// Most elements a body may hold once its replicates are unfolded (a guard
/// against a few nested replicates asking for billions).
const MAX_MEMBERS: usize = 1 << 20;

/// A rigid placement: where a frame sits and how it is turned in its parent.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Placement {
    pub pos: Vector3<f64>,
    pub rot: Rotation3<f64>,
}

impl Placement {
    pub fn identity() -> Self {
        Placement {
            pos: Vector3::zeros(),
            rot: Rotation3::identity(),
        }
    }

    /// `inner`, given in this frame, in this frame's parent.
    pub fn then(&self, inner: &Placement) -> Placement {
        Placement {
            pos: self.point(&inner.pos),
            rot: self.rot * inner.rot,
        }
    }

    /// A point given in this frame, in the parent.
    pub fn point(&self, p: &Vector3<f64>) -> Vector3<f64> {
        self.pos + self.rot * p
    }
}

/// An element that belongs to a body, with what its frames and replicates
/// give it.
#[derive(Clone, Debug)]
pub struct Member<'a> {
    pub node: Node<'a>,
    /// The enclosing frames composed (identity outside any frame).
    pub frame: Placement,
    /// The default class of the element (when it names none).
    pub class: &'a str,
    /// Appended to the element's name and every name inside it.
    pub suffix: String,
    /// Whether it sits inside a `<frame>` or `<replicate>`.
    pub framed: bool,
}

impl<'a> Reader<'a> {
    /// The elements of a body (or `<worldbody>`) `node` whose default class
    /// is `class` and whose names get `suffix`, frames and replicates
    /// unfolded.
    pub(super) fn members(
        &self,
        node: Node<'a>,
        class: &'a str,
        suffix: &str,
    ) -> Result<Vec<Member<'a>>> {
        let mut out = vec![];
        let top = Member {
            node,
            frame: Placement::identity(),
            class,
            suffix: suffix.to_string(),
            framed: false,
        };
        self.unfold(&top, &mut out)?;
        Ok(out)
    }

    /// Appends the elements inside `parent` (a body, frame or replicate copy,
    /// with what it passes on) to `out`.
    fn unfold(&self, parent: &Member<'a>, out: &mut Vec<Member<'a>>) -> Result<()> {
        for node in elements(parent.node) {
            match tag(node) {
                "frame" => {
                    check_attributes(self.file, node, FRAME_ATTRS)?;
                    let a = Attrs::of(self.file, node);
                    let own = Placement {
                        pos: a.vector("pos")?.unwrap_or_default(),
                        rot: self.orientation(&a)?,
                    };
                    let frame = Member {
                        node,
                        frame: parent.frame.then(&own),
                        class: self.class_name(node, "childclass")?.unwrap_or(parent.class),
                        suffix: parent.suffix.clone(),
                        framed: true,
                    };
                    self.unfold(&frame, out)?;
                }
                "replicate" => self.replicate(parent, node, out)?,
                _ => {
                    if out.len() >= MAX_MEMBERS {
                        let msg = format!("more than {MAX_MEMBERS} elements in one body");
                        return Err(self.error(node, msg));
                    }
                    out.push(Member {
                        node,
                        ..parent.clone()
                    });
                }
            }
        }
        Ok(())
    }

    /// The copies of a `<replicate>` inside `parent`.
    fn replicate(
        &self,
        parent: &Member<'a>,
        node: Node<'a>,
        out: &mut Vec<Member<'a>>,
    ) -> Result<()> {
        check_attributes(self.file, node, REPLICATE_ATTRS)?;
        let a = Attrs::of(self.file, node);
        let count = a
            .int("count")?
            .ok_or_else(|| self.error(node, "<replicate> needs a count"))?;
        let count = usize::try_from(count)
            .ok()
            .filter(|c| *c <= MAX_MEMBERS)
            .ok_or_else(|| {
                self.error(
                    node,
                    format!("count must be in 0..={MAX_MEMBERS}, got {count}"),
                )
            })?;
        let offset = a.vector("offset")?.unwrap_or_default();
        let euler = a.exact::<3>("euler")?.unwrap_or_default();
        let sep = a.text("sep").unwrap_or("");
        let class = self.class_name(node, "childclass")?.unwrap_or(parent.class);
        let digits = count.to_string().len();
        let mut pos = Vector3::zeros();
        for i in 0..count {
            // MuJoCo turns each copy by i * euler (not by the product of i
            // turns), and moves the next one along this copy's offset.
            let rot = self.euler(euler.map(|x| x * i as f64));
            let copy = Member {
                node,
                frame: parent.frame.then(&Placement { pos, rot }),
                class,
                suffix: format!("{sep}{i:0digits$}{}", parent.suffix),
                framed: true,
            };
            self.unfold(&copy, out)?;
            pos += rot * offset;
        }
        Ok(())
    }
}
