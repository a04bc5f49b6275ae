//! The subcommands of the `diffosi` binary, one file each.

pub mod eval;
pub mod identify;
pub mod jacobian;
pub mod mpc;
pub mod reproduce;
pub mod simulate;
pub mod train;
pub mod wiping;
