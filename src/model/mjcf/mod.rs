//! MJCF loader: the part of MuJoCo's XML format that real robot models use, read
//! with the meaning MuJoCo 4's compiler gives it.
//!
//! Read: `<compiler>` (angle, eulerseq, inertiafromgeom, inertiagrouprange,
//! autolimits, settotalmass, boundmass, boundinertia, balanceinertia),
//! `<option>` (timestep, gravity, integrator, `<flag eulerdamp>`), `<default>`
//! classes for joints, geoms and actuators, `<worldbody>` with nested `<body>`,
//! `<joint>` (hinge, slide), `<inertial>`, `<geom>` (plane, sphere, capsule,
//! cylinder, box, ellipsoid), and `<actuator>` `<motor>`/`<general>` on joints.
//!
//! Ignored, since they do not change the smooth dynamics: visual, asset, size,
//! statistic, custom, keyframe, sensor, contact (pairs and exclusions), site,
//! camera, light, and contact/solver/limit attributes.
//!
//! Rejected with [`ModelError::Invalid`] naming the element and its line:
//! - what changes the dynamics beyond a tree of one-dof joints with linear
//!   passive forces and motors: free and ball joints, tendons, equalities,
//!   fluid forces (option density/viscosity, fluidshape), gravcomp, mocap
//!   bodies, the `implicit` integrator, disabling springs, dampers, actuation
//!   or control clamping, polynomial or springdamper joint
//!   parameters, joint actuator-force limits, and actuators other than motors
//!   on joints (servos, muscles, tendon/site/body transmissions, gains with
//!   bias or dynamics, force limits, actuator damping/armature/delay);
//! - what builds the model from elsewhere: include, frame, replicate,
//!   composite, flexcomp, attach, plugins, meshes, height fields, shell
//!   inertia, fusestatic, global coordinates;
//! - what MuJoCo rejects: unknown elements and attributes, malformed or
//!   miscounted numbers, unknown classes and joints, repeated names, zero axes
//!   and quaternions, bad ranges, non-physical inertias, moving bodies without
//!   mass;
//! - stricter than MuJoCo (which clamps or accepts them): negative masses and
//!   inertias, negative damping, stiffness, armature and frictionloss.
//!
//! XML syntax errors are [`ModelError::Xml`].
//!
//! Conventions (MuJoCo's unless said otherwise):
//! - The model's name is the `model` attribute, else "MuJoCo Model".
//! - Numbering: bodies depth-first in document order, the world (named "world")
//!   first; joints and geoms by body, in document order within a body;
//!   actuators in document order.
//! - Names: MuJoCo leaves unnamed objects nameless; here they are named
//!   `body<i>`, `joint<i>`, `geom<i>` or `actuator<i>` after their index, with
//!   `_` appended while a named object holds that name. Actuators can only
//!   refer to joints by their names in the file.
//! - Angles: `euler`, `axisangle` and hinge `range`, `ref`, `springref` are in
//!   degrees unless `<compiler angle="radian">`; `quat`, `xyaxes` and `zaxis`
//!   are never angles.
//! - Defaults: a class holds the `<joint>`, `<geom>` and actuator elements of
//!   its `<default>` and of every enclosing one. An attribute takes its value
//!   from the element, else from the innermost class element that sets it; a
//!   short list of numbers (`size`, `friction`, `gear`, ...) overwrites only the
//!   leading entries of the inherited one. An element uses its `class`, else the
//!   `childclass` of the nearest enclosing body that has one, else `main`. Of
//!   the orientation attributes, an alternative form (`axisangle`, `xyaxes`,
//!   `zaxis`, `euler`) set anywhere along that chain beats `quat`.
//! - Inertia: a body's mass, centre of mass and inertia come from its geoms when
//!   `inertiafromgeom` is true, or auto (the default) and the body has no
//!   `<inertial>`; see [`super::geom_inertia`]. Geoms count whatever their
//!   contype/conaffinity, if their group is in `inertiagrouprange`.
//! - Options: `Euler` and `RK4` map to [`Integrator::Euler`] and
//!   [`Integrator::Rk4`]. `implicitfast` differs from Euler only by treating
//!   velocity-dependent forces implicitly; with joint damping the only such
//!   force here, that is Euler with implicit damping, so it loads as
//!   [`Integrator::Euler`] with [`PassiveMode::ImplicitDamping`]. `implicit`
//!   also linearises Coriolis forces (an O(h) difference) and is rejected.
//!   Passive forces are explicit under RK4 or when `<flag eulerdamp="disable">`
//!   (Euler only), else damping is implicit. `<flag gravity="disable">` loads
//!   as zero gravity.
//! - Actuators: a `<general>` with gain `gainprm[0]` and gear `g` is stored
//!   with `gear = g * gainprm[0]`, the torque per unit control.

use std::collections::{HashMap, HashSet};
use std::f64::consts::PI;

use nalgebra::{Matrix3, Quaternion, Rotation3, Unit, UnitQuaternion, Vector3};

use super::geom_inertia::{self, MassProperties};
use super::{
    Actuator, Body, Geom, Integrator, Joint, JointKind, Model, ModelError, Options, PassiveMode,
    Shape,
};

type Node<'a> = roxmltree::Node<'a, 'a>;
type Result<T> = std::result::Result<T, ModelError>;

/// MuJoCo's `mjEPS`: smallest squared norm it normalises, smallest geom mass it
/// counts, smallest principal moment of a full inertia tensor.
const MJ_EPS: f64 = 1e-14;
/// MuJoCo's `mjMINVAL`: smallest mass and principal moment of a moving body.
const MJ_MINVAL: f64 = 1e-15;

/// Parses an MJCF document; `file` names it in errors.
pub fn parse(text: &str, file: &str) -> Result<Model> {
    let doc = roxmltree::Document::parse(text).map_err(|e| ModelError::Xml {
        file: file.to_string(),
        message: e.to_string(),
    })?;
    let root = doc.root_element();
    check_document(file, root)?;
    let mut reader = Reader {
        file,
        compiler: Compiler::read(file, root)?,
        classes: HashMap::from([("main", Class::default())]),
    };
    let opt = read_options(file, root)?;
    for section in children(root, "default") {
        reader.read_default(section, None)?;
    }
    let mut tree = Tree::new();
    reader.read_world(&mut tree, &children(root, "worldbody"))?;
    check_unsupported_sections(file, root)?;
    reader.check_moving_bodies(&tree)?;
    reader.scale_total_mass(&mut tree);
    let mut actuators = reader.read_actuators(&tree, root)?;
    fill_names(&mut actuators, "actuator", |a| &mut a.name);
    let (bodies, joints, geoms) = tree.finish();
    let name = root
        .attribute("model")
        .unwrap_or("MuJoCo Model")
        .to_string();
    Model::new(name, bodies, joints, actuators, geoms, opt)
}

// ---------------------------------------------------------------- errors, XML

fn invalid(file: &str, node: Node, message: impl Into<String>) -> ModelError {
    let pos = node.document().text_pos_at(node.range().start);
    ModelError::Invalid {
        file: file.to_string(),
        line: pos.row,
        element: node.tag_name().name().to_string(),
        message: message.into(),
    }
}

fn elements<'a>(node: Node<'a>) -> impl Iterator<Item = Node<'a>> {
    node.children().filter(|n| n.is_element())
}

fn children<'a>(node: Node<'a>, tag: &str) -> Vec<Node<'a>> {
    elements(node).filter(|n| n.has_tag_name(tag)).collect()
}

fn tag<'a>(node: Node<'a>) -> &'a str {
    node.tag_name().name()
}

/// Rejects attributes MuJoCo does not know (its schema check).
fn check_attributes(file: &str, node: Node, allowed: &[&str]) -> Result<()> {
    match node.attributes().find(|a| !allowed.contains(&a.name())) {
        Some(a) => Err(invalid(
            file,
            node,
            format!("unrecognized attribute '{}'", a.name()),
        )),
        None => Ok(()),
    }
}

/// Attributes of an element inside `<default>`: all but its name and class.
fn check_default_attributes(file: &str, node: Node, allowed: &[&str]) -> Result<()> {
    let in_default: Vec<&str> = allowed
        .iter()
        .copied()
        .filter(|a| !["name", "class"].contains(a))
        .collect();
    check_attributes(file, node, &in_default)
}

fn unsupported(file: &str, node: Node, why: &str) -> ModelError {
    invalid(
        file,
        node,
        format!("<{}> is not supported: {why}", tag(node)),
    )
}

/// The root must be `<mujoco>` and its sections MJCF sections.
fn check_document(file: &str, root: Node) -> Result<()> {
    if tag(root) != "mujoco" {
        return Err(invalid(
            file,
            root,
            "the top-level element of an MJCF file must be <mujoco>",
        ));
    }
    check_attributes(file, root, &["model"])?;
    if let Some(include) = root.descendants().find(|n| n.has_tag_name("include")) {
        return Err(unsupported(
            file,
            include,
            "merge the included file into this one",
        ));
    }
    const SECTIONS: &[&str] = &[
        "compiler",
        "option",
        "size",
        "statistic",
        "visual",
        "default",
        "asset",
        "worldbody",
        "contact",
        "actuator",
        "sensor",
        "custom",
        "keyframe",
        "tendon",
        "equality",
        "deformable",
        "extension",
    ];
    match elements(root).find(|s| !SECTIONS.contains(&tag(*s))) {
        Some(s) => Err(invalid(
            file,
            s,
            format!("unrecognized element <{}>", tag(s)),
        )),
        None => Ok(()),
    }
}

/// Sections that change the dynamics beyond what a Model holds must be empty.
/// (Checked after the bodies, whose problems tend to be the more basic ones.)
fn check_unsupported_sections(file: &str, root: Node) -> Result<()> {
    for section in elements(root) {
        let why = match tag(section) {
            "tendon" => "tendons change the dynamics",
            "equality" => "equality constraints change the dynamics",
            "deformable" => "flexes and skins change the dynamics",
            "extension" => "plugins change the dynamics",
            _ => continue,
        };
        if let Some(first) = elements(section).next() {
            return Err(unsupported(file, first, why));
        }
    }
    Ok(())
}

// ------------------------------------------------------------------ attributes

/// One element's attributes as MuJoCo resolves them: its own, else those of its
/// default class elements (innermost first).
#[derive(Clone, Copy)]
struct Attrs<'a, 'b> {
    file: &'a str,
    /// The class's elements of this kind, outermost first.
    defaults: &'b [Node<'a>],
    element: Node<'a>,
}

impl<'a, 'b> Attrs<'a, 'b> {
    /// An element that takes no defaults.
    fn of(file: &'a str, element: Node<'a>) -> Self {
        Attrs {
            file,
            defaults: &[],
            element,
        }
    }

    /// Class elements then the element itself.
    fn nodes(&self) -> impl DoubleEndedIterator<Item = Node<'a>> + 'b {
        self.defaults
            .iter()
            .copied()
            .chain(std::iter::once(self.element))
    }

    /// The innermost value of `name` with the node that sets it (an empty value
    /// counts as unset, as in MuJoCo).
    fn find(&self, name: &str) -> Option<(Node<'a>, &'a str)> {
        self.nodes()
            .rev()
            .find_map(|n| value(n, name).map(|v| (n, v)))
    }

    fn text(&self, name: &str) -> Option<&'a str> {
        self.find(name).map(|(_, v)| v)
    }

    fn error(&self, node: Node, message: impl Into<String>) -> ModelError {
        invalid(self.file, node, message)
    }

    /// Exactly `N` numbers.
    fn exact<const N: usize>(&self, name: &str) -> Result<Option<[f64; N]>> {
        let Some((node, text)) = self.find(name) else {
            return Ok(None);
        };
        let v = self.numbers(node, name, text)?;
        let n = v.len();
        v.try_into().map(Some).map_err(|_| {
            self.error(
                node,
                format!("attribute '{name}' needs {N} numbers, got {n}: \"{text}\""),
            )
        })
    }

    fn number(&self, name: &str) -> Result<Option<f64>> {
        Ok(self.exact::<1>(name)?.map(|[x]| x))
    }

    /// Up to `N` numbers, each setting overwriting the leading entries of the
    /// value so far, which starts at `init` (MuJoCo's `size`, `gear`, ...).
    fn leading<const N: usize>(&self, name: &str, init: [f64; N]) -> Result<[f64; N]> {
        let mut out = init;
        for node in self.nodes() {
            let Some(text) = value(node, name) else {
                continue;
            };
            let v = self.numbers(node, name, text)?;
            if v.len() > N {
                let msg = format!("attribute '{name}' takes at most {N} numbers, got \"{text}\"");
                return Err(self.error(node, msg));
            }
            out[..v.len()].copy_from_slice(&v);
        }
        Ok(out)
    }

    fn numbers(&self, node: Node, name: &str, text: &str) -> Result<Vec<f64>> {
        let parse = |t: &str| t.parse::<f64>().ok().filter(|x| x.is_finite());
        text.split_whitespace()
            .map(parse)
            .collect::<Option<Vec<f64>>>()
            .ok_or_else(|| {
                self.error(
                    node,
                    format!("attribute '{name}' must be finite numbers, got \"{text}\""),
                )
            })
    }

    fn ints<const N: usize>(&self, name: &str) -> Result<Option<[i64; N]>> {
        let Some((node, text)) = self.find(name) else {
            return Ok(None);
        };
        let bad = || {
            self.error(
                node,
                format!("attribute '{name}' needs {N} integers, got \"{text}\""),
            )
        };
        let v = text.split_whitespace().map(|t| t.parse::<i64>().ok());
        let v = v.collect::<Option<Vec<i64>>>().ok_or_else(bad)?;
        v.try_into().map(Some).map_err(|_| bad())
    }

    fn int(&self, name: &str) -> Result<Option<i64>> {
        Ok(self.ints::<1>(name)?.map(|[x]| x))
    }

    fn keyword(&self, name: &str, allowed: &[&'static str]) -> Result<Option<&'static str>> {
        let Some((node, v)) = self.find(name) else {
            return Ok(None);
        };
        match allowed.iter().find(|k| **k == v) {
            Some(k) => Ok(Some(*k)),
            None => {
                let msg = format!("attribute '{name}' must be one of {allowed:?}, got \"{v}\"");
                Err(self.error(node, msg))
            }
        }
    }

    fn flag(&self, name: &str) -> Result<Option<bool>> {
        Ok(self.keyword(name, &["false", "true"])?.map(|k| k == "true"))
    }

    fn vector(&self, name: &str) -> Result<Option<Vector3<f64>>> {
        Ok(self.exact::<3>(name)?.map(Vector3::from))
    }

    /// MuJoCo's limits: `limited` is false, true, or auto (limited when a
    /// `range` is given in increasing order). Returns the range if limited.
    fn limits(&self, limited: &str, range: &str, autolimits: bool) -> Result<Option<[f64; 2]>> {
        let r = self.exact::<2>(range)?.unwrap_or([0.0; 2]);
        let mode = self
            .keyword(limited, &["false", "true", "auto"])?
            .unwrap_or("auto");
        if mode == "auto" && r != [0.0; 2] && !autolimits {
            let msg = format!(
                "'{range}' without '{limited}': set <compiler autolimits=\"true\"> or '{limited}'"
            );
            return Err(self.error(self.element, msg));
        }
        let on = mode == "true" || (mode == "auto" && r[0] < r[1]);
        if on && r[0] >= r[1] {
            let msg = format!("{range}[0] must be smaller than {range}[1], got {r:?}");
            return Err(self.error(self.element, msg));
        }
        Ok(on.then_some(r))
    }
}

fn value<'a>(node: Node<'a>, name: &str) -> Option<&'a str> {
    node.attribute(name).filter(|v| !v.trim().is_empty())
}

// ---------------------------------------------------------- compiler, options

#[derive(Clone, Copy, PartialEq, Eq)]
enum FromGeom {
    False,
    True,
    Auto,
}

/// The `<compiler>` settings that change the compiled model.
struct Compiler {
    degree: bool,
    eulerseq: [u8; 3],
    inertia_from_geom: FromGeom,
    inertia_groups: [i64; 2],
    autolimits: bool,
    settotalmass: f64,
    boundmass: f64,
    boundinertia: f64,
    balanceinertia: bool,
}

#[rustfmt::skip]
const COMPILER_ATTRS: &[&str] = &[
    "autolimits", "boundmass", "boundinertia", "settotalmass", "balanceinertia", "strippath",
    "coordinate", "angle", "fitaabb", "eulerseq", "meshdir", "texturedir", "discardvisual",
    "usethread", "fusestatic", "inertiafromgeom", "inertiagrouprange", "saveinertial", "assetdir",
    "alignfree", "conflict",
];

impl Compiler {
    /// MuJoCo's defaults, then every `<compiler>` in document order.
    fn read(file: &str, root: Node) -> Result<Compiler> {
        let mut c = Compiler {
            degree: true,
            eulerseq: *b"xyz",
            inertia_from_geom: FromGeom::Auto,
            inertia_groups: [0, 5],
            autolimits: true,
            settotalmass: -1.0,
            boundmass: 0.0,
            boundinertia: 0.0,
            balanceinertia: false,
        };
        for node in children(root, "compiler") {
            check_attributes(file, node, COMPILER_ATTRS)?;
            let a = Attrs::of(file, node);
            if let Some(angle) = a.keyword("angle", &["degree", "radian"])? {
                c.degree = angle == "degree";
            }
            if let Some(seq) = a.text("eulerseq") {
                c.eulerseq = seq
                    .as_bytes()
                    .try_into()
                    .ok()
                    .filter(|s: &[u8; 3]| s.iter().all(|b| b"xyzXYZ".contains(b)))
                    .ok_or_else(|| a.error(node, "eulerseq must be 3 of x, y, z, X, Y, Z"))?;
            }
            if let Some(k) = a.keyword("inertiafromgeom", &["false", "true", "auto"])? {
                c.inertia_from_geom = match k {
                    "false" => FromGeom::False,
                    "true" => FromGeom::True,
                    _ => FromGeom::Auto,
                };
            }
            c.inertia_groups = a
                .ints::<2>("inertiagrouprange")?
                .unwrap_or(c.inertia_groups);
            c.autolimits = a.flag("autolimits")?.unwrap_or(c.autolimits);
            c.settotalmass = a.number("settotalmass")?.unwrap_or(c.settotalmass);
            c.boundmass = a.number("boundmass")?.unwrap_or(c.boundmass);
            c.boundinertia = a.number("boundinertia")?.unwrap_or(c.boundinertia);
            c.balanceinertia = a.flag("balanceinertia")?.unwrap_or(c.balanceinertia);
            if a.keyword("coordinate", &["local", "global"])? == Some("global") {
                return Err(a.error(
                    node,
                    "coordinate=\"global\" is not supported (nor by MuJoCo)",
                ));
            }
            if a.flag("fusestatic")? == Some(true) {
                return Err(a.error(node, "fusestatic=\"true\" is not supported"));
            }
        }
        Ok(c)
    }

    /// MuJoCo's conversion of joint angles (`range`, `ref`, `springref`).
    fn joint_angle(&self, x: f64) -> f64 {
        if self.degree {
            x * (PI / 180.0)
        } else {
            x
        }
    }

    /// MuJoCo's conversion of orientation angles (`euler`, `axisangle`).
    fn frame_angle(&self, x: f64) -> f64 {
        if self.degree {
            x / 180.0 * PI
        } else {
            x
        }
    }
}

#[rustfmt::skip]
const OPTION_ATTRS: &[&str] = &[
    "timestep", "impratio", "tolerance", "ls_tolerance", "noslip_tolerance", "ccd_tolerance",
    "sleep_tolerance", "gravity", "wind", "magnetic", "density", "viscosity", "o_margin",
    "o_solref", "o_solimp", "o_friction", "integrator", "cone", "jacobian", "solver", "iterations",
    "ls_iterations", "noslip_iterations", "ccd_iterations", "sdf_iterations", "sdf_initpoints",
    "actuatorgroupdisable",
];

/// Flags that only concern contacts, constraints, sensors or the solver.
#[rustfmt::skip]
const IGNORED_FLAGS: &[&str] = &[
    "constraint", "equality", "frictionloss", "limit", "contact", "warmstart", "filterparent",
    "refsafe", "sensor", "midphase", "autoreset", "nativeccd", "island", "multiccd", "override",
    "energy", "fwdinv", "invdiscrete", "sleep", "diagexact",
];

/// Flags whose disabling changes the smooth dynamics in ways we do not model.
const REJECTED_FLAGS: &[&str] = &["spring", "damper", "clampctrl", "actuation"];

/// The `<flag>` settings we model; MuJoCo enables both by default.
struct Flags {
    /// Implicit joint damping under the Euler integrator.
    eulerdamp: bool,
    /// Gravity; disabled it is the same as zero gravity.
    gravity: bool,
}

/// Every `<option>` in document order, over MuJoCo's defaults.
fn read_options(file: &str, root: Node) -> Result<Options> {
    let mut opt = Options::default();
    let mut integrator = "Euler";
    let mut flags = Flags {
        eulerdamp: true,
        gravity: true,
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
        let integrators = ["Euler", "RK4", "implicit", "implicitfast"];
        integrator = a.keyword("integrator", &integrators)?.unwrap_or(integrator);
        if integrator == "implicit" {
            let msg = "integrator \"implicit\" is not supported: it linearises Coriolis forces; \
                       use Euler, RK4 or implicitfast";
            return Err(a.error(node, msg));
        }
        let density = a.number("density")?.unwrap_or(0.0);
        let viscosity = a.number("viscosity")?.unwrap_or(0.0);
        if density != 0.0 || viscosity != 0.0 {
            let msg = format!(
                "fluid forces are not supported (density=\"{density}\" viscosity=\"{viscosity}\")"
            );
            return Err(a.error(node, msg));
        }
        if a.text("actuatorgroupdisable").is_some() {
            return Err(a.error(node, "actuatorgroupdisable is not supported"));
        }
        for flag in elements(node) {
            if tag(flag) != "flag" {
                return Err(invalid(
                    file,
                    flag,
                    format!("unrecognized element <{}>", tag(flag)),
                ));
            }
            read_flags(file, flag, &mut flags)?;
        }
    }
    if !flags.gravity {
        opt.gravity = Vector3::zeros();
    }
    opt.integrator = if integrator == "RK4" {
        Integrator::Rk4
    } else {
        Integrator::Euler
    };
    opt.passive = match integrator {
        "RK4" => PassiveMode::Explicit,
        "Euler" if !flags.eulerdamp => PassiveMode::Explicit,
        _ => PassiveMode::ImplicitDamping,
    };
    Ok(opt)
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
                return Err(invalid(file, flag, msg));
            }
        };
        match attr.name() {
            "eulerdamp" => flags.eulerdamp = enabled,
            "gravity" => flags.gravity = enabled,
            name if IGNORED_FLAGS.contains(&name) => {}
            name if REJECTED_FLAGS.contains(&name) => {
                if !enabled {
                    let msg = format!("flag {name}=\"disable\" is not supported");
                    return Err(invalid(file, flag, msg));
                }
            }
            name => {
                return Err(invalid(
                    file,
                    flag,
                    format!("unrecognized attribute '{name}'"),
                ))
            }
        }
    }
    Ok(())
}

// -------------------------------------------------------------------- defaults

/// A default class: its joint, geom and actuator elements and those of every
/// enclosing class, outermost first.
#[derive(Clone, Default)]
struct Class<'a> {
    joint: Vec<Node<'a>>,
    geom: Vec<Node<'a>>,
    actuator: Vec<Node<'a>>,
}

/// Actuator shortcuts MuJoCo accepts in `<default>` and `<actuator>`.
#[rustfmt::skip]
const ACTUATOR_KINDS: &[&str] = &[
    "general", "motor", "position", "velocity", "damper", "intvelocity", "orientation", "pid",
    "cylinder", "muscle", "adhesion", "dcmotor",
];

/// Default elements that only set up elements we ignore or reject anyway.
#[rustfmt::skip]
const INERT_DEFAULTS: &[&str] = &[
    "mesh", "material", "site", "camera", "light", "pair", "equality", "tendon",
];

// ------------------------------------------------------------- orientations

const ALTERNATIVES: [&str; 4] = ["axisangle", "xyaxes", "zaxis", "euler"];

/// MuJoCo's minimal rotation taking the z axis to the unit vector `v`.
fn z_to(v: &Vector3<f64>) -> Rotation3<f64> {
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
fn unit(v: Vector3<f64>) -> Option<Vector3<f64>> {
    let n2 = v.norm_squared();
    (n2 >= MJ_EPS).then(|| v / n2.sqrt())
}

// ---------------------------------------------------------------- inertials

/// A body's inertial properties in MuJoCo's form: principal `moments` along
/// the columns of `axes` (body coordinates), about `com`.
#[derive(Clone, Debug)]
struct Principal {
    mass: f64,
    com: Vector3<f64>,
    axes: Matrix3<f64>,
    moments: Vector3<f64>,
}

impl Principal {
    fn massless() -> Self {
        Principal {
            mass: 0.0,
            com: Vector3::zeros(),
            axes: Matrix3::identity(),
            moments: Vector3::zeros(),
        }
    }

    /// The principal form of a full tensor; `None` unless its moments are all
    /// at least `mjEPS` (MuJoCo's requirement).
    fn from_tensor(mass: f64, com: Vector3<f64>, tensor: Matrix3<f64>) -> Option<Self> {
        let eig = tensor.symmetric_eigen();
        (eig.eigenvalues.min() >= MJ_EPS).then_some(Principal {
            mass,
            com,
            axes: eig.eigenvectors,
            moments: eig.eigenvalues,
        })
    }

    fn mass_properties(&self) -> MassProperties {
        MassProperties::from_principal(self.mass, self.com, &self.axes, &self.moments)
    }

    fn has_mass(&self) -> bool {
        self.mass >= MJ_MINVAL && self.moments.min() >= MJ_MINVAL
    }
}

// ------------------------------------------------------------------- the tree

/// The bodies, joints and geoms read so far, with what the later checks need.
struct Tree<'a> {
    bodies: Vec<Body>,
    /// Per body: its inertial properties (bodies get theirs at the end).
    inertials: Vec<Principal>,
    /// Per body: its element (`None` for the world).
    nodes: Vec<Option<Node<'a>>>,
    joints: Vec<Joint>,
    geoms: Vec<Geom>,
    names: [HashSet<String>; 3],
}

#[derive(Clone, Copy)]
enum Kind {
    Body = 0,
    Joint = 1,
    Geom = 2,
}

impl<'a> Tree<'a> {
    fn new() -> Self {
        let world = Body {
            name: "world".into(),
            parent: 0,
            pos: Vector3::zeros(),
            rot: Rotation3::identity(),
            mass: 0.0,
            com: Vector3::zeros(),
            inertia: Matrix3::zeros(),
            joints: 0..0,
        };
        Tree {
            bodies: vec![world],
            inertials: vec![Principal::massless()],
            nodes: vec![None],
            joints: vec![],
            geoms: vec![],
            names: [
                HashSet::from(["world".to_string()]),
                HashSet::new(),
                HashSet::new(),
            ],
        }
    }

    /// Records an explicit name; MuJoCo rejects a repeated one.
    fn claim(&mut self, file: &str, node: Node, kind: Kind) -> Result<String> {
        let name = node.attribute("name").unwrap_or("");
        if !name.is_empty() && !self.names[kind as usize].insert(name.to_string()) {
            return Err(invalid(file, node, format!("repeated name '{name}'")));
        }
        Ok(name.to_string())
    }

    /// The bodies (with their final inertial properties), joints and geoms,
    /// every one named.
    fn finish(mut self) -> (Vec<Body>, Vec<Joint>, Vec<Geom>) {
        for (body, p) in self.bodies.iter_mut().zip(&self.inertials).skip(1) {
            body.mass = p.mass;
            body.com = p.com;
            body.inertia = p.mass_properties().inertia;
        }
        fill_names(&mut self.bodies, "body", |b| &mut b.name);
        fill_names(&mut self.joints, "joint", |j| &mut j.name);
        fill_names(&mut self.geoms, "geom", |g| &mut g.name);
        (self.bodies, self.joints, self.geoms)
    }
}

/// Names unnamed items `<prefix><index>`, appending `_` while that is taken.
fn fill_names<T>(items: &mut [T], prefix: &str, name: impl Fn(&mut T) -> &mut String) {
    let mut taken: HashSet<String> = items.iter_mut().map(|i| name(i).clone()).collect();
    for (i, item) in items.iter_mut().enumerate() {
        let n = name(item);
        if n.is_empty() {
            let mut generated = format!("{prefix}{i}");
            while taken.contains(&generated) {
                generated.push('_');
            }
            taken.insert(generated.clone());
            *n = generated;
        }
    }
}

// ------------------------------------------------------------------ the reader

#[rustfmt::skip]
const BODY_ATTRS: &[&str] = &[
    "name", "childclass", "pos", "quat", "axisangle", "xyaxes", "zaxis", "euler", "mocap",
    "gravcomp", "sleep", "simple", "user",
];
#[rustfmt::skip]
const INERTIAL_ATTRS: &[&str] = &[
    "pos", "quat", "mass", "diaginertia", "axisangle", "xyaxes", "zaxis", "euler", "fullinertia",
];
#[rustfmt::skip]
const JOINT_ATTRS: &[&str] = &[
    "name", "class", "type", "group", "pos", "axis", "springdamper", "limited",
    "actuatorfrclimited", "solreflimit", "solimplimit", "solreffriction", "solimpfriction",
    "stiffness", "range", "actuatorfrcrange", "actuatorgravcomp", "margin", "ref", "springref",
    "armature", "damping", "frictionloss", "user",
];
#[rustfmt::skip]
const GEOM_ATTRS: &[&str] = &[
    "name", "class", "type", "contype", "conaffinity", "condim", "group", "priority", "size",
    "material", "friction", "mass", "density", "shellinertia", "solmix", "solref", "solimp",
    "margin", "gap", "surfacevel", "adhesion", "fromto", "pos", "quat", "axisangle", "xyaxes",
    "zaxis", "euler", "hfield", "mesh", "fitscale", "rgba", "fluidshape", "fluidcoef", "user",
];
#[rustfmt::skip]
const MOTOR_ATTRS: &[&str] = &[
    "name", "class", "group", "nsample", "interp", "delay", "ctrlrange", "user", "ctrllimited",
    "forcelimited", "forcerange", "lengthrange", "gear", "damping", "armature", "cranklength",
    "joint", "jointinparent", "tendon", "slidersite", "cranksite", "site", "refsite",
];
#[rustfmt::skip]
const GENERAL_ONLY_ATTRS: &[&str] = &[
    "actlimited", "actrange", "body", "actdim", "input", "velrange", "ffrange", "dyntype",
    "gaintype", "biastype", "dynprm", "gainprm", "biasprm", "actearly",
];

/// Reads the model once the compiler settings are known.
struct Reader<'a> {
    file: &'a str,
    compiler: Compiler,
    classes: HashMap<&'a str, Class<'a>>,
}

impl<'a> Reader<'a> {
    fn error(&self, node: Node, message: impl Into<String>) -> ModelError {
        invalid(self.file, node, message)
    }

    /// Reads a `<default>` and the classes nested in it. `parent` is the
    /// enclosing class; top-level defaults all add to `main`.
    fn read_default(&mut self, node: Node<'a>, parent: Option<&'a str>) -> Result<()> {
        check_attributes(self.file, node, &["class"])?;
        let name = match (parent, value(node, "class")) {
            (None, None | Some("main")) => "main",
            (None, Some(_)) => return Err(self.error(node, "the top-level class is 'main'")),
            (Some(_), None) => return Err(self.error(node, "a nested <default> needs a class")),
            (Some(_), Some(name)) if self.classes.contains_key(name) => {
                return Err(self.error(node, format!("repeated default class '{name}'")));
            }
            (Some(_), Some(name)) => name,
        };
        let mut class = self.classes[parent.unwrap_or("main")].clone();
        for child in elements(node) {
            match tag(child) {
                "joint" => {
                    check_default_attributes(self.file, child, JOINT_ATTRS)?;
                    class.joint.push(child);
                }
                "geom" => {
                    check_default_attributes(self.file, child, GEOM_ATTRS)?;
                    class.geom.push(child);
                }
                "motor" => {
                    check_default_attributes(self.file, child, MOTOR_ATTRS)?;
                    class.actuator.push(child);
                }
                "general" => {
                    let attrs = [MOTOR_ATTRS, GENERAL_ONLY_ATTRS].concat();
                    check_default_attributes(self.file, child, &attrs)?;
                    class.actuator.push(child);
                }
                kind if ACTUATOR_KINDS.contains(&kind) => class.actuator.push(child),
                "default" => {}
                kind if INERT_DEFAULTS.contains(&kind) => {}
                other => return Err(self.error(child, format!("unrecognized element <{other}>"))),
            }
        }
        self.classes.insert(name, class);
        for nested in children(node, "default") {
            self.read_default(nested, Some(name))?;
        }
        Ok(())
    }

    /// The class named by `attr` (class or childclass) of `node`, if any.
    fn class_name(&self, node: Node<'a>, attr: &str) -> Result<Option<&'a str>> {
        match value(node, attr) {
            Some(name) if !self.classes.contains_key(name) => {
                Err(self.error(node, format!("unknown default class '{name}'")))
            }
            found => Ok(found),
        }
    }

    /// `node`'s attributes with the defaults of its class, else of `inherited`.
    fn attrs<'s>(
        &'s self,
        node: Node<'a>,
        inherited: &str,
        pick: for<'c> fn(&'c Class<'a>) -> &'c Vec<Node<'a>>,
    ) -> Result<Attrs<'a, 's>> {
        let name = self.class_name(node, "class")?.unwrap_or(inherited);
        Ok(Attrs {
            file: self.file,
            defaults: pick(&self.classes[name]),
            element: node,
        })
    }

    /// The rotation given by an element's orientation attributes.
    fn orientation(&self, a: &Attrs<'a, '_>) -> Result<Rotation3<f64>> {
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
            return self.alternative(Attrs::of(self.file, node), kind);
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

    /// axisangle, xyaxes, zaxis or euler, converted as MuJoCo does.
    fn alternative(&self, a: Attrs<'a, '_>, kind: &str) -> Result<Rotation3<f64>> {
        let node = a.element;
        let too_small = |what: &str| self.error(node, format!("{kind}: {what} is too small"));
        match kind {
            "axisangle" => {
                let [x, y, z, angle] = a.exact::<4>(kind)?.unwrap_or_default();
                let axis = unit(Vector3::new(x, y, z)).ok_or_else(|| too_small("axis"))?;
                let angle = self.compiler.frame_angle(angle);
                let q = UnitQuaternion::from_axis_angle(&Unit::new_unchecked(axis), angle);
                Ok(q.to_rotation_matrix())
            }
            "xyaxes" => {
                let v = a.exact::<6>(kind)?.unwrap_or_default();
                let x = unit(Vector3::new(v[0], v[1], v[2])).ok_or_else(|| too_small("x axis"))?;
                let y = Vector3::new(v[3], v[4], v[5]);
                let y = unit(y - x * x.dot(&y)).ok_or_else(|| too_small("y axis"))?;
                let z = unit(x.cross(&y)).ok_or_else(|| too_small("x cross y"))?;
                Ok(Rotation3::from_matrix_unchecked(Matrix3::from_columns(&[
                    x, y, z,
                ])))
            }
            "zaxis" => {
                let z = a.vector(kind)?.unwrap_or_default();
                Ok(z_to(&unit(z).ok_or_else(|| too_small("axis"))?))
            }
            _ => {
                let angles = a.exact::<3>(kind)?.unwrap_or_default();
                let mut q = UnitQuaternion::identity();
                for (angle, axis) in angles.iter().zip(self.compiler.eulerseq) {
                    let unit_axis = match axis.to_ascii_lowercase() {
                        b'x' => Vector3::x_axis(),
                        b'y' => Vector3::y_axis(),
                        _ => Vector3::z_axis(),
                    };
                    let r = UnitQuaternion::from_axis_angle(
                        &unit_axis,
                        self.compiler.frame_angle(*angle),
                    );
                    // Lower case: rotations about the moving axes, upper case: fixed axes.
                    q = if axis.is_ascii_lowercase() {
                        q * r
                    } else {
                        r * q
                    };
                }
                Ok(q.to_rotation_matrix())
            }
        }
    }

    // ------------------------------------------------------------- bodies

    /// All `<worldbody>` sections: their geoms belong to the world, then come
    /// their bodies.
    fn read_world(&self, tree: &mut Tree<'a>, sections: &[Node<'a>]) -> Result<()> {
        let mut contents = vec![];
        for section in sections {
            if let Some(attr) = section.attributes().next() {
                let msg = format!("the world body cannot have attributes ('{}')", attr.name());
                return Err(self.error(*section, msg));
            }
            contents.extend(elements(*section));
        }
        for node in &contents {
            match tag(*node) {
                "joint" | "freejoint" => {
                    return Err(self.error(*node, "the world cannot have joints"))
                }
                "inertial" => return Err(self.error(*node, "the world cannot have an inertial")),
                _ => self.check_body_child(*node)?,
            }
        }
        self.read_geoms(tree, &contents, 0, "main", true, false)?;
        self.read_child_bodies(tree, &contents, 0, "main", true)
    }

    /// Rejects body children we do not read.
    fn check_body_child(&self, node: Node<'a>) -> Result<()> {
        match tag(node) {
            "body" | "joint" | "geom" | "inertial" | "site" | "camera" | "light" => Ok(()),
            "freejoint" => Err(self.error(
                node,
                "free joints are not supported: \
                 a model is a tree of hinge and slide joints",
            )),
            "frame" | "replicate" | "composite" | "flexcomp" | "attach" | "plugin" => Err(
                unsupported(self.file, node, "write the bodies out explicitly"),
            ),
            other => Err(self.error(node, format!("unrecognized element <{other}>"))),
        }
    }

    fn read_child_bodies(
        &self,
        tree: &mut Tree<'a>,
        contents: &[Node<'a>],
        parent: usize,
        class: &'a str,
        parent_static: bool,
    ) -> Result<()> {
        for node in contents.iter().filter(|n| n.has_tag_name("body")) {
            self.read_body(tree, *node, parent, class, parent_static)?;
        }
        Ok(())
    }

    /// A `<body>`: its joints, geoms and inertia, then its child bodies.
    /// `parent_static` tells whether the parent is welded to the world.
    fn read_body(
        &self,
        tree: &mut Tree<'a>,
        node: Node<'a>,
        parent: usize,
        parent_class: &'a str,
        parent_static: bool,
    ) -> Result<()> {
        check_attributes(self.file, node, BODY_ATTRS)?;
        let class = self.class_name(node, "childclass")?.unwrap_or(parent_class);
        let a = Attrs::of(self.file, node);
        if a.flag("mocap")? == Some(true) {
            return Err(self.error(node, "mocap bodies are not supported"));
        }
        if a.number("gravcomp")?.is_some_and(|g| g != 0.0) {
            return Err(self.error(node, "gravity compensation (gravcomp) is not supported"));
        }
        let contents: Vec<Node<'a>> = elements(node).collect();
        for child in &contents {
            self.check_body_child(*child)?;
        }
        let index = tree.bodies.len();
        let name = tree.claim(self.file, node, Kind::Body)?;
        let first_joint = tree.joints.len();
        for joint in contents.iter().filter(|n| n.has_tag_name("joint")) {
            let joint = self.read_joint(tree, *joint, index, class)?;
            tree.joints.push(joint);
        }
        let joints = first_joint..tree.joints.len();
        let is_static = parent_static && joints.is_empty();
        let inertial = match children(node, "inertial").as_slice() {
            [] => None,
            [one] => Some(*one),
            [_, second, ..] => return Err(self.error(*second, "a body has at most one <inertial>")),
        };
        let inertial = inertial.map(|n| self.read_inertial(n)).transpose()?;
        let geoms_count = self.compiler.inertia_from_geom == FromGeom::True || inertial.is_none();
        let parts = self.read_geoms(tree, &contents, index, class, is_static, geoms_count)?;
        let principal = self.body_inertial(node, inertial, &parts)?;
        tree.bodies.push(Body {
            name,
            parent,
            pos: a.vector("pos")?.unwrap_or_default(),
            rot: self.orientation(&a)?,
            mass: principal.mass,
            com: principal.com,
            inertia: Matrix3::zeros(),
            joints,
        });
        tree.inertials.push(principal);
        tree.nodes.push(Some(node));
        self.read_child_bodies(tree, &contents, index, class, is_static)
    }

    /// The geoms among `contents`, attached to `body`; returns the inertial
    /// parts of those that count for the body's inertia (when `count`).
    fn read_geoms(
        &self,
        tree: &mut Tree<'a>,
        contents: &[Node<'a>],
        body: usize,
        class: &'a str,
        is_static: bool,
        count: bool,
    ) -> Result<Vec<Principal>> {
        let mut parts = vec![];
        for node in contents.iter().filter(|n| n.has_tag_name("geom")) {
            let (geom, part) =
                self.read_geom(tree, *node, body, class, is_static, count && body > 0)?;
            tree.geoms.push(geom);
            parts.extend(part);
        }
        Ok(parts)
    }

    /// A body's inertial properties: from its geoms (`parts`, if any), else
    /// from its `<inertial>`, then bounded and checked as MuJoCo does.
    fn body_inertial(
        &self,
        body: Node<'a>,
        inertial: Option<Principal>,
        parts: &[Principal],
    ) -> Result<Principal> {
        let mut p = match (parts, inertial) {
            ([one], _) => one.clone(),
            ([], Some(explicit)) => explicit,
            ([], None) => Principal::massless(),
            (many, _) => {
                let all: Vec<MassProperties> =
                    many.iter().map(Principal::mass_properties).collect();
                let sum = MassProperties::combine(&all).expect("geom parts have positive mass");
                Principal::from_tensor(sum.mass, sum.com, sum.inertia)
                    .ok_or_else(|| self.error(body, "the geoms' inertia is degenerate"))?
            }
        };
        let c = &self.compiler;
        p.mass = p.mass.max(c.boundmass);
        p.moments = p.moments.map(|m| m.max(c.boundinertia));
        if p.mass < 0.0 || p.moments.min() < 0.0 {
            return Err(self.error(body, "mass and inertia cannot be negative"));
        }
        let [a, b, d] = [p.moments.x, p.moments.y, p.moments.z];
        if a + b < d || a + d < b || b + d < a {
            if !c.balanceinertia {
                let msg = format!(
                    "principal moments {:?} violate A + B >= C (use balanceinertia to fix)",
                    [a, b, d]
                );
                return Err(self.error(body, msg));
            }
            p.moments = Vector3::repeat((a + b + d) / 3.0);
        }
        Ok(p)
    }

    fn read_inertial(&self, node: Node<'a>) -> Result<Principal> {
        check_attributes(self.file, node, INERTIAL_ATTRS)?;
        let a = Attrs::of(self.file, node);
        let required =
            |name: &str| self.error(node, format!("required attribute missing: '{name}'"));
        let com = a.vector("pos")?.ok_or_else(|| required("pos"))?;
        let mass = a.number("mass")?.ok_or_else(|| required("mass"))?;
        let diagonal = a.vector("diaginertia")?;
        // MuJoCo would clamp these to boundmass and boundinertia (0 by default).
        if mass < 0.0 || diagonal.is_some_and(|d| d.min() < 0.0) {
            return Err(self.error(node, "mass and diaginertia cannot be negative"));
        }
        let Some([xx, yy, zz, xy, xz, yz]) = a.exact::<6>("fullinertia")? else {
            let axes = *self.orientation(&a)?.matrix();
            return Ok(Principal {
                mass,
                com,
                axes,
                moments: diagonal.unwrap_or_default(),
            });
        };
        if ["quat"]
            .iter()
            .chain(&ALTERNATIVES)
            .any(|k| value(node, k).is_some())
        {
            return Err(self.error(node, "fullinertia and an orientation cannot both be given"));
        }
        if diagonal.is_some_and(|d| d != Vector3::zeros()) {
            return Err(self.error(node, "fullinertia and diaginertia cannot both be given"));
        }
        let tensor = Matrix3::new(xx, xy, xz, xy, yy, yz, xz, yz, zz);
        Principal::from_tensor(mass, com, tensor)
            .ok_or_else(|| self.error(node, "fullinertia must have positive eigenvalues"))
    }

    // ------------------------------------------------------------- joints

    fn read_joint(
        &self,
        tree: &mut Tree<'a>,
        node: Node<'a>,
        body: usize,
        class: &str,
    ) -> Result<Joint> {
        check_attributes(self.file, node, JOINT_ATTRS)?;
        let a = self.attrs(node, class, |c| &c.joint)?;
        let kind = match a
            .keyword("type", &["hinge", "slide", "ball", "free"])?
            .unwrap_or("hinge")
        {
            "hinge" => JointKind::Hinge,
            "slide" => JointKind::Slide,
            other => {
                let msg = format!(
                    "{other} joints are not supported: a model is a tree of hinge and slide joints"
                );
                return Err(self.error(node, msg));
            }
        };
        let axis = a.vector("axis")?.unwrap_or(Vector3::z());
        let axis = unit(axis).ok_or_else(|| self.error(node, "joint axis is too small"))?;
        let angle = |x: f64| match kind {
            JointKind::Hinge => self.compiler.joint_angle(x),
            JointKind::Slide => x,
        };
        let autolimits = self.compiler.autolimits;
        let range = a.limits("limited", "range", autolimits)?;
        let force_limits = a.limits("actuatorfrclimited", "actuatorfrcrange", autolimits)?;
        if force_limits.is_some() {
            return Err(self.error(node, "actuator force limits on joints are not supported"));
        }
        if a.exact::<2>("springdamper")?.is_some_and(|s| s != [0.0; 2]) {
            return Err(self.error(
                node,
                "springdamper is not supported: give stiffness and damping",
            ));
        }
        let [damping, stiffness] = ["damping", "stiffness"].map(|k| a.leading::<3>(k, [0.0; 3]));
        let (damping, stiffness) = (damping?, stiffness?);
        if damping[1..] != [0.0; 2] || stiffness[1..] != [0.0; 2] {
            return Err(self.error(node, "polynomial damping and stiffness are not supported"));
        }
        let joint = Joint {
            name: tree.claim(self.file, node, Kind::Joint)?,
            kind,
            body,
            axis,
            anchor: a.vector("pos")?.unwrap_or_default(),
            reference: angle(a.number("ref")?.unwrap_or(0.0)),
            damping: damping[0],
            stiffness: stiffness[0],
            springref: angle(a.number("springref")?.unwrap_or(0.0)),
            armature: a.number("armature")?.unwrap_or(0.0),
            frictionloss: a.number("frictionloss")?.unwrap_or(0.0),
            range: range.map(|[lo, hi]| (angle(lo), angle(hi))),
        };
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
        Ok(joint)
    }

    // --------------------------------------------------------------- geoms

    /// A geom, and its inertial part when it `counts` for its body's inertia
    /// (and has a mass above MuJoCo's threshold).
    fn read_geom(
        &self,
        tree: &mut Tree<'a>,
        node: Node<'a>,
        body: usize,
        class: &str,
        is_static: bool,
        counts: bool,
    ) -> Result<(Geom, Option<Principal>)> {
        check_attributes(self.file, node, GEOM_ATTRS)?;
        let a = self.attrs(node, class, |c| &c.geom)?;
        let types = [
            "plane",
            "sphere",
            "capsule",
            "ellipsoid",
            "cylinder",
            "box",
            "mesh",
            "hfield",
            "sdf",
        ];
        let kind = a.keyword("type", &types)?.unwrap_or("sphere");
        if ["mesh", "hfield", "sdf"].contains(&kind)
            || a.text("mesh").is_some()
            || a.text("hfield").is_some()
        {
            return Err(self.error(node, "mesh, height field and SDF geoms are not supported"));
        }
        if a.flag("shellinertia")? == Some(true) {
            return Err(self.error(node, "shellinertia is not supported"));
        }
        if a.keyword("fluidshape", &["none", "ellipsoid"])? == Some("ellipsoid") {
            return Err(self.error(node, "fluid forces (fluidshape) are not supported"));
        }
        let mut size = a.leading::<3>("size", [0.0; 3])?;
        let mut pos = a.vector("pos")?.unwrap_or_default();
        let rot = match a.exact::<6>("fromto")? {
            Some(ft) => self.fromto_frame(node, kind, ft, &mut pos, &mut size)?,
            None => self.orientation(&a)?,
        };
        let shape = self.shape(node, kind, size)?;
        if kind == "plane" && !is_static {
            return Err(self.error(node, "planes are only allowed in static bodies"));
        }
        let bitmask = |name: &str| -> Result<u32> {
            let v = a.int(name)?.unwrap_or(1);
            u32::try_from(v)
                .map_err(|_| self.error(node, format!("{name} must be a 32-bit mask, got {v}")))
        };
        let geom = Geom {
            name: tree.claim(self.file, node, Kind::Geom)?,
            body,
            shape,
            pos,
            rot,
            contype: bitmask("contype")?,
            conaffinity: bitmask("conaffinity")?,
            friction: a.leading::<3>("friction", [1.0, 0.005, 0.0001])?,
        };
        let group = a.int("group")?.unwrap_or(0);
        let [lo, hi] = self.compiler.inertia_groups;
        if !counts || group < lo || group > hi {
            return Ok((geom, None));
        }
        let density = a.number("density")?.unwrap_or(1000.0);
        let explicit = a.number("mass")?;
        let mass = geom_inertia::mass(&shape, explicit, density);
        if mass < 0.0 || (explicit.is_none() && density < 0.0) {
            return Err(self.error(node, "geom mass and density cannot be negative"));
        }
        let part = (mass > MJ_EPS).then(|| Principal {
            mass,
            com: pos,
            axes: *rot.matrix(),
            moments: geom_inertia::principal_moments(&shape, mass),
        });
        Ok((geom, part))
    }

    /// MuJoCo's `fromto`: the geom sits midway, its z axis along from - to, its
    /// half-length half the distance (size[1] for capsules and cylinders,
    /// size[2] with size[1] = size[0] for boxes and ellipsoids).
    fn fromto_frame(
        &self,
        node: Node<'a>,
        kind: &str,
        ft: [f64; 6],
        pos: &mut Vector3<f64>,
        size: &mut [f64; 3],
    ) -> Result<Rotation3<f64>> {
        if !["capsule", "cylinder", "ellipsoid", "box"].contains(&kind) {
            return Err(self.error(
                node,
                "fromto requires a capsule, cylinder, box or ellipsoid",
            ));
        }
        if *pos != Vector3::zeros() {
            return Err(self.error(node, "pos and fromto cannot both be given"));
        }
        let (from, to) = (
            Vector3::new(ft[0], ft[1], ft[2]),
            Vector3::new(ft[3], ft[4], ft[5]),
        );
        let dir = unit(from - to).ok_or_else(|| self.error(node, "fromto points are too close"))?;
        size[1] = (from - to).norm() / 2.0;
        if kind == "box" || kind == "ellipsoid" {
            size[2] = size[1];
            size[1] = size[0];
        }
        *pos = (from + to) / 2.0;
        Ok(z_to(&dir))
    }

    fn shape(&self, node: Node<'a>, kind: &str, s: [f64; 3]) -> Result<Shape> {
        let needed = match kind {
            "plane" => {
                if s[2] <= 0.0 {
                    return Err(self.error(node, "plane size[2] must be positive"));
                }
                return Ok(Shape::Plane);
            }
            "sphere" => 1,
            "capsule" | "cylinder" => 2,
            _ => 3,
        };
        if let Some(i) = s[..needed].iter().position(|x| *x <= 0.0) {
            let msg = format!(
                "a {kind} needs {needed} positive size values; size[{i}] = {}",
                s[i]
            );
            return Err(self.error(node, msg));
        }
        Ok(match kind {
            "sphere" => Shape::Sphere { radius: s[0] },
            "capsule" => Shape::Capsule {
                radius: s[0],
                half_length: s[1],
            },
            "cylinder" => Shape::Cylinder {
                radius: s[0],
                half_length: s[1],
            },
            "box" => Shape::Box {
                half: Vector3::from(s),
            },
            _ => Shape::Ellipsoid {
                radii: Vector3::from(s),
            },
        })
    }

    // ------------------------------------------------------ whole-model checks

    /// MuJoCo requires each body with joints, or some body welded to it, to
    /// have mass and principal moments of at least `mjMINVAL`.
    fn check_moving_bodies(&self, tree: &Tree<'a>) -> Result<()> {
        let welded_mass = |b: usize| -> bool {
            let mut stack = vec![b];
            while let Some(i) = stack.pop() {
                if tree.inertials[i].has_mass() {
                    return true;
                }
                let welded = (i + 1..tree.bodies.len())
                    .filter(|&c| tree.bodies[c].parent == i && tree.bodies[c].joints.is_empty());
                stack.extend(welded);
            }
            false
        };
        for (i, node) in tree.nodes.iter().enumerate().skip(1) {
            if !tree.bodies[i].joints.is_empty() && !welded_mass(i) {
                let msg = "a body with joints needs mass and inertia (>= 1e-15), \
                           itself or in a body welded to it";
                return Err(self.error(node.expect("bodies past the world have elements"), msg));
            }
        }
        Ok(())
    }

    /// `settotalmass`: scales every mass and inertia so the masses sum to it.
    fn scale_total_mass(&self, tree: &mut Tree<'a>) {
        let target = self.compiler.settotalmass;
        if target <= 0.0 {
            return;
        }
        let total: f64 = tree.inertials.iter().skip(1).map(|p| p.mass).sum();
        let scale = (target / total.max(MJ_MINVAL)).max(MJ_MINVAL);
        for p in tree.inertials.iter_mut().skip(1) {
            p.mass *= scale;
            p.moments *= scale;
        }
    }

    // ----------------------------------------------------------- actuators

    fn read_actuators(&self, tree: &Tree<'a>, root: Node<'a>) -> Result<Vec<Actuator>> {
        let mut names = HashSet::new();
        let mut actuators = vec![];
        for node in children(root, "actuator").into_iter().flat_map(elements) {
            let actuator = self.read_actuator(tree, node)?;
            if !actuator.name.is_empty() && !names.insert(actuator.name.clone()) {
                return Err(self.error(node, format!("repeated name '{}'", actuator.name)));
            }
            actuators.push(actuator);
        }
        Ok(actuators)
    }

    fn read_actuator(&self, tree: &Tree<'a>, node: Node<'a>) -> Result<Actuator> {
        match tag(node) {
            "motor" => check_attributes(self.file, node, MOTOR_ATTRS)?,
            "general" => {
                check_attributes(self.file, node, &[MOTOR_ATTRS, GENERAL_ONLY_ATTRS].concat())?
            }
            kind if ACTUATOR_KINDS.contains(&kind) || kind == "plugin" => {
                return Err(unsupported(
                    self.file,
                    node,
                    "only motor and motor-like general actuators",
                ));
            }
            other => return Err(self.error(node, format!("unrecognized element <{other}>"))),
        }
        let a = self.attrs(node, "main", |c| &c.actuator)?;
        for target in ["tendon", "site", "body", "jointinparent", "cranksite"] {
            if value(node, target).is_some() {
                let msg = format!("actuators on a {target} are not supported: only on joints");
                return Err(self.error(node, msg));
            }
        }
        let joint_name = value(node, "joint")
            .ok_or_else(|| self.error(node, "an actuator needs a joint to act on"))?;
        let joint = tree
            .joints
            .iter()
            .position(|j| j.name == joint_name)
            .ok_or_else(|| self.error(node, format!("unknown joint '{joint_name}'")))?;
        let autolimits = self.compiler.autolimits;
        let force_limits = a.limits("forcelimited", "forcerange", autolimits)?;
        if force_limits.is_some() {
            return Err(self.error(node, "force-limited actuators are not supported"));
        }
        let damping = a.leading::<3>("damping", [0.0; 3])?;
        let armature = a.number("armature")?.unwrap_or(0.0);
        let delay = a.number("delay")?.unwrap_or(0.0);
        if damping != [0.0; 3] || armature != 0.0 || delay != 0.0 {
            return Err(self.error(
                node,
                "actuator damping, armature and delay are not supported",
            ));
        }
        let gear = a.leading::<6>("gear", [1.0, 0.0, 0.0, 0.0, 0.0, 0.0])?[0];
        Ok(Actuator {
            name: value(node, "name").unwrap_or("").to_string(),
            joint,
            gear: gear * self.motor_gain(&a)?,
            ctrl_range: a
                .limits("ctrllimited", "ctrlrange", autolimits)?
                .map(|[lo, hi]| (lo, hi)),
        })
    }

    /// The force per unit control of a motor-like actuator (gaintype fixed,
    /// biastype none, dyntype none): 1 for `<motor>`, `gainprm[0]` for
    /// `<general>`. A `<motor>` default resets a class to motor settings; other
    /// shortcut defaults (position, ...) make a `<general>` unsupported.
    fn motor_gain(&self, a: &Attrs<'a, '_>) -> Result<f64> {
        let motor: (f64, [&'a str; 3]) = (1.0, ["fixed", "none", "none"]);
        let (mut gain, mut types) = motor;
        let mut shortcut = None;
        for node in a.nodes() {
            match tag(node) {
                "motor" => ((gain, types), shortcut) = (motor, None),
                "general" => {
                    let prm = Attrs::of(self.file, node).leading::<10>("gainprm", [gain; 10])?;
                    gain = prm[0];
                    for (t, key) in types.iter_mut().zip(["gaintype", "biastype", "dyntype"]) {
                        *t = value(node, key).unwrap_or(t);
                    }
                }
                _ => shortcut = Some(node),
            }
        }
        if let Some(s) = shortcut {
            let msg = format!(
                "this general actuator inherits <{}> defaults (line {}); only motor-like \
                 actuators are supported",
                tag(s),
                s.document().text_pos_at(s.range().start).row
            );
            return Err(self.error(a.element, msg));
        }
        if types != motor.1 {
            let [g, b, d] = types;
            let msg = format!(
                "gaintype \"{g}\", biastype \"{b}\", dyntype \"{d}\": only fixed gain, no bias \
                 and no activation dynamics are supported"
            );
            return Err(self.error(a.element, msg));
        }
        Ok(gain)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn load(xml: &str) -> Model {
        parse(xml, "test.xml").unwrap_or_else(|e| panic!("{e}"))
    }

    /// The line, element and message of the error `xml` must give.
    fn error(xml: &str) -> (u32, String, String) {
        match parse(xml, "test.xml") {
            Err(ModelError::Invalid {
                file,
                line,
                element,
                message,
            }) => {
                assert_eq!(file, "test.xml");
                (line, element, message)
            }
            other => panic!("expected an Invalid error, got {other:?}"),
        }
    }

    /// Asserts `xml` is rejected with a message containing `expected`.
    fn assert_rejects(xml: &str, expected: &str) {
        let (line, element, message) = error(xml);
        assert!(line >= 1 && !element.is_empty());
        let context = format!("{xml}\n  gave: {message}\n  expected: {expected}");
        assert!(message.contains(expected), "{context}");
    }

    /// A model whose worldbody holds `bodies`, with `head` before it and
    /// `tail` after it.
    fn model(head: &str, bodies: &str, tail: &str) -> String {
        format!("<mujoco>{head}<worldbody>{bodies}</worldbody>{tail}</mujoco>")
    }

    /// A body with a joint and a 0.1 m ball, holding `inner` too.
    fn body(inner: &str) -> String {
        format!(r#"<body><joint/><geom size="0.1"/>{inner}</body>"#)
    }

    /// The (w, x, y, z) quaternion of a rotation, with w >= 0 as MuJoCo has it.
    fn quat_of(rot: &Rotation3<f64>) -> [f64; 4] {
        let q = UnitQuaternion::from_rotation_matrix(rot).into_inner();
        let q = if q.w < 0.0 { -q } else { q };
        [q.w, q.i, q.j, q.k]
    }

    fn assert_close(ours: &[f64], theirs: &[f64], tol: f64) {
        assert_eq!(ours.len(), theirs.len());
        for (a, b) in ours.iter().zip(theirs) {
            assert!((a - b).abs() <= tol, "{ours:?} vs {theirs:?}");
        }
    }

    #[test]
    fn errors_name_the_line_and_element() {
        let xml = "<mujoco>\n<worldbody>\n<body pos=\"1 2 x\">\n</body>\n</worldbody></mujoco>";
        let (line, element, message) = error(xml);
        assert_eq!((line, element.as_str()), (3, "body"));
        assert!(
            message.contains("'pos'") && message.contains("\"1 2 x\""),
            "{message}"
        );

        let xml = "<mujoco><worldbody>\n\n<body>\n<joint/><geom size=\"1 2 3 4\"/></body>";
        let (line, element, message) = error(&format!("{xml}</worldbody></mujoco>"));
        assert_eq!((line, element.as_str()), (4, "geom"));
        assert!(
            message.contains("'size' takes at most 3 numbers"),
            "{message}"
        );

        let xml = model("", "", "<actuator>\n\n<motor joint=\"nope\"/></actuator>");
        let (line, element, message) = error(&xml);
        assert_eq!((line, element.as_str()), (3, "motor"));
        assert!(message.contains("unknown joint 'nope'"), "{message}");
    }

    #[test]
    fn malformed_or_unphysical_input_is_rejected() {
        #[rustfmt::skip]
        let cases = [
            (r#"<body pos="1 2"/>"#, "needs 3 numbers, got 2"),
            (r#"<body pos="1 2 inf"/>"#, "must be finite numbers"),
            (r#"<body quat="0 0 0 0"/>"#, "zero quaternion"),
            (r#"<body euler="1 2 3" quat="1 0 0 0"/>"#, "multiple orientation specifiers"),
            (r#"<body name="b"/><body name="b"/>"#, "repeated name 'b'"),
            (&body(r#"<joint name="j"/><joint name="j"/>"#), "repeated name 'j'"),
            (&body(r#"<geom size="0.1" mass="-1"/>"#), "cannot be negative"),
            (r#"<body><joint/><inertial pos="0 0 0" mass="-1" diaginertia="1 1 1"/></body>"#,
             "cannot be negative"),
            (r#"<body><joint/><inertial pos="0 0 0" mass="1" diaginertia="1 1 3"/></body>"#,
             "violate A + B >= C"),
            (&body(r#"<joint axis="0 0 0"/>"#), "axis is too small"),
            (&body(r#"<joint damping="-1"/>"#), "must be >= 0"),
            (&body(r#"<joint limited="true"/>"#), "range[0] must be smaller"),
            (&body(r#"<joint dampnig="1"/>"#), "unrecognized attribute 'dampnig'"),
            (&body(r#"<joint type="hinged"/>"#), "attribute 'type' must be one of"),
            (&body("<bodyy/>"), "unrecognized element <bodyy>"),
            (&body(r#"<geom type="box" size="1 1"/>"#), "size[2] = 0"),
            (&body(r#"<geom type="plane" size="1 1 1"/>"#), "only allowed in static bodies"),
            (&body(r#"<geom class="nope" size="1"/>"#), "unknown default class 'nope'"),
            ("<body><joint/></body>", "needs mass and inertia"),
            (r#"<joint name="j"/>"#, "the world cannot have joints"),
        ];
        for (bodies, expected) in cases {
            assert_rejects(&model("", bodies, ""), expected);
        }
        assert!(matches!(
            parse("<mujoco><worldbody>", "x.xml"),
            Err(ModelError::Xml { .. })
        ));
    }

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

    #[test]
    fn default_classes_nest_and_follow_childclass() {
        let head = r#"<default>
              <joint damping="1"/><geom size="0.1 0.2 0.3" type="box"/><motor gear="3"/>
              <default class="a">
                <joint damping="2" stiffness="5"/><geom size="0.5"/>
                <default class="b"><joint armature="7"/></default>
              </default>
            </default>"#;
        let bodies = r#"<body childclass="a">
              <joint name="j0"/><geom/>
              <body><joint name="j1" class="b"/><joint name="j2" class="main"/><geom class="main"/></body>
            </body>"#;
        let tail = r#"<actuator><motor joint="j0" gear="2 1"/><general joint="j1"/></actuator>"#;
        let m = load(&model(head, bodies, tail));
        let passive: Vec<_> = m
            .joints
            .iter()
            .map(|j| (j.damping, j.stiffness, j.armature))
            .collect();
        assert_eq!(passive, [(2.0, 5.0, 0.0), (2.0, 5.0, 7.0), (1.0, 0.0, 0.0)]);
        // A short size overwrites only the leading entries of the class's size.
        let boxes = [[0.5, 0.2, 0.3], [0.1, 0.2, 0.3]].map(|s| Shape::Box { half: s.into() });
        assert_eq!([m.geoms[0].shape, m.geoms[1].shape], boxes);
        assert_eq!([m.actuators[0].gear, m.actuators[1].gear], [2.0, 3.0]);
    }

    #[test]
    fn fromto_capsule_is_placed_and_weighed_as_in_mujoco() {
        let capsule = r#"<geom type="capsule" fromto="0 0 0 0.3 0 0.4" size="0.05 9"/>"#;
        let m = load(&model("", &format!("<body><joint/>{capsule}</body>"), ""));
        let g = &m.geoms[0];
        assert_eq!(
            g.shape,
            Shape::Capsule {
                radius: 0.05,
                half_length: 0.25
            }
        );
        assert_close(g.pos.as_slice(), &[0.15, 0.0, 0.2], 1e-16);
        // MuJoCo's geom_quat: the z axis points from `to` towards `from`.
        let expected = [0.31622776601683794, 0.0, -0.9486832980505138, 0.0];
        assert_close(&quat_of(&g.rot), &expected, 1e-15);
        let (r, h): (f64, f64) = (0.05, 0.5);
        let mass = 1000.0 * PI * (r * r * h + 4.0 * r * r * r / 3.0);
        let b = &m.bodies[1];
        assert!((b.mass - mass).abs() < 1e-14 * mass);
        assert_close(b.com.as_slice(), g.pos.as_slice(), 1e-16);
        let axis = g.rot * Vector3::z();
        let axial = (b.inertia * axis).dot(&axis);
        assert!((axial - geom_inertia::principal_moments(&g.shape, mass).z).abs() < 1e-15);

        let sphere = r#"<geom fromto="0 0 0 0 0 1" size="0.1"/>"#;
        assert_rejects(&model("", &body(sphere), ""), "fromto requires");
        let both = r#"<geom type="capsule" pos="1 0 0" fromto="0 0 0 0 0 1" size="0.1"/>"#;
        assert_rejects(&model("", &body(both), ""), "pos and fromto");
    }

    #[test]
    fn explicit_inertial_and_geoms_follow_inertiafromgeom() {
        let bodies = body(r#"<inertial pos="0 0 1" mass="2" diaginertia="1 2 2"/>"#);
        let m = load(&model("", &bodies, ""));
        assert_eq!((m.bodies[1].mass, m.bodies[1].com.z), (2.0, 1.0));
        let diagonal = Matrix3::from_diagonal(&Vector3::new(1.0, 2.0, 2.0));
        assert_eq!(m.bodies[1].inertia, diagonal);
        let m = load(&model(r#"<compiler inertiafromgeom="true"/>"#, &bodies, ""));
        assert!((m.bodies[1].mass - 1000.0 * 4.0 / 3.0 * PI * 1e-3).abs() < 1e-12);
    }

    #[test]
    fn options_map_to_integrator_and_passive_mode() {
        use Integrator::{Euler, Rk4};
        use PassiveMode::{Explicit, ImplicitDamping};
        #[rustfmt::skip]
        let cases = [
            ("", Euler, ImplicitDamping),
            (r#"<option integrator="RK4"/>"#, Rk4, Explicit),
            (r#"<option><flag eulerdamp="disable"/></option>"#, Euler, Explicit),
            (r#"<option integrator="implicitfast"/>"#, Euler, ImplicitDamping),
            (r#"<option integrator="implicitfast"><flag eulerdamp="disable"/></option>"#,
             Euler, ImplicitDamping),
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

    #[test]
    fn unnamed_objects_get_indexed_names() {
        let m = load(&model(
            "",
            &body(r#"<body name="body1"><joint/><geom size="1"/></body>"#),
            "",
        ));
        let names: Vec<&str> = m.bodies.iter().map(|b| b.name.as_str()).collect();
        assert_eq!(names, ["world", "body1_", "body1"]);
        let names: Vec<&str> = m.joints.iter().map(|j| j.name.as_str()).collect();
        assert_eq!(names, ["joint0", "joint1"]);
        assert_eq!(m.name, "MuJoCo Model");
    }

    #[test]
    fn empty_sections_and_ignored_elements_load() {
        let head = r#"<default><tendon/></default><visual/><size nstack="10"/>"#;
        let bodies = format!("<light/>{}", body("<camera/><site/>"));
        let tail = r#"<tendon/><equality/><sensor><jointpos joint="x"/></sensor>
                      <contact><exclude body1="a" body2="b"/></contact>"#;
        assert_eq!(load(&model(head, &bodies, tail)).nv(), 1);
    }

    #[test]
    fn unsupported_features_are_rejected() {
        // (before <worldbody>, inside a body, after </worldbody>, expected message)
        #[rustfmt::skip]
        let cases = [
            ("", r#"<joint type="free"/>"#, "", "free joints are not supported"),
            ("", "<freejoint/>", "", "free joints are not supported"),
            ("", r#"<joint type="ball"/>"#, "", "ball joints are not supported"),
            ("", r#"<geom type="mesh" mesh="m"/>"#, "", "mesh"),
            ("", "", r#"<tendon><fixed name="t"/></tendon>"#, "tendons"),
            ("", "", r#"<equality><weld body1="b"/></equality>"#, "equality"),
            (r#"<option viscosity="0.1"/>"#, "", "", "fluid forces"),
            (r#"<option integrator="implicit"/>"#, "", "", "implicit"),
            (r#"<option><flag damper="disable"/></option>"#, "", "", "damper=\"disable\""),
            (r#"<include file="x.xml"/>"#, "", "", "<include> is not supported"),
            ("", r#"<frame><geom size="1"/></frame>"#, "", "<frame> is not supported"),
            ("", r#"<replicate count="2"/>"#, "", "<replicate> is not supported"),
            ("", r#"<composite type="grid"/>"#, "", "<composite> is not supported"),
            ("", r#"<body gravcomp="1"><joint/><geom size="1"/></body>"#, "", "gravcomp"),
            ("", r#"<joint name="j"/>"#, r#"<actuator><position joint="j"/></actuator>"#,
             "<position> is not supported"),
            ("", r#"<joint name="j"/>"#, r#"<actuator><motor tendon="t"/></actuator>"#,
             "on a tendon"),
            ("", r#"<joint name="j"/>"#,
             r#"<actuator><general joint="j" biastype="affine"/></actuator>"#,
             "biastype \"affine\""),
            (r#"<default><position kp="3"/></default>"#, r#"<joint name="j"/>"#,
             r#"<actuator><general joint="j"/></actuator>"#, "inherits <position> defaults"),
            ("", r#"<joint name="j"/>"#,
             r#"<actuator><motor joint="j" forcerange="-1 1"/></actuator>"#, "force-limited"),
            ("", r#"<joint damping="1 2"/>"#, "", "polynomial"),
            (r#"<compiler coordinate="global"/>"#, "", "", "global"),
        ];
        for (head, inner, tail, expected) in cases {
            assert_rejects(&model(head, &body(inner), tail), expected);
        }
    }
}
