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

use diffosi::model::ContactModel;
use diffosi::Model;

/// A model file, and optionally the contact law to run it with.
#[derive(clap::Args, Debug)]
pub struct ModelFile {
    /// Model file: .xml (MJCF) or .urdf.
    pub model: PathBuf,
    /// Contact, limit and dry-friction law: constraint (MuJoCo's soft
    /// constraints, the default for MJCF) or smooth (the penalty model, the
    /// default for URDF).
    #[arg(long, value_enum)]
    pub contact_model: Option<ContactLaw>,
}

#[derive(clap::ValueEnum, Clone, Copy, Debug)]
pub enum ContactLaw {
    Constraint,
    Smooth,
}

impl ModelFile {
    pub fn load(&self) -> Result<Model, String> {
        let model = Model::load(&self.model).map_err(|e| e.to_string())?;
        let Some(law) = self.contact_model else {
            return Ok(model);
        };
        let law = match law {
            ContactLaw::Constraint => ContactModel::Constraint,
            ContactLaw::Smooth => ContactModel::Smooth,
        };
        model
            .edited(|s| s.opt.contact_model = law)
            .map_err(|e| e.to_string())
    }
}
