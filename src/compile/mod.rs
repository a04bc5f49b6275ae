//! The compile layer: a [`Spec`] (what a file says, [`crate::model`]) becomes
//! a [`Model`], the validated spec with its compiled numeric tree
//! ([`crate::dynamics::Tree`]: options inside, derived constants computed once,
//! module `tree`); the dynamics run on the tree with a
//! [`Data`](crate::dynamics::Data) workspace
//! (MuJoCo's mjSpec -> mjModel -> mjData, Pinocchio's Model/Data).
//! Parameter edits ([`Model::set`], module `edit`) recompile through the same
//! builders, only where the edit reaches.

mod edit;
mod fluid;
mod simulate;
mod tree;

pub use simulate::RolloutError;
pub use tree::{body_inertia, mass_properties};

use crate::dynamics::Tree;
use crate::model::{mjcf, urdf, Actuator, Body, Geom, Joint, ModelError, Options, Spec};

/// A validated [`Spec`] together with the numeric tree the dynamics run on.
/// Its fields read through `Deref` (`model.joints`); changes go through
/// [`Model::edited`], which validates again and rebuilds the tree, so the two
/// never disagree.
#[derive(Clone, Debug)]
pub struct Model {
    spec: Spec,
    tree: Tree<f64>,
    /// Distinct for every built or edited model (see [`Model::stamp`]).
    stamp: u64,
}

/// Stamps start at 1, so a cache's 0 matches no model.
fn next_stamp() -> u64 {
    static NEXT: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(1);
    NEXT.fetch_add(1, std::sync::atomic::Ordering::Relaxed)
}

impl std::ops::Deref for Model {
    type Target = Spec;
    fn deref(&self) -> &Spec {
        &self.spec
    }
}

impl Model {
    /// Checks the parts for consistency and builds the dynamics tree.
    pub fn new(
        name: String,
        bodies: Vec<Body>,
        joints: Vec<Joint>,
        actuators: Vec<Actuator>,
        geoms: Vec<Geom>,
        opt: Options,
    ) -> Result<Model, ModelError> {
        Model::from_spec(Spec {
            name,
            bodies,
            joints,
            actuators,
            geoms,
            opt,
            pairs: vec![],
            excludes: vec![],
            meshes: vec![],
        })
    }

    /// Validates `spec` and compiles it.
    pub fn from_spec(spec: Spec) -> Result<Model, ModelError> {
        spec.validate()?;
        let tree = Tree::build(&spec);
        check_tree_inertia(&spec, &tree, 1..spec.bodies.len())?;
        Ok(Model {
            spec,
            tree,
            stamp: next_stamp(),
        })
    }

    /// A number that changes whenever the model does (built, or edited in
    /// place); clones share it. Caches of derived data key on it.
    pub fn stamp(&self) -> u64 {
        self.stamp
    }

    /// Marks the model as changed (see [`Model::stamp`]).
    fn restamp(&mut self) {
        self.stamp = next_stamp();
    }

    /// A copy of this model with `edit` applied to its description.
    pub fn edited(&self, edit: impl FnOnce(&mut Spec)) -> Result<Model, ModelError> {
        let mut spec = self.spec.clone();
        edit(&mut spec);
        Model::from_spec(spec)
    }

    /// Loads an MJCF (`.xml`) or URDF (`.urdf`) file.
    pub fn load(path: impl AsRef<std::path::Path>) -> Result<Model, ModelError> {
        let path = path.as_ref();
        let shown = path.display().to_string();
        let text = std::fs::read_to_string(path).map_err(|source| ModelError::Io {
            path: shown.clone(),
            source,
        })?;
        match path.extension().and_then(|e| e.to_str()) {
            Some("xml") | Some("mjcf") => Model::from_mjcf(&text, &shown),
            Some("urdf") => Model::from_urdf(&text, &shown),
            _ => Err(ModelError::UnknownFormat(shown)),
        }
    }

    /// Reads MJCF text and compiles it; `file` names it in errors.
    pub fn from_mjcf(text: &str, file: &str) -> Result<Model, ModelError> {
        Model::from_spec(mjcf::parse(text, file)?)
    }

    /// Reads URDF text and compiles it; `file` names it in errors.
    pub fn from_urdf(text: &str, file: &str) -> Result<Model, ModelError> {
        Model::from_spec(urdf::parse(text, file)?)
    }

    /// Writes the model as MJCF to a `.xml` (or `.mjcf`) path; see
    /// [`mjcf::write`] for what MJCF cannot express.
    pub fn save(&self, path: impl AsRef<std::path::Path>) -> Result<(), ModelError> {
        let path = path.as_ref();
        let shown = path.display().to_string();
        if !matches!(
            path.extension().and_then(|e| e.to_str()),
            Some("xml" | "mjcf")
        ) {
            let why = format!("{shown}: models are saved as MJCF, to a .xml (or .mjcf) path");
            return Err(ModelError::Unwritable(why));
        }
        let text = mjcf::write(&self.spec)?;
        std::fs::write(path, text).map_err(|e| ModelError::Unwritable(format!("{shown}: {e}")))
    }

    pub fn nu(&self) -> usize {
        self.actuators.len()
    }

    /// The numeric tree the dynamics algorithms run on.
    pub fn tree(&self) -> &Tree<f64> {
        &self.tree
    }

    pub fn body_index(&self, name: &str) -> Option<usize> {
        self.bodies.iter().position(|b| b.name == name)
    }

    pub fn joint_index(&self, name: &str) -> Option<usize> {
        self.joints.iter().position(|j| j.name == name)
    }
}

/// Checks that the joint nodes carrying `bodies` have finite inertia: mass,
/// COM and tensor can each be finite while the inertia about the joint frame
/// (m |c|^2 and sums of bodies) overflows.
fn check_tree_inertia(
    spec: &Spec,
    tree: &Tree<f64>,
    bodies: impl IntoIterator<Item = usize>,
) -> Result<(), ModelError> {
    for b in bodies {
        let Some(node) = tree.body[b].node else {
            continue;
        };
        let i = &tree.inertia[node];
        let finite = i.mass.is_finite()
            && i.h.iter().all(|x| x.is_finite())
            && i.rot.iter().all(|x| x.is_finite());
        if !finite {
            let body = &spec.bodies[b];
            return Err(ModelError::NotPhysical(format!(
                "body '{}': mass {} at COM {:?} gives an inertia about its joint frame that overflows",
                body.name,
                body.mass,
                body.com.as_slice()
            )));
        }
    }
    Ok(())
}
