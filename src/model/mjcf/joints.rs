//! `<joint>` and `<freejoint>`: hinges, slides, balls and free joints with
//! linear springs and dampers. Hinge `range`, `ref` and `springref` are
//! angles (see `compiler.rs`); a ball or free joint has no axis, `ref` or
//! `springref` (MuJoCo ignores them), and a free joint no anchor.

use nalgebra::Vector3;

use super::attributes::Attrs;
use super::frames::Member;
use super::orientation::unit;
use super::schema::{check_attributes, FREEJOINT_ATTRS, JOINT_ATTRS};
use super::tree::{Kind, Tree};
use super::{Reader, Result};
use crate::model::{Joint, JointKind};

impl<'a> Reader<'a> {
    /// A `<joint>`; its anchor and axis are moved out of its frames.
    pub(super) fn read_joint(
        &self,
        tree: &mut Tree<'a>,
        m: &Member<'a>,
        body: usize,
    ) -> Result<Joint> {
        let node = m.node;
        check_attributes(self.file, node, JOINT_ATTRS)?;
        let a = self.attrs(node, m.class, |c| &c.joint)?;
        let kind = joint_kind(&a)?;
        let axis = a.vector("axis")?.unwrap_or(Vector3::z());
        let axis = unit(axis).ok_or_else(|| self.error(node, "joint axis is too small"))?;
        let angle = |x: f64| match kind {
            JointKind::Hinge => self.compiler.joint_angle(x),
            JointKind::Slide => x,
            JointKind::Ball | JointKind::Free => 0.0,
        };
        let autolimits = self.compiler.autolimits;
        let range = a.limits("limited", "range", autolimits)?;
        let force_limits = a.limits("actuatorfrclimited", "actuatorfrcrange", autolimits)?;
        if force_limits.is_some() {
            return Err(self.error(node, "actuator force limits on joints are not supported"));
        }
        if a.flag("actuatorgravcomp")? == Some(true) {
            let msg = "actuatorgravcomp (gravity compensation routed through the actuators, \
                       clamped by their force range) is not supported; leave it false to apply \
                       gravcomp as a passive force";
            return Err(self.error(node, msg));
        }
        let (damping, stiffness) = damping_and_stiffness(&a)?;
        let joint = Joint {
            name: tree.claim(self.file, node, Kind::Joint, &m.suffix)?,
            kind,
            body,
            axis: match kind {
                JointKind::Hinge | JointKind::Slide => m.frame.rot * axis,
                JointKind::Ball | JointKind::Free => axis,
            },
            anchor: match kind {
                JointKind::Free => Vector3::zeros(),
                _ => m.frame.point(&a.vector("pos")?.unwrap_or_default()),
            },
            reference: angle(a.number("ref")?.unwrap_or(0.0)),
            damping,
            stiffness,
            springref: angle(a.number("springref")?.unwrap_or(0.0)),
            armature: a.number("armature")?.unwrap_or(0.0),
            frictionloss: a.number("frictionloss")?.unwrap_or(0.0),
            range: range.map(|[lo, hi]| (angle(lo), angle(hi))),
            margin: a.number("margin")?.unwrap_or(0.0),
            limit_sol: a.sol_params("solreflimit", "solimplimit")?,
            friction_sol: a.sol_params("solreffriction", "solimpfriction")?,
            springdamper: springdamper(&a)?,
        };
        let owner = format!("joint '{}'", joint.name);
        for sol in [&joint.limit_sol, &joint.friction_sol] {
            sol.check(&owner).map_err(|e| self.error(node, e))?;
        }
        if joint.margin < 0.0 {
            return Err(self.error(node, "margin must be >= 0"));
        }
        let passive = [
            joint.damping,
            joint.stiffness,
            joint.armature,
            joint.frictionloss,
        ];
        if passive.iter().any(|x| *x < 0.0) {
            let msg = "damping, stiffness, armature and frictionloss must be >= 0";
            return Err(self.error(node, msg));
        }
        if matches!(kind, JointKind::Ball | JointKind::Free) {
            if joint.range.is_some() {
                let msg = "limits on ball and free joints are not supported";
                return Err(self.error(node, msg));
            }
            if joint.frictionloss > 0.0 {
                let msg = "dry friction on ball and free joints is not supported";
                return Err(self.error(node, msg));
            }
        }
        Ok(joint)
    }

    /// `<freejoint>`: a free joint without damping, spring, armature or dry
    /// friction, whatever the defaults say (MuJoCo's shortcut).
    pub(super) fn read_freejoint(
        &self,
        tree: &mut Tree<'a>,
        m: &Member<'a>,
        body: usize,
    ) -> Result<Joint> {
        check_attributes(self.file, m.node, FREEJOINT_ATTRS)?;
        let name = tree.claim(self.file, m.node, Kind::Joint, &m.suffix)?;
        Ok(Joint::free(name, body))
    }
}

/// Hinge (the default), slide, ball or free.
fn joint_kind(a: &Attrs) -> Result<JointKind> {
    let kinds = [
        ("hinge", JointKind::Hinge),
        ("slide", JointKind::Slide),
        ("ball", JointKind::Ball),
        ("free", JointKind::Free),
    ];
    let names = kinds.map(|(name, _)| name);
    let name = a.keyword("type", &names)?.unwrap_or("hinge");
    Ok(kinds
        .iter()
        .find(|(n, _)| *n == name)
        .expect("a listed keyword")
        .1)
}

/// `springdamper`, unless absent or zero: both values positive, as MuJoCo
/// requires.
fn springdamper(a: &Attrs) -> Result<Option<[f64; 2]>> {
    match a.exact::<2>("springdamper")? {
        Some(s) if s != [0.0; 2] => {
            if !(s[0] > 0.0 && s[1] > 0.0) {
                let msg = "when defined, springdamper values must be positive";
                return Err(a.error(a.element, msg));
            }
            Ok(Some(s))
        }
        _ => Ok(None),
    }
}

/// The linear damping and stiffness coefficients; the polynomial terms of
/// `damping` and `stiffness` are rejected.
fn damping_and_stiffness(a: &Attrs) -> Result<(f64, f64)> {
    let damping = a.leading::<3>("damping", [0.0; 3])?;
    let stiffness = a.leading::<3>("stiffness", [0.0; 3])?;
    if damping[1..] != [0.0; 2] || stiffness[1..] != [0.0; 2] {
        let msg = "polynomial damping and stiffness are not supported";
        return Err(a.error(a.element, msg));
    }
    Ok((damping[0], stiffness[0]))
}
