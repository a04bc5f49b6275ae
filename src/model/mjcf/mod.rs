//! MJCF loader: the part of MuJoCo's XML format that real robot models use, read
//! with the meaning MuJoCo 4's compiler gives it.
//!
//! Read: `<compiler>` (angle, eulerseq, inertiafromgeom, inertiagrouprange,
//! autolimits, settotalmass, boundmass, boundinertia, balanceinertia,
//! meshdir, assetdir), `<option>` (timestep, gravity, integrator: Euler, RK4,
//! implicit, implicitfast; the solver's cone, impratio and iterations, the
//! medium's density, viscosity and wind, and `<flag>`s: see `options.rs`),
//! `<default>` classes for joints, geoms, sites, meshes, pairs, tendons and
//! actuators, `<worldbody>` with nested `<body>` (gravcomp), `<joint>`
//! (hinge, slide, ball, free) and `<freejoint>`, `<inertial>`, `<geom>`
//! (plane, sphere, capsule, cylinder, box, ellipsoid, mesh, hfield, with
//! their contact settings), `<asset><mesh>` (`meshes.rs`), `<asset><hfield>`
//! (`hfields.rs`; height fields load, their collisions are not computed
//! yet: a step refuses while one is within reach), `<contact>` (`<pair>`
//! and `<exclude>`), `<actuator>` (MuJoCo's motor, position, velocity,
//! intvelocity, damper and general on hinges and slides: `actuators.rs`),
//! `<site>` and `<sensor>` (`sites.rs`, `sensors.rs`: every sensor type laid
//! out, the common ones computed), `<tendon>` (fixed and spatial tendons: `tendons.rs`),
//! `<equality>` (connect, weld, joint, tendon: `equality.rs`), `<keyframe>` (`keyframes.rs`), and
//! `<custom>`'s `diffosi:` settings (the contact model, the smooth model's
//! constants). The medium's forces are MuJoCo's inertia-box model and its
//! ellipsoid model (geom `fluidshape`, `fluidcoef`; refused by the model's
//! check under the implicit integrators, naming the geom): `dynamics/fluid.rs`.
//!
//! Composition, as MuJoCo's XML reader does it: `<include>` (`include.rs`),
//! `<frame>`, `<replicate>` and `childclass` (`frames.rs`).
//!
//! Ignored, since they do not change the dynamics: visual, the other assets
//! (textures, materials, skins), size, statistic, other custom data, camera,
//! light, the looks of geoms and tendons (rgba, material, group, width),
//! `<compiler>`'s texturedir, and the solver
//! settings that only tune how the answer is approached (`options.rs`).
//!
//! Rejected with [`ModelError::Invalid`] naming the element and its line:
//! - what changes the dynamics beyond a tree of joints with linear passive
//!   forces, actuators, contacts, limits, dry friction and fluid forces:
//!   limits and dry friction on ball and free joints, a free joint
//!   that is not the only joint of a child of the world,
//!   tendon armature (fixed tendons: `tendons.rs`), flex equalities,
//!   flexes and skins, the ellipsoid fluid model (fluidshape) on a plane,
//!   mesh or height field,
//!   gravcomp routed through actuators (`actuatorgravcomp`), bodies inside
//!   a mocap body, the `override`
//!   flag, disabling springs, dampers, actuation or control clamping,
//!   polynomial joint parameters, joint actuator-force
//!   limits, and the actuators `actuators.rs` lists (muscles, cylinders,
//!   adhesion, PID and DC motors; tendon, site, body, ball and free-joint
//!   transmissions; actuator damping's polynomial terms and delay);
//! - what builds the model from elsewhere: composite, flexcomp, attach,
//!   plugins, builtin meshes, PNG height fields, SDFs, shell inertia of
//!   geoms, fusestatic, global coordinates;
//! - what MuJoCo rejects: unknown elements and attributes, malformed or
//!   miscounted numbers, unknown classes, joints, geoms and bodies, repeated
//!   names, zero axes and quaternions, bad ranges, non-physical inertias,
//!   moving bodies without mass;
//! - stricter than MuJoCo (which clamps or accepts them): negative masses and
//!   inertias, negative damping, stiffness, armature and frictionloss.
//!
//! XML syntax errors are [`ModelError::Xml`].
//!
//! The model's name is the `model` attribute, else "MuJoCo Model". The other
//! conventions (MuJoCo's unless said otherwise) are stated where they are
//! applied: numbering and names in `tree.rs`, angles in `compiler.rs`, default
//! classes in `defaults.rs`, orientations in `orientation.rs`, inertia in
//! `inertial.rs`, joints in `joints.rs`, options in `options.rs`, contact
//! pairs in `contact.rs`, tendons in `tendons.rs`, actuators in `actuators.rs`.
//!
//! [`write()`] goes the other way, from a [`super::Spec`] to an MJCF document.

mod actuators;
mod attributes;
mod bodies;
mod compiler;
mod contact;
mod defaults;
mod equality;
mod frames;
mod geoms;
mod hfields;
mod include;
mod inertial;
mod joints;
mod keyframes;
mod meshes;
mod options;
mod orientation;
mod schema;
mod sensors;
mod sites;
mod tendons;
#[cfg(test)]
mod test_util;
mod tree;
mod write;

use std::cell::Cell;
use std::collections::HashMap;

use super::{xml, InertiaRule, ModelError, Spec};
use compiler::Compiler;
use defaults::Class;
use schema::check_attributes;
use tree::Tree;
pub use write::write;

type Node<'a> = roxmltree::Node<'a, 'a>;
type Result<T> = std::result::Result<T, ModelError>;

/// Parses an MJCF document into its spec (validated and compiled by
/// [`crate::Model::from_spec`]); `file` names it in errors and is where its
/// `<include>`s are looked up (`include.rs`).
pub fn parse(text: &str, file: &str) -> Result<Spec> {
    let expanded = include::expand(text, file)?;
    parse_expanded(&expanded.text, file).map_err(|e| expanded.locate(e))
}

/// [`parse`] once the includes are expanded.
fn parse_expanded(text: &str, file: &str) -> Result<Spec> {
    let doc = xml::document(text, file)?;
    let root = doc.root_element();
    check_document(file, root)?;
    let mut reader = Reader {
        file,
        compiler: Compiler::read(file, root)?,
        classes: HashMap::from([("main", Class::default())]),
        unfolded: Cell::new(0),
        meshes: meshes::Meshes::default(),
        hfields: hfields::HFields::default(),
    };
    let opt = options::read(file, root)?;
    for section in children(root, "default") {
        reader.read_default(section, None)?;
    }
    reader.meshes = reader.read_meshes(root)?;
    reader.hfields = reader.read_hfields(root)?;
    let mut tree = Tree::new();
    reader.read_world(&mut tree, &children(root, "worldbody"))?;
    check_unsupported_sections(file, root)?;
    let mut tendons = reader.read_tendons(&tree, root)?;
    let tendon_names: Vec<String> = tendons.iter().map(|t| t.name.clone()).collect();
    let limited: Vec<bool> = tendons.iter().map(|t| t.range.is_some()).collect();
    tree::fill_names(&mut tendons, "tendon", |t| &mut t.name);
    reader.check_moving_bodies(&tree)?;
    reader.scale_total_mass(&mut tree);
    let mut actuators = reader.read_actuators(&tree, &tendons, root)?;
    let written: Vec<String> = actuators.iter().map(|a| a.name.clone()).collect();
    tree::fill_names(&mut actuators, "actuator", |a| &mut a.name);
    let named = sensors::Named {
        actuators: &written,
        tendons: &tendon_names,
        limited: &limited,
    };
    let mut sensors = reader.read_sensors(&tree, &named, root)?;
    tree::fill_names(&mut sensors, "sensor", |s| &mut s.name);
    let (bodies, joints, geoms, sites) = tree.finish();
    let body_names: Vec<&str> = bodies.iter().map(|b| b.name.as_str()).collect();
    let (pairs, excludes) = reader.read_contact(root, &geoms, &body_names)?;
    let named = equality::Named {
        bodies: &bodies,
        joints: &joints,
        sites: &sites,
        tendons: &tendons,
    };
    let equalities = reader.read_equalities(root, &named)?;
    let mut meshes = std::mem::take(&mut reader.meshes);
    let paired: Vec<usize> = pairs.iter().flat_map(|p| p.geoms).collect();
    reader.add_hulls(&mut meshes, &geoms, &paired)?;
    let name = root
        .attribute("model")
        .unwrap_or("MuJoCo Model")
        .to_string();
    let mut spec = Spec {
        name,
        bodies,
        joints,
        actuators,
        geoms,
        opt,
        pairs,
        excludes,
        keyframes: vec![],
        inertia_rule: InertiaRule::Triangle,
        sites,
        sensors,
        meshes: meshes.compiled,
        hfields: std::mem::take(&mut reader.hfields.compiled),
        equalities,
        tendons,
    };
    spec.keyframes = reader.read_keyframes(root, &spec)?;
    Ok(spec)
}

/// Reads the model once the compiler settings and default classes are known.
/// Its methods live with the elements they read.
struct Reader<'a> {
    file: &'a str,
    compiler: Compiler,
    classes: HashMap<&'a str, Class<'a>>,
    /// Body elements read so far, frames and replicates unfolded (see
    /// [`frames::MAX_MEMBERS`]).
    unfolded: Cell<usize>,
    meshes: meshes::Meshes<'a>,
    hfields: hfields::HFields,
}

impl Reader<'_> {
    fn error(&self, node: Node, message: impl Into<String>) -> ModelError {
        xml::invalid(self.file, node, message)
    }
}

fn unsupported(file: &str, node: Node, why: &str) -> ModelError {
    xml::invalid(
        file,
        node,
        format!("<{}> is not supported: {why}", tag(node)),
    )
}

fn unrecognized(file: &str, node: Node) -> ModelError {
    xml::invalid(file, node, format!("unrecognized element <{}>", tag(node)))
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

/// The root must be `<mujoco>` and its sections MJCF sections.
fn check_document(file: &str, root: Node) -> Result<()> {
    if tag(root) != "mujoco" {
        return Err(xml::invalid(
            file,
            root,
            "the top-level element of an MJCF file must be <mujoco>",
        ));
    }
    check_attributes(file, root, &["model"])?;
    match elements(root).find(|s| !schema::SECTIONS.contains(&tag(*s))) {
        Some(s) => Err(unrecognized(file, s)),
        None => Ok(()),
    }
}

/// Sections that change the dynamics beyond what a Model holds must be empty
/// (but for skins, which only draw). (Checked after the bodies, whose
/// problems tend to be the more basic ones.)
fn check_unsupported_sections(file: &str, root: Node) -> Result<()> {
    for section in elements(root) {
        let why = match tag(section) {
            "deformable" => "flexes change the dynamics",
            "extension" => "plugins change the dynamics",
            _ => continue,
        };
        if let Some(first) = elements(section).find(|n| !n.has_tag_name("skin")) {
            return Err(unsupported(file, first, why));
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::test_util::*;
    use super::*;

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
    fn empty_sections_and_ignored_elements_load() {
        let head = r#"<default><tendon/></default><visual/><size nstack="10"/>"#;
        let bodies = format!("<light/>{}", body("<camera/><site/>"));
        let tail = r#"<tendon/><equality/><sensor><clock/></sensor>
                      <contact/><deformable><skin vertex="0 0 0 1 0 0 0 1 0" face="0 1 2"/></deformable>"#;
        assert_eq!(load(&model(head, &bodies, tail)).nv(), 1);
    }

    #[test]
    fn unsupported_features_are_rejected() {
        // (before <worldbody>, inside a body, after </worldbody>, expected message)
        #[rustfmt::skip]
        let cases = [
            ("", "<freejoint/>", "", "only joint of a body whose parent is the world"),
            ("", r#"<body><freejoint/><joint/></body>"#, "", "only joint of a body"),
            ("", r#"<joint type="ball" range="0 1"/>"#, "", "limits on ball and free joints"),
            ("", r#"<joint type="ball" frictionloss="1"/>"#, "", "dry friction on ball"),
            ("", r#"<joint name="b" type="ball"/>"#, r#"<actuator><motor joint="b"/></actuator>"#,
             "actuators drive hinges and slides"),
            ("", r#"<geom type="mesh" mesh="m"/>"#, "", "mesh"),
            ("", "", r#"<tendon><spatial name="t"/></tendon>"#, "needs a path of sites"),
            ("", r#"<geom name="g" type="box" size="1 1 1"/><site name="s"/>"#,
             r#"<tendon><spatial><site site="s"/><geom geom="g"/><site site="s"/></spatial></tendon>"#,
             "wrap geom 'g' must be a sphere or a cylinder"),
            ("", "", r#"<tendon><spatial><site site="nowhere"/></spatial></tendon>"#,
             "unknown site 'nowhere'"),
            ("", r#"<joint name="j"/>"#,
             r#"<tendon><fixed armature="1"><joint joint="j" coef="1"/></fixed></tendon>"#,
             "tendon armature"),
            ("", "", r#"<tendon><fixed><joint joint="nowhere" coef="1"/></fixed></tendon>"#,
             "unknown joint 'nowhere'"),
            ("", "", r#"<equality><tendon tendon1="t"/></equality>"#, "tendon1 't' is not a tendon"),
            (r#"<option density="-1"/>"#, "", "", "density must be finite and >= 0"),
            ("", r#"<geom type="plane" size="1 1 1" fluidshape="ellipsoid"/>"#, "",
             "the ellipsoid fluid model (fluidshape) on a plane"),
            (r#"<option integrator="Verlet"/>"#, "", "", "must be one of"),
            (r#"<option><flag damper="disable"/></option>"#, "", "", "damper=\"disable\""),
            ("", r#"<composite type="grid"/>"#, "", "<composite> is not supported"),
            ("", r#"<joint name="j"/>"#, r#"<actuator><muscle joint="j"/></actuator>"#,
             "<muscle> is not supported"),
            ("", r#"<joint name="j"/>"#, r#"<actuator><cylinder joint="j"/></actuator>"#,
             "<cylinder> is not supported"),
            ("", r#"<body gravcomp="nan"><joint/><geom size="1"/></body>"#, "", "gravcomp"),
            ("", r#"<joint actuatorgravcomp="true"/>"#, "", "actuatorgravcomp"),
            ("", r#"<body mocap="true"><geom size="1"/></body>"#, "", "mocap"),
            ("", r#"<joint name="j"/>"#, r#"<actuator><motor tendon="t"/></actuator>"#,
             "unknown tendon 't'"),
            ("", r#"<joint name="j"/>"#, r#"<actuator><motor site="s"/></actuator>"#,
             "unknown site 's'"),
            ("", r#"<joint name="j"/>"#,
             r#"<actuator><general joint="j" biastype="muscle"/></actuator>"#,
             "biastype \"muscle\""),
            ("", r#"<joint name="j"/>"#,
             r#"<actuator><general joint="j" dyntype="user"/></actuator>"#, "dyntype \"user\""),
            (r#"<default><position kp="3"/></default>"#, r#"<joint name="j"/>"#,
             r#"<actuator><general joint="j"/></actuator>"#, "inherits <position> defaults"),
            (r#"<default><position kp="3"/></default>"#, r#"<joint name="j"/>"#,
             r#"<actuator><velocity joint="j"/></actuator>"#, "inherits <position> defaults"),
            (r#"<default><general gainprm="3"/></default>"#, r#"<joint name="j"/>"#,
             r#"<actuator><position joint="j"/></actuator>"#, "inherits <general> defaults"),
            ("", r#"<joint name="j"/>"#,
             r#"<actuator><position joint="j" kv="1" dampratio="1"/></actuator>"#,
             "kv and dampratio cannot both be defined"),
            ("", r#"<joint name="j"/>"#, r#"<actuator><position joint="j" kp="-1"/></actuator>"#,
             "kp cannot be negative"),
            ("", r#"<joint name="j"/>"#,
             r#"<actuator><position joint="j" inheritrange="1"/></actuator>"#,
             "inheritrange needs a joint or tendon with a range"),
            ("", r#"<joint name="j"/>"#, r#"<actuator><damper joint="j" kv="1"/></actuator>"#,
             "invalid ctrlrange"),
            ("", r#"<joint name="j"/>"#,
             r#"<actuator><damper joint="j" ctrlrange="-1 1"/></actuator>"#,
             "damper control range cannot be negative"),
            ("", r#"<joint name="j"/>"#, r#"<actuator><intvelocity joint="j"/></actuator>"#,
             "invalid actrange"),
            ("", r#"<joint name="j"/>"#,
             r#"<actuator><motor joint="j" damping="1 2"/></actuator>"#, "polynomial terms"),
            ("", r#"<joint name="j"/>"#,
             r#"<actuator><motor joint="j" delay="0.1"/></actuator>"#, "delay"),
            ("", r#"<joint name="j"/>"#,
             r#"<actuator><motor joint="j" armature="-1"/></actuator>"#, "must be >= 0"),
            ("", r#"<joint damping="1 2"/>"#, "", "polynomial"),
            (r#"<compiler coordinate="global"/>"#, "", "", "global"),
        ];
        for (head, inner, tail, expected) in cases {
            assert_rejects(&model(head, &body(inner), tail), expected);
        }
    }
}
