//! The elements and attributes MuJoCo's schema allows. An attribute outside
//! these lists is an error, as in MuJoCo; which of the allowed ones we read,
//! ignore or reject is decided where the element is read.

use super::{xml, Node, Result};

/// The sections of `<mujoco>`.
#[rustfmt::skip]
pub const SECTIONS: &[&str] = &[
    "compiler", "option", "size", "statistic", "visual", "default", "asset", "worldbody",
    "contact", "actuator", "sensor", "custom", "keyframe", "tendon", "equality", "deformable",
    "extension",
];

/// Actuator shortcuts MuJoCo accepts in `<default>` and `<actuator>`.
#[rustfmt::skip]
pub const ACTUATOR_KINDS: &[&str] = &[
    "general", "motor", "position", "velocity", "damper", "intvelocity", "orientation", "pid",
    "cylinder", "muscle", "adhesion", "dcmotor",
];

#[rustfmt::skip]
pub const COMPILER_ATTRS: &[&str] = &[
    "autolimits", "boundmass", "boundinertia", "settotalmass", "balanceinertia", "strippath",
    "coordinate", "angle", "fitaabb", "eulerseq", "meshdir", "texturedir", "discardvisual",
    "usethread", "fusestatic", "inertiafromgeom", "inertiagrouprange", "saveinertial", "assetdir",
    "alignfree", "conflict",
];
#[rustfmt::skip]
pub const OPTION_ATTRS: &[&str] = &[
    "timestep", "impratio", "tolerance", "ls_tolerance", "noslip_tolerance", "ccd_tolerance",
    "sleep_tolerance", "gravity", "wind", "magnetic", "density", "viscosity", "o_margin",
    "o_solref", "o_solimp", "o_friction", "integrator", "cone", "jacobian", "solver", "iterations",
    "ls_iterations", "noslip_iterations", "ccd_iterations", "sdf_iterations", "sdf_initpoints",
    "actuatorgroupdisable",
];
#[rustfmt::skip]
pub const BODY_ATTRS: &[&str] = &[
    "name", "childclass", "pos", "quat", "axisangle", "xyaxes", "zaxis", "euler", "mocap",
    "gravcomp", "sleep", "simple", "user",
];
#[rustfmt::skip]
pub const FRAME_ATTRS: &[&str] = &[
    "name", "childclass", "pos", "quat", "axisangle", "xyaxes", "zaxis", "euler",
];
pub const REPLICATE_ATTRS: &[&str] = &["count", "offset", "euler", "sep", "childclass"];
#[rustfmt::skip]
pub const INERTIAL_ATTRS: &[&str] = &[
    "pos", "quat", "mass", "diaginertia", "axisangle", "xyaxes", "zaxis", "euler", "fullinertia",
];
#[rustfmt::skip]
pub const JOINT_ATTRS: &[&str] = &[
    "name", "class", "type", "group", "pos", "axis", "springdamper", "limited",
    "actuatorfrclimited", "solreflimit", "solimplimit", "solreffriction", "solimpfriction",
    "stiffness", "range", "actuatorfrcrange", "actuatorgravcomp", "margin", "ref", "springref",
    "armature", "damping", "frictionloss", "user",
];
pub const FREEJOINT_ATTRS: &[&str] = &["name", "group", "align"];
#[rustfmt::skip]
pub const FIXED_TENDON_ATTRS: &[&str] = &[
    "name", "class", "group", "limited", "actuatorfrclimited", "range", "actuatorfrcrange",
    "solreflimit", "solimplimit", "solreffriction", "solimpfriction", "frictionloss",
    "springlength", "margin", "stiffness", "damping", "armature", "rgba", "user",
];
/// A `<default>`'s `<tendon>` takes these (a spatial tendon's looks) besides
/// [`FIXED_TENDON_ATTRS`].
pub const DEFAULT_TENDON_ONLY_ATTRS: &[&str] = &["width", "material"];
/// A `<spatial>` takes these: a fixed tendon's and its looks.
#[rustfmt::skip]
pub const SPATIAL_TENDON_ATTRS: &[&str] = &[
    "name", "class", "group", "limited", "actuatorfrclimited", "range", "actuatorfrcrange",
    "solreflimit", "solimplimit", "solreffriction", "solimpfriction", "frictionloss",
    "springlength", "margin", "stiffness", "damping", "armature", "rgba", "user", "width",
    "material",
];
#[rustfmt::skip]
pub const GEOM_ATTRS: &[&str] = &[
    "name", "class", "type", "contype", "conaffinity", "condim", "group", "priority", "size",
    "material", "friction", "mass", "density", "shellinertia", "solmix", "solref", "solimp",
    "margin", "gap", "surfacevel", "adhesion", "fromto", "pos", "quat", "axisangle", "xyaxes",
    "zaxis", "euler", "hfield", "mesh", "fitscale", "rgba", "fluidshape", "fluidcoef", "user",
];
#[rustfmt::skip]
pub const SITE_ATTRS: &[&str] = &[
    "name", "class", "type", "group", "pos", "quat", "axisangle", "xyaxes", "zaxis", "euler",
    "material", "size", "fromto", "rgba", "user",
];
/// Attributes of every sensor element.
#[rustfmt::skip]
pub const SENSOR_ATTRS: &[&str] = &[
    "name", "nsample", "interp", "delay", "interval", "cutoff", "noise", "user",
];
#[rustfmt::skip]
pub const PAIR_ATTRS: &[&str] = &[
    "name", "class", "geom1", "geom2", "condim", "friction", "solref", "solreffriction", "solimp",
    "gap", "margin",
];
#[rustfmt::skip]
pub const MESH_ATTRS: &[&str] = &[
    "name", "class", "content_type", "file", "vertex", "normal", "texcoord", "face", "refpos",
    "refquat", "scale", "smoothnormal", "maxhullvert", "inertia", "builtin", "params", "material",
];
pub const HFIELD_ATTRS: &[&str] = &[
    "name",
    "content_type",
    "file",
    "nrow",
    "ncol",
    "size",
    "elevation",
];
/// What a `<default>`'s `<mesh>` may set.
pub const MESH_DEFAULT_ATTRS: &[&str] = &["scale", "maxhullvert", "inertia"];
/// Attributes of every `<equality>` element (and, but for name and class,
/// of a `<default>`'s `<equality>`).
pub const EQUALITY_ATTRS: &[&str] = &["name", "class", "active", "solref", "solimp"];
pub const EXCLUDE_ATTRS: &[&str] = &["name", "body1", "body2"];
#[rustfmt::skip]
pub const MOTOR_ATTRS: &[&str] = &[
    "name", "class", "group", "nsample", "interp", "delay", "ctrlrange", "user", "ctrllimited",
    "forcelimited", "forcerange", "lengthrange", "gear", "damping", "armature", "cranklength",
    "joint", "jointinparent", "tendon", "slidersite", "cranksite", "site", "refsite",
];
/// `<general>` takes these besides [`MOTOR_ATTRS`].
#[rustfmt::skip]
pub const GENERAL_ONLY_ATTRS: &[&str] = &[
    "actlimited", "actrange", "body", "actdim", "input", "velrange", "ffrange", "dyntype",
    "gaintype", "biastype", "dynprm", "gainprm", "biasprm", "actearly",
];

/// The attributes of an actuator kind we read (besides [`MOTOR_ATTRS`]),
/// None for the kinds we refuse.
pub fn actuator_attributes(kind: &str) -> Option<Vec<&'static str>> {
    let own: &[&str] = match kind {
        "motor" => &[],
        "general" => GENERAL_ONLY_ATTRS,
        "position" => &["kp", "kv", "dampratio", "timeconst", "inheritrange"],
        "intvelocity" => &[
            "kp",
            "kv",
            "dampratio",
            "timeconst",
            "inheritrange",
            "actrange",
        ],
        "velocity" | "damper" => &["kv"],
        _ => return None,
    };
    Some([MOTOR_ATTRS, own].concat())
}

/// Rejects attributes MuJoCo does not know (its schema check).
pub fn check_attributes(file: &str, node: Node, allowed: &[&str]) -> Result<()> {
    match node.attributes().find(|a| !allowed.contains(&a.name())) {
        Some(a) => Err(xml::invalid(
            file,
            node,
            format!("unrecognized attribute '{}'", a.name()),
        )),
        None => Ok(()),
    }
}

/// Attributes of an element inside `<default>`: all but its name and class.
pub fn check_default_attributes(file: &str, node: Node, allowed: &[&str]) -> Result<()> {
    let in_default: Vec<&str> = allowed
        .iter()
        .copied()
        .filter(|a| !["name", "class"].contains(a))
        .collect();
    check_attributes(file, node, &in_default)
}
