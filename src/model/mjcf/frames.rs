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

/// Most elements a model may hold once its replicates are unfolded (a guard
/// against a few nested replicates asking for billions).
pub const MAX_MEMBERS: usize = 1 << 20;

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
                    let unfolded = self.unfolded.get() + 1;
                    if unfolded > MAX_MEMBERS {
                        let msg = format!("the model has more than {MAX_MEMBERS} elements");
                        return Err(self.error(node, msg));
                    }
                    self.unfolded.set(unfolded);
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

#[cfg(test)]
mod tests {
    use super::super::test_util::*;
    use crate::model::Shape;

    /// Frames around geoms (one with fromto), a joint, bodies and frames,
    /// with a childclass; MuJoCo 4.0.0's compiled model of the same file.
    #[test]
    fn frames_place_their_contents_as_mujoco_compiles_them() {
        let head = r#"<default><default class="big"><geom size="0.2"/><joint damping="3"/></default></default>"#;
        let bodies = r#"
            <frame pos="0.1 0.2 0.3" euler="10 20 30">
              <geom name="wg" type="box" size="0.1 0.2 0.3" pos="1 0 0" quat="1 0 0 1"/>
              <body name="b" pos="0 0 1" axisangle="1 0 0 30">
                <frame pos="0 0.5 0" zaxis="1 1 0" childclass="big">
                  <joint name="h" pos="0.1 0 0" axis="0 1 0"/>
                  <geom name="g1" type="capsule" fromto="0 0 0 0.3 0 0.4" size="0.05"/>
                  <frame euler="0 90 0"><geom name="g2"/></frame>
                </frame>
                <geom name="g3" size="0.1" pos="0 0 -0.2"/>
                <frame pos="1 0 0"><body name="c" pos="0 1 0"><joint name="s" type="slide" axis="1 0 0"/><geom name="g4" size="0.1"/></body></frame>
              </body>
            </frame>"#;
        let m = load(&model(head, bodies, ""));
        let b = &m.bodies[1];
        #[rustfmt::skip]
        let expected = (
            [0.44202014332566864, 0.03682408883346522, 1.2254165783983233],
            [0.8785122060499201, 0.36758011983238364, 0.20944370822536446, 0.22188846840275755],
            42.14970143566307,
            [0.02285194444741777, 0.4573239941368587, -0.03107529373929003],
        );
        assert_close(b.pos.as_slice(), &expected.0, 1e-15);
        assert_close(&quat_of(&b.rot), &expected.1, 1e-15);
        assert!((b.mass - expected.2).abs() < 1e-13);
        assert_close(b.com.as_slice(), &expected.3, 1e-15);
        assert_close(m.bodies[2].pos.as_slice(), &[1.0, 1.0, 0.0], 0.0);
        let h = &m.joints[0];
        assert_close(
            h.anchor.as_slice(),
            &[0.05000000000000002, 0.45, -0.07071067811865475],
            1e-15,
        );
        assert_close(
            h.axis.as_slice(),
            &[-0.4999999999999998, 0.5000000000000002, -0.7071067811865475],
            1e-15,
        );
        assert_eq!((h.damping, m.joints[1].damping), (3.0, 0.0));
        #[rustfmt::skip]
        let geoms = [
            ("wg", 0, [0.9137976813493736, 0.7438381424823255, 0.0951258712971379],
             [0.4774233251326969, 0.19272730326230894, 0.012161306594124704, 0.8571903276509836]),
            ("g1", 1, [0.21642135623730951, 0.5664213562373095, -0.10606601717798204],
             [0.6979484467752357, -0.15811388300841894, -0.512706510241518, 0.4743416490252568]),
            ("g2", 1, [0.0, 0.5, 0.0],
             [0.14644660940672644, -0.35355339059327373, 0.8535533905932737, -0.3535533905932737]),
            ("g3", 1, [0.0, 0.0, -0.2], [1.0, 0.0, 0.0, 0.0]),
            ("g4", 2, [0.0, 0.0, 0.0], [1.0, 0.0, 0.0, 0.0]),
        ];
        assert_eq!(m.geoms.len(), geoms.len());
        for (g, (name, body, pos, quat)) in m.geoms.iter().zip(geoms) {
            assert_eq!((g.name.as_str(), g.body), (name, body));
            assert_close(g.pos.as_slice(), &pos, 1e-15);
            assert_close(&quat_of(&g.rot), &quat, 1e-15);
        }
        assert_eq!(m.geoms[2].shape, Shape::Sphere { radius: 0.2 });
    }

    /// Copies, their names and placements, nested; MuJoCo 4.0.0's numbers.
    #[test]
    fn replicate_copies_as_mujoco_compiles_them() {
        let bodies = r#"
            <replicate count="3" offset="0.5 0 0" euler="0 0 30" sep="-">
              <body name="r" pos="0 1 0"><joint name="j"/><geom name="rg" size="0.1"/>
                <replicate count="2" offset="0 0 0.2"><geom name="inner" size="0.05"/></replicate>
              </body>
            </replicate>
            <replicate count="12" offset="0 0.1 0"><geom name="w" size="0.01"/></replicate>"#;
        let m = load(&model(
            "",
            bodies,
            r#"<actuator><motor joint="j-1"/></actuator>"#,
        ));
        assert_eq!(m.actuators[0].joint(), Some(1));
        let names = |v: Vec<&str>| v.join(" ");
        assert_eq!(
            names(m.bodies.iter().map(|b| b.name.as_str()).collect()),
            "world r-0 r-1 r-2"
        );
        assert_eq!(
            names(m.joints.iter().map(|j| j.name.as_str()).collect()),
            "j-0 j-1 j-2"
        );
        let geoms: Vec<&str> = m.geoms.iter().map(|g| g.name.as_str()).collect();
        assert_eq!(
            names(geoms[..12].to_vec()),
            "w00 w01 w02 w03 w04 w05 w06 w07 w08 w09 w10 w11"
        );
        assert_eq!(
            names(geoms[12..].to_vec()),
            "rg-0 inner0-0 inner1-0 rg-1 inner0-1 inner1-1 rg-2 inner0-2 inner1-2"
        );
        #[rustfmt::skip]
        let placements = [
            ([0.0, 1.0, 0.0], [1.0, 0.0, 0.0, 0.0]),
            ([5.551115123125783e-17, 0.8660254037844387, 0.0],
             [0.9659258262890683, 0.0, 0.0, 0.25881904510252074]),
            ([0.06698729810778081, 0.7500000000000002, 0.0],
             [0.8660254037844387, 0.0, 0.0, 0.49999999999999994]),
        ];
        for (b, (pos, quat)) in m.bodies[1..].iter().zip(placements) {
            assert_close(b.pos.as_slice(), &pos, 1e-15);
            assert_close(&quat_of(&b.rot), &quat, 1e-15);
            assert_close(b.com.as_slice(), &[0.0, 0.0, 0.02], 1e-16);
        }
        assert_close(
            m.geoms[11].pos.as_slice(),
            &[0.0, 1.0999999999999999, 0.0],
            1e-15,
        );
        assert_close(m.geoms[14].pos.as_slice(), &[0.0, 0.0, 0.2], 0.0);
    }

    #[test]
    fn bad_frames_and_replicates_are_rejected() {
        #[rustfmt::skip]
        let cases = [
            (r#"<frame mocap="true"/>"#, "unrecognized attribute 'mocap'"),
            (r#"<frame childclass="nope"/>"#, "unknown default class 'nope'"),
            (r#"<frame pos="1 2"/>"#, "needs 3 numbers"),
            ("<replicate/>", "needs a count"),
            (r#"<replicate count="-1"/>"#, "count must be in"),
            (r#"<replicate count="1000"><replicate count="1000"><replicate count="1000">
                <geom size="1"/></replicate></replicate></replicate>"#, "more than 1048576 elements"),
            (r#"<body name="x1"/><replicate count="2"><body name="x"/></replicate>"#,
             "repeated name 'x1'"),
            (r#"<body><frame><inertial mass="1" diaginertia="1 1 1" pos="0 0 0"/></frame></body>"#,
             "<inertial> inside a <frame>"),
            (r#"<frame><joint/></frame>"#, "the world cannot have joints"),
        ];
        for (bodies, expected) in cases {
            assert_rejects(&model("", bodies, ""), expected);
        }
    }
}
