//! The parameters of the constraint contact model as a model file gives them:
//! MuJoCo's soft-constraint settings per geom, joint, explicit pair and for
//! the solver (see [`crate::dynamics::constraint`] for what they mean in the
//! dynamics).
//!
//! Conventions, MuJoCo's:
//! - `solref` = (timeconst, dampratio) when both are positive: the constraint
//!   behaves as a spring-damper with that time constant (s) and damping ratio;
//!   when both are <= 0 it is the direct form (-stiffness, -damping).
//! - `solimp` = (dmin, dmax, width, midpoint, power): the impedance d in
//!   (0, 1) rises from dmin at zero violation to dmax at a violation of
//!   `width` (m or rad), along a sigmoid of that midpoint and power.
//! - A contact is detected while its geoms are closer than margin + gap (m),
//!   and takes part in the solver while closer than margin.
//! - condim 1: frictionless; 3: sliding friction; 4: and torsional; 6: and
//!   rolling. Friction is (sliding, torsional, rolling).

use super::{CCD_ITERATIONS, CCD_TOLERANCE, MINVAL};

/// MuJoCo's default `solref` and `solimp`.
pub const SOLREF: [f64; 2] = [0.02, 1.0];
pub const SOLIMP: [f64; 5] = [0.9, 0.95, 0.001, 0.5, 2.0];

/// A constraint's reference (`solref`) and impedance (`solimp`); in the
/// model f64, in the dynamics any scalar (derivatives seed them).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SolParams<T = f64> {
    pub solref: [T; 2],
    pub solimp: [T; 5],
}

impl Default for SolParams {
    fn default() -> Self {
        SolParams {
            solref: SOLREF,
            solimp: SOLIMP,
        }
    }
}

impl SolParams {
    /// The values in scalar T, solref's lifted by `solref` and solimp's by
    /// `solimp` (component index, value).
    pub fn lift<T>(
        &self,
        solref: impl Fn(usize, f64) -> T,
        solimp: impl Fn(usize, f64) -> T,
    ) -> SolParams<T> {
        SolParams {
            solref: std::array::from_fn(|k| solref(k, self.solref[k])),
            solimp: std::array::from_fn(|k| solimp(k, self.solimp[k])),
        }
    }

    /// Checks the values MuJoCo would otherwise replace or clamp silently
    /// (errors name `owner`):
    /// solref of mixed sign; solimp with dmin, dmax or midpoint outside
    /// [0, 1], a negative width or a power below 1; anything not finite.
    pub fn check(&self, owner: &str) -> Result<(), String> {
        check_solref(&self.solref, owner, "solref")?;
        let [dmin, dmax, width, mid, power] = self.solimp;
        let unit = |x: f64| (0.0..=1.0).contains(&x);
        if !(unit(dmin) && unit(dmax) && width >= 0.0 && unit(mid) && power >= 1.0) {
            return Err(format!(
                "{owner}: solimp {:?} must have dmin, dmax and midpoint in [0, 1], \
                 width >= 0 and power >= 1",
                self.solimp
            ));
        }
        Ok(())
    }
}

/// Checks a solref: finite, both positive (time constant and damping ratio)
/// or both <= 0 (direct stiffness and damping).
pub fn check_solref(solref: &[f64; 2], owner: &str, what: &str) -> Result<(), String> {
    if !solref.iter().all(|x| x.is_finite()) || (solref[0] > 0.0) != (solref[1] > 0.0) {
        return Err(format!(
            "{owner}: {what} {solref:?} must be two positive numbers (time constant, damping \
             ratio) or two numbers <= 0 (-stiffness, -damping)"
        ));
    }
    Ok(())
}

/// How a geom's contacts are made and solved (MJCF geom attributes).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GeomContact {
    pub condim: usize,
    /// The pair takes condim, friction, solref and solimp from its geom of
    /// higher priority; at equal priority they mix (see [`crate::dynamics::collision`]).
    pub priority: i32,
    /// Weight of this geom's solref and solimp when they mix.
    pub solmix: f64,
    pub sol: SolParams,
    pub margin: f64,
    pub gap: f64,
}

impl Default for GeomContact {
    fn default() -> Self {
        GeomContact {
            condim: 3,
            priority: 0,
            solmix: 1.0,
            sol: SolParams::default(),
            margin: 0.0,
            gap: 0.0,
        }
    }
}

impl GeomContact {
    pub fn check(&self, owner: &str) -> Result<(), String> {
        check_condim(self.condim, owner)?;
        self.sol.check(owner)?;
        check_margin(self.margin, self.gap, owner)?;
        if !(self.solmix.is_finite() && self.solmix >= 0.0) {
            return Err(format!(
                "{owner}: solmix must be finite and >= 0, got {}",
                self.solmix
            ));
        }
        Ok(())
    }
}

fn check_condim(condim: usize, owner: &str) -> Result<(), String> {
    if ![1, 3, 4, 6].contains(&condim) {
        return Err(format!(
            "{owner}: condim must be 1, 3, 4 or 6, got {condim}"
        ));
    }
    Ok(())
}

fn check_margin(margin: f64, gap: f64, owner: &str) -> Result<(), String> {
    if !(margin.is_finite() && margin >= 0.0 && gap.is_finite() && gap >= 0.0) {
        return Err(format!(
            "{owner}: margin and gap must be finite and >= 0, got {margin} and {gap}"
        ));
    }
    Ok(())
}

/// What a geom pair's contacts carry into the solver: its own (an explicit
/// pair's) or its geoms' mixed (see [`crate::dynamics::collision`]). Friction
/// has MuJoCo's five components (sliding 1 and 2, torsional, rolling 1 and 2).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PairParams<T = f64> {
    pub condim: usize,
    pub friction: [T; 5],
    pub sol: SolParams<T>,
    /// The reference of the friction rows under elliptic cones; (0, 0) uses `sol.solref`.
    pub solreffriction: [T; 2],
    pub margin: f64,
    pub gap: f64,
}

/// An explicit contact pair (MJCF `<contact><pair>`): its geoms always
/// collide, with these parameters instead of the geoms' mix.
#[derive(Clone, Debug, PartialEq)]
pub struct ContactPair {
    pub name: String,
    pub geoms: [usize; 2],
    pub params: PairParams,
}

impl ContactPair {
    pub fn check(&self, ngeom: usize) -> Result<(), String> {
        let owner = format!("contact pair '{}'", self.name);
        if self.geoms.iter().any(|g| *g >= ngeom) || self.geoms[0] == self.geoms[1] {
            return Err(format!("{owner}: needs two different geoms"));
        }
        let p = &self.params;
        check_condim(p.condim, &owner)?;
        check_friction(&p.friction, &owner)?;
        p.sol.check(&owner)?;
        if p.solreffriction != [0.0; 2] {
            check_solref(&p.solreffriction, &owner, "solreffriction")?;
        }
        check_margin(p.margin, p.gap, &owner)
    }
}

/// Checks friction coefficients: finite and >= 0.
pub fn check_friction(friction: &[f64], owner: &str) -> Result<(), String> {
    if !friction.iter().all(|f| f.is_finite() && *f >= 0.0) {
        return Err(format!(
            "{owner}: friction {friction:?} must be finite and >= 0"
        ));
    }
    Ok(())
}

/// The friction cone of contacts with friction.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Cone {
    /// 2 (condim - 1) rows per contact, each the normal plus or minus mu
    /// times one tangent direction (MuJoCo's default).
    Pyramidal,
    /// condim rows per contact, the force inside |f_t / mu| <= f_n.
    Elliptic,
}

impl Cone {
    pub const NAMES: [(&'static str, Cone); 2] =
        [("pyramidal", Cone::Pyramidal), ("elliptic", Cone::Elliptic)];
}

/// Which contact and joint-limit law a model runs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ContactModel {
    /// Forces smooth in the state ([`crate::dynamics::contact`]): the
    /// default for models built in code.
    Smooth,
    /// MuJoCo's soft constraints solved to convergence
    /// ([`crate::dynamics::constraint`]): the default for MJCF and URDF
    /// files.
    Constraint,
}

impl ContactModel {
    pub const NAMES: [(&'static str, ContactModel); 2] = [
        ("smooth", ContactModel::Smooth),
        ("constraint", ContactModel::Constraint),
    ];
}

/// The constraint solver's settings (MJCF `<option>`). MuJoCo's `tolerance`
/// is not kept: the solver runs Newton's method until its answer is exact
/// (the final active set, the gradient at rounding level), at most
/// `iterations` Newton steps (MuJoCo's default 100 is far more than a
/// converging solve takes).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SolverOptions {
    pub cone: Cone,
    /// Ratio of frictional to normal impedance (MuJoCo's `impratio`).
    pub impratio: f64,
    pub iterations: usize,
    /// MuJoCo's flags: equality rows at all; dry-friction rows at all; a
    /// solref time constant of at least two timesteps; no contacts between
    /// a body and its parent.
    pub equality: bool,
    pub frictionloss: bool,
    pub refsafe: bool,
    pub filterparent: bool,
    /// MuJoCo's convex-collision settings (`ccd_iterations`,
    /// `ccd_tolerance`, the `nativeccd` and `multiccd` flags). The convex collider runs
    /// MuJoCo's defaults only; under any other setting its pairs have no
    /// collider ([`Ccd::is_default`]).
    pub ccd: Ccd,
    /// MuJoCo's noslip post-processing (`noslip_iterations`,
    /// `noslip_tolerance`), [`crate::dynamics::constraint::noslip`].
    pub noslip: NoSlip,
}

/// See [`SolverOptions::noslip`]: at most `iterations` sweeps (0, MuJoCo's
/// default, none), stopping once a sweep's scaled cost improvement falls
/// below `tolerance` (default 1e-6).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NoSlip {
    pub iterations: usize,
    pub tolerance: f64,
}

impl Default for NoSlip {
    fn default() -> Self {
        NoSlip {
            iterations: 0,
            tolerance: 1e-6,
        }
    }
}

/// See [`SolverOptions::ccd`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ccd {
    pub iterations: usize,
    pub tolerance: f64,
    /// MuJoCo's own GJK and EPA (else libccd's).
    pub native: bool,
    /// The `multiccd` flag: extra contacts of touching faces and edges.
    pub multi: bool,
}

impl Default for Ccd {
    fn default() -> Self {
        Ccd {
            iterations: CCD_ITERATIONS,
            tolerance: CCD_TOLERANCE,
            native: true,
            multi: true,
        }
    }
}

impl Ccd {
    /// Whether these are the settings the convex collider runs.
    pub fn is_default(&self) -> bool {
        *self == Ccd::default()
    }
}

impl Default for SolverOptions {
    fn default() -> Self {
        SolverOptions {
            cone: Cone::Pyramidal,
            impratio: 1.0,
            iterations: 100,
            equality: true,
            frictionloss: true,
            refsafe: true,
            filterparent: true,
            ccd: Ccd::default(),
            noslip: NoSlip::default(),
        }
    }
}

impl SolverOptions {
    pub fn check(&self) -> Result<(), String> {
        if !(self.impratio.is_finite() && self.impratio > 0.0) || self.iterations == 0 {
            return Err(format!(
                "impratio must be positive and iterations at least 1, got {} and {}",
                self.impratio, self.iterations
            ));
        }
        if self.noslip.tolerance.is_nan() {
            return Err("noslip_tolerance must be a number".into());
        }
        Ok(())
    }
}

/// The weight of the first geom's solref and solimp when two geoms of equal
/// priority mix theirs: solmix_1 / (solmix_1 + solmix_2), with MuJoCo's
/// rule for weights below 1e-15 (both: 0.5; one: the other geom's values).
pub fn solmix(first: f64, second: f64) -> f64 {
    match (first >= MINVAL, second >= MINVAL) {
        (true, true) => first / (first + second),
        (false, false) => 0.5,
        (false, true) => 0.0,
        (true, false) => 1.0,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn settings_mujoco_would_silently_replace_are_refused() {
        let sol = |solref, solimp| SolParams { solref, solimp };
        assert!(sol(SOLREF, SOLIMP).check("g").is_ok());
        assert!(sol([-1000.0, -10.0], [0.0, 1.0, 0.0, 0.0, 1.0])
            .check("g")
            .is_ok());
        for bad in [
            sol([0.02, 0.0], SOLIMP),
            sol([-1.0, 1.0], SOLIMP),
            sol([f64::NAN, 1.0], SOLIMP),
            sol(SOLREF, [1.1, 0.95, 0.001, 0.5, 2.0]),
            sol(SOLREF, [0.9, 0.95, -0.001, 0.5, 2.0]),
            sol(SOLREF, [0.9, 0.95, 0.001, 1.5, 2.0]),
            sol(SOLREF, [0.9, 0.95, 0.001, 0.5, 0.5]),
        ] {
            let e = bad.check("geom 'g'").unwrap_err();
            assert!(e.starts_with("geom 'g': sol"), "{e}");
        }
        let contact = |condim, margin, gap| GeomContact {
            condim,
            margin,
            gap,
            ..GeomContact::default()
        };
        assert!(contact(6, 0.01, 0.0).check("g").is_ok());
        for (bad, expected) in [
            (contact(2, 0.0, 0.0), "condim"),
            (contact(3, -0.01, 0.0), "margin and gap"),
            (contact(3, 0.0, -1.0), "margin and gap"),
        ] {
            assert!(bad.check("g").unwrap_err().contains(expected));
        }
    }

    #[test]
    fn solmix_follows_mujocos_rule() {
        assert_eq!(solmix(1.0, 3.0), 0.25);
        assert_eq!(solmix(0.0, 0.0), 0.5);
        assert_eq!(solmix(0.0, 2.0), 0.0);
        assert_eq!(solmix(2.0, 1e-16), 1.0);
    }
}
