//! The link tree: links, the joints as edges between them, the root and the
//! depth-first order in which links become bodies.

use std::collections::{HashMap, HashSet};

use super::{children, Node, Reader, Result};

/// A `<link>` element and its name.
#[derive(Clone, Copy)]
pub(super) struct Link<'a> {
    pub node: Node<'a>,
    pub name: &'a str,
}

/// A `<joint>` element as an edge of the link tree.
pub(super) struct Edge<'a> {
    pub node: Node<'a>,
    pub name: &'a str,
    pub parent: usize,
    pub child: usize,
}

/// The root link and the links in depth-first order, each with the edge
/// (joint) that leads to it.
pub(super) struct Tree {
    pub root: usize,
    pub order: Vec<usize>,
    pub parent_edge: Vec<Option<usize>>,
}

impl Reader<'_> {
    /// The links in document order; their names must differ.
    pub(super) fn links<'a>(&self, robot: Node<'a>) -> Result<Vec<Link<'a>>> {
        let mut names = HashSet::new();
        let mut links = Vec::new();
        for node in children(robot, "link") {
            let name = self.attr(node, "name")?;
            if !names.insert(name) {
                return Err(self.error(node, "duplicate link name"));
            }
            links.push(Link { node, name });
        }
        Ok(links)
    }

    /// The joints as edges between link indices; their names must differ.
    pub(super) fn edges<'a>(&self, robot: Node<'a>, links: &[Link<'a>]) -> Result<Vec<Edge<'a>>> {
        let index: HashMap<&str, usize> =
            links.iter().enumerate().map(|(i, l)| (l.name, i)).collect();
        let mut edges: Vec<Edge> = Vec::new();
        for node in children(robot, "joint") {
            let name = self.attr(node, "name")?;
            if edges.iter().any(|e| e.name == name) {
                return Err(self.error(node, format!("duplicate joint name '{name}'")));
            }
            let parent = self.end(node, name, "parent", &index)?;
            let child = self.end(node, name, "child", &index)?;
            edges.push(Edge {
                node,
                name,
                parent,
                child,
            });
        }
        Ok(edges)
    }

    /// The index of the link that the `<parent>` or `<child>` (`role`) of
    /// joint `name` names.
    fn end(
        &self,
        joint: Node,
        name: &str,
        role: &str,
        index: &HashMap<&str, usize>,
    ) -> Result<usize> {
        let element = self.required_child(joint, role)?;
        let link = self.attr(element, "link")?;
        index.get(link).copied().ok_or_else(|| {
            self.error(
                element,
                format!("joint '{name}' names unknown link '{link}'"),
            )
        })
    }

    /// Checks that the links form one tree and orders them depth-first.
    pub(super) fn tree(&self, robot: Node, links: &[Link], edges: &[Edge]) -> Result<Tree> {
        let parent_edge = self.parent_edges(links, edges)?;
        let root = self.root(robot, links, &parent_edge)?;
        let order = depth_first(root, edges);
        if let Some(lost) = (0..links.len()).find(|l| !order.contains(l)) {
            let edge = parent_edge[lost].map_or(robot, |e| edges[e].node);
            return Err(self.error(
                edge,
                format!(
                    "link '{}' is not reachable from the root link: the joints form a cycle",
                    links[lost].name
                ),
            ));
        }
        Ok(Tree {
            root,
            order,
            parent_edge,
        })
    }

    /// Per link, the edge that leads to it; a link has at most one.
    fn parent_edges(&self, links: &[Link], edges: &[Edge]) -> Result<Vec<Option<usize>>> {
        let mut parent_edge: Vec<Option<usize>> = vec![None; links.len()];
        for (e, edge) in edges.iter().enumerate() {
            if let Some(first) = parent_edge[edge.child].replace(e) {
                return Err(self.error(
                    edge.node,
                    format!(
                        "link '{}' has two parents: joints '{}' and '{}'",
                        links[edge.child].name, edges[first].name, edge.name
                    ),
                ));
            }
        }
        Ok(parent_edge)
    }

    /// The one link that is no joint's child.
    fn root(&self, robot: Node, links: &[Link], parent_edge: &[Option<usize>]) -> Result<usize> {
        let roots: Vec<usize> = (0..links.len())
            .filter(|&l| parent_edge[l].is_none())
            .collect();
        match roots[..] {
            [root] => Ok(root),
            [] if links.is_empty() => Err(self.error(robot, "the robot has no links")),
            [] => Err(self.error(robot, "no root link: the joints form a cycle")),
            [first, second, ..] => Err(self.error(
                links[second].node,
                format!(
                    "two root links '{}' and '{}' (neither is a joint's child)",
                    links[first].name, links[second].name
                ),
            )),
        }
    }
}

/// The links reachable from `root`, depth-first, children in the document
/// order of their joints. Each appears once, since a link has at most one
/// parent edge.
fn depth_first(root: usize, edges: &[Edge]) -> Vec<usize> {
    let mut order = Vec::new();
    let mut stack = vec![root];
    while let Some(l) = stack.pop() {
        order.push(l);
        stack.extend(
            edges
                .iter()
                .rev()
                .filter(|e| e.parent == l)
                .map(|e| e.child),
        );
    }
    order
}
