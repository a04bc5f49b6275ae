//! Policy refinement by analytic policy gradients: the gradient of a
//! closed-loop rollout's cost with respect to the policy's weights,
//! back-propagated through the engine's exact step Jacobians
//! (backpropagation through time).
//!
//! A rollout of H control steps from x_0 in an episode with parameters mu,
//! under the policy u_t = pi(x_t) (the network's mean action, clamped to
//! [-1, 1]), costs L = sum_t l_t with l_t = Task::cost(mu, x_t, u_t, x_t+1),
//! the planning cost the iLQR expert minimises. With A_t = dx_t+1/dx_t and
//! B_t = dx_t+1/du_t (exact), l_x and l_u the step cost's gradient (x_t+1
//! moving with x_t and u_t; [`Ilqr::differentiate`]), and P_t = du_t/dx_t the
//! policy's own Jacobian (network, input normalisation, observation; zero in
//! a clamped component), the adjoint lambda_t = dL/dx_t of the cost from step
//! t on runs backward from lambda_H = 0:
//!
//!   g_t      = l_u + B_t^T lambda_t+1            (dL/du_t with x_t held)
//!   lambda_t = l_x + A_t^T lambda_t+1 + P_t^T g_t
//!
//! and dL/dweights = sum_t (du_t/dweights)^T g_t: one backward pass of the
//! network over every step of every rollout. The observation's Jacobian
//! dobs/dx is taken by central differences of [`Task::observe`] (exact for
//! the tasks' linear observations, up to rounding).
//!
//! Rollouts start from the task's reset distribution with mu uniform in its
//! range or, with probability `change`, where the policy itself has brought
//! the system after 1..=`lead` control steps under another mu drawn
//! uniformly (a mid-episode change, the paper's Table 4): the rollout then
//! runs at the new mu. A rollout stops where the task ends the episode:
//! run on, a fallen pole spins and its cost's gradient swamps the others
//! (the training measured unstable that way). An iteration is one Adam step
//! on the mean cost per step of `batch` rollouts, the gradient's norm
//! clipped. Every `eval_every`
//! iterations the policy plays fixed validation episodes of the full horizon
//! with the true mu (half of them with a change of mu at a step uniform in
//! the middle half); the best-scoring policy, the initial one included, is
//! returned. One thread, one seed: the same seed gives bitwise the same
//! weights.

use std::time::Instant;

use nalgebra::{DMatrix, DVector};
use rand::rngs::StdRng;
use rand::{RngExt, SeedableRng};

use super::policy::{Policy, TrainingInfo};
use super::stats::normalize_into;
use crate::control::ilqr::{Ilqr, IlqrOptions, StepDerivatives};
use crate::control::{run_episode, ControlError, Episode, OracleMu};
use crate::model::State;
use crate::nn::{Adam, Tape};
use crate::tasks::{sample_mu, Env, Task};

#[derive(Clone, Debug, PartialEq)]
pub struct ApgConfig {
    pub seed: u64,
    /// Gradient steps.
    pub iterations: usize,
    /// Rollouts per gradient step.
    pub batch: usize,
    /// Control steps of each rollout.
    pub horizon: usize,
    /// Adam's step size.
    pub lr: f64,
    /// Probability that a rollout starts after a change of mu, and the most
    /// control steps run under the first mu before it.
    pub change: f64,
    pub lead: usize,
    /// Largest norm of a gradient step's gradient.
    pub max_grad_norm: f64,
    /// Iterations between validations, and validation episodes.
    pub eval_every: usize,
    pub validation: usize,
}

impl Default for ApgConfig {
    /// The cartpole's settings: 1560 steps of 32 rollouts of 80 control
    /// steps (1.6 s: the swing to a tilted balance and the catch after it),
    /// a fifth of them after a change of mu; about 2 minutes on one core.
    fn default() -> Self {
        ApgConfig {
            seed: 0,
            iterations: 1560,
            batch: 32,
            horizon: 80,
            lr: 1e-4,
            change: 0.2,
            lead: 300,
            max_grad_norm: 1.0,
            eval_every: 10,
            validation: 100,
        }
    }
}

/// One iteration of the learning curve.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct ApgRow {
    pub iteration: usize,
    /// Control steps simulated in rollouts so far.
    pub env_steps: usize,
    /// Mean cost per step of the iteration's rollouts.
    pub mean_cost: f64,
    /// Mean validation score, when the iteration validated.
    pub validation: Option<f64>,
    pub seconds: f64,
}

impl ApgRow {
    pub const CSV_HEADER: &'static str = "iteration,env_steps,mean_cost,validation,seconds";

    pub fn csv(&self) -> String {
        format!(
            "{},{},{},{},{:.3}",
            self.iteration,
            self.env_steps,
            self.mean_cost,
            self.validation.map_or(String::new(), |v| v.to_string()),
            self.seconds
        )
    }
}

/// The validation episodes' stream: fixed, apart from every evaluation seed
/// the reports use.
const VALIDATION_SEED: u64 = 0xa9_7a11_da7e;

/// Refines `init` on `task` by analytic policy gradients; `progress` sees
/// each iteration. Returns the best policy met and the learning curve.
pub fn train_apg(
    task: &dyn Task,
    init: &Policy,
    config: &ApgConfig,
    mut progress: impl FnMut(&ApgRow),
) -> Result<(Policy, Vec<ApgRow>), ControlError> {
    let started = Instant::now();
    let mut rng = StdRng::seed_from_u64(config.seed);
    let mut policy = init.clone();
    let mut adam = Adam::new(policy.actor.params().len(), config.lr);
    let mut best = (validate(task, &policy, config.validation)?, policy.clone());
    let mut rows = vec![];
    for iteration in 1..=config.iterations {
        let rollouts = (0..config.batch)
            .map(|_| {
                let start = start(task, &policy, config, &mut rng)?;
                rollout(task, &policy, config.horizon, start)
            })
            .collect::<Result<Vec<_>, _>>()?;
        let mut grad = gradient(&policy, &rollouts);
        let norm = grad.iter().map(|g| (g * g) as f64).sum::<f64>().sqrt();
        if norm > config.max_grad_norm {
            let scale = (config.max_grad_norm / norm) as f32;
            grad.iter_mut().for_each(|g| *g *= scale);
        }
        adam.step(policy.actor.params_mut(), &grad);
        let validation = (iteration % config.eval_every == 0)
            .then(|| validate(task, &policy, config.validation))
            .transpose()?;
        if let Some(score) = validation.filter(|&s| s > best.0) {
            best = (score, policy.clone());
        }
        let steps: usize = rollouts.iter().map(|r| r.steps.len()).sum();
        let row = ApgRow {
            iteration,
            env_steps: rows.last().map_or(0, |r: &ApgRow| r.env_steps) + steps,
            mean_cost: rollouts.iter().map(|r| r.cost).sum::<f64>() / steps as f64,
            validation,
            seconds: started.elapsed().as_secs_f64(),
        };
        progress(&row);
        rows.push(row);
    }
    let (score, mut policy) = best;
    policy.training = Some(TrainingInfo {
        seed: config.seed,
        env_steps: rows.last().map_or(0, |r| r.env_steps),
        iterations: config.iterations,
        wall_seconds: started.elapsed().as_secs_f64(),
        final_metric: Some(score),
    });
    Ok((policy, rows))
}

/// Where a rollout starts: its mu and initial state (see the module docs).
fn start(
    task: &dyn Task,
    policy: &Policy,
    config: &ApgConfig,
    rng: &mut StdRng,
) -> Result<(Vec<f64>, State), ControlError> {
    let mu = sample_mu(task, rng);
    let reset = task.reset(rng);
    if rng.random::<f64>() >= config.change {
        return Ok((mu, reset));
    }
    let before = sample_mu(task, rng);
    let lead = rng.random_range(1..=config.lead);
    let mut env = Env::new(task);
    env.reset_to(&before, reset.clone())?;
    for _ in 0..lead {
        let action = policy.act(&policy.observation(task, env.state(), &before));
        if env.step(&action)?.terminated {
            // The policy lost the first mu's episode: start afresh at the new one.
            return Ok((mu, reset));
        }
    }
    Ok((mu, env.state().clone()))
}

/// One rollout under the policy and what its gradient needs.
struct Rollout {
    /// The network's normalised inputs, a row per step.
    z: Vec<f32>,
    /// Per step, dz/dx (inputs x 2 nv).
    dz_dx: Vec<DMatrix<f64>>,
    /// Per step and action component, whether the action is inside its clamp.
    inside: Vec<bool>,
    steps: Vec<StepDerivatives>,
    cost: f64,
}

fn rollout(
    task: &dyn Task,
    policy: &Policy,
    horizon: usize,
    (mu, mut x): (Vec<f64>, State),
) -> Result<Rollout, ControlError> {
    let mut sim = Ilqr::new(task, &mu, IlqrOptions::default())?;
    let mut out = Rollout {
        z: vec![],
        dz_dx: vec![],
        inside: vec![],
        steps: vec![],
        cost: 0.0,
    };
    for _ in 0..horizon {
        let input = policy.observation(task, &x, &mu);
        let u = policy.act(&input);
        normalize_into(
            &policy.obs_mean,
            &policy.obs_std,
            policy.obs_clip,
            &input,
            &mut out.z,
        );
        out.dz_dx.push(input_jacobian(task, policy, &x, &mu));
        out.inside.extend(u.iter().map(|a| a.abs() < 1.0));
        let step = sim.differentiate(&x, &u)?;
        out.cost += step.cost;
        x = step.next.clone();
        out.steps.push(step);
        if task.terminated(&x) {
            break;
        }
    }
    Ok(out)
}

/// dz/dx of the policy's normalised input z at state x: zero where the
/// normalisation clips, the observation differenced centrally.
fn input_jacobian(task: &dyn Task, policy: &Policy, x: &State, mu: &[f64]) -> DMatrix<f64> {
    let nq = x.q.len();
    let flat: Vec<f64> = x.q.iter().chain(&x.v).copied().collect();
    let at = |k: usize, d: f64| {
        let mut moved = flat.clone();
        moved[k] += d;
        let state = State::new(moved[..nq].to_vec(), moved[nq..].to_vec());
        policy.observation(task, &state, mu)
    };
    let base = policy.observation(task, x, mu);
    let mut jac = DMatrix::zeros(base.len(), flat.len());
    for (k, value) in flat.iter().enumerate() {
        let h = 1e-6 * value.abs().max(1.0);
        let (plus, minus) = (at(k, h), at(k, -h));
        for i in 0..base.len() {
            jac[(i, k)] = (plus[i] - minus[i]) / (2.0 * h);
        }
    }
    for (i, mut row) in jac.row_iter_mut().enumerate() {
        let scaled = (base[i] - policy.obs_mean[i]) / policy.obs_std[i];
        let slope = if scaled.abs() < policy.obs_clip {
            1.0 / policy.obs_std[i]
        } else {
            0.0
        };
        row *= slope;
    }
    jac
}

/// The gradient of the mean cost per step of `rollouts` in the policy's
/// weights (the adjoint of the module docs).
fn gradient(policy: &Policy, rollouts: &[Rollout]) -> Vec<f32> {
    let net = &policy.actor;
    let (dim, m) = (net.inputs(), net.outputs());
    let z: Vec<f32> = rollouts.iter().flat_map(|r| r.z.iter().copied()).collect();
    let rows = z.len() / dim;
    let mut tape = Tape::default();
    net.forward(&z, &mut tape);
    // The network's Jacobian dz -> action, one backward pass per output.
    let mut unused = vec![0.0; net.params().len()];
    let jacobians: Vec<Vec<f32>> = (0..m)
        .map(|j| {
            let mut dout = vec![0.0; rows * m];
            dout.iter_mut().skip(j).step_by(m).for_each(|d| *d = 1.0);
            net.backward_to_inputs(&mut tape, &dout, &mut unused)
                .to_vec()
        })
        .collect();
    let mut dout = vec![0.0f32; rows * m];
    let mut first = 0;
    for r in rollouts {
        let n2 = r.steps[0].a.nrows();
        let mut lambda = DVector::zeros(n2);
        for (t, step) in r.steps.iter().enumerate().rev() {
            let row = first + t;
            let g = &step.l_u + step.b.transpose() * &lambda;
            let mut p = DMatrix::zeros(m, dim);
            for j in (0..m).filter(|&j| r.inside[t * m + j]) {
                for i in 0..dim {
                    p[(j, i)] = jacobians[j][row * dim + i] as f64;
                }
                dout[row * m + j] = g[j] as f32;
            }
            let p = p * &r.dz_dx[t];
            lambda = &step.l_x + step.a.transpose() * &lambda + p.transpose() * &g;
        }
        first += r.steps.len();
    }
    let mut grad = vec![0.0; net.params().len()];
    net.backward(&mut tape, &dout, &mut grad);
    let scale = 1.0 / rows as f32;
    grad.iter_mut().for_each(|g| *g *= scale);
    grad
}

/// The policy's mean score on the fixed validation episodes (true mu; every
/// second one with a change of mu at a step uniform in the middle half).
fn validate(task: &dyn Task, policy: &Policy, episodes: usize) -> Result<f64, ControlError> {
    let mut rng = StdRng::seed_from_u64(VALIDATION_SEED);
    let horizon = task.horizon();
    let mut total = 0.0;
    for e in 0..episodes {
        let mut episode = Episode::draw(task, &mut rng);
        if e % 2 == 1 {
            let at = rng.random_range(horizon / 4..3 * horizon / 4);
            episode.change = Some((at, sample_mu(task, &mut rng)));
        }
        let mut oracle = OracleMu::default();
        total += run_episode(task, policy, Some(&mut oracle), &episode)?.score();
    }
    Ok(total / episodes as f64)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::tasks::Cartpole;

    fn shipped_uc() -> Policy {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("policies/cartpole/uc-seed0.json");
        Policy::load(&path).unwrap()
    }

    /// The mean cost per step of rollouts from fixed starts under `policy`.
    fn rollouts(task: &Cartpole, policy: &Policy, horizon: usize) -> Vec<Rollout> {
        let starts = [(-0.55, 0.03), (0.3, -0.04), (-0.2, 0.02)];
        starts
            .iter()
            .map(|&(mu, theta)| {
                let x0 = State::new(vec![0.02, theta], vec![-0.01, 0.03]);
                rollout(task, policy, horizon, (vec![mu], x0)).unwrap()
            })
            .collect()
    }

    fn mean_cost(task: &Cartpole, policy: &Policy, horizon: usize) -> f64 {
        let r = rollouts(task, policy, horizon);
        let steps: usize = r.iter().map(|r| r.steps.len()).sum();
        assert_eq!(steps, 3 * horizon, "a rollout ended early");
        r.iter().map(|r| r.cost).sum::<f64>() / steps as f64
    }

    #[test]
    fn the_adjoint_gradient_is_the_slope_of_the_rollouts_cost() {
        // A swing to a tilted balance (mu = -0.55) and two gentler poles,
        // 40 control steps each; the slope along the gradient by central
        // differences of whole rollouts (weights in f32, so a step of 1e-3).
        let task = Cartpole::new();
        let policy = shipped_uc();
        let horizon = 40;
        let grad = gradient(&policy, &rollouts(&task, &policy, horizon));
        let norm = grad.iter().map(|g| (g * g) as f64).sum::<f64>().sqrt();
        assert!(norm > 0.0);
        let moved = |eps: f64| {
            let mut p = policy.clone();
            for (w, g) in p.actor.params_mut().iter_mut().zip(&grad) {
                *w += (eps * *g as f64 / norm) as f32;
            }
            mean_cost(&task, &p, horizon)
        };
        let eps = 1e-3;
        let slope = (moved(eps) - moved(-eps)) / (2.0 * eps);
        assert!(
            (slope - norm).abs() < 0.02 * norm,
            "slope {slope}, gradient norm {norm}"
        );
        // Orthogonal to the gradient the cost is flat to first order.
        let mut other = policy.clone();
        let n = grad.len();
        let probe: Vec<f64> = (0..n).map(|i| ((i * 7919) % 13) as f64 - 6.0).collect();
        let along = probe
            .iter()
            .zip(&grad)
            .map(|(p, g)| p * *g as f64)
            .sum::<f64>()
            / norm;
        let side: Vec<f64> = probe
            .iter()
            .zip(&grad)
            .map(|(p, g)| p - along * *g as f64 / norm)
            .collect();
        let side_norm = side.iter().map(|s| s * s).sum::<f64>().sqrt();
        let shift = |eps: f64, p: &mut Policy| {
            for (w, s) in p.actor.params_mut().iter_mut().zip(&side) {
                *w += (eps * s / side_norm) as f32;
            }
        };
        shift(eps, &mut other);
        let plus = mean_cost(&task, &other, horizon);
        shift(-2.0 * eps, &mut other);
        let minus = mean_cost(&task, &other, horizon);
        let side_slope = (plus - minus) / (2.0 * eps);
        assert!(
            side_slope.abs() < 0.02 * norm,
            "side slope {side_slope} vs {norm}"
        );
    }

    #[test]
    fn training_is_seeded_and_returns_the_best_validated_policy() {
        let task = Cartpole::new();
        let init = shipped_uc();
        let config = ApgConfig {
            iterations: 4,
            batch: 2,
            horizon: 20,
            lr: 1e-2,
            lead: 50,
            eval_every: 2,
            validation: 4,
            ..ApgConfig::default()
        };
        let (a, rows) = train_apg(&task, &init, &config, |_| {}).unwrap();
        let (b, _) = train_apg(&task, &init, &config, |_| {}).unwrap();
        assert_eq!(a.actor, b.actor);
        assert_eq!(rows.len(), 4);
        assert!(rows
            .iter()
            .all(|r| r.env_steps > 0 && r.mean_cost.is_finite()));
        let validated: Vec<f64> = rows.iter().filter_map(|r| r.validation).collect();
        assert_eq!(validated.len(), 2);
        let start = validate(&task, &init, 4).unwrap();
        let best = validated.iter().fold(start, |m, &v| m.max(v));
        assert_eq!(a.training.as_ref().unwrap().final_metric, Some(best));
        assert_eq!(a.actor == init.actor, best == start);
    }
}
