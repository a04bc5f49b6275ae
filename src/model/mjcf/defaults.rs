//! Default classes.
//!
//! A class holds the `<joint>`, `<geom>`, `<site>`, `<mesh>`, `<equality>` and actuator elements of its
//! `<default>` and of every enclosing one; see [`Attrs`] for how an attribute
//! is resolved through them. A short list of numbers (`size`, `friction`,
//! `gear`, ...) overwrites only the leading entries of the inherited one. An
//! element uses its `class`, else the `childclass` of the nearest enclosing body
//! that has one, else `main`.

use super::attributes::{value, Attrs};
use super::schema::{
    actuator_attributes, check_attributes, check_default_attributes, ACTUATOR_KINDS,
    DEFAULT_TENDON_ONLY_ATTRS, EQUALITY_ATTRS, FIXED_TENDON_ATTRS, GEOM_ATTRS, JOINT_ATTRS,
    MESH_DEFAULT_ATTRS, PAIR_ATTRS, SITE_ATTRS,
};
use super::{children, elements, tag, unrecognized, Node, Reader, Result};

/// A default class: its joint, geom, site and actuator elements and those of every
/// enclosing class, outermost first.
#[derive(Clone, Default)]
pub struct Class<'a> {
    pub joint: Vec<Node<'a>>,
    pub geom: Vec<Node<'a>>,
    pub site: Vec<Node<'a>>,
    pub pair: Vec<Node<'a>>,
    pub actuator: Vec<Node<'a>>,
    pub tendon: Vec<Node<'a>>,
    pub mesh: Vec<Node<'a>>,
    pub equality: Vec<Node<'a>>,
}

/// Default elements that only set up elements we ignore or reject anyway.
#[rustfmt::skip]
const INERT_DEFAULTS: &[&str] = &[
    "material", "camera", "light",
];

impl<'a> Reader<'a> {
    /// Reads a `<default>` and the classes nested in it. `parent` is the
    /// enclosing class; top-level defaults all add to `main`.
    pub(super) fn read_default(&mut self, node: Node<'a>, parent: Option<&'a str>) -> Result<()> {
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
            self.add_to_class(&mut class, child)?;
        }
        self.classes.insert(name, class);
        for nested in children(node, "default") {
            self.read_default(nested, Some(name))?;
        }
        Ok(())
    }

    /// Adds one child of a `<default>` to its class.
    fn add_to_class(&self, class: &mut Class<'a>, child: Node<'a>) -> Result<()> {
        let file = self.file;
        match tag(child) {
            "joint" => {
                check_default_attributes(file, child, JOINT_ATTRS)?;
                class.joint.push(child);
            }
            "geom" => {
                check_default_attributes(file, child, GEOM_ATTRS)?;
                class.geom.push(child);
            }
            "site" => {
                check_default_attributes(file, child, SITE_ATTRS)?;
                class.site.push(child);
            }
            "pair" => {
                check_default_attributes(file, child, PAIR_ATTRS)?;
                class.pair.push(child);
            }
            kind if actuator_attributes(kind).is_some() => {
                let attrs = actuator_attributes(kind).unwrap_or_default();
                check_default_attributes(file, child, &attrs)?;
                class.actuator.push(child);
            }
            kind if ACTUATOR_KINDS.contains(&kind) => class.actuator.push(child),
            "tendon" => {
                let attrs = [FIXED_TENDON_ATTRS, DEFAULT_TENDON_ONLY_ATTRS].concat();
                check_default_attributes(file, child, &attrs)?;
                class.tendon.push(child);
            }
            "equality" => {
                check_default_attributes(file, child, EQUALITY_ATTRS)?;
                class.equality.push(child);
            }
            "mesh" => {
                check_attributes(file, child, MESH_DEFAULT_ATTRS)?;
                class.mesh.push(child);
            }
            "default" => {}
            kind if INERT_DEFAULTS.contains(&kind) => {}
            _ => return Err(unrecognized(file, child)),
        }
        Ok(())
    }

    /// The class named by `attr` (class or childclass) of `node`, if any.
    pub(super) fn class_name(&self, node: Node<'a>, attr: &str) -> Result<Option<&'a str>> {
        match value(node, attr) {
            Some(name) if !self.classes.contains_key(name) => {
                Err(self.error(node, format!("unknown default class '{name}'")))
            }
            found => Ok(found),
        }
    }

    /// `node`'s attributes with the defaults of its class, else of `inherited`;
    /// `pick` chooses the class's elements of `node`'s kind.
    pub(super) fn attrs<'s>(
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
}

#[cfg(test)]
mod tests {
    use super::super::test_util::*;
    use crate::model::Shape;

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
        assert_eq!([m.actuators[0].gear[0], m.actuators[1].gear[0]], [2.0, 3.0]);
    }
}
