//! `<option>` and its `<flag>`s, read into [`Options`]; every `<option>`
//! applies in document order over MuJoCo's defaults.
//!
//! `Euler`, `RK4`, `implicitfast` and `implicit` map to the [`Integrator`]
//! of the same name ([`Integrator::NAMES`]). The implicit ones treat
//! velocity-dependent forces implicitly (their velocity derivative,
//! MuJoCo's qDeriv, joins the mass matrix; `implicit` with the Coriolis
//! forces'; in a fluid the fluid forces' too). Passive forces are explicit under RK4 or when
//! `<flag eulerdamp="disable">` (Euler only), else damping is implicit (the
//! implicit integrators ignore eulerdamp, as MuJoCo does, and load with
//! [`PassiveMode::ImplicitDamping`], which they do not read).
//! `<flag gravity="disable">` loads as zero gravity; `<flag contact="disable">`
//! and `<flag limit="disable">` switch off [`Options::contact`] and
//! [`Options::limits`].
//!
//! An MJCF model runs the constraint contact model ([`ContactModel`]) unless
//! `<custom><text name="diffosi:contact" data="smooth"/></custom>` names the
//! smooth one. The solver's `cone`, `impratio`, `iterations`,
//! `noslip_iterations` and `noslip_tolerance` are read;
//! `solver`, `tolerance`, `jacobian` and the line-search settings only tune
//! how MuJoCo approaches the same answer and are ignored (ours converges).
//! The flags `constraint`, `equality`, `frictionloss`, `refsafe` and `filterparent` are
//! read into [`SolverOptions`]; the `override` flag changes the answer and
//! is rejected.
//!
//! The soft-contact constants ([`SoftOptions`]) are read from `<custom>`
//! numerics named `diffosi:<setting>` ([`SoftOptions::NAMES`]), one number
//! each; other numerics (and other custom elements) are ignored, as MuJoCo's
//! dynamics ignore them, and an unknown `diffosi:` name is an error.

use nalgebra::Vector3;

use super::attributes::Attrs;
use super::schema::{check_attributes, OPTION_ATTRS};
use super::{children, elements, tag, unrecognized, xml, Node, Result};
use crate::model::{
    Cone, ContactModel, Fluid, Integrator, Options, PassiveMode, SoftOptions, SolverOptions,
};

/// Flags that only concern contacts, constraints, sensors or the solver.
#[rustfmt::skip]
const IGNORED_FLAGS: &[&str] = &[
    "warmstart", "sensor", "midphase", "autoreset", "island",
    "energy", "fwdinv", "invdiscrete", "sleep", "diagexact",
];

/// Flags whose disabling changes the smooth dynamics in ways we do not model.
const REJECTED_FLAGS: &[&str] = &["spring", "damper", "clampctrl", "actuation"];

/// Flags whose enabling changes the contacts in ways we do not model.
const REJECTED_ENABLED: &[&str] = &["override"];

/// The `<flag>` settings we model; MuJoCo enables both by default.
struct Flags {
    /// Implicit joint damping under the Euler integrator.
    eulerdamp: bool,
    /// Gravity; disabled it is the same as zero gravity.
    gravity: bool,
    /// Contacts and joint limits ([`Options::contact`], [`Options::limits`]).
    contact: bool,
    limit: bool,
    /// All constraints; dry friction rows; the time-constant floor of
    /// solref; the parent-child contact filter ([`SolverOptions`]).
    constraint: bool,
    equality: bool,
    frictionloss: bool,
    refsafe: bool,
    filterparent: bool,
    nativeccd: bool,
    multiccd: bool,
}

pub fn read(file: &str, root: Node) -> Result<Options> {
    let mut opt = Options::default();
    let mut integrator = "Euler";
    let mut flags = Flags {
        eulerdamp: true,
        gravity: true,
        contact: true,
        limit: true,
        constraint: true,
        equality: true,
        frictionloss: true,
        refsafe: true,
        filterparent: true,
        nativeccd: true,
        multiccd: true,
    };
    for node in children(root, "option") {
        check_attributes(file, node, OPTION_ATTRS)?;
        let a = Attrs::of(file, node);
        if let Some(h) = a.number("timestep")? {
            if h <= 0.0 {
                return Err(a.error(node, format!("timestep must be positive, got {h}")));
            }
            opt.timestep = h;
        }
        opt.gravity = a.vector("gravity")?.unwrap_or(opt.gravity);
        opt.magnetic = a.vector("magnetic")?.unwrap_or(opt.magnetic);
        if let Some(name) = read_integrator(&a)? {
            integrator = name;
        }
        read_solver(&a, &mut opt.solver)?;
        read_fluid(&a, &mut opt.fluid)?;
        check_unsupported(&a)?;
        for flag in elements(node) {
            if tag(flag) != "flag" {
                return Err(unrecognized(file, flag));
            }
            read_flags(file, flag, &mut flags)?;
        }
    }
    let (_, chosen) = *Integrator::NAMES
        .iter()
        .find(|(name, _)| *name == integrator)
        .expect("read from the names");
    if !flags.gravity {
        opt.gravity = Vector3::zeros();
    }
    (opt.contact, opt.limits) = (
        flags.contact && flags.constraint,
        flags.limit && flags.constraint,
    );
    opt.solver.frictionloss = flags.frictionloss && flags.constraint;
    opt.solver.equality = flags.equality && flags.constraint;
    (opt.solver.refsafe, opt.solver.filterparent) = (flags.refsafe, flags.filterparent);
    (opt.solver.ccd.native, opt.solver.ccd.multi) = (flags.nativeccd, flags.multiccd);
    opt.contact_model = contact_model(file, root)?;
    opt.integrator = chosen;
    opt.passive = match integrator {
        "RK4" => PassiveMode::Explicit,
        "Euler" if !flags.eulerdamp => PassiveMode::Explicit,
        _ => PassiveMode::ImplicitDamping,
    };
    read_soft(file, root, &mut opt.soft)?;
    Ok(opt)
}

/// The `diffosi:` numerics of every `<custom>` section into `soft`.
fn read_soft(file: &str, root: Node, soft: &mut SoftOptions) -> Result<()> {
    for custom in children(root, "custom") {
        for numeric in children(custom, "numeric") {
            let a = Attrs::of(file, numeric);
            let Some(name) = a.text("name").and_then(|n| n.strip_prefix("diffosi:")) else {
                continue;
            };
            let Some((_, field)) = SoftOptions::NAMES.iter().find(|(n, _)| *n == name) else {
                let known = SoftOptions::NAMES.map(|(n, _)| n).join(", ");
                let msg = format!("unknown setting 'diffosi:{name}' (known: {known})");
                return Err(a.error(numeric, msg));
            };
            let Some(value) = a.number("data")? else {
                return Err(a.error(numeric, format!("diffosi:{name} needs its data")));
            };
            *field(soft) = value;
        }
    }
    Ok(())
}

fn read_solver(a: &Attrs, solver: &mut SolverOptions) -> Result<()> {
    if let Some(cone) = a.keyword("cone", &Cone::NAMES.map(|(n, _)| n))? {
        solver.cone = Cone::NAMES
            .iter()
            .find(|(n, _)| *n == cone)
            .expect("listed")
            .1;
    }
    solver.impratio = a.number("impratio")?.unwrap_or(solver.impratio);
    if let Some(n) = a.int("ccd_iterations")? {
        solver.ccd.iterations = usize::try_from(n).unwrap_or(0);
    }
    solver.ccd.tolerance = a.number("ccd_tolerance")?.unwrap_or(solver.ccd.tolerance);
    if let Some(n) = a.int("iterations")? {
        solver.iterations = usize::try_from(n).unwrap_or(0);
    }
    a.keyword("solver", &["PGS", "CG", "Newton"])?;
    if let Some(n) = a.int("noslip_iterations")? {
        solver.noslip.iterations = usize::try_from(n)
            .map_err(|_| a.error(a.element, "noslip_iterations must be non-negative"))?;
    }
    solver.noslip.tolerance = a
        .number("noslip_tolerance")?
        .unwrap_or(solver.noslip.tolerance);
    solver.check().map_err(|e| a.error(a.element, e))
}

/// The contact model a file asks for: `diffosi:contact` in `<custom><text>`,
/// else the constraint model.
fn contact_model(file: &str, root: Node) -> Result<ContactModel> {
    let names = ContactModel::NAMES.map(|(n, _)| n);
    for custom in children(root, "custom") {
        for text in children(custom, "text") {
            let a = Attrs::of(file, text);
            if a.text("name") != Some("diffosi:contact") {
                continue;
            }
            let Some(data) = a.keyword("data", &names)? else {
                return Err(a.error(text, "diffosi:contact needs its data"));
            };
            return Ok(ContactModel::NAMES
                .iter()
                .find(|(n, _)| *n == data)
                .expect("listed")
                .1);
        }
    }
    Ok(ContactModel::Constraint)
}

fn read_integrator(a: &Attrs) -> Result<Option<&'static str>> {
    a.keyword("integrator", &Integrator::NAMES.map(|(name, _)| name))
}

/// The medium: `density`, `viscosity` (finite, >= 0) and `wind`.
fn read_fluid(a: &Attrs, fluid: &mut Fluid) -> Result<()> {
    for (name, value) in [
        ("density", &mut fluid.density),
        ("viscosity", &mut fluid.viscosity),
    ] {
        if let Some(x) = a.number(name)? {
            if !(x.is_finite() && x >= 0.0) {
                return Err(a.error(
                    a.element,
                    format!("{name} must be finite and >= 0, got {x}"),
                ));
            }
            *value = x;
        }
    }
    fluid.wind = a.vector("wind")?.unwrap_or(fluid.wind);
    Ok(())
}

/// Disabled actuator groups.
fn check_unsupported(a: &Attrs) -> Result<()> {
    if a.text("actuatorgroupdisable").is_some() {
        return Err(a.error(a.element, "actuatorgroupdisable is not supported"));
    }
    Ok(())
}

/// Checks a `<flag>` element and applies it to `flags`.
fn read_flags(file: &str, flag: Node, flags: &mut Flags) -> Result<()> {
    for attr in flag.attributes() {
        let enabled = match attr.value() {
            "enable" => true,
            "disable" => false,
            v => {
                let msg = format!(
                    "flag '{}' must be enable or disable, got \"{v}\"",
                    attr.name()
                );
                return Err(xml::invalid(file, flag, msg));
            }
        };
        match attr.name() {
            "eulerdamp" => flags.eulerdamp = enabled,
            "gravity" => flags.gravity = enabled,
            "contact" => flags.contact = enabled,
            "limit" => flags.limit = enabled,
            "constraint" => flags.constraint = enabled,
            "equality" => flags.equality = enabled,
            "frictionloss" => flags.frictionloss = enabled,
            "refsafe" => flags.refsafe = enabled,
            "filterparent" => flags.filterparent = enabled,
            "nativeccd" => flags.nativeccd = enabled,
            "multiccd" => flags.multiccd = enabled,
            name if REJECTED_ENABLED.contains(&name) => {
                if enabled {
                    let msg = format!("flag {name}=\"enable\" is not supported");
                    return Err(xml::invalid(file, flag, msg));
                }
            }
            name if IGNORED_FLAGS.contains(&name) => {}
            name if REJECTED_FLAGS.contains(&name) => {
                if !enabled {
                    let msg = format!("flag {name}=\"disable\" is not supported");
                    return Err(xml::invalid(file, flag, msg));
                }
            }
            name => {
                let msg = format!("unrecognized attribute '{name}'");
                return Err(xml::invalid(file, flag, msg));
            }
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use nalgebra::Vector3;

    use super::super::test_util::*;
    use crate::model::{Integrator, PassiveMode, SoftOptions, SolverOptions};

    #[test]
    fn options_map_to_integrator_and_passive_mode() {
        use Integrator::{Euler, Implicit, ImplicitFast, Rk4};
        use PassiveMode::{Explicit, ImplicitDamping};
        #[rustfmt::skip]
        let cases = [
            ("", Euler, ImplicitDamping),
            (r#"<option integrator="RK4"/>"#, Rk4, Explicit),
            (r#"<option><flag eulerdamp="disable"/></option>"#, Euler, Explicit),
            (r#"<option integrator="implicitfast"/>"#, ImplicitFast, ImplicitDamping),
            (r#"<option integrator="implicitfast"><flag eulerdamp="disable"/></option>"#,
             ImplicitFast, ImplicitDamping),
            (r#"<option integrator="implicit"/>"#, Implicit, ImplicitDamping),
        ];
        for (option, integrator, passive) in cases {
            let m = load(&model(option, &body(""), ""));
            assert_eq!(
                (m.opt.integrator, m.opt.passive),
                (integrator, passive),
                "{option}"
            );
        }
        let option = r#"<option timestep="0.01" gravity="0 0 -1"/>"#;
        let m = load(&model(option, "", ""));
        assert_eq!((m.opt.timestep, m.opt.gravity), (0.01, -Vector3::z()));
        let m = load(&model(
            r#"<option><flag gravity="disable"/></option>"#,
            "",
            "",
        ));
        assert_eq!(m.opt.gravity, Vector3::zeros());
    }

    /// implicitfast and implicit load in a fluid (their qDeriv holds the
    /// fluid forces' derivative), and an edit may switch the fluid on.
    #[test]
    fn implicit_integrators_load_in_a_fluid() {
        let xml = model(
            r#"<option integrator="implicitfast" density="1.2"/>"#,
            &body(""),
            "",
        );
        assert_eq!(load(&xml).opt.integrator, Integrator::ImplicitFast);
        let m = load(&model(r#"<option integrator="implicit"/>"#, &body(""), ""));
        assert_eq!(
            m.edited(|s| s.opt.fluid.viscosity = 1e-5)
                .unwrap()
                .opt
                .fluid
                .viscosity,
            1e-5
        );
    }

    #[test]
    fn solver_options_flags_and_the_contact_model_are_read() {
        use crate::model::{Cone, ContactModel};
        let m = load(&model("", &body(""), ""));
        assert_eq!(m.opt.contact_model, ContactModel::Constraint);
        assert_eq!(m.opt.solver, SolverOptions::default());
        let xml = model(
            r#"<option ccd_iterations="50" ccd_tolerance="1e-8"><flag nativeccd="disable" multiccd="disable"/></option>"#,
            &body(""),
            "",
        );
        let expected = crate::model::Ccd {
            iterations: 50,
            tolerance: 1e-8,
            native: false,
            multi: false,
        };
        assert_eq!(load(&xml).opt.solver.ccd, expected);
        // The writer keeps them.
        let written = super::super::write(&super::super::parse(&xml, "t.xml").unwrap()).unwrap();
        assert_eq!(load(&written).opt.solver.ccd, expected);
        let option = r#"<option cone="elliptic" impratio="10" iterations="7" tolerance="1e-3">
            <flag frictionloss="disable" refsafe="disable" filterparent="disable"/></option>"#;
        let smooth = r#"<custom><text name="diffosi:contact" data="smooth"/></custom>"#;
        let m = load(&model(option, &body(""), smooth));
        let s = m.opt.solver;
        assert_eq!(
            (s.cone, s.impratio, s.iterations),
            (Cone::Elliptic, 10.0, 7)
        );
        assert!(!s.frictionloss && !s.refsafe && !s.filterparent);
        let noslip = r#"<option noslip_iterations="10" noslip_tolerance="1e-9"/>"#;
        let expected = crate::model::NoSlip {
            iterations: 10,
            tolerance: 1e-9,
        };
        let xml = model(noslip, &body(""), "");
        assert_eq!(load(&xml).opt.solver.noslip, expected);
        let written = super::super::write(&super::super::parse(&xml, "t.xml").unwrap()).unwrap();
        assert_eq!(load(&written).opt.solver.noslip, expected);
        assert_eq!(m.opt.contact_model, ContactModel::Smooth);
        let off = load(&model(
            r#"<option><flag constraint="disable"/></option>"#,
            "",
            "",
        ));
        assert!(!off.opt.contact && !off.opt.limits && !off.opt.solver.frictionloss);
        for (head, tail, expected) in [
            (
                r#"<option noslip_iterations="-3"/>"#,
                "",
                "noslip_iterations must be non-negative",
            ),
            (
                r#"<option><flag override="enable"/></option>"#,
                "",
                "override",
            ),
            (r#"<option impratio="0"/>"#, "", "impratio must be positive"),
            (r#"<option cone="round"/>"#, "", "cone"),
            (
                "",
                r#"<custom><text name="diffosi:contact" data="soft"/></custom>"#,
                "data",
            ),
        ] {
            assert_rejects(&model(head, "", tail), expected);
        }
    }

    #[test]
    fn soft_settings_come_from_diffosi_numerics() {
        let custom = r#"<custom><numeric name="other" data="1 2"/>
            <numeric name="diffosi:contact_stiffness" data="2500"/>
            <numeric name="diffosi:limit_width" data="0.002"/></custom>"#;
        let m = load(&model("", &body(""), custom));
        let expected = SoftOptions {
            stiffness: 2500.0,
            limit_width: 0.002,
            ..SoftOptions::default()
        };
        assert_eq!(m.opt.soft, expected);
        let typo = r#"<custom><numeric name="diffosi:contact_stifness" data="1"/></custom>"#;
        let (line, element, message) = error(&model("", "", typo));
        assert_eq!((line, element.as_str()), (1, "numeric"));
        assert!(
            message.contains("unknown setting 'diffosi:contact_stifness'"),
            "{message}"
        );
        let two = r#"<custom><numeric name="diffosi:contact_slip" data="1 2"/></custom>"#;
        let (_, _, message) = error(&model("", "", two));
        assert!(message.contains("needs 1 numbers"), "{message}");
    }
}
