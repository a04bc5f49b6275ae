//! Orientation attributes: `quat` (w x y z, normalised) and its alternatives
//! `axisangle`, `xyaxes`, `zaxis` and `euler`, converted as MuJoCo does.
//!
//! An element may set at most one of them. Through default classes, an
//! alternative set anywhere along the chain beats `quat`.

use nalgebra::{Matrix3, Quaternion, Rotation3, Unit, UnitQuaternion, Vector3};

use super::attributes::{value, Attrs};
use super::{Reader, Result};
use crate::model::geom_inertia::MJ_EPS;

/// The orientation attributes other than `quat`.
pub const ALTERNATIVES: [&str; 4] = ["axisangle", "xyaxes", "zaxis", "euler"];

impl<'a> Reader<'a> {
    /// The rotation given by an element's orientation attributes (identity if
    /// none).
    pub(super) fn orientation(&self, a: &Attrs<'a, '_>) -> Result<Rotation3<f64>> {
        let mut quat = None;
        let mut alternative = None;
        for node in a.nodes() {
            let given: Vec<&str> = std::iter::once("quat")
                .chain(ALTERNATIVES)
                .filter(|k| value(node, k).is_some())
                .collect();
            match given.as_slice() {
                [] => {}
                ["quat"] => quat = Some(node),
                [kind] => alternative = Some((node, *kind)),
                _ => {
                    let msg = format!("multiple orientation specifiers {given:?} are not allowed");
                    return Err(self.error(node, msg));
                }
            }
        }
        if let Some((node, kind)) = alternative {
            return self.alternative(&Attrs::of(self.file, node), kind);
        }
        let Some(node) = quat else {
            return Ok(Rotation3::identity());
        };
        let [w, x, y, z] = Attrs::of(self.file, node)
            .exact::<4>("quat")?
            .unwrap_or([1.0, 0.0, 0.0, 0.0]);
        if [w, x, y, z] == [0.0; 4] {
            return Err(self.error(node, "zero quaternion is not allowed"));
        }
        Ok(UnitQuaternion::from_quaternion(Quaternion::new(w, x, y, z)).to_rotation_matrix())
    }

    /// The rotation an alternative form `kind` of the element `a` gives.
    fn alternative(&self, a: &Attrs, kind: &str) -> Result<Rotation3<f64>> {
        let too_small = |what: &str| a.error(a.element, format!("{kind}: {what} is too small"));
        match kind {
            "axisangle" => {
                let [x, y, z, angle] = a.exact::<4>(kind)?.unwrap_or_default();
                let axis = unit(Vector3::new(x, y, z)).ok_or_else(|| too_small("axis"))?;
                let angle = self.compiler.frame_angle(angle);
                let q = UnitQuaternion::from_axis_angle(&Unit::new_unchecked(axis), angle);
                Ok(q.to_rotation_matrix())
            }
            "xyaxes" => xy_axes(a.exact::<6>(kind)?.unwrap_or_default()).map_err(too_small),
            "zaxis" => {
                let z = a.vector(kind)?.unwrap_or_default();
                Ok(z_to(&unit(z).ok_or_else(|| too_small("axis"))?))
            }
            _ => Ok(self.euler(a.exact::<3>(kind)?.unwrap_or_default())),
        }
    }

    /// Successive rotations about the axes of `eulerseq`: lower case about
    /// the moving axes, upper case about the fixed ones.
    pub(super) fn euler(&self, angles: [f64; 3]) -> Rotation3<f64> {
        let mut q = UnitQuaternion::identity();
        for (angle, axis) in angles.iter().zip(self.compiler.eulerseq) {
            let unit_axis = match axis.to_ascii_lowercase() {
                b'x' => Vector3::x_axis(),
                b'y' => Vector3::y_axis(),
                _ => Vector3::z_axis(),
            };
            let r = UnitQuaternion::from_axis_angle(&unit_axis, self.compiler.frame_angle(*angle));
            q = if axis.is_ascii_lowercase() {
                q * r
            } else {
                r * q
            };
        }
        q.to_rotation_matrix()
    }
}

/// The frame whose x axis is along the first three numbers and whose y axis is
/// the last three made orthogonal to it; `Err` names the vector that is too
/// small.
fn xy_axes(v: [f64; 6]) -> std::result::Result<Rotation3<f64>, &'static str> {
    let x = unit(Vector3::new(v[0], v[1], v[2])).ok_or("x axis")?;
    let y = Vector3::new(v[3], v[4], v[5]);
    let y = unit(y - x * x.dot(&y)).ok_or("y axis")?;
    let z = unit(x.cross(&y)).ok_or("x cross y")?;
    Ok(Rotation3::from_matrix_unchecked(Matrix3::from_columns(&[
        x, y, z,
    ])))
}

/// MuJoCo's minimal rotation taking the z axis to the unit vector `v`.
pub fn z_to(v: &Vector3<f64>) -> Rotation3<f64> {
    let cross = Vector3::z().cross(v);
    let s = cross.norm();
    let (axis, s) = if s * s < MJ_EPS {
        (Vector3::x(), 0.0)
    } else {
        (cross / s, s)
    };
    UnitQuaternion::from_axis_angle(&Unit::new_unchecked(axis), s.atan2(v.z)).to_rotation_matrix()
}

/// `v` scaled to unit length, or `None` when MuJoCo finds it too small.
pub fn unit(v: Vector3<f64>) -> Option<Vector3<f64>> {
    let n2 = v.norm_squared();
    (n2 >= MJ_EPS).then(|| v / n2.sqrt())
}

#[cfg(test)]
mod tests {
    use super::super::test_util::*;

    #[test]
    fn orientations_match_mujoco() {
        // MuJoCo 4.0.0's body_quat for euler="10 20 30" (degrees) in four sequences.
        #[rustfmt::skip]
        let cases = [
            ("xyz", [0.943714364147489, 0.12767944069578063, 0.14487812541736914, 0.2685358227515692]),
            ("XYZ", [0.9515485246437885, 0.03813457647485015, 0.18930785741199999, 0.2392983377447303]),
            ("zyx", [0.9515485246437885, 0.2392983377447303, 0.18930785741199999, 0.03813457647485015]),
            ("zYx", [0.943714364147489, 0.2685358227515692, 0.18930785741199999, 0.03813457647485015]),
        ];
        for (seq, expected) in cases {
            let head = format!(r#"<compiler eulerseq="{seq}"/>"#);
            let m = load(&model(&head, r#"<body euler="10 20 30"/>"#, ""));
            assert_close(&quat_of(&m.bodies[1].rot), &expected, 1e-15);
        }
        // xyaxes, zaxis and an unnormalised quat, also MuJoCo's numbers.
        #[rustfmt::skip]
        let cases = [
            ("xyaxes=\"1 1 0 0 1 1\"",
             [0.8204732385702833, 0.42470820027786693, 0.1759198966061612, 0.3398511429799873]),
            ("zaxis=\"1 2 3\"", [0.9491532346616307, -0.28157860306687144, 0.14078930153343572, 0.0]),
            ("zaxis=\"0 0 -1\"", [6.123233995736766e-17, 1.0, 0.0, 0.0]),
            ("quat=\"1 2 3 4\"", [0.18257418583505536, 0.3651483716701107, 0.5477225575051661, 0.7302967433402214]),
        ];
        for (attribute, expected) in cases {
            let m = load(&model("", &format!("<body {attribute}/>"), ""));
            assert_close(&quat_of(&m.bodies[1].rot), &expected, 1e-15);
        }
    }
}
