//! The compile layer: a [`Spec`] (what a file says, [`crate::model`]) becomes
//! a [`Model`], the validated spec with its compiled numeric tree
//! ([`crate::dynamics::Tree`]: options inside, derived constants computed once,
//! module `tree`); the dynamics run on the tree with a
//! [`Data`](crate::dynamics::Data) workspace
//! (MuJoCo's mjSpec -> mjModel -> mjData, Pinocchio's Model/Data).
//! Parameter edits ([`Model::set`], module `edit`) recompile through the same
//! builders, only where the edit reaches.

mod actuators;
mod edit;
mod equality;
mod fluid;
mod gravcomp;
mod invweight;
mod mixing;
mod pairs;
mod ray;
mod sensors;
mod simulate;
mod springdamper;
mod tendon;
mod tree;

pub use invweight::invweight0;
pub use pairs::{candidates, collision_pairs, contact_pairs, lawless_pairs, Filter};
pub use simulate::RolloutError;
pub use tree::{body_inertia, mass_properties};

use crate::dynamics::Tree;
use crate::model::urdf::{Inertials, LoadOptions};
use crate::model::{
    mjcf, urdf, Actuator, Body, Geom, InertiaRule, Joint, ModelError, Options, Spec,
};

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
    /// What the loader took as written or ignored (see [`Model::warnings`]).
    warnings: Vec<String>,
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
            keyframes: vec![],
            inertia_rule: InertiaRule::Triangle,
            sites: vec![],
            sensors: vec![],
            meshes: vec![],
            hfields: vec![],
            equalities: vec![],
            tendons: vec![],
        })
    }

    /// Validates `spec` and compiles it.
    pub fn from_spec(mut spec: Spec) -> Result<Model, ModelError> {
        spec.validate()?;
        let mut tree = Tree::build(&spec);
        check_tree_inertia(&spec, &tree, 1..spec.bodies.len())?;
        if springdamper::resolve_spring_dampers(&mut spec, &tree) {
            tree = Tree::build(&spec);
        }
        if actuators::resolve_damp_ratios(&mut spec, &tree) {
            tree.actuators = tree::actuator_terms(&spec);
        }
        Ok(Model {
            spec,
            tree,
            stamp: next_stamp(),
            warnings: vec![],
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
        let mut model = Model::from_spec(spec)?;
        model.warnings = self.warnings.clone();
        Ok(model)
    }

    /// Loads an MJCF (`.xml`) or URDF (`.urdf`) file with the default
    /// [`LoadOptions`] (a URDF's root link welded to the world).
    pub fn load(path: impl AsRef<std::path::Path>) -> Result<Model, ModelError> {
        Model::load_with(path, &LoadOptions::default())
    }

    /// Loads an MJCF or URDF file; `options` say how to read a URDF (an MJCF
    /// file takes only the default `floating_base`, off: it says its joints,
    /// and the default `inertials`).
    pub fn load_with(
        path: impl AsRef<std::path::Path>,
        options: &LoadOptions,
    ) -> Result<Model, ModelError> {
        let path = path.as_ref();
        let shown = path.display().to_string();
        let text = std::fs::read_to_string(path).map_err(|source| ModelError::Io {
            path: shown.clone(),
            source,
        })?;
        match path.extension().and_then(|e| e.to_str()) {
            Some("xml") | Some("mjcf") if options.floating_base => {
                Err(ModelError::NotApplicable(format!(
                    "{shown}: floating_base applies to URDF files; an MJCF file floats a body \
                     with a <freejoint>"
                )))
            }
            Some("xml") | Some("mjcf") if options.inertials != Inertials::default() => {
                Err(ModelError::NotApplicable(format!(
                    "{shown}: inertial applies to URDF files; MuJoCo reads an MJCF <inertial> \
                     as written"
                )))
            }
            Some("xml") | Some("mjcf") => Model::from_mjcf(&text, &shown),
            Some("urdf") => Model::from_urdf_with(&text, &shown, options),
            _ => Err(ModelError::UnknownFormat(shown)),
        }
    }

    /// Reads MJCF text and compiles it; `file` names it in errors.
    pub fn from_mjcf(text: &str, file: &str) -> Result<Model, ModelError> {
        Model::from_spec(mjcf::parse(text, file)?)
    }

    /// Reads URDF text with the default [`LoadOptions`] and compiles it;
    /// `file` names it in errors.
    pub fn from_urdf(text: &str, file: &str) -> Result<Model, ModelError> {
        Model::from_urdf_with(text, file, &LoadOptions::default())
    }

    /// Reads URDF text as `options` say and compiles it; `file` names it in
    /// errors and is where its relative and `package://` paths start.
    pub fn from_urdf_with(
        text: &str,
        file: &str,
        options: &LoadOptions,
    ) -> Result<Model, ModelError> {
        let loaded = urdf::parse(text, file, options)?;
        let mut model = Model::from_spec(loaded.spec)?;
        model.warnings = loaded.warnings;
        Ok(model)
    }

    /// What the loader took as written or ignored, each naming its file,
    /// line and element (a URDF's inertias that MuJoCo would refuse, links
    /// without `<inertial>`, ignored transmissions); empty for MJCF. Edited
    /// copies keep them.
    pub fn warnings(&self) -> &[String] {
        &self.warnings
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

    /// The keyframe named `name` (see [`crate::model::Keyframe`]).
    pub fn keyframe(&self, name: &str) -> Option<&crate::model::Keyframe> {
        self.keyframes.iter().find(|k| k.name == name)
    }

    pub fn joint_index(&self, name: &str) -> Option<usize> {
        self.joints.iter().position(|j| j.name == name)
    }

    /// The first position coordinate and first dof of the joint named `name`
    /// (MuJoCo's jnt_qposadr and jnt_dofadr; see [`Spec::joint_address`]).
    pub fn joint_address_of(&self, name: &str) -> Option<(usize, usize)> {
        self.joint_index(name).map(|j| self.joint_address(j))
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
