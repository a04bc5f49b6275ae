//! `<actuator>`: `<motor>`, `<position>`, `<velocity>`, `<intvelocity>`,
//! `<damper>` and `<general>` on hinge and slide joints, on tendons and on
//! sites (`joint=`, `tendon=`, `site=` with an optional `refsite=`), as
//! MuJoCo 4's compiler sets their gain, bias and dynamics ([`Actuator`]).
//! Body and crank transmissions are refused.
//!
//! Defaults: the attributes every kind shares (`gear`, `ctrlrange`,
//! `forcerange`, ...) come from the class's actuator elements of any kind;
//! a shortcut's own parameters (`kp`, `kv`, `dampratio`, `timeconst`,
//! `inheritrange`) from the class's elements of its own kind. A `<general>`
//! reads its gain, bias and dynamics through the class's `<general>`
//! elements, a `<motor>` among them resetting them to a motor's. Other
//! mixes (a `<velocity>` under `<position>` defaults, a shortcut under a
//! `<general>` default that sets gains) are refused: MuJoCo 4 resolves them
//! in ways not reproduced here.

use std::collections::HashSet;

use super::attributes::{value, Attrs};
use super::schema::{actuator_attributes, check_attributes, ACTUATOR_KINDS};
use super::tree::Tree;
use super::{children, elements, tag, unrecognized, unsupported, Node, Reader, Result};
use crate::model::{ActDynamics, Actuator, Bias, Gain, Tendon, Transmission};

/// The attributes of `<general>` that set gain, bias or dynamics.
const DYNAMICS_ATTRS: &[&str] = &[
    "gaintype", "biastype", "dyntype", "gainprm", "biasprm", "dynprm", "actearly",
];

/// Gain, bias and dynamics as a kind's setter leaves them.
struct Law {
    gain: Gain,
    bias: Bias,
    dynamics: ActDynamics,
    act_early: bool,
    /// The fraction of the joint's range the control (position) or the
    /// activation (intvelocity) spans, 0 for none.
    inherit_range: f64,
}

impl Law {
    const MOTOR: Law = Law {
        gain: Gain::Fixed(1.0),
        bias: Bias::None,
        dynamics: ActDynamics::None,
        act_early: false,
        inherit_range: 0.0,
    };
}

impl<'a> Reader<'a> {
    /// Every actuator in document order; explicit names must differ.
    pub(super) fn read_actuators(
        &self,
        tree: &Tree<'a>,
        tendons: &[Tendon],
        root: Node<'a>,
    ) -> Result<Vec<Actuator>> {
        let mut names = HashSet::new();
        let mut actuators = vec![];
        for node in children(root, "actuator").into_iter().flat_map(elements) {
            let actuator = self.read_actuator(tree, tendons, node)?;
            if !actuator.name.is_empty() && !names.insert(actuator.name.clone()) {
                return Err(self.error(node, format!("repeated name '{}'", actuator.name)));
            }
            actuators.push(actuator);
        }
        Ok(actuators)
    }

    fn read_actuator(
        &self,
        tree: &Tree<'a>,
        tendons: &[Tendon],
        node: Node<'a>,
    ) -> Result<Actuator> {
        self.check_actuator_kind(node)?;
        let a = self.attrs(node, "main", |c| &c.actuator)?;
        let transmission = self.target(tree, tendons, node)?;
        let autolimits = self.compiler.autolimits;
        check_unsupported(&a)?;
        let law = self.law(&a)?;
        let gear = a.leading::<6>("gear", [1.0, 0.0, 0.0, 0.0, 0.0, 0.0])?;
        let pair = |r: Option<[f64; 2]>| r.map(|[lo, hi]| (lo, hi));
        let kind = tag(node);
        let mut ctrl_range = pair(a.limits("ctrllimited", "ctrlrange", autolimits)?);
        let mut act_range = pair(a.limits("actlimited", "actrange", autolimits)?);
        if kind == "damper" {
            ctrl_range = Some(self.forced_range(&a, "ctrlrange")?);
            if ctrl_range.is_some_and(|(lo, hi)| lo < 0.0 || hi < 0.0) {
                return Err(self.error(node, "damper control range cannot be negative"));
            }
        }
        if kind == "intvelocity" && law.inherit_range <= 0.0 {
            act_range = Some(self.forced_range(&a, "actrange")?);
        }
        if law.inherit_range > 0.0 {
            let (target, name) = match kind {
                "position" => (&mut ctrl_range, "ctrlrange"),
                _ => (&mut act_range, "actrange"),
            };
            if a.exact::<2>(name)?.is_some_and(|r| r != [0.0; 2]) {
                let msg = format!("{name} and inheritrange cannot both be defined");
                return Err(self.error(node, msg));
            }
            let range = match transmission {
                Transmission::Joint(j) => tree.joints[j].range,
                Transmission::Tendon(t) => tendons[t].range.map(|[lo, hi]| (lo, hi)),
                Transmission::Site { .. } => None,
            };
            let Some((lo, hi)) = range else {
                let msg = "inheritrange needs a joint or tendon with a range";
                return Err(self.error(node, msg));
            };
            let (mid, half) = ((lo + hi) / 2.0, (hi - lo) / 2.0 * law.inherit_range);
            *target = Some((mid - half, mid + half));
        }
        let damping = a.leading::<3>("damping", [0.0; 3])?[0];
        let armature = a.number("armature")?.unwrap_or(0.0);
        if damping < 0.0 || armature < 0.0 {
            return Err(self.error(node, "actuator damping and armature must be >= 0"));
        }
        Ok(Actuator {
            name: value(node, "name").unwrap_or("").to_string(),
            target: transmission,
            gear,
            ctrl_range,
            force_range: pair(a.limits("forcelimited", "forcerange", autolimits)?),
            act_range,
            gain: law.gain,
            bias: law.bias,
            dynamics: law.dynamics,
            act_early: law.act_early,
            damping,
            armature,
        })
    }

    /// A range MuJoCo's setter limits regardless of `*limited` (a damper's
    /// control, an intvelocity's activation): it must be increasing.
    fn forced_range(&self, a: &Attrs<'a, '_>, name: &str) -> Result<(f64, f64)> {
        match a.exact::<2>(name)?.unwrap_or([0.0; 2]) {
            [lo, hi] if lo < hi => Ok((lo, hi)),
            r => Err(self.error(
                a.element,
                format!("invalid {name} {r:?}: this actuator is always limited"),
            )),
        }
    }

    /// The six kinds read; the others refused.
    fn check_actuator_kind(&self, node: Node<'a>) -> Result<()> {
        match actuator_attributes(tag(node)) {
            Some(allowed) => check_attributes(self.file, node, &allowed),
            None if ACTUATOR_KINDS.contains(&tag(node)) || tag(node) == "plugin" => {
                Err(unsupported(
                    self.file,
                    node,
                    "only motor, position, velocity, intvelocity, damper and general actuators \
                     (not muscle, cylinder, adhesion, pid, dcmotor, orientation, plugin)",
                ))
            }
            None => Err(unrecognized(self.file, node)),
        }
    }

    /// What the actuator drives: exactly one of `joint`, `tendon` and
    /// `site` (with `refsite` only beside `site`).
    fn target(&self, tree: &Tree<'a>, tendons: &[Tendon], node: Node<'a>) -> Result<Transmission> {
        for target in ["body", "jointinparent", "cranksite"] {
            if value(node, target).is_some() {
                let msg = format!(
                    "actuators on a {target} are not supported: only on joints, tendons and sites"
                );
                return Err(self.error(node, msg));
            }
        }
        let named = ["joint", "tendon", "site"].map(|k| value(node, k));
        if named.iter().flatten().count() > 1 {
            return Err(self.error(node, "an actuator has one transmission target"));
        }
        let refsite = value(node, "refsite");
        match named {
            [_, _, Some(site)] => Ok(Transmission::Site {
                site: self.target_site(tree, node, site)?,
                refsite: match refsite {
                    Some(name) => Some(self.target_site(tree, node, name)?),
                    None => None,
                },
            }),
            _ if refsite.is_some() => Err(self.error(node, "refsite needs a site")),
            [None, Some(name), _] => tendons
                .iter()
                .position(|t| t.name == name)
                .map(Transmission::Tendon)
                .ok_or_else(|| self.error(node, format!("unknown tendon '{name}'"))),
            [joint, ..] => self
                .target_joint(tree, node, joint)
                .map(Transmission::Joint),
        }
    }

    /// The index of the site named `name`.
    fn target_site(&self, tree: &Tree<'a>, node: Node<'a>, name: &str) -> Result<usize> {
        let site = tree.sites.iter().position(|s| s.name == name);
        site.ok_or_else(|| self.error(node, format!("unknown site '{name}'")))
    }

    /// The index of the joint named `joint_name`.
    fn target_joint(
        &self,
        tree: &Tree<'a>,
        node: Node<'a>,
        joint_name: Option<&str>,
    ) -> Result<usize> {
        let joint_name = joint_name.ok_or_else(|| {
            self.error(node, "an actuator needs a joint, tendon or site to act on")
        })?;
        let joint = tree
            .joints
            .iter()
            .position(|j| j.name == joint_name)
            .ok_or_else(|| self.error(node, format!("unknown joint '{joint_name}'")))?;
        if tree.joints[joint].kind.nv() != 1 {
            let msg = format!(
                "'{joint_name}' is a ball or free joint; actuators drive hinges and slides"
            );
            return Err(self.error(node, msg));
        }
        Ok(joint)
    }

    /// Gain, bias and dynamics of the element's kind from its attributes and
    /// its class's (see the module documentation for which).
    fn law(&self, a: &Attrs<'a, '_>) -> Result<Law> {
        let kind = tag(a.element);
        for node in a.defaults {
            let other = tag(*node);
            let general_sets_law = other == "general"
                && kind != "general"
                && kind != "motor"
                && DYNAMICS_ATTRS.iter().any(|k| value(*node, k).is_some());
            let foreign = !["general", "motor", kind].contains(&other)
                || (other == "motor" && kind != "general" && kind != "motor");
            if foreign || general_sets_law {
                let msg = format!(
                    "this <{kind}> inherits <{other}> defaults (line {}) that MuJoCo 4 \
                     resolves in ways not reproduced here; set its parameters on the element \
                     or in a default of its own kind",
                    node.document().text_pos_at(node.range().start).row
                );
                return Err(self.error(a.element, msg));
            }
        }
        if kind == "general" {
            return self.general_law(a);
        }
        let own: Vec<Node<'a>> = a.nodes().filter(|n| tag(*n) == kind).collect();
        let own = Attrs {
            file: a.file,
            defaults: &own[..own.len() - 1],
            element: a.element,
        };
        let non_negative = |name: &str, default: Option<f64>| -> Result<Option<f64>> {
            match own.number(name)?.or(default) {
                Some(x) if x < 0.0 => {
                    Err(self.error(a.element, format!("{name} cannot be negative")))
                }
                x => Ok(x),
            }
        };
        Ok(match kind {
            "motor" => Law::MOTOR,
            "velocity" => {
                let kv = non_negative("kv", Some(1.0))?.unwrap_or(1.0);
                let bias = Bias::Affine([0.0, 0.0, -kv]);
                Law {
                    gain: Gain::Fixed(kv),
                    bias,
                    ..Law::MOTOR
                }
            }
            "damper" => {
                let kv = non_negative("kv", Some(0.0))?.unwrap_or(0.0);
                let gain = Gain::Affine([0.0, 0.0, -kv]);
                Law { gain, ..Law::MOTOR }
            }
            _ => {
                // position and intvelocity
                let kp = non_negative("kp", Some(1.0))?.unwrap_or(1.0);
                let kv = non_negative("kv", None)?;
                let ratio = non_negative("dampratio", None)?;
                let damping = match (kv, ratio) {
                    (Some(_), Some(_)) => {
                        let msg = "kv and dampratio cannot both be defined";
                        return Err(self.error(a.element, msg));
                    }
                    (Some(kv), None) => -kv,
                    (None, Some(ratio)) => ratio,
                    (None, None) => 0.0,
                };
                let timeconst = non_negative("timeconst", Some(0.0))?.unwrap_or(0.0);
                let dynamics = match (kind, timeconst > 0.0) {
                    ("intvelocity", _) => ActDynamics::Integrator,
                    (_, true) => ActDynamics::FilterExact(timeconst),
                    (_, false) => ActDynamics::None,
                };
                Law {
                    gain: Gain::Fixed(kp),
                    bias: Bias::Affine([0.0, -kp, damping]),
                    dynamics,
                    act_early: false,
                    inherit_range: own.number("inheritrange")?.unwrap_or(0.0),
                }
            }
        })
    }

    /// A `<general>`'s gain, bias and dynamics: MuJoCo's general defaults
    /// (fixed gain 1, no bias, no dynamics, dynprm 1) overwritten by the
    /// class's `<general>` elements and its own in turn; a class `<motor>`
    /// resets them to a motor's.
    fn general_law(&self, a: &Attrs<'a, '_>) -> Result<Law> {
        let (mut gainprm, mut biasprm, mut dynprm) = ([1.0, 0.0, 0.0], [0.0; 3], 1.0);
        let mut types = ["fixed", "none", "none"];
        let mut act_early = false;
        for node in a.nodes() {
            if tag(node) == "motor" {
                (gainprm, biasprm, types, act_early) =
                    ([1.0, 0.0, 0.0], [0.0; 3], ["fixed", "none", "none"], false);
                continue;
            }
            let own = Attrs::of(self.file, node);
            gainprm = own.leading("gainprm", gainprm)?;
            biasprm = own.leading("biasprm", biasprm)?;
            dynprm = own.leading("dynprm", [dynprm])?[0];
            act_early = own.flag("actearly")?.unwrap_or(act_early);
            let keys = [
                ("gaintype", &["fixed", "affine", "muscle", "user"][..]),
                ("biastype", &["none", "affine", "muscle", "user"][..]),
                (
                    "dyntype",
                    &[
                        "none",
                        "integrator",
                        "filter",
                        "filterexact",
                        "muscle",
                        "user",
                    ][..],
                ),
            ];
            for (t, (key, allowed)) in types.iter_mut().zip(keys) {
                *t = own.keyword(key, allowed)?.unwrap_or(t);
            }
        }
        let refuse = |what: String| Err(self.error(a.element, what));
        let gain = match types[0] {
            "fixed" => Gain::Fixed(gainprm[0]),
            "affine" => Gain::Affine(gainprm),
            other => return refuse(format!("gaintype \"{other}\" is not supported")),
        };
        let bias = match types[1] {
            "none" => Bias::None,
            "affine" => Bias::Affine(biasprm),
            other => return refuse(format!("biastype \"{other}\" is not supported")),
        };
        let dynamics = match types[2] {
            "none" => ActDynamics::None,
            "integrator" => ActDynamics::Integrator,
            "filter" => ActDynamics::Filter(dynprm),
            "filterexact" => ActDynamics::FilterExact(dynprm),
            other => return refuse(format!("dyntype \"{other}\" is not supported")),
        };
        Ok(Law {
            gain,
            bias,
            dynamics,
            act_early,
            inherit_range: 0.0,
        })
    }
}

/// Actuator damping's polynomial terms (MuJoCo's dampingpoly), delay, more
/// than one activation, and other inputs than one control.
fn check_unsupported(a: &Attrs) -> Result<()> {
    let damping = a.leading::<3>("damping", [0.0; 3])?;
    let delay = a.number("delay")?.unwrap_or(0.0);
    if damping[1..] != [0.0; 2] || delay != 0.0 {
        let msg = "actuator damping's polynomial terms and delay are not supported";
        return Err(a.error(a.element, msg));
    }
    if a.int("actdim")?.is_some_and(|n| n > 1) {
        return Err(a.error(a.element, "actdim above 1 is not supported"));
    }
    for input in ["input", "velrange", "ffrange", "nsample", "interp"] {
        if a.text(input).is_some() {
            let msg = format!("actuator attribute '{input}' is not supported");
            return Err(a.error(a.element, msg));
        }
    }
    Ok(())
}
