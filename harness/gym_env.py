"""Gymnasium environments of the paper's tasks on our engine: the cartpole (Section 4.2), the
half cheetah (4.3) and the wiping arm (4.4), and the quadruped (issue 41).

Registered as "diffosi/CartPole-v0", "diffosi/HalfCheetah-v0", "diffosi/Wiping-v0" and
"diffosi/Quadruped-v0" by
harness/gym_hook.py wherever the wheel is installed (in the checkout, `import harness.gym_env`
registers them); each is also vectorised by gymnasium (`gymnasium.make_vec(id, num_envs=8,
vectorization_mode="sync" | "async")`; "async" steps the copies in processes of their own), and
renders render_mode="rgb_array" frames through MuJoCo (harness/gym_render.py):

    import gymnasium
    env = gymnasium.make("diffosi/CartPole-v0", mu=0.3)
    envs = gymnasium.make_vec("diffosi/HalfCheetah-v0", num_envs=8)   # mu drawn per reset

The cartpole (CartPoleEnv below):

Conventions (SI units, angles in radians):
- dynamics: reference_models/cartpole.xml through `diffosi.Model`, one physics
  step of 0.02 s (the file's timestep) per env step, i.e. 50 Hz control;
- observation (x, theta, x_dot, theta_dot), float64; x the cart position along
  world x (m), theta the pole angle about y, 0 = upright;
- action a in [-1, 1] (clipped), the cart force a * max_force in N; the default
  max_force = 500 N is the paper's bound ("an impulse of [-500 N, 500 N] dt");
- reward 1 for each step that ends with |theta| <= pi/2 and |x| <= 2.5 (the
  paper's task metric), 0 on the step that leaves them, which terminates;
  truncated after 500 steps;
- reset: x, theta, x_dot, theta_dot each uniform in [-0.05, 0.05], from the
  generator seeded by reset(seed=...);
- mu (m): the pole's COM moved from its geometric centre by (mu, 0, 0.2 mu) in
  the pole frame, i.e. to (mu, 0, 0.5 + 0.2 mu) (parameter body/pole/com); the
  paper samples mu in [-0.6, 0.6].
"""

import gymnasium
import numpy as np
from gymnasium import spaces

import diffosi
from harness import gym_hook
from harness.engines.base import MODELS
from harness.gym_render import RENDER_MODES, MjcfRendering, checked_mode

ENV_ID = "diffosi/CartPole-v0"
MODEL = MODELS / "cartpole.xml"


def pole_com(mu: float) -> list:
    """The paper's mu as the pole COM in the pole frame (m): the geometric centre
    (0, 0, 0.5), the hinge being the frame's origin, moved by (mu, 0, 0.2 mu)."""
    return [mu, 0.0, 0.5 + 0.2 * mu]
X_LIMIT = 2.5
THETA_LIMIT = np.pi / 2
MAX_STEPS = 500
RESET_RANGE = 0.05


class CartPoleEnv(MjcfRendering, gymnasium.Env):
    """The cartpole on diffosi; see the module docstring for spaces, reward and mu."""

    metadata = {"render_modes": RENDER_MODES, "render_fps": 50}
    mjcf = MODEL

    def __init__(self, mu=0.0, max_force=500.0, render_mode=None):
        self.render_mode = checked_mode(render_mode)
        self.model = diffosi.Model.load(str(MODEL))
        self.model.set_param("body/pole/com", pole_com(mu))
        self.mu = float(mu)
        self.max_force = float(max_force)
        # The state is unbounded (the step that terminates may overshoot any limit);
        # the largest float stands for infinity, which gymnasium's checker rejects.
        big = np.finfo(np.float64).max
        self.observation_space = spaces.Box(-big, big, shape=(4,), dtype=np.float64)
        self.action_space = spaces.Box(-1.0, 1.0, shape=(1,), dtype=np.float64)
        self._q = self._v = None
        self._steps = 0

    def _observation(self):
        return np.concatenate([self._q, self._v])

    def render_q(self):
        return self._q

    def reset(self, *, seed=None, options=None):
        super().reset(seed=seed)
        state = self.np_random.uniform(-RESET_RANGE, RESET_RANGE, size=4)
        self._q, self._v = state[:2], state[2:]
        self._steps = 0
        return self._observation(), {}

    def step(self, action):
        a = float(np.asarray(action, dtype=np.float64).reshape(-1)[0])
        force = self.max_force * min(max(a, -1.0), 1.0)
        self._q, self._v = self.model.step(self._q, self._v, np.array([force, 0.0]))
        self._steps += 1
        x, theta = self._q
        terminated = bool(abs(theta) > THETA_LIMIT or abs(x) > X_LIMIT)
        truncated = self._steps >= MAX_STEPS
        return self._observation(), 0.0 if terminated else 1.0, terminated, truncated, {}




class TaskEnv(gymnasium.Env):
    """A diffosi.Task stepped as gymnasium steps: the subclass sets `task` and, at reset, `model`
    (the task's model at the episode's mu), `_q`, `_v` and `_steps`."""

    def _spaces(self):
        # The largest float stands for infinity, which gymnasium's checker rejects.
        big = np.finfo(np.float64).max
        self.observation_space = spaces.Box(-big, big, shape=(self.task.obs_dim,), dtype=np.float64)
        self.action_space = spaces.Box(-1.0, 1.0, shape=(self.task.act_dim,), dtype=np.float64)
        self.mu, self.model, self._q, self._v, self._steps = None, None, None, None, 0

    def _control_step(self, action):
        """One control step (the action clipped, its inputs held for the task's substeps):
        (observation, reward = the task metric, terminated, truncated)."""
        action = np.clip(np.asarray(action, dtype=np.float64).reshape(self.action_space.shape), -1.0, 1.0)
        tau, ctrl = self.task.inputs(action)
        ctrl = ctrl if len(ctrl) else None
        q, v = self._q, self._v
        for _ in range(self.task.substeps):
            q, v = self.model.step(q, v, tau, ctrl=ctrl)
        reward = self.task.metric(self._q, self._v, action, q, v)
        self._q, self._v = q, v
        self._steps += 1
        terminated = self.task.terminated(q, v)
        truncated = not terminated and self._steps >= self.task.horizon
        return self.task.observe(q, v), float(reward), terminated, truncated


class HalfCheetahEnv(MjcfRendering, TaskEnv):
    """The paper's half cheetah, diffosi.Task("half_cheetah") (src/tasks/half_cheetah.rs has its
    conventions, gymnasium HalfCheetah-v5's): observation (17) the torso's height and pitch, the
    six leg joints, then every velocity; action six motor controls in [-1, 1] (clipped), held for
    the task's 5 physics steps of 0.01 s; reward the forward speed minus 0.1 |a|^2 (the task
    metric: the return is the paper's task performance); never terminated, truncated after
    1000 steps. mu (kg) is the torso mass: fixed if given (in [1, 50]), else drawn uniformly
    from [1, 50] at every reset (domain randomisation); info["mu"] says which. reset(seed=...)
    seeds the mu draw and the task's reset noise."""

    metadata = {"render_modes": RENDER_MODES, "render_fps": 20}
    mjcf = MODELS / "half_cheetah.xml"

    def __init__(self, mu=None, render_mode=None):
        self.render_mode = checked_mode(render_mode)
        self.task = diffosi.Task("half_cheetah")
        self.mu_range = tuple(float(b[0]) for b in self.task.mu_range)
        if mu is not None and not self.mu_range[0] <= mu <= self.mu_range[1]:
            raise ValueError(f"mu = {mu} kg: the torso mass lies in {list(self.mu_range)}")
        self.fixed_mu = None if mu is None else float(mu)
        self._spaces()

    def reset(self, *, seed=None, options=None):
        super().reset(seed=seed)
        self.mu = self.fixed_mu if self.fixed_mu is not None else float(self.np_random.uniform(*self.mu_range))
        self.model = self.task.model([self.mu])
        self._q, self._v = self.task.reset(int(self.np_random.integers(2**63)))
        self._steps = 0
        return self.task.observe(self._q, self._v), {"mu": self.mu}

    def step(self, action):
        return *self._control_step(action), {"mu": self.mu}

    def render_q(self):
        return self._q


class WipingEnv(MjcfRendering, gymnasium.Env):
    """The wiping task, diffosi.Wiping (src/tasks/wiping/: a KUKA iiwa pressing a compliant tool
    on a table while it strokes back and forth), with the admittance controller's gains as the
    action, chosen anew at every 1 ms control step: a in [-1, 1]^2 (clipped) maps log-uniformly
    onto the task's gain box, (k_tau, k_xi) = exp(ln lo + (a + 1) / 2 (ln hi - ln lo)).
    Observation (19): q (8: the arm's seven joints, the tool's slide), v (8), the admittance
    offset xi (m), the normal force sensed over the last step (N) and the time (s). Reward
    -(F - 3 N)^2 per step of the strokes (t >= 0.5 s; a lost contact counts as F = 0), 0 during
    the approach: the mean over the steps in contact is the task metric. Truncated after the
    task's 3000 steps; terminated (reward -F_goal^2 for the rest) if a step fails. mu = the
    tool's (k_p in N/cm, k_d in N s/m), each in [1, 100]: fixed if given, else drawn uniformly
    at every reset; info["mu"] says which."""

    metadata = {"render_modes": RENDER_MODES, "render_fps": 1000}
    mjcf = MODELS / "wiping_arm.xml"

    def __init__(self, mu=None, render_mode=None):
        self.render_mode = checked_mode(render_mode)
        self.task = diffosi.Wiping(2)
        self.mu_range = tuple(np.asarray(b, float) for b in self.task.mu_range)
        if mu is not None:
            mu = np.asarray(mu, float)
            if mu.shape != (2,) or not np.all((self.mu_range[0] <= mu) & (mu <= self.mu_range[1])):
                raise ValueError(f"mu = {mu}: (k_p, k_d), each in [1, 100]")
        self.fixed_mu = mu
        lo, hi = self.task.gains_range
        self._log_lo, self._log_hi = np.log(lo), np.log(hi)
        big = np.finfo(np.float64).max
        self.observation_space = spaces.Box(-big, big, shape=(19,), dtype=np.float64)
        self.action_space = spaces.Box(-1.0, 1.0, shape=(2,), dtype=np.float64)
        self.mu, self.run = None, None

    def gains(self, action) -> np.ndarray:
        """(k_tau, k_xi) of an action."""
        a = np.clip(np.asarray(action, dtype=np.float64).reshape(2), -1.0, 1.0)
        return np.exp(self._log_lo + (a + 1.0) / 2.0 * (self._log_hi - self._log_lo))

    def render_q(self):
        return None if self.run is None else self.run.q

    def _observation(self):
        run = self.run
        return np.concatenate([run.q, run.v, [run.xi, run.force, run.k * run.timestep]])

    def reset(self, *, seed=None, options=None):
        super().reset(seed=seed)
        self.mu = self.fixed_mu if self.fixed_mu is not None else self.np_random.uniform(*self.mu_range)
        self.run = self.task.run(self.mu)
        return self._observation(), {"mu": self.mu.copy()}

    def step(self, action):
        run, goal = self.run, self.task.force_goal
        stroking = run.stroking
        try:
            force = run.step(self.gains(action))
        except ValueError as e:  # the step failed: the state stays, the episode ends
            left = run.steps - run.k
            return self._observation(), -goal**2 * left, True, False, {"mu": self.mu.copy(), "error": str(e)}
        touching = force > self.task.contact_force
        reward = -((force if touching else 0.0) - goal) ** 2 if stroking else 0.0
        return self._observation(), float(reward), False, run.k >= run.steps, {"mu": self.mu.copy()}


class QuadrupedEnv(TaskEnv):
    """The quadruped, diffosi.Task("quadruped") (src/tasks/quadruped/ has its conventions): a
    Unitree Go1 with a payload walks forward at 0.5 m/s. Observation (34): base height, gravity
    in base axes, base linear and angular velocity in base axes, joint offsets from the standing
    pose, joint rates; action twelve servo targets in [-1, 1] (clipped; target = standing pose +
    0.5 a rad), held for the task's 4 physics steps of 0.005 s (50 Hz); reward the task metric
    (velocity and yaw-rate tracking + uprightness - energy); terminated on a fall (info["fell"]), truncated
    after 1000 steps. mu = (payload mass in [0, 8] kg, its COM offset along the trunk's x in
    [-0.1, 0.1] m): fixed if given, else drawn uniformly at every reset; info["mu"] says which.
    reset(seed=...) seeds the mu draw and the task's reset noise. It does not render (its model
    is a URDF, which the MJCF renderer does not draw)."""

    metadata = {"render_modes": []}

    def __init__(self, mu=None, render_mode=None):
        if render_mode is not None:
            raise ValueError(f"render_mode={render_mode!r}: diffosi/Quadruped-v0 does not render")
        self.render_mode = None
        self.task = diffosi.Task("quadruped")
        self.mu_range = tuple(np.asarray(b, float) for b in self.task.mu_range)
        if mu is not None:
            mu = np.asarray(mu, float)
            if mu.shape != (2,) or not np.all((self.mu_range[0] <= mu) & (mu <= self.mu_range[1])):
                raise ValueError(f"mu = {mu}: (payload mass in [0, 8] kg, COM offset in [-0.1, 0.1] m)")
        self.fixed_mu = mu
        self._spaces()

    def reset(self, *, seed=None, options=None):
        super().reset(seed=seed)
        drawn = self.np_random.uniform(*self.mu_range)
        self.mu = self.fixed_mu.copy() if self.fixed_mu is not None else drawn
        self.model = self.task.model(self.mu)
        self._q, self._v = self.task.reset(int(self.np_random.integers(2**63)))
        self._steps = 0
        return self.task.observe(self._q, self._v), {"mu": self.mu.copy()}

    def step(self, action):
        observation, reward, fell, truncated = self._control_step(action)
        return observation, reward, fell, truncated, {"mu": self.mu.copy(), "fell": fell}


HALF_CHEETAH_ID, WIPING_ID = "diffosi/HalfCheetah-v0", "diffosi/Wiping-v0"
QUADRUPED_ID = "diffosi/Quadruped-v0"
gym_hook.register()
