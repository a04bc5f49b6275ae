//! Tendons as a model file gives them (MJCF `<tendon>`, MuJoCo's
//! mjsTendon): fixed and spatial.
//!
//! Conventions, MuJoCo 4's:
//! - A fixed tendon's length is L(q) = sum_k coef_k q_k over its joints
//!   (hinges and slides; q in radians or metres), its moment (Jacobian)
//!   dL/dq the coefficients at the joints' dofs, its velocity J v.
//! - A spatial tendon's path ([`Wrap`]) runs through sites (metres, world
//!   frame): its length is the sum of the straight segments between
//!   consecutive sites, where a sphere or cylinder geom between two sites
//!   may bend a segment around it (tangent lines and the arc between them),
//!   each branch after a pulley divided by the pulley's divisor. Its
//!   moment is dL/dq and its velocity J v as for a fixed one.
//! - Spring: with the deadband [lo, hi] (`springlength`), the force along
//!   the tendon is -stiffness (L - hi) above it, -stiffness (L - lo) below
//!   it, zero within; `springlength` -1 -1 (the default) means both ends
//!   at the length at qpos_spring (each joint at its `springref`). Damping: -damping L-dot. Both act on the dofs
//!   through J^T (explicitly, also under Euler, as MuJoCo's do).
//! - `range` bounds L by unilateral constraint rows within `margin`
//!   (solreflimit, solimplimit); `frictionloss` bounds a dry-friction row
//!   J (solreffriction, solimpfriction).

use super::SolParams;

/// One element of a spatial tendon's path (MJCF `<site>`, `<geom>`,
/// `<pulley>` in a `<spatial>`; indices into the spec's sites and geoms).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Wrap {
    Site(usize),
    /// A sphere or cylinder the path may wrap around between the sites
    /// before and after it; with a sidesite, on the side of that site.
    Geom {
        geom: usize,
        sidesite: Option<usize>,
    },
    /// Starts a branch whose length counts divided by `divisor`.
    Pulley {
        divisor: f64,
    },
}

/// One tendon.
#[derive(Clone, Debug, PartialEq)]
pub struct Tendon {
    pub name: String,
    /// A fixed tendon's terms: (joint index, coefficient); empty for a
    /// spatial one.
    pub joints: Vec<(usize, f64)>,
    /// A spatial tendon's path, in order; empty for a fixed one.
    pub spatial: Vec<Wrap>,
    pub stiffness: f64,
    pub damping: f64,
    /// The spring's deadband (lo, hi); None: the length at qpos_spring
    /// (MJCF `springlength="-1 -1"`).
    pub springlength: Option<[f64; 2]>,
    pub frictionloss: f64,
    /// The limited range of the length (None: not limited).
    pub range: Option<[f64; 2]>,
    pub margin: f64,
    pub limit_sol: SolParams,
    pub friction_sol: SolParams,
}

impl Tendon {
    /// Whether it changes the dynamics (beyond measuring).
    pub fn acts(&self) -> bool {
        self.stiffness != 0.0
            || self.damping != 0.0
            || self.frictionloss != 0.0
            || self.range.is_some()
    }

    /// Checks what MuJoCo would replace silently or what has no meaning
    /// (errors name the tendon): known hinges or slides, finite numbers,
    /// stiffness, damping, frictionloss and margin >= 0, a range with lo <
    /// hi, a deadband with lo <= hi, solver parameters.
    pub fn check(&self, joints: &[super::Joint]) -> Result<(), String> {
        let owner = format!("tendon '{}'", self.name);
        if self.joints.is_empty() && self.spatial.is_empty() {
            return Err(format!("{owner}: a fixed tendon needs at least one joint"));
        }
        check_path(&self.spatial).map_err(|e| format!("{owner}: {e}"))?;
        for (j, coef) in &self.joints {
            let Some(joint) = joints.get(*j) else {
                return Err(format!("{owner}: names a joint that does not exist"));
            };
            if !matches!(
                joint.kind,
                super::JointKind::Hinge | super::JointKind::Slide
            ) {
                let name = &joint.name;
                return Err(format!(
                    "{owner}: joint '{name}' must be a hinge or a slide"
                ));
            }
            if !coef.is_finite() {
                return Err(format!("{owner}: coef must be finite, got {coef}"));
            }
        }
        let positive = [
            ("stiffness", self.stiffness),
            ("damping", self.damping),
            ("frictionloss", self.frictionloss),
            ("margin", self.margin),
        ];
        for (what, x) in positive {
            if !(x.is_finite() && x >= 0.0) {
                return Err(format!("{owner}: {what} must be finite and >= 0, got {x}"));
            }
        }
        if let Some([lo, hi]) = self.range {
            if !(lo.is_finite() && hi.is_finite() && lo < hi) {
                return Err(format!(
                    "{owner}: range ({lo}, {hi}) must be finite with lo < hi"
                ));
            }
        }
        if let Some([lo, hi]) = self.springlength {
            if !(lo.is_finite() && hi.is_finite() && lo <= hi) {
                return Err(format!(
                    "{owner}: springlength ({lo}, {hi}) must be finite with lo <= hi"
                ));
            }
        }
        self.limit_sol.check(&owner)?;
        self.friction_sol.check(&owner)
    }
}

/// A spatial path as MuJoCo compiles it: sites at both ends, a geom
/// between two sites, a pulley between two sites with a divisor > 0.
fn check_path(path: &[Wrap]) -> Result<(), String> {
    let site = |k: Option<&Wrap>| matches!(k, Some(Wrap::Site(_)));
    if path.is_empty() {
        return Ok(());
    }
    if path.len() < 2 || !site(path.first()) || !site(path.last()) {
        return Err("a spatial path starts and ends at a site".into());
    }
    for (k, w) in path.iter().enumerate() {
        let between = site(path.get(k.wrapping_sub(1))) && site(path.get(k + 1));
        match w {
            Wrap::Site(_) => {}
            Wrap::Geom { .. } if !between => {
                return Err("a wrap geom stands between two sites".into());
            }
            Wrap::Pulley { divisor } if !(divisor.is_finite() && *divisor > 0.0) => {
                return Err(format!(
                    "a pulley's divisor must be finite and > 0, got {divisor}"
                ));
            }
            Wrap::Pulley { .. } if !between => {
                return Err("a pulley stands between two sites".into());
            }
            _ => {}
        }
    }
    Ok(())
}
