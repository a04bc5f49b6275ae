//! Tendons as a model file gives them (MJCF `<tendon>`, MuJoCo's
//! mjsTendon); today fixed tendons.
//!
//! Conventions, MuJoCo 4's:
//! - A fixed tendon's length is L(q) = sum_k coef_k q_k over its joints
//!   (hinges and slides; q in radians or metres), its moment (Jacobian)
//!   dL/dq the coefficients at the joints' dofs, its velocity J v.
//! - Spring: with the deadband [lo, hi] (`springlength`), the force along
//!   the tendon is -stiffness (L - hi) above it, -stiffness (L - lo) below
//!   it, zero within; `springlength` -1 -1 (the default) means both ends
//!   at the length at qpos_spring (each joint at its `springref`). Damping: -damping L-dot. Both act on the dofs
//!   through J^T (explicitly, also under Euler, as MuJoCo's do).
//! - `range` bounds L by unilateral constraint rows within `margin`
//!   (solreflimit, solimplimit); `frictionloss` bounds a dry-friction row
//!   J (solreffriction, solimpfriction).

use super::SolParams;

/// One tendon.
#[derive(Clone, Debug, PartialEq)]
pub struct Tendon {
    pub name: String,
    /// A fixed tendon's terms: (joint index, coefficient).
    pub joints: Vec<(usize, f64)>,
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
        if self.joints.is_empty() {
            return Err(format!("{owner}: a fixed tendon needs at least one joint"));
        }
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
