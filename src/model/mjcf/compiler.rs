//! The `<compiler>` settings that change the compiled model.
//!
//! Angles: `euler`, `axisangle` and hinge `range`, `ref`, `springref` are in
//! degrees unless `<compiler angle="radian">`; `quat`, `xyaxes` and `zaxis` are
//! never angles. Every `<compiler>` applies in document order over MuJoCo's
//! defaults.

use std::f64::consts::PI;

use super::attributes::Attrs;
use super::schema::{check_attributes, COMPILER_ATTRS};
use super::{children, Node, Result};

/// `inertiafromgeom`: whether a body's inertia comes from its geoms.
#[derive(Clone, Copy, PartialEq, Eq)]
pub enum FromGeom {
    False,
    True,
    /// Only for bodies without an `<inertial>`.
    Auto,
}

pub struct Compiler {
    degree: bool,
    pub eulerseq: [u8; 3],
    pub inertia_from_geom: FromGeom,
    pub inertia_groups: [i64; 2],
    pub autolimits: bool,
    pub settotalmass: f64,
    pub boundmass: f64,
    pub boundinertia: f64,
    pub balanceinertia: bool,
    /// Where mesh files are, relative to the model file's directory
    /// (`meshdir`, else `assetdir`); `strippath` drops a file's directories.
    pub meshdir: String,
    pub strippath: bool,
    /// `fitaabb`: primitives fitted to a mesh enclose its bounding box
    /// (else they match its inertia box).
    pub fit_aabb: bool,
}

impl Default for Compiler {
    /// MuJoCo's defaults.
    fn default() -> Self {
        Compiler {
            degree: true,
            eulerseq: *b"xyz",
            inertia_from_geom: FromGeom::Auto,
            inertia_groups: [0, 5],
            autolimits: true,
            settotalmass: -1.0,
            boundmass: 0.0,
            boundinertia: 0.0,
            balanceinertia: false,
            meshdir: String::new(),
            strippath: false,
            fit_aabb: false,
        }
    }
}

impl Compiler {
    pub fn read(file: &str, root: Node) -> Result<Compiler> {
        let mut c = Compiler::default();
        for node in children(root, "compiler") {
            check_attributes(file, node, COMPILER_ATTRS)?;
            let a = Attrs::of(file, node);
            c.read_angles(&a)?;
            c.read_inertia(&a)?;
            c.read_paths(&a)?;
            check_rejected(&a)?;
        }
        Ok(c)
    }

    fn read_angles(&mut self, a: &Attrs) -> Result<()> {
        if let Some(angle) = a.keyword("angle", &["degree", "radian"])? {
            self.degree = angle == "degree";
        }
        if let Some(seq) = a.text("eulerseq") {
            self.eulerseq = seq
                .as_bytes()
                .try_into()
                .ok()
                .filter(|s: &[u8; 3]| s.iter().all(|b| b"xyzXYZ".contains(b)))
                .ok_or_else(|| a.error(a.element, "eulerseq must be 3 of x, y, z, X, Y, Z"))?;
        }
        Ok(())
    }

    /// The inertia settings, and `autolimits` (read in MuJoCo's order).
    fn read_inertia(&mut self, a: &Attrs) -> Result<()> {
        if let Some(k) = a.keyword("inertiafromgeom", &["false", "true", "auto"])? {
            self.inertia_from_geom = match k {
                "false" => FromGeom::False,
                "true" => FromGeom::True,
                _ => FromGeom::Auto,
            };
        }
        self.inertia_groups = a
            .ints::<2>("inertiagrouprange")?
            .unwrap_or(self.inertia_groups);
        self.autolimits = a.flag("autolimits")?.unwrap_or(self.autolimits);
        self.settotalmass = a.number("settotalmass")?.unwrap_or(self.settotalmass);
        self.boundmass = a.number("boundmass")?.unwrap_or(self.boundmass);
        self.boundinertia = a.number("boundinertia")?.unwrap_or(self.boundinertia);
        self.balanceinertia = a.flag("balanceinertia")?.unwrap_or(self.balanceinertia);
        Ok(())
    }

    /// `assetdir`, then `meshdir` over it (MuJoCo's order), `strippath` and
    /// `fitaabb` (how meshes are read and fitted).
    fn read_paths(&mut self, a: &Attrs) -> Result<()> {
        for dir in ["assetdir", "meshdir"] {
            if let Some(d) = a.text(dir) {
                self.meshdir = d.to_string();
            }
        }
        self.strippath = a.flag("strippath")?.unwrap_or(self.strippath);
        self.fit_aabb = a.flag("fitaabb")?.unwrap_or(self.fit_aabb);
        Ok(())
    }

    /// MuJoCo's conversion of joint angles (`range`, `ref`, `springref`).
    pub fn joint_angle(&self, x: f64) -> f64 {
        if self.degree {
            x * (PI / 180.0)
        } else {
            x
        }
    }

    /// MuJoCo's conversion of orientation angles (`euler`, `axisangle`).
    pub fn frame_angle(&self, x: f64) -> f64 {
        if self.degree {
            x / 180.0 * PI
        } else {
            x
        }
    }
}

/// Settings that build the model in ways we do not support.
fn check_rejected(a: &Attrs) -> Result<()> {
    if a.keyword("coordinate", &["local", "global"])? == Some("global") {
        return Err(a.error(
            a.element,
            "coordinate=\"global\" is not supported (nor by MuJoCo)",
        ));
    }
    if a.flag("fusestatic")? == Some(true) {
        return Err(a.error(a.element, "fusestatic=\"true\" is not supported"));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use std::f64::consts::PI;

    use super::super::test_util::*;

    #[test]
    fn hinge_angles_are_degrees_unless_radian() {
        let bodies = body(
            r#"<joint name="h" range="-90 45" ref="30" springref="60"/>
               <joint name="s" type="slide" range="-90 45" ref="30"/>"#,
        );
        let degree = PI / 180.0;
        let m = load(&model("", &bodies, ""));
        let (h, s) = (&m.joints[1], &m.joints[2]);
        assert_eq!(h.range, Some((-90.0 * degree, 45.0 * degree)));
        assert_eq!((h.reference, h.springref), (30.0 * degree, 60.0 * degree));
        assert_eq!((s.range, s.reference), (Some((-90.0, 45.0)), 30.0));

        let m = load(&model(r#"<compiler angle="radian"/>"#, &bodies, ""));
        assert_eq!(
            (m.joints[1].range, m.joints[1].reference),
            (Some((-90.0, 45.0)), 30.0)
        );

        let m = load(&model("", r#"<body axisangle="0 0 1 90"/>"#, ""));
        let half = 0.5f64.sqrt();
        assert_close(&quat_of(&m.bodies[1].rot), &[half, 0.0, 0.0, half], 1e-15);
    }
}
