//! Typed reading of attributes and of `<origin>`. An attribute name
//! `diffosi:x` is the attribute `x` in [`NAMESPACE`], whatever prefix the file
//! binds to it.

use nalgebra::{Rotation3, Vector3};

use super::{child, pybullet_numbers, Node, Reader, Result, NAMESPACE};

/// A frame in its parent: translation and rotation.
pub(super) type Pose = (Vector3<f64>, Rotation3<f64>);

/// The pose of a frame that coincides with its parent.
pub(super) fn identity() -> Pose {
    (Vector3::zeros(), Rotation3::identity())
}

/// The text of attribute `name` of `node`.
pub(super) fn value<'a>(node: Node<'a>, name: &str) -> Option<&'a str> {
    match name.strip_prefix("diffosi:") {
        Some(local) => node.attribute((NAMESPACE, local)),
        None => node.attribute(name),
    }
}

impl Reader<'_> {
    /// `xyz` and `rpy` of the `<origin>` child of `node` (identity if absent).
    pub(super) fn origin(&self, node: Node) -> Result<Pose> {
        let Some(origin) = child(node, "origin") else {
            return Ok(identity());
        };
        let [x, y, z] = self.numbers(origin, "xyz")?.unwrap_or_default();
        let [roll, pitch, yaw] = self.numbers(origin, "rpy")?.unwrap_or_default();
        Ok((
            Vector3::new(x, y, z),
            Rotation3::from_euler_angles(roll, pitch, yaw),
        ))
    }

    pub(super) fn attr<'a>(&self, node: Node<'a>, name: &str) -> Result<&'a str> {
        value(node, name).ok_or_else(|| self.error(node, format!("missing attribute '{name}'")))
    }

    pub(super) fn required_child<'a>(&self, node: Node<'a>, name: &str) -> Result<Node<'a>> {
        child(node, name).ok_or_else(|| self.error(node, format!("missing <{name}>")))
    }

    pub(super) fn number(&self, node: Node, name: &str) -> Result<Option<f64>> {
        Ok(self.numbers::<1>(node, name)?.map(|[x]| x))
    }

    pub(super) fn required_number(&self, node: Node, name: &str) -> Result<f64> {
        Ok(self.required_numbers::<1>(node, name)?[0])
    }

    /// A required number that must be positive.
    pub(super) fn positive(&self, node: Node, name: &str) -> Result<f64> {
        let value = self.required_number(node, name)?;
        self.check_positive(node, name, value)
    }

    pub(super) fn check_positive(&self, node: Node, name: &str, value: f64) -> Result<f64> {
        if value > 0.0 {
            Ok(value)
        } else {
            Err(self.error(node, format!("{name} must be positive, got {value}")))
        }
    }

    /// An optional number that must not be negative; 0 if absent.
    pub(super) fn nonnegative(&self, node: Node, name: &str) -> Result<f64> {
        match self.number(node, name)?.unwrap_or(0.0) {
            v if v < 0.0 => Err(self.error(node, format!("{name} must be >= 0, got {v}"))),
            v => Ok(v),
        }
    }

    pub(super) fn numbers<const K: usize>(
        &self,
        node: Node,
        name: &str,
    ) -> Result<Option<[f64; K]>> {
        value(node, name)
            .map(|text| self.parse_numbers(node, name, text))
            .transpose()
    }

    pub(super) fn required_numbers<const K: usize>(
        &self,
        node: Node,
        name: &str,
    ) -> Result<[f64; K]> {
        self.parse_numbers(node, name, self.attr(node, name)?)
    }

    /// Exactly `K` finite numbers separated by whitespace; `what` names them in
    /// errors. The forms PyBullet reads with an evident meaning
    /// (`pybullet_numbers.rs`) are accepted with a warning, except in our
    /// extension attributes.
    pub(super) fn parse_numbers<const K: usize>(
        &self,
        node: Node,
        what: &str,
        text: &str,
    ) -> Result<[f64; K]> {
        if let Some(v) = pybullet_numbers::strict(text) {
            return Ok(v);
        }
        let lenient = match what.starts_with("diffosi:") {
            true => None,
            false => pybullet_numbers::read::<K>(text),
        };
        let Some((v, how)) = lenient else {
            let expected = if K == 1 {
                "a finite number".to_string()
            } else {
                format!("{K} finite numbers")
            };
            return Err(self.error(node, format!("{what}: expected {expected}, got '{text}'")));
        };
        self.warn(node, format!("{what}=\"{text}\": {how}: {v:?}"));
        Ok(v)
    }

    /// The value paired with the keyword that attribute `name` holds, if set.
    pub(super) fn keyword<T: Copy>(
        &self,
        node: Node,
        name: &str,
        choices: &[(&str, T)],
    ) -> Result<Option<T>> {
        let Some(text) = value(node, name) else {
            return Ok(None);
        };
        if let Some((_, v)) = choices.iter().find(|(k, _)| *k == text) {
            return Ok(Some(*v));
        }
        let words: Vec<&str> = choices.iter().map(|(k, _)| *k).collect();
        let (last, rest) = words.split_last().expect("at least one choice");
        let expected = format!("{} or {last}", rest.join(", "));
        Err(self.error(node, format!("{name} must be {expected}, got '{text}'")))
    }
}

#[cfg(test)]
mod tests {
    use std::f64::consts::FRAC_PI_2;

    use nalgebra::{Rotation3, Vector3};

    use super::super::test_util::*;
    use crate::model::ModelError;

    #[test]
    fn rpy_is_fixed_axis_roll_then_pitch_then_yaw() {
        let origin = "<origin xyz=\"1 2 3\" rpy=\"0.3 -0.7 1.1\"/>";
        let text = format!(
            "<link name=\"world\"/>{}{}",
            link("a"),
            joint("j", "fixed", "world", "a", origin)
        );
        let m = load(&text).unwrap();
        let about = |axis: Vector3<f64>, angle: f64| {
            Rotation3::from_axis_angle(&nalgebra::Unit::new_normalize(axis), angle)
        };
        let expected =
            about(Vector3::z(), 1.1) * about(Vector3::y(), -0.7) * about(Vector3::x(), 0.3);
        assert!(close(m.bodies[1].rot.matrix(), expected.matrix()));
        assert_eq!(m.bodies[1].pos, Vector3::new(1.0, 2.0, 3.0));

        // A known rotation: roll 90 degrees turns the body's y axis onto world z.
        let origin = format!("<origin rpy=\"{FRAC_PI_2} 0 0\"/>");
        let text = format!(
            "<link name=\"world\"/>{}{}",
            link("a"),
            joint("j", "fixed", "world", "a", &origin)
        );
        let m = load(&text).unwrap();
        assert!((m.bodies[1].rot * Vector3::y() - Vector3::z()).norm() < 1e-15);
    }

    /// A fixed joint world -> a with `origin`, and a box of `size` on a.
    fn welded(origin: &str, size: &str) -> String {
        let a = link("a").replace(
            "</link>",
            &format!("<collision><geometry><box size=\"{size}\"/></geometry></collision></link>"),
        );
        format!(
            "<link name=\"world\"/>\n{a}\n{}",
            joint("j", "fixed", "world", "a", origin)
        )
    }

    #[test]
    fn numbers_pybullet_reads_with_a_meaning_are_accepted_with_a_warning() {
        let cases = [
            (
                r#"<origin xyz="0.07, 0, -0.69"/>"#,
                "1 1 1",
                [0.07, 0.0, -0.69],
                0.0,
            ),
            (r#"<origin rpy="0 1.5 0 0"/>"#, "1 1 1", [0.0; 3], 1.5),
            (
                r#"<origin xyz="$(optenv HUSKY_IMU_XYZ 0.19 0 0.149)"/>"#,
                "1 1 1",
                [0.19, 0.0, 0.149],
                0.0,
            ),
            ("", "1 1 1 1", [0.0; 3], 0.0),
        ];
        for (origin, size, xyz, pitch) in cases {
            let m = load(&welded(origin, size)).unwrap();
            assert_eq!(m.bodies[1].pos, Vector3::from(xyz), "{origin}");
            assert!((m.bodies[1].rot.euler_angles().1 - pitch).abs() < 1e-15);
            let [warning] = m.warnings() else {
                panic!("one warning expected: {:?}", m.warnings())
            };
            let line = if size == "1 1 1" { 4 } else { 3 };
            assert!(
                warning.starts_with(&format!("test.urdf:{line}: <")),
                "{warning}"
            );
        }
        let m = load(&welded("", "1 2 3 4")).unwrap();
        assert!(
            m.warnings()[0].contains("the first three"),
            "{:?}",
            m.warnings()
        );
        assert!(
            m.warnings()[0].contains("[1.0, 2.0, 3.0]"),
            "{:?}",
            m.warnings()
        );
    }

    #[test]
    fn garbage_numbers_are_still_refused_with_the_line() {
        for (origin, size) in [
            (r#"<origin xyz="a b c"/>"#, "1 1 1"),
            (r#"<origin xyz="1,2,3"/>"#, "1 1 1"),
            (r#"<origin rpy="0 1"/>"#, "1 1 1"),
            (r#"<origin rpy="$(optenv R 0 1)"/>"#, "1 1 1"),
            (r#"<origin xyz="$(arg x)"/>"#, "1 1 1"),
            ("", "1 1 1 x"),
        ] {
            let (line, element) = if size == "1 1 1" {
                (4, "origin")
            } else {
                (3, "box")
            };
            match load(&welded(origin, size)) {
                Err(ModelError::Invalid {
                    line: l,
                    element: e,
                    message,
                    ..
                }) => {
                    assert_eq!((l, e.as_str()), (line, element), "{message}");
                    assert!(message.contains("expected 3 finite numbers"), "{message}");
                }
                other => panic!("{origin} {size}: expected an error, got {other:?}"),
            }
        }
    }
}
