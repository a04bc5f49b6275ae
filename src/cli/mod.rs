//! The subcommands of the `diffosi` binary, one file each.

pub mod eval;
pub mod identify;
pub mod jacobian;
pub mod mpc;
pub mod reproduce;
pub mod simulate;
pub mod train;
pub mod wiping;

use std::path::PathBuf;

use diffosi::model::urdf::{Inertials, LoadOptions};
use diffosi::model::ContactModel;
use diffosi::Model;

/// A model file, how to read it, and optionally the contact law to run it
/// with.
#[derive(clap::Args, Debug)]
pub struct ModelFile {
    /// Model file: .xml (MJCF) or .urdf.
    pub model: PathBuf,
    /// Contact, limit and dry-friction law: constraint (MuJoCo's soft
    /// constraints, the default) or smooth (the penalty model).
    #[arg(long, value_enum)]
    pub contact_model: Option<ContactLaw>,
    /// URDF: a free joint on the root link, as PyBullet's loadURDF default
    /// (without it the root link is welded to the world, as MuJoCo's importer
    /// and Pinocchio read it).
    #[arg(long)]
    pub floating_base: bool,
    /// URDF: a directory to look for `package://NAME/...` packages in
    /// (repeatable; searched before the file's own directories and
    /// ROS_PACKAGE_PATH).
    #[arg(long = "package-dir", value_name = "DIR")]
    pub package_dirs: Vec<PathBuf>,
    /// URDF: whose reading of <inertial>: pinocchio (as written, a link
    /// without one massless; the default) or pybullet (PyBullet's importer:
    /// 1 kg and unit inertia where none, principal axes, unphysical moments
    /// zeroed).
    #[arg(long, value_name = "READING", default_value = "pinocchio")]
    pub inertial: Inertials,
    /// Set a named parameter after loading, as Python's `Model.set_param`
    /// (repeatable; a vector's values comma separated, e.g.
    /// `--set body/pole/mass=0.3 --set body/pole/com=0,0,0.5`).
    #[arg(long = "set", value_name = "NAME=VALUE", allow_hyphen_values = true)]
    pub set: Vec<String>,
}

#[derive(clap::ValueEnum, Clone, Copy, Debug)]
pub enum ContactLaw {
    Constraint,
    Smooth,
}

impl ModelFile {
    /// The model, its load warnings printed to stderr, under the contact law
    /// asked, then with the `--set` parameters.
    pub fn load(&self) -> Result<Model, String> {
        let options = LoadOptions {
            floating_base: self.floating_base,
            package_dirs: self.package_dirs.clone(),
            inertials: self.inertial,
        };
        let mut model = Model::load_with(&self.model, &options).map_err(|e| e.to_string())?;
        for warning in model.warnings() {
            eprintln!("warning: {warning}");
        }
        if let Some(law) = self.contact_model {
            let law = match law {
                ContactLaw::Constraint => ContactModel::Constraint,
                ContactLaw::Smooth => ContactModel::Smooth,
            };
            model = model
                .edited(|s| s.opt.contact_model = law)
                .map_err(|e| e.to_string())?;
        }
        for assignment in &self.set {
            let (name, value) = parse_set(assignment)?;
            model
                .set_param(name, &value)
                .map_err(|e| format!("--set {assignment}: {e}"))?;
        }
        Ok(model)
    }
}

/// `NAME=VALUE` with VALUE one or more comma-separated finite numbers.
fn parse_set(assignment: &str) -> Result<(&str, Vec<f64>), String> {
    let bad = |why: &str| format!("--set {assignment}: {why} (expected NAME=VALUE[,VALUE...])");
    let (name, value) = assignment.split_once('=').ok_or_else(|| bad("no '='"))?;
    let values = value
        .split(',')
        .map(|x| match x.trim().parse::<f64>() {
            Ok(v) if v.is_finite() => Ok(v),
            _ => Err(bad(&format!("'{x}' is not a finite number"))),
        })
        .collect::<Result<Vec<f64>, String>>()?;
    Ok((name.trim(), values))
}
