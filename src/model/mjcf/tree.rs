//! The bodies, joints and geoms read so far, and how they are numbered and
//! named.
//!
//! Numbering: bodies depth-first in document order, the world (named "world")
//! first; joints, geoms and sites by body, in document order within a body;
//! actuators and sensors in document order.
//!
//! Names: MuJoCo leaves unnamed objects nameless; here they are named
//! `body<i>`, `joint<i>`, `geom<i>`, `site<i>`, `actuator<i>` or `sensor<i>` after their index, with `_`
//! appended while a named object holds that name. Actuators and sensors can
//! only refer to objects by their names in the file.

use std::collections::HashSet;

use super::inertial::Principal;
use super::{xml, Node, Result};
use crate::model::{Body, Geom, Joint, Shape, Site};

pub struct Tree<'a> {
    pub bodies: Vec<Body>,
    /// Per body: its inertial properties (bodies get theirs at the end).
    pub inertials: Vec<Principal>,
    /// Per body: its element (`None` for the world).
    pub nodes: Vec<Option<Node<'a>>>,
    pub joints: Vec<Joint>,
    pub geoms: Vec<Geom>,
    pub sites: Vec<Site>,
    /// Per site: its volume (MJCF type and size in the site's frame), the
    /// zone a touch sensor reads.
    pub site_zones: Vec<Shape>,
    /// Per geom: what a rangefinder's ray sees of it.
    pub geom_looks: Vec<Looks<'a>>,
    /// Explicit names taken, per [`Kind`].
    names: [HashSet<String>; 4],
}

/// How a geom looks to MuJoCo's mj_ray: its rgba alpha and its material
/// (whose alpha, when it names one, replaces its own), and a plane's
/// rendered half-extents (`size`, 0: unbounded).
#[derive(Clone, Copy, Debug)]
pub struct Looks<'a> {
    pub alpha: f64,
    pub material: Option<&'a str>,
    pub plane: [f64; 2],
}

/// The kinds of object whose names must differ.
#[derive(Clone, Copy)]
pub enum Kind {
    Body = 0,
    Joint = 1,
    Geom = 2,
    Site = 3,
}

impl<'a> Tree<'a> {
    /// Just the world.
    pub fn new() -> Self {
        Tree {
            bodies: vec![Body::world()],
            inertials: vec![Principal::massless()],
            nodes: vec![None],
            joints: vec![],
            geoms: vec![],
            sites: vec![],
            site_zones: vec![],
            geom_looks: vec![],
            names: [
                HashSet::from(["world".to_string()]),
                HashSet::new(),
                HashSet::new(),
                HashSet::new(),
            ],
        }
    }

    /// Records an explicit name with `suffix` appended (see `frames.rs`);
    /// MuJoCo rejects a repeated one.
    pub fn claim(&mut self, file: &str, node: Node, kind: Kind, suffix: &str) -> Result<String> {
        let name = match node.attribute("name").unwrap_or("") {
            "" => String::new(),
            given => format!("{given}{suffix}"),
        };
        if !name.is_empty() && !self.names[kind as usize].insert(name.clone()) {
            return Err(xml::invalid(file, node, format!("repeated name '{name}'")));
        }
        Ok(name)
    }

    /// The bodies (with their final inertial properties), joints, geoms and
    /// sites, every one named.
    pub fn finish(mut self) -> (Vec<Body>, Vec<Joint>, Vec<Geom>, Vec<Site>) {
        for (body, p) in self.bodies.iter_mut().zip(&self.inertials).skip(1) {
            body.mass = p.mass;
            body.com = p.com;
            body.inertia = p.mass_properties().inertia;
            body.inertia_frame = p.frame();
        }
        fill_names(&mut self.bodies, "body", |b| &mut b.name);
        fill_names(&mut self.joints, "joint", |j| &mut j.name);
        fill_names(&mut self.geoms, "geom", |g| &mut g.name);
        fill_names(&mut self.sites, "site", |s| &mut s.name);
        (self.bodies, self.joints, self.geoms, self.sites)
    }
}

/// Names unnamed items `<prefix><index>`, appending `_` while that is taken.
pub fn fill_names<T>(items: &mut [T], prefix: &str, name: impl Fn(&mut T) -> &mut String) {
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

#[cfg(test)]
mod tests {
    use super::super::test_util::*;

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
}
