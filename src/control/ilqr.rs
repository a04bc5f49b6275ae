//! iLQR trajectory optimisation and model-predictive control on any [`Task`],
//! the baseline of the paper's runtime comparison.
//!
//! Conventions:
//! - The planner's model is the task's model with the episode's mu applied
//!   (an oracle model: the planner knows mu, as UC-Oracle does).
//! - The state x = (q, v) has 2 nv components (the task models have nq = nv);
//!   a control u is a task action, each component in [-1, 1].
//! - One control step is [`Task::substeps`] physics steps with the forces
//!   `Task::forces(u)` held. Its Jacobians A = dx'/dx and B = dx'/du chain the
//!   engine's exact step Jacobians ([`transition_jacobians`]) through the substeps;
//!   dtau/du is the secant of `Task::forces` over [0, 1] per component, exact
//!   because a task's forces are affine in the action inside [-1, 1]
//!   (checked when the planner is built).
//! - The cost of a plan is the sum over its H control steps of the task's
//!   planning cost l = Task::cost(mu, x, u, x') (the negated training reward
//!   unless the task gives a smooth one), no terminal cost. The tasks give no
//!   cost derivatives, so the gradient and Hessian of the cost in
//!   z = (x, u, x') are central finite differences of the cost alone (the
//!   dynamics derivatives stay exact); only the coordinates of z the cost
//!   depends on are differenced, found once per planner by perturbing each
//!   coordinate at a few reset states under random actions (fixed seed).
//!   With x' = f(x, u), the cost's derivatives in (x, u) are
//!   l_xu = Z^T g and l_xu,xu = Z^T H Z, Z = dz/d(x, u): the second
//!   derivatives of the dynamics are dropped (iLQR, Li and Todorov 2004),
//!   and H is replaced by its positive semi-definite part (negative
//!   eigenvalues set to zero), so the value function's Hessian stays
//!   positive semi-definite where the cost is not convex.
//! - Action bounds: each backward-pass step solves the box-constrained
//!   quadratic for the feed-forward change by projected Newton (Tassa, Mansard
//!   and Todorov 2014); the feedback gains of clamped components are zero.
//!   The forward pass clamps u = clamp(u_bar + alpha k + K (x - x_bar)).
//! - Levenberg-Marquardt regularisation lambda I is added to Quu: multiplied
//!   by 10 when Quu + lambda I is not positive definite or no line-search step
//!   decreases the cost, divided by 10 after an accepted step. The line search
//!   tries alpha = 1, 1/2, ..., 1/2^9 and accepts the first strictly lower cost,
//!   so the cost decreases monotonically over accepted iterations.
//! - MPC ([`run_mpc_episode`]): plan H control steps from the current state
//!   (the episode's first plan, from zero actions, grows its horizon R, 2R,
//!   4R, ..., H, each stage warm-started by the last: where the cost
//!   vanishes once the task fails, as the cartpole's, a zero-action rollout
//!   fails early and gives no gradient past the failure), execute the first
//!   R with the plan's feedback law
//!   u = clamp(u_bar + K (x - x_bar)) (equal to the open-loop actions when the
//!   planner's model is the environment's, as here), then replan from the
//!   reached state, warm-started with the previous plan shifted by R steps
//!   (zero actions appended). Everything is deterministic; only the recorded
//!   wall times vary.

use std::time::Instant;

use nalgebra::{DMatrix, DVector};
use rand::rngs::StdRng;
use rand::{RngExt, SeedableRng};

use super::ControlError;
use crate::derivatives::{transition_jacobians, TransitionJacobians, Workspace};
use crate::dynamics::{Data, StepError};
use crate::model::{Inputs, State};
use crate::tasks::{Env, Task};
use crate::Model;

/// Settings of the trajectory optimiser.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct IlqrOptions {
    /// Most iLQR iterations (backward + forward pass) per plan.
    pub iterations: usize,
    /// Stop when an accepted step lowers the cost by less than this fraction.
    pub tolerance: f64,
    /// Initial Levenberg-Marquardt regularisation of Quu.
    pub lambda: f64,
    /// Give up on a plan once the regularisation exceeds this.
    pub lambda_max: f64,
}

impl Default for IlqrOptions {
    /// At most 10 iterations, tolerance 1e-6, lambda 1e-6 up to 1e10.
    fn default() -> Self {
        IlqrOptions {
            iterations: 10,
            tolerance: 1e-6,
            lambda: 1e-6,
            lambda_max: 1e10,
        }
    }
}

/// A locally optimal plan: states x_0..x_H, actions u_0..u_{H-1}, feedback
/// gains K_t (act_dim x 2 nv) and the plan's cost.
#[derive(Clone, Debug, PartialEq)]
pub struct Plan {
    pub states: Vec<State>,
    pub actions: Vec<Vec<f64>>,
    pub gains: Vec<DMatrix<f64>>,
    pub cost: f64,
}

impl Plan {
    /// The plan's action at step t for the actual state x: u_t + K_t (x - x_t), clamped.
    pub fn action(&self, t: usize, x: &State) -> Vec<f64> {
        self.law(t, x, 0.0, &DVector::zeros(self.actions[t].len()))
    }

    /// u_t + alpha k + K_t (x - x_t), clamped to [-1, 1].
    fn law(&self, t: usize, State { q, v, .. }: &State, alpha: f64, k: &DVector<f64>) -> Vec<f64> {
        let State {
            q: q_bar, v: v_bar, ..
        } = &self.states[t];
        let dx: DVector<f64> = DVector::from_iterator(
            q.len() + v.len(),
            q.iter()
                .zip(q_bar)
                .chain(v.iter().zip(v_bar))
                .map(|(a, b)| a - b),
        );
        let du = &self.gains[t] * dx + k * alpha;
        self.actions[t]
            .iter()
            .zip(du.iter())
            .map(|(u, d)| (u + d).clamp(-1.0, 1.0))
            .collect()
    }
}

/// What one planning call did: the cost of the warm start, then the cost
/// after each accepted iteration, and the final regularisation.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize)]
pub struct PlanLog {
    pub costs: Vec<f64>,
    /// Backward passes run (accepted or not).
    pub iterations: usize,
    pub lambda: f64,
}

/// The iLQR planner of one task at one mu (see the module conventions).
pub struct Ilqr<'a> {
    task: &'a dyn Task,
    model: Model,
    mu: Vec<f64>,
    options: IlqrOptions,
    data: Data<f64>,
    ws: Workspace,
    /// dtau/du (nv x act_dim).
    dtau_du: DMatrix<f64>,
    /// The coordinates of z = (q, v, u, q', v') the cost depends on.
    cost_coords: Vec<usize>,
}

/// The cost's arguments, laid out as z = (q, v, u, q', v') for differencing.
struct CostPoint {
    state: State,
    action: Vec<f64>,
    next: State,
}

impl CostPoint {
    fn slot(&mut self, i: usize) -> &mut f64 {
        let (n, m) = (self.state.q.len(), self.action.len());
        match i {
            i if i < n => &mut self.state.q[i],
            i if i < 2 * n => &mut self.state.v[i - n],
            i if i < 2 * n + m => &mut self.action[i - 2 * n],
            i if i < 3 * n + m => &mut self.next.q[i - 2 * n - m],
            i => &mut self.next.v[i - 3 * n - m],
        }
    }

    fn cost(&self, task: &dyn Task, mu: &[f64]) -> f64 {
        task.cost(mu, &self.state, &self.action, &self.next)
    }

    /// The cost with coordinates i and j moved by di and dj (i may equal j).
    fn moved(
        &mut self,
        task: &dyn Task,
        mu: &[f64],
        (i, di): (usize, f64),
        (j, dj): (usize, f64),
    ) -> f64 {
        let (zi, zj) = (*self.slot(i), *self.slot(j));
        *self.slot(i) += di;
        *self.slot(j) += dj;
        let c = self.cost(task, mu);
        *self.slot(i) = zi;
        *self.slot(j) = zj;
        c
    }
}

/// Relative difference steps: gradient (cube root of epsilon) and Hessian (fourth root).
const GRADIENT_STEP: f64 = 6e-6;
const HESSIAN_STEP: f64 = 1e-4;

impl<'a> Ilqr<'a> {
    /// A planner for `task` with the true parameters `mu`.
    pub fn new(
        task: &'a dyn Task,
        mu: &[f64],
        options: IlqrOptions,
    ) -> Result<Ilqr<'a>, ControlError> {
        let mut model = task.model().clone();
        task.mu_map()
            .apply(&mut model, mu)
            .map_err(|e| ControlError::Env(e.into()))?;
        assert_eq!(model.nq(), model.nv(), "iLQR needs nq = nv");
        let m = task.act_dim();
        let tau0 = task.forces(&vec![0.0; m]);
        let mut dtau_du = DMatrix::zeros(model.nv(), m);
        for j in 0..m {
            let mut u = vec![0.0; m];
            u[j] = 1.0;
            let one = task.forces(&u);
            u[j] = -0.5;
            let minus_half = task.forces(&u);
            for i in 0..model.nv() {
                let slope = one[i] - tau0[i];
                let affine = tau0[i] - 0.5 * slope - minus_half[i];
                assert!(
                    affine.abs() <= 1e-9 * (1.0 + slope.abs()),
                    "Task::forces is not affine"
                );
                dtau_du[(i, j)] = slope;
            }
        }
        let mut planner = Ilqr {
            task,
            data: model.data(),
            ws: Workspace::new(&model),
            model,
            mu: mu.to_vec(),
            options,
            dtau_du,
            cost_coords: vec![],
        };
        planner.cost_coords = planner.probe_cost_coords()?;
        Ok(planner)
    }

    /// The coordinates of z whose change moves the cost at any of a few
    /// reset states under random actions (seeded, so always the same).
    fn probe_cost_coords(&mut self) -> Result<Vec<usize>, ControlError> {
        let mut rng = StdRng::seed_from_u64(0);
        let (n, m) = (self.model.nv(), self.task.act_dim());
        let mut used = vec![false; 4 * n + m];
        for _ in 0..8 {
            let state = self.task.reset(&mut rng);
            let action: Vec<f64> = (0..m).map(|_| rng.random_range(-1.0..=1.0)).collect();
            let next = self.control_step(&state, &action).map_err(step_error)?;
            let mut point = CostPoint {
                state,
                action,
                next,
            };
            let c = point.cost(self.task, &self.mu);
            for (i, flag) in used.iter_mut().enumerate() {
                let h = 1e-3 * point.slot(i).abs().max(1.0);
                for d in [h, -h] {
                    *flag |= point.moved(self.task, &self.mu, (i, d), (i, 0.0)) != c;
                }
            }
        }
        Ok((0..used.len()).filter(|&i| used[i]).collect())
    }

    /// One control step from `state` under `action` (held forces).
    fn control_step(&mut self, state: &State, action: &[f64]) -> Result<State, StepError> {
        let tau = self.task.forces(action);
        let u = Inputs::tau(&tau);
        let mut next = state.clone();
        for _ in 0..self.task.substeps() {
            let State { q, v, .. } = self.model.step(&mut self.data, &next, &u)?;
            (next.q, next.v) = (q, v);
        }
        Ok(next)
    }

    /// The states visited from x0 under `actions` and their cost; None if a step diverged.
    fn rollout(&mut self, x0: &State, actions: &[Vec<f64>]) -> Option<(Vec<State>, f64)> {
        let mut states = vec![x0.clone()];
        let mut cost = 0.0;
        for u in actions {
            let x = states.last().expect("starts with x0");
            let next = self.control_step(x, u).ok()?;
            cost += self.task.cost(&self.mu, x, u, &next);
            states.push(next);
        }
        cost.is_finite().then_some((states, cost))
    }

    /// The rollout from x0 under the feedback law around `plan` with step size alpha.
    fn forward(
        &mut self,
        x0: &State,
        plan: &Plan,
        feedforward: &[DVector<f64>],
        alpha: f64,
    ) -> Option<(Vec<State>, Vec<Vec<f64>>, f64)> {
        let mut states = vec![x0.clone()];
        let mut actions = Vec::with_capacity(plan.actions.len());
        let mut cost = 0.0;
        for (t, k) in feedforward.iter().enumerate() {
            let x = states.last().expect("starts with x0");
            let u = plan.law(t, x, alpha, k);
            let next = self.control_step(x, &u).ok()?;
            cost += self.task.cost(&self.mu, x, &u, &next);
            states.push(next);
            actions.push(u);
        }
        cost.is_finite().then_some((states, actions, cost))
    }

    /// A = dx'/dx and B = dx'/du of one control step, by the exact step
    /// Jacobians, and the state it reaches.
    fn linearise(
        &mut self,
        State { q, v, .. }: &State,
        action: &[f64],
    ) -> Result<(DMatrix<f64>, DMatrix<f64>, State), StepError> {
        let n = self.model.nv();
        let tau = self.task.forces(action);
        let mut a = DMatrix::identity(2 * n, 2 * n);
        let mut b_tau = DMatrix::zeros(2 * n, n);
        let (mut q, mut v) = (q.clone(), v.clone());
        let mut step = TransitionJacobians::new(n, n);
        for _ in 0..self.task.substeps() {
            transition_jacobians(&self.model, &mut self.ws, (&q, &v, &tau), &mut step)?;
            a = &step.a * a;
            b_tau = &step.a * b_tau + &step.b;
            q.copy_from_slice(&step.q_next);
            v.copy_from_slice(&step.v_next);
        }
        Ok((a, b_tau * &self.dtau_du, State::new(q, v)))
    }

    /// One control step from `x` under the action `u` and its derivatives:
    /// the next state, A = dx'/dx and B = dx'/du (exact), the step's cost and
    /// its gradient in (x, u) through x' = f(x, u) (what a gradient of a
    /// closed-loop rollout's cost needs: [`crate::rl::train_apg`]).
    pub fn differentiate(&mut self, x: &State, u: &[f64]) -> Result<StepDerivatives, ControlError> {
        let (a, b, next) = self.linearise(x, u).map_err(step_error)?;
        let mut point = CostPoint {
            state: x.clone(),
            action: u.to_vec(),
            next,
        };
        let cost = point.cost(self.task, &self.mu);
        let gradient = self.chain_rule(&a, &b).transpose() * self.cost_gradient(&mut point);
        let n2 = a.nrows();
        Ok(StepDerivatives {
            next: point.next,
            cost,
            l_x: gradient.rows(0, n2).into_owned(),
            l_u: gradient.rows(n2, b.ncols()).into_owned(),
            a,
            b,
        })
    }

    /// Z, the rows dz_i / d(x, u) of the coordinates the cost depends on.
    fn chain_rule(&self, a: &DMatrix<f64>, b: &DMatrix<f64>) -> DMatrix<f64> {
        let (n2, m) = (a.nrows(), b.ncols());
        let mut z = DMatrix::zeros(self.cost_coords.len(), n2 + m);
        for (row, &i) in self.cost_coords.iter().enumerate() {
            if i < n2 + m {
                z[(row, i)] = 1.0;
            } else {
                let k = i - n2 - m;
                z.view_mut((row, 0), (1, n2)).copy_from(&a.row(k));
                z.view_mut((row, n2), (1, m)).copy_from(&b.row(k));
            }
        }
        z
    }

    /// The cost's difference steps, one per used coordinate of z.
    fn cost_steps(&self, point: &mut CostPoint) -> Vec<f64> {
        self.cost_coords
            .iter()
            .map(|&i| point.slot(i).abs().max(1.0))
            .collect()
    }

    /// The cost's gradient in the used coordinates of z (central differences).
    fn cost_gradient(&self, point: &mut CostPoint) -> DVector<f64> {
        let steps = self.cost_steps(point);
        let (task, mu) = (self.task, &self.mu[..]);
        DVector::from_iterator(
            steps.len(),
            self.cost_coords.iter().zip(&steps).map(|(&i, &step)| {
                let s = GRADIENT_STEP * step;
                let plus = point.moved(task, mu, (i, s), (i, 0.0));
                let minus = point.moved(task, mu, (i, -s), (i, 0.0));
                (plus - minus) / (2.0 * s)
            }),
        )
    }

    /// Gradient and Hessian of the step cost l in (x, u), through x' = f(x, u)
    /// with the dynamics' second derivatives dropped.
    fn cost_derivatives(
        &self,
        point: &mut CostPoint,
        a: &DMatrix<f64>,
        b: &DMatrix<f64>,
    ) -> (DVector<f64>, DMatrix<f64>) {
        let coords = &self.cost_coords;
        let d = coords.len();
        let z = self.chain_rule(a, b);
        let steps = self.cost_steps(point);
        let (task, mu) = (self.task, &self.mu[..]);
        let c0 = point.cost(task, mu);
        let g = self.cost_gradient(point);
        let mut h = DMatrix::zeros(d, d);
        for (p, &i) in coords.iter().enumerate() {
            let s = HESSIAN_STEP * steps[p];
            let plus = point.moved(task, mu, (i, s), (i, 0.0));
            let minus = point.moved(task, mu, (i, -s), (i, 0.0));
            h[(p, p)] = (plus - 2.0 * c0 + minus) / (s * s);
            for (r, &j) in coords.iter().enumerate().take(p) {
                let t = HESSIAN_STEP * steps[r];
                let pp = point.moved(task, mu, (i, s), (j, t));
                let pm = point.moved(task, mu, (i, s), (j, -t));
                let mp = point.moved(task, mu, (i, -s), (j, t));
                let mm = point.moved(task, mu, (i, -s), (j, -t));
                h[(p, r)] = (pp - pm - mp + mm) / (4.0 * s * t);
                h[(r, p)] = h[(p, r)];
            }
        }
        let curvature = convex_part(h);
        (z.transpose() * g, z.transpose() * curvature * &z)
    }

    /// Optimises the actions of the next `warm.len()` control steps from x0,
    /// starting from `warm` (run open loop).
    pub fn plan(
        &mut self,
        x0: &State,
        warm: Vec<Vec<f64>>,
    ) -> Result<(Plan, PlanLog), ControlError> {
        let h_len = warm.len();
        assert!(h_len > 0, "an empty horizon");
        let (n2, m) = (2 * self.model.nv(), self.task.act_dim());
        let warm: Vec<Vec<f64>> = warm
            .into_iter()
            .map(|u| u.iter().map(|x| x.clamp(-1.0, 1.0)).collect())
            .collect();
        let (states, cost) = self
            .rollout(x0, &warm)
            .ok_or(step_error(StepError::Diverged))?;
        self.improve(Plan {
            states,
            actions: warm,
            gains: vec![DMatrix::zeros(m, n2); h_len],
            cost,
        })
    }

    /// Optimises the next `horizon` control steps from x0, starting from
    /// `previous` without its first `shift` steps, run under its feedback law
    /// (so that a start off the old trajectory stays close to it instead of
    /// drifting away open loop) and padded with zero actions.
    pub fn replan(
        &mut self,
        x0: &State,
        previous: &Plan,
        shift: usize,
        horizon: usize,
    ) -> Result<(Plan, PlanLog), ControlError> {
        let (n2, m) = (2 * self.model.nv(), self.task.act_dim());
        let mut warm = Plan {
            states: previous.states[shift..].to_vec(),
            actions: previous.actions[shift..].to_vec(),
            gains: previous.gains[shift..].to_vec(),
            cost: previous.cost,
        };
        warm.states.truncate(warm.actions.len());
        let end = previous.states.last().expect("a plan has states").clone();
        warm.states.resize(horizon, end);
        warm.actions.resize(horizon, vec![0.0; m]);
        warm.gains.resize(horizon, DMatrix::zeros(m, n2));
        warm.actions.truncate(horizon);
        warm.gains.truncate(horizon);
        warm.states.truncate(horizon);
        let no_change = vec![DVector::zeros(m); horizon];
        let (states, actions, cost) = self
            .forward(x0, &warm, &no_change, 0.0)
            .ok_or(step_error(StepError::Diverged))?;
        self.improve(Plan {
            states,
            actions,
            gains: warm.gains,
            cost,
        })
    }

    /// iLQR iterations from `plan` (its states the rollout of its actions).
    fn improve(&mut self, mut plan: Plan) -> Result<(Plan, PlanLog), ControlError> {
        let cost = plan.cost;
        let mut log = PlanLog {
            costs: vec![cost],
            iterations: 0,
            lambda: self.options.lambda,
        };
        let mut lambda = self.options.lambda;
        // The local models along the current plan, rebuilt after each accepted step.
        let mut local = None;
        while log.iterations < self.options.iterations && lambda <= self.options.lambda_max {
            log.iterations += 1;
            if local.is_none() {
                local = Some(self.linearise_plan(&plan)?);
            }
            let models = local.as_ref().expect("just built");
            let Some(Update {
                feedforward,
                gains,
                expected,
            }) = backward(models, &plan.actions, lambda)
            else {
                lambda *= 10.0;
                continue;
            };
            let trial = Plan {
                gains,
                ..plan.clone()
            };
            let accepted = (0..10).map(|k| 0.5f64.powi(k)).find_map(|alpha| {
                self.forward(&trial.states[0], &trial, &feedforward, alpha)
                    .filter(|(_, _, cost)| *cost < plan.cost)
            });
            let Some((states, actions, cost)) = accepted else {
                lambda *= 10.0;
                continue;
            };
            let decrease = plan.cost - cost;
            plan = Plan {
                states,
                actions,
                gains: trial.gains,
                cost,
            };
            log.costs.push(cost);
            lambda = (lambda / 10.0).max(1e-12);
            local = None;
            if decrease <= self.options.tolerance * plan.cost.abs().max(1.0)
                || expected.abs() < 1e-12
            {
                break;
            }
        }
        log.lambda = lambda;
        Ok((plan, log))
    }

    /// The local models along `plan`: each step's Jacobians and cost derivatives.
    fn linearise_plan(&mut self, plan: &Plan) -> Result<Vec<Local>, ControlError> {
        let mut local = Vec::with_capacity(plan.actions.len());
        for (t, u) in plan.actions.iter().enumerate() {
            let x = &plan.states[t];
            let (a, b, _) = self.linearise(x, u).map_err(step_error)?;
            let mut point = CostPoint {
                state: x.clone(),
                action: u.clone(),
                next: plan.states[t + 1].clone(),
            };
            let (l, l2) = self.cost_derivatives(&mut point, &a, &b);
            local.push(Local { a, b, l, l2 });
        }
        Ok(local)
    }
}

/// One control step and its derivatives ([`Ilqr::differentiate`]).
#[derive(Clone, Debug)]
pub struct StepDerivatives {
    pub next: State,
    /// A = dx'/dx (2 nv x 2 nv) and B = dx'/du (2 nv x act_dim).
    pub a: DMatrix<f64>,
    pub b: DMatrix<f64>,
    /// The step's cost l = Task::cost(mu, x, u, x') and its gradient in x and
    /// in u, x' moving with them.
    pub cost: f64,
    pub l_x: DVector<f64>,
    pub l_u: DVector<f64>,
}

/// One control step's local model: x' ~ A x + B u, the step cost's gradient
/// and (Gauss-Newton) Hessian in (x, u).
struct Local {
    a: DMatrix<f64>,
    b: DMatrix<f64>,
    l: DVector<f64>,
    l2: DMatrix<f64>,
}

/// What a backward pass proposes: feed-forward changes k_t, gains K_t and
/// the expected cost change at alpha = 1.
struct Update {
    feedforward: Vec<DVector<f64>>,
    gains: Vec<DMatrix<f64>>,
    expected: f64,
}

/// The backward pass along the local models; None when Quu + lambda I is not
/// positive definite somewhere.
fn backward(local: &[Local], actions: &[Vec<f64>], lambda: f64) -> Option<Update> {
    let (n2, m) = (local[0].a.nrows(), local[0].b.ncols());
    let mut v_x = DVector::zeros(n2);
    let mut v_xx = DMatrix::zeros(n2, n2);
    let mut feedforward = vec![DVector::zeros(m); local.len()];
    let mut gains = vec![DMatrix::zeros(m, n2); local.len()];
    let mut expected = 0.0;
    for t in (0..local.len()).rev() {
        let Local { a, b, l, l2 } = &local[t];
        let q_x = l.rows(0, n2) + a.transpose() * &v_x;
        let q_u = l.rows(n2, m) + b.transpose() * &v_x;
        let vxx_a = &v_xx * a;
        let q_xx = l2.view((0, 0), (n2, n2)) + a.transpose() * &vxx_a;
        let q_ux = l2.view((n2, 0), (m, n2)) + b.transpose() * &vxx_a;
        let q_uu = l2.view((n2, n2), (m, m)) + b.transpose() * &v_xx * b;
        let q_uu_reg = &q_uu + DMatrix::identity(m, m) * lambda;
        q_uu_reg.clone().cholesky()?;
        let lower = DVector::from_iterator(m, actions[t].iter().map(|u| -1.0 - u));
        let upper = DVector::from_iterator(m, actions[t].iter().map(|u| 1.0 - u));
        let (k, free) = box_qp(&q_uu_reg, &q_u, (&lower, &upper), &DVector::zeros(m))?;
        let gain = free_gain(&q_uu_reg, &q_ux, &free);
        let quu_k = &q_uu * &k;
        expected += k.dot(&q_u) + 0.5 * k.dot(&quu_k);
        v_x = q_x + gain.transpose() * (&quu_k + &q_u) + q_ux.transpose() * &k;
        let cross = gain.transpose() * &q_ux;
        v_xx = q_xx + gain.transpose() * &q_uu * &gain + &cross + cross.transpose();
        v_xx = (&v_xx + v_xx.transpose()) * 0.5;
        feedforward[t] = k;
        gains[t] = gain;
    }
    Some(Update {
        feedforward,
        gains,
        expected,
    })
}

/// The positive semi-definite part of a symmetric matrix (negative
/// eigenvalues set to zero).
fn convex_part(h: DMatrix<f64>) -> DMatrix<f64> {
    let eigen = h.symmetric_eigen();
    let clipped = eigen.eigenvalues.map(|l| l.max(0.0));
    &eigen.eigenvectors * DMatrix::from_diagonal(&clipped) * eigen.eigenvectors.transpose()
}

fn step_error(e: StepError) -> ControlError {
    ControlError::Env(e.into())
}

/// -H_ff^-1 Q_ux on the free rows, zero on the clamped ones.
fn free_gain(h: &DMatrix<f64>, q_ux: &DMatrix<f64>, free: &[bool]) -> DMatrix<f64> {
    let idx: Vec<usize> = (0..free.len()).filter(|&i| free[i]).collect();
    let mut gain = DMatrix::zeros(free.len(), q_ux.ncols());
    if idx.is_empty() {
        return gain;
    }
    let h_ff = h.select_rows(&idx).select_columns(&idx);
    let chol = h_ff
        .cholesky()
        .expect("a principal block of a positive definite matrix");
    let solved = -chol.solve(&q_ux.select_rows(&idx));
    for (r, &i) in idx.iter().enumerate() {
        gain.set_row(i, &solved.row(r));
    }
    gain
}

/// Minimises 0.5 x^T H x + g^T x on the box lower <= x <= upper by projected
/// Newton from `start` (H positive definite). Returns the minimiser and which
/// components are free (not held at a bound by the gradient); None if H's
/// free block is not positive definite.
fn box_qp(
    h: &DMatrix<f64>,
    g: &DVector<f64>,
    (lower, upper): (&DVector<f64>, &DVector<f64>),
    start: &DVector<f64>,
) -> Option<(DVector<f64>, Vec<bool>)> {
    let value = |x: &DVector<f64>| 0.5 * x.dot(&(h * x)) + g.dot(x);
    let project = |x: DVector<f64>| x.zip_zip_map(lower, upper, |x, l, u| x.max(l).min(u));
    let mut x = project(start.clone());
    let mut free = vec![true; x.len()];
    for _ in 0..50 {
        let grad = h * &x + g;
        for i in 0..x.len() {
            free[i] = !((x[i] <= lower[i] && grad[i] > 0.0) || (x[i] >= upper[i] && grad[i] < 0.0));
        }
        let idx: Vec<usize> = (0..free.len()).filter(|&i| free[i]).collect();
        if idx.is_empty() {
            break;
        }
        let grad_f = grad.select_rows(&idx);
        if grad_f.norm() < 1e-12 {
            break;
        }
        let chol = h.select_rows(&idx).select_columns(&idx).cholesky()?;
        let step_f = -chol.solve(&grad_f);
        let mut direction = DVector::zeros(x.len());
        for (r, &i) in idx.iter().enumerate() {
            direction[i] = step_f[r];
        }
        let f0 = value(&x);
        let mut alpha = 1.0;
        let mut moved = false;
        while alpha > 1e-10 {
            let candidate = project(&x + &direction * alpha);
            if value(&candidate) - f0 <= 0.1 * grad.dot(&(&candidate - &x)) {
                moved = (&candidate - &x).norm() > 1e-14;
                x = candidate;
                break;
            }
            alpha *= 0.5;
        }
        if !moved {
            break;
        }
    }
    let grad = h * &x + g;
    for i in 0..x.len() {
        free[i] = !((x[i] <= lower[i] && grad[i] > 0.0) || (x[i] >= upper[i] && grad[i] < 0.0));
    }
    Some((x, free))
}

/// The MPC loop's settings: the planner's and the replanning period R.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct MpcOptions {
    pub ilqr: IlqrOptions,
    /// Control steps planned (the paper's MPC: 200).
    pub horizon: usize,
    /// Control steps executed between replans (the paper's MPC: 40).
    pub replan: usize,
}

impl Default for MpcOptions {
    /// The paper's MPC: horizon 200, replanning every 40 control steps.
    fn default() -> Self {
        MpcOptions {
            ilqr: IlqrOptions::default(),
            horizon: 200,
            replan: 40,
        }
    }
}

impl MpcOptions {
    /// Plans of `horizon` control steps, replanned every `replan`, with at
    /// most `iterations` iLQR iterations (the other iLQR settings default).
    pub fn new(horizon: usize, replan: usize, iterations: usize) -> MpcOptions {
        MpcOptions {
            ilqr: IlqrOptions {
                iterations,
                ..IlqrOptions::default()
            },
            horizon,
            replan,
        }
    }

    /// The settings `diffosi mpc` uses for a task by name. The half cheetah:
    /// the paper's horizon and replanning period, at most 5 iterations per
    /// plan. The cartpole: 60 control steps (1.2 s, enough to swing a pole
    /// to a balance angle up to 1 rad from the start), replanning every 5, at
    /// most 10 iterations; it balances every pole of the mu range (the
    /// paper's 200 / 40 leaves the swing of the poles with |mu| near 0.6 to
    /// 40 open-loop steps, which a falling pole does not survive).
    pub fn for_task(task: &str) -> MpcOptions {
        let (horizon, replan, iterations) = match task {
            "cartpole" => (60, 5, 10),
            _ => (200, 40, 5),
        };
        MpcOptions::new(horizon, replan, iterations)
    }
}

/// One replan of an MPC episode.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Replan {
    /// The control step it planned from.
    pub t: usize,
    /// Wall time of the planning call (s), linearisations and line searches included.
    pub seconds: f64,
    pub log: PlanLog,
}

/// An MPC episode: the per-step reward and task metric, and each replan.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize)]
pub struct MpcEpisode {
    pub rewards: Vec<f64>,
    pub metric: Vec<f64>,
    pub actions: Vec<Vec<f64>>,
    pub replans: Vec<Replan>,
}

impl MpcEpisode {
    /// The task metric's sum.
    pub fn score(&self) -> f64 {
        self.metric.iter().sum()
    }
}

/// iLQR MPC as a feedback controller for one episode at one mu (see the
/// module conventions): [`Mpc::act`] replans every `replan` calls from the
/// state it is given, the first time from zero actions with a growing
/// horizon, then warm-started by the last plan shifted by the steps taken.
pub struct Mpc<'a> {
    planner: Ilqr<'a>,
    horizon: usize,
    replan: usize,
    plan: Option<Plan>,
    /// Control steps taken on the current plan.
    taken: usize,
}

impl<'a> Mpc<'a> {
    pub fn new(task: &'a dyn Task, mu: &[f64], options: &MpcOptions) -> Result<Self, ControlError> {
        let replan = options.replan.min(options.horizon);
        assert!(replan > 0, "replanning every 0 steps");
        Ok(Mpc {
            planner: Ilqr::new(task, mu, options.ilqr.clone())?,
            horizon: options.horizon,
            replan,
            plan: None,
            taken: 0,
        })
    }

    /// The action at `state`, and the replan made for it if one was due.
    pub fn act(&mut self, state: &State) -> Result<(Vec<f64>, Option<Replan>), ControlError> {
        let mut replan = None;
        if self.plan.is_none() || self.taken == self.replan {
            let start = Instant::now();
            let (plan, log) = match self.plan.take() {
                Some(old) => self.planner.replan(state, &old, self.taken, self.horizon)?,
                None => cold_plan(&mut self.planner, state, self.replan, self.horizon)?,
            };
            replan = Some(Replan {
                t: 0,
                seconds: start.elapsed().as_secs_f64(),
                log,
            });
            self.plan = Some(plan);
            self.taken = 0;
        }
        let plan = self.plan.as_ref().expect("planned above");
        let action = plan.action(self.taken, state);
        self.taken += 1;
        Ok((action, replan))
    }
}

/// Runs iLQR MPC for one episode of `task` with true parameters `mu` from
/// `initial` (see the module conventions), to the task's horizon or its end.
pub fn run_mpc_episode(
    task: &dyn Task,
    mu: &[f64],
    initial: &State,
    options: &MpcOptions,
) -> Result<MpcEpisode, ControlError> {
    let mut mpc = Mpc::new(task, mu, options)?;
    let mut env = Env::new(task);
    env.reset_to(mu, initial.clone())?;
    let mut episode = MpcEpisode::default();
    loop {
        let (action, replan) = mpc.act(env.state())?;
        if let Some(replan) = replan {
            episode.replans.push(Replan {
                t: env.t(),
                ..replan
            });
        }
        let out = env.step(&action)?;
        episode.rewards.push(out.reward);
        episode.metric.push(out.metric);
        episode.actions.push(action);
        if out.terminated || out.truncated {
            return Ok(episode);
        }
    }
}

/// The first plan of an episode, from zero actions over horizons R, 2R, 4R,
/// ..., H, each stage warm-started by the last (padded with zeros); the log
/// is the last stage's, with the iterations of all stages.
fn cold_plan(
    planner: &mut Ilqr,
    x0: &State,
    replan: usize,
    horizon: usize,
) -> Result<(Plan, PlanLog), ControlError> {
    let zero = vec![0.0; planner.task.act_dim()];
    let (mut actions, mut len, mut iterations) = (vec![], replan, 0);
    loop {
        actions.resize(len, zero.clone());
        let (plan, log) = planner.plan(x0, actions)?;
        iterations += log.iterations;
        if len == horizon {
            return Ok((plan, PlanLog { iterations, ..log }));
        }
        actions = plan.actions;
        len = (2 * len).min(horizon);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::ParamMap;
    use crate::tasks::Cartpole;

    /// The cartpole with each control step held for three physics steps.
    struct Held(Cartpole);

    impl Task for Held {
        fn name(&self) -> &'static str {
            "held-cartpole"
        }
        fn model(&self) -> &Model {
            self.0.model()
        }
        fn mu_map(&self) -> &ParamMap {
            self.0.mu_map()
        }
        fn mu_range(&self) -> (&[f64], &[f64]) {
            self.0.mu_range()
        }
        fn horizon(&self) -> usize {
            self.0.horizon()
        }
        fn substeps(&self) -> usize {
            3
        }
        fn obs_dim(&self) -> usize {
            self.0.obs_dim()
        }
        fn act_dim(&self) -> usize {
            1
        }
        fn reset(&self, rng: &mut StdRng) -> State {
            self.0.reset(rng)
        }
        fn observe(&self, state: &State, out: &mut Vec<f64>) {
            self.0.observe(state, out)
        }
        fn forces(&self, action: &[f64]) -> Vec<f64> {
            self.0.forces(action)
        }
        fn reward(&self, mu: &[f64], state: &State, action: &[f64], next: &State) -> f64 {
            self.0.reward(mu, state, action, next)
        }
        fn cost(&self, mu: &[f64], state: &State, action: &[f64], next: &State) -> f64 {
            self.0.cost(mu, state, action, next)
        }
        fn terminated(&self, state: &State) -> bool {
            self.0.terminated(state)
        }
        fn metric(&self, state: &State, action: &[f64], next: &State) -> f64 {
            self.0.metric(state, action, next)
        }
    }

    fn flat(State { q, v, .. }: &State) -> Vec<f64> {
        q.iter().chain(v).copied().collect()
    }

    #[test]
    fn control_step_jacobians_chain_the_substeps() {
        let task = Held(Cartpole::new());
        let mut planner = Ilqr::new(&task, &[0.2], IlqrOptions::default()).unwrap();
        let (x, u) = (State::new(vec![0.3, -0.2], vec![0.4, 1.1]), vec![0.03]);
        let (a, b, _) = planner.linearise(&x, &u).unwrap();
        let h = 1e-6;
        let mut worst: f64 = 0.0;
        for col in 0..5 {
            let (mut xp, mut xm, mut up, mut um) = (x.clone(), x.clone(), u.clone(), u.clone());
            let (step_p, step_m) = if col < 4 {
                let slot = |s: &mut State, d: f64| {
                    if col < 2 {
                        s.q[col] += d
                    } else {
                        s.v[col - 2] += d
                    }
                };
                slot(&mut xp, h);
                slot(&mut xm, -h);
                (h, h)
            } else {
                up[0] += h / 500.0;
                um[0] -= h / 500.0;
                (h / 500.0, h / 500.0)
            };
            let fp = flat(&planner.control_step(&xp, &up).unwrap());
            let fm = flat(&planner.control_step(&xm, &um).unwrap());
            for row in 0..4 {
                let fd = (fp[row] - fm[row]) / (step_p + step_m);
                let exact = if col < 4 { a[(row, col)] } else { b[(row, 0)] };
                worst = worst.max((fd - exact).abs() / (1.0 + exact.abs()));
            }
        }
        assert!(worst < 1e-6, "{worst:e}");
        // The cartpole's cost reads the action and the end state (z = (x, u, x')).
        assert!(
            planner.cost_coords == vec![4, 5, 6, 7, 8],
            "{:?}",
            planner.cost_coords
        );
    }

    /// On the half cheetah standing on its floor under either contact model
    /// (MuJoCo's constraints, the task's; the smooth penalty): the control
    /// step's Jacobians (five substeps of exact derivatives) equal central
    /// differences, and a plan lowers the cost of its warm start.
    #[test]
    fn plans_through_contact() {
        use crate::model::ContactModel;
        use crate::tasks::HalfCheetah;
        for law in [ContactModel::Constraint, ContactModel::Smooth] {
            let model = HalfCheetah::new()
                .model()
                .edited(|s| s.opt.contact_model = law)
                .unwrap();
            plans_on(&HalfCheetah::with_model(model).unwrap());
        }
    }

    fn plans_on(task: &crate::tasks::HalfCheetah) {
        let mut planner = Ilqr::new(task, &[6.25], IlqrOptions::default()).unwrap();
        let n = task.model().nv();
        let mut x = State::new(task.model().reference_q(), vec![0.0; n]);
        for _ in 0..60 {
            x = planner.control_step(&x, &[0.0; 6]).unwrap();
        }
        let contacts = task
            .model()
            .contacts(&mut task.model().data(), &x, &Inputs::tau(&[0.0; 9]));
        assert!(!contacts.unwrap().is_empty(), "standing on the floor");
        let u = vec![0.1, -0.2, 0.3, -0.1, 0.2, 0.05];
        let (a, b, _) = planner.linearise(&x, &u).unwrap();
        let h = 1e-7;
        let mut worst: f64 = 0.0;
        for col in 0..2 * n + 6 {
            let (mut xp, mut xm, mut up, mut um) = (x.clone(), x.clone(), u.clone(), u.clone());
            match col {
                c if c < n => (xp.q[c] += h, xm.q[c] -= h),
                c if c < 2 * n => (xp.v[c - n] += h, xm.v[c - n] -= h),
                c => (up[c - 2 * n] += h, um[c - 2 * n] -= h),
            };
            let fp = flat(&planner.control_step(&xp, &up).unwrap());
            let fm = flat(&planner.control_step(&xm, &um).unwrap());
            for row in 0..2 * n {
                let fd = (fp[row] - fm[row]) / (2.0 * h);
                let exact = if col < 2 * n {
                    a[(row, col)]
                } else {
                    b[(row, col - 2 * n)]
                };
                worst = worst.max((fd - exact).abs() / (1.0 + exact.abs()));
            }
        }
        assert!(worst < 1e-5, "{worst:e}");
        let (plan, log) = planner.plan(&x, vec![vec![0.0; 6]; 10]).unwrap();
        assert!(plan.cost < log.costs[0], "{:?}", log.costs);
    }

    #[test]
    fn box_qp_matches_a_grid_search() {
        let h = DMatrix::from_row_slice(2, 2, &[2.0, 0.8, 0.8, 1.0]);
        let (lower, upper) = (
            DVector::from_element(2, -1.0),
            DVector::from_element(2, 0.5),
        );
        for g in [[-3.0, 0.2], [0.1, -0.1], [4.0, 4.0], [-0.5, 2.0]] {
            let g = DVector::from_row_slice(&g);
            let (x, free) = box_qp(&h, &g, (&lower, &upper), &DVector::zeros(2)).unwrap();
            let value = |x: &DVector<f64>| 0.5 * x.dot(&(&h * x)) + g.dot(x);
            let mut best = f64::INFINITY;
            for i in 0..=300 {
                for j in 0..=300 {
                    let y = DVector::from_row_slice(&[
                        -1.0 + 0.005 * i as f64,
                        -1.0 + 0.005 * j as f64,
                    ]);
                    best = best.min(value(&y));
                }
            }
            assert!(
                value(&x) <= best + 1e-12,
                "{g:?}: {x:?} {} vs {best}",
                value(&x)
            );
            for i in 0..2 {
                let at_bound = x[i] == lower[i] || x[i] == upper[i];
                assert!(free[i] || at_bound, "{g:?}: {x:?} {free:?}");
            }
        }
    }
}
