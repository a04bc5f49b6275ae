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
    /// Simulate a model and write one transition per step as CSV, in the
    /// layout `identify` reads: t, q_..., v_..., tau_..., q_next_...,
    /// v_next_..., and for a model with contacts each geom pair's normal force
    /// fn_... (N) at the row's state.
    Simulate {
        #[command(flatten)]
        model: cli::ModelFile,
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
        #[command(flatten)]
        model: cli::ModelFile,
        #[command(flatten)]
        state: cli::jacobian::State,
        /// Named parameters, comma separated (e.g. body/pole/com,joint/hinge/damping).
        #[arg(long, value_delimiter = ',')]
        params: Vec<String>,
        /// Print JSON instead of tables.
        #[arg(long)]
        json: bool,
    },
    /// Identify named physical parameters from observed transitions (DiffOSI).
    ///
    /// mu is the named parameters themselves: each scalar of each parameter,
    /// in the order given, is one component (a COM gives 3, an inertia 6:
    /// xx yy zz xy xz yz). The loss is the sum over transitions of
    /// ||(step(q, v, tau) - (q_next, v_next)) / scale||^2. Prints each value
    /// with its standard error, the final loss, iterations, evaluations and
    /// flags (unexcited: a direction the data does not excite kept its start
    /// value; at_bound; not_converged; misfit: the residuals are larger than
    /// --scale says the noise is, loss per degree of freedom above 4).
    #[command(verbatim_doc_comment)]
    Identify {
        #[command(flatten)]
        model: cli::ModelFile,
        /// Named parameters, comma separated (e.g. body/pole/mass,joint/hinge/damping).
        #[arg(long, value_delimiter = ',', required = true)]
        params: Vec<String>,
        /// CSV of transitions, one per row: q (nq values), v (nv), tau (nv),
        /// q_next (nq), v_next (nv), i.e. nq+nv+nv+nq+nv comma-separated numbers.
        /// A first row that is not numeric is a header; blank lines are skipped.
        /// A header naming its columns q_..., v_..., tau_..., q_next_...,
        /// v_next_... (simulate's CSV) selects them and ignores the others.
        #[arg(long)]
        transitions: PathBuf,
        /// Solver: lm (bounded Levenberg-Marquardt), adam (the paper's variant) or
        /// cmaes (derivative-free baseline).
        #[arg(long, value_enum, default_value = "lm")]
        method: cli::identify::Method,
        /// Lower bounds, one per mu component, comma separated. Default, from
        /// the model's value x: x/10 for masses and inertia diagonals, x - 1 for
        /// COM coordinates, x - (largest diagonal) for inertia products, 0 for
        /// damping, stiffness and armature.
        #[arg(long, value_delimiter = ',', allow_hyphen_values = true)]
        lower: Option<Vec<f64>>,
        /// Upper bounds, one per mu component. Default: 10x for masses and inertia
        /// diagonals, x + 1 for COM coordinates, x + (largest diagonal) for
        /// inertia products, max(10x, 1) for damping, stiffness and armature.
        #[arg(long, value_delimiter = ',', allow_hyphen_values = true)]
        upper: Option<Vec<f64>>,
        /// Start values (the prior), one per mu component; the model's values,
        /// clamped into the bounds, if omitted.
        #[arg(long, value_delimiter = ',', allow_hyphen_values = true)]
        init: Option<Vec<f64>>,
        /// Residual scale: 2 nv values (q part then v part) or one for all; best
        /// the measurement noise of each state component. Default 1e-3 dt for
        /// positions and 1e-3 for velocities, as Python's DiffOsi.
        #[arg(long, value_delimiter = ',')]
        scale: Option<Vec<f64>>,
        /// The transitions' contact, limits and dry friction are not ours
        /// (another engine's law): eliminate the impulse of any body within
        /// MARGIN (m) of touching and of any joint within MARGIN of its
        /// range's ends or with dry friction; the residuals are then nv
        /// generalized forces per transition over --force-scale (--scale is
        /// unused). Needs the Euler integrator.
        #[arg(long, value_name = "MARGIN", allow_hyphen_values = true)]
        unknown_constraints: Option<f64>,
        /// With --unknown-constraints: nv values (N or N m) or one for all;
        /// default 1.
        #[arg(long, value_delimiter = ',', requires = "unknown_constraints")]
        force_scale: Option<Vec<f64>>,
        /// With --unknown-constraints: how the transitions' engine applies its
        /// constraint impulses: model (through M + E, E the implicit passive
        /// diagonal: MuJoCo, ours) or mass (through M alone: DART).
        #[arg(
            long,
            value_enum,
            default_value = "model",
            requires = "unknown_constraints"
        )]
        impulses: cli::identify::ImpulsesArg,
        /// Print JSON instead of text: Python's DiffOsi.identify result
        /// (params, std, loss, iterations, evaluations, flags: a list of
        /// names) with names, method and transitions.
        #[arg(long)]
        json: bool,
    },
    /// Train a task's policy with PPO (writes the policy JSON and its learning
    /// curve, CSV and SVG), or a UC-MLP identifier (writes its weights JSON).
    Train {
        /// Task name (cartpole, half_cheetah, half_cheetah_contact, quadruped).
        #[arg(long, default_value = "cartpole")]
        task: String,
        /// uc: Universal Controller (observes the state and mu); dr:
        /// domain-randomised baseline (state only); both see a fresh uniform mu
        /// each episode. mlp / mlp-narrow: the UC-MLP identifier on the whole /
        /// the narrow ([-0.2, 0.2]) mu range, from episodes of --controller.
        #[arg(long, value_enum)]
        policy: cli::train::Target,
        /// Universal Controllers that collect a UC-MLP's data (repeat).
        #[arg(long = "controller", default_values = ["policies/cartpole/uc-seed0.json", "policies/cartpole/uc-seed1.json", "policies/cartpole/uc-seed2.json"])]
        controllers: Vec<PathBuf>,
        #[arg(long, default_value_t = 0)]
        seed: u64,
        /// Environment steps (default: the task's tuned budget; for a UC-MLP,
        /// roughly the steps of data collected).
        #[arg(long)]
        steps: Option<usize>,
        /// Output policy file (.json).
        #[arg(short, long)]
        output: PathBuf,
        /// Learning-curve CSV (default: the output path with extension .curve.csv).
        #[arg(long)]
        curve: Option<PathBuf>,
        /// How a uc or dr policy learns: ppo, imitation of the iLQR MPC
        /// expert (DAgger; its --steps is ignored), or apg, analytic policy
        /// gradients through the engine refining the --init policy (--steps
        /// sets the rollout steps; the shipped cartpole UCs are imitation,
        /// then apg).
        #[arg(long, value_enum, default_value = "ppo")]
        method: cli::train::Method,
        /// ppo: start from this policy's network and input normalisation
        /// instead of a random network; apg: the policy to refine (required).
        #[arg(long)]
        init: Option<PathBuf>,
    },
    /// Evaluate trained policies: mean +- std of the task metric over
    /// episodes with the true mu drawn uniformly (the same episodes for every
    /// policy and source). With several --policy files the summary pools them.
    Eval {
        /// Task name (cartpole, half_cheetah, half_cheetah_contact, quadruped).
        #[arg(long, default_value = "cartpole")]
        task: String,
        /// Policy file(s) written by `diffosi train`; repeat for several.
        #[arg(long, required = true)]
        policy: Vec<PathBuf>,
        /// The mu fed to a Universal Controller: oracle (the true mu), random
        /// (uniform guess per episode), average (middle of the range), mlp /
        /// mlp-narrow (UC-MLP, predicted from the last transitions), cmaes,
        /// diffosi (identified online from the recent window; diffosi with
        /// change detection, diffosi-no-cd without). The first step uses the
        /// middle of the range. Domain-randomised policies ignore it.
        #[arg(long, value_enum, default_value = "oracle")]
        mu_source: diffosi::control::Source,
        /// UC-MLP weights for --mu-source mlp.
        #[arg(long, default_value = "policies/cartpole/uc-mlp.json")]
        mlp: PathBuf,
        /// UC-MLP weights for --mu-source mlp-narrow.
        #[arg(long, default_value = "policies/cartpole/uc-mlp-narrow.json")]
        mlp_narrow: PathBuf,
        /// Transitions per DiffOSI / CMA-ES window (context window N = this + 1).
        #[arg(long, default_value_t = 4)]
        window: usize,
        #[arg(long, default_value_t = 10)]
        episodes: usize,
        /// Seed of the episodes (true mu, initial states, random guesses).
        #[arg(long, default_value_t = 0)]
        seed: u64,
        /// Print JSON (per-episode metrics and mu) instead of text.
        #[arg(long)]
        json: bool,
    },
    /// The paper's runtime comparison: iLQR MPC (exact step Jacobians, the
    /// true mu) against the Universal Controller with online DiffOSI on the
    /// same episodes; wall time per replan next to the UC's compute over the
    /// same control steps, and both task performances. Writes
    /// reports/mpc-<task>.{md,json}.
    Mpc {
        /// Task name (half_cheetah or cartpole).
        #[arg(long, default_value = "half_cheetah")]
        task: String,
        /// Universal Controller weights (default policies/<task>/uc-seed0.json);
        /// without them only the MPC side is reported.
        #[arg(long)]
        policy: Option<PathBuf>,
        /// Control steps planned (default: the task's; half cheetah 200 as the
        /// paper, cartpole 60).
        #[arg(long)]
        horizon: Option<usize>,
        /// Control steps executed between replans (default: the task's; half
        /// cheetah 40 as the paper, cartpole 5).
        #[arg(long)]
        replan: Option<usize>,
        /// Most iLQR iterations per plan (per stage of an episode's first plan;
        /// default: the task's, half cheetah 5, which keeps its run under a
        /// minute or two, cartpole 10).
        #[arg(long)]
        iterations: Option<usize>,
        #[arg(long, default_value_t = 3)]
        episodes: usize,
        /// Seed of the episodes (true mu, initial states).
        #[arg(long, default_value_t = 0)]
        seed: u64,
        /// Transitions per DiffOSI window.
        #[arg(long, default_value_t = 4)]
        window: usize,
        /// Output directory.
        #[arg(long, default_value = "reports")]
        reports: PathBuf,
    },
    /// One episode of the wiping task (a KUKA iiwa pressing a compliant
    /// tool on a table with 3 N while it strokes back and forth) as CSV:
    /// t, q, v, tau per dof, the sensed normal force and the admittance
    /// offset xi; optionally identify the tool's compliance from it.
    Wipe {
        /// The tool's mu = (k_p in N/cm, k_d in N s/m), each in [1, 100].
        #[arg(long, value_delimiter = ',', required = true)]
        mu: Vec<f64>,
        /// Admittance gains k_tau (1/s^2), k_xi (m/(N s)); the canonical ones
        /// if omitted.
        #[arg(long, value_delimiter = ',')]
        gains: Option<Vec<f64>>,
        /// Physics steps (1 ms each).
        #[arg(long, default_value_t = 3000)]
        steps: usize,
        /// Identify mu by DiffOSI from 50 closed-loop segments of the episode.
        #[arg(long)]
        identify: bool,
        /// Seed of the segments' sampling.
        #[arg(long, default_value_t = 0)]
        seed: u64,
        /// Also write the arm with this mu's compliance as MJCF (to replay
        /// the torques elsewhere).
        #[arg(long)]
        model_out: Option<PathBuf>,
        /// Output CSV.
        #[arg(short, long)]
        output: PathBuf,
    },
    /// Train the wiping task's controllers into a directory: the UC's
    /// (mu, theta*) dataset and network, DR's gains, UC-MLP.
    TrainWiping {
        #[arg(short, long, default_value = "policies/wiping")]
        output: PathBuf,
        /// (mu, theta*) pairs (the paper's 85).
        #[arg(long, default_value_t = 85)]
        pairs: usize,
        #[arg(long, default_value_t = 0)]
        seed: u64,
        /// Worker threads (default: all cores); results do not depend on it.
        #[arg(long)]
        threads: Option<usize>,
    },
    /// Reproduce the paper's experiments on the shipped controllers and UC-MLP
    /// weights: for cartpole, Tables 1 and 4 and the context-window study
    /// (reports/{table1,table4}-cartpole.{md,json}, reports/window-cartpole.{json,svg});
    /// for cheetah, Table 2 and its window study (reports/table2-half_cheetah.{md,json},
    /// reports/window-half_cheetah.{json,svg}); for wiping, Table 3; for
    /// wiping-dims, the higher-dimension study. Prints the tables. `all` runs
    /// every one.
    Reproduce {
        /// cartpole, cheetah, wiping (Table 3), wiping-dims (the higher-dimension study) or all.
        #[arg(default_value = "all")]
        what: String,
        /// Directory of the shipped weights (one subdirectory per task).
        #[arg(long, default_value = "policies")]
        policies: PathBuf,
        /// Output directory.
        #[arg(long, default_value = "reports")]
        reports: PathBuf,
        /// Episodes per trained model.
        #[arg(long, default_value_t = 10)]
        episodes: usize,
        /// Trained models (seeds 0..models) per policy kind.
        #[arg(long, default_value_t = 3)]
        models: usize,
        /// Seed of the episodes.
        #[arg(long, default_value_t = 0)]
        seed: u64,
        /// Worker threads (default: all cores); results do not depend on it.
        #[arg(long)]
        threads: Option<usize>,
    },
}

/// All cores.
fn cores() -> usize {
    std::thread::available_parallelism().map_or(1, |n| n.get())
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
        Command::Identify {
            model,
            params,
            transitions,
            method,
            lower,
            upper,
            init,
            scale,
            unknown_constraints,
            force_scale,
            impulses,
            json,
        } => cli::identify::identify(cli::identify::Request {
            model: &model,
            params: &params,
            transitions: &transitions,
            method,
            lower,
            upper,
            init,
            scale,
            unknown_constraints: unknown_constraints.map(|m| (m, force_scale, impulses.into())),
            json,
        }),
        Command::Train {
            task,
            policy,
            controllers,
            seed,
            steps,
            output,
            curve,
            method,
            init,
        } => cli::train::train(cli::train::Request {
            task: &task,
            target: policy,
            controllers: &controllers,
            seed,
            steps,
            output: &output,
            curve,
            method,
            init,
        }),
        Command::Eval {
            task,
            policy,
            mu_source,
            mlp,
            mlp_narrow,
            window,
            episodes,
            seed,
            json,
        } => cli::eval::eval(cli::eval::Request {
            task: &task,
            policies: &policy,
            source: mu_source,
            mlp: &mlp,
            mlp_narrow: &mlp_narrow,
            window,
            episodes,
            seed,
            json,
        }),
        Command::Mpc {
            task,
            policy,
            horizon,
            replan,
            iterations,
            episodes,
            seed,
            window,
            reports,
        } => cli::mpc::mpc(cli::mpc::Request {
            task: &task,
            policy,
            horizon,
            replan,
            iterations,
            episodes,
            seed,
            window,
            reports: &reports,
        }),
        Command::Wipe {
            mu,
            gains,
            steps,
            identify,
            seed,
            model_out,
            output,
        } => match gains.as_deref() {
            None => Ok(None),
            Some(&[k_tau, k_xi]) => Ok(Some(diffosi::control::admittance::Gains { k_tau, k_xi })),
            Some(g) => Err(format!("--gains takes k_tau,k_xi: got {} values", g.len())),
        }
        .and_then(|gains| {
            let outputs = (output.as_path(), model_out.as_deref());
            cli::wiping::wipe(&mu, gains, (steps, seed), outputs, identify)
        }),
        Command::TrainWiping {
            output,
            pairs,
            seed,
            threads,
        } => cli::wiping::train(&output, (pairs, seed), threads.unwrap_or_else(cores)),
        Command::Reproduce {
            what,
            policies,
            reports,
            episodes,
            models,
            seed,
            threads,
        } => cli::reproduce::reproduce(cli::reproduce::Request {
            what: &what,
            policies: &policies,
            reports: &reports,
            episodes,
            models,
            seed,
            threads: threads.unwrap_or_else(cores),
        }),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(message) => {
            eprintln!("error: {message}");
            ExitCode::FAILURE
        }
    }
}
