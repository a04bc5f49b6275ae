//! The `diffosi` command line.

use std::path::PathBuf;
use std::process::ExitCode;

use clap::{Parser, Subcommand};

mod cli;

#[derive(Parser)]
#[command(
    name = "diffosi",
    version,
    about = "Differentiable rigid-body dynamics with online system identification"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Simulate a model and write t, q..., v... per step as CSV.
    Simulate {
        /// Model file: .xml (MJCF) or .urdf.
        model: PathBuf,
        /// Number of steps.
        #[arg(long)]
        steps: usize,
        /// CSV of generalized forces, one row of nv values per step (a header row
        /// of names is allowed); zero forces if omitted.
        #[arg(long)]
        torques: Option<PathBuf>,
        /// Initial positions (nq values, comma separated); the model's reference
        /// configuration if omitted.
        #[arg(long, value_delimiter = ',', allow_hyphen_values = true)]
        q0: Option<Vec<f64>>,
        /// Initial velocities (nv values, comma separated); zero if omitted.
        #[arg(long, value_delimiter = ',', allow_hyphen_values = true)]
        v0: Option<Vec<f64>>,
        /// Output CSV.
        #[arg(short, long)]
        output: PathBuf,
    },
    /// One step's Jacobians d(q', v')/d(q, v, tau) and d(q', v')/d(params).
    Jacobian {
        /// Model file: .xml (MJCF) or .urdf.
        model: PathBuf,
        #[command(flatten)]
        state: cli::jacobian::State,
        /// Named parameters, comma separated (e.g. body/pole/com,joint/hinge/damping).
        #[arg(long, value_delimiter = ',')]
        params: Vec<String>,
        /// Print JSON instead of tables.
        #[arg(long)]
        json: bool,
    },
}

fn main() -> ExitCode {
    let result = match Cli::parse().command {
        Command::Simulate {
            model,
            steps,
            torques,
            q0,
            v0,
            output,
        } => cli::simulate::simulate(&model, steps, torques.as_deref(), q0, v0, &output),
        Command::Jacobian {
            model,
            state,
            params,
            json,
        } => cli::jacobian::jacobian(&model, state, &params, json),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(message) => {
            eprintln!("error: {message}");
            ExitCode::FAILURE
        }
    }
}
