"""A gymnasium environment: the paper's cartpole (Section 4.2) on our engine.

`import harness.gym_env` registers it as "diffosi/CartPole-v0":

    import gymnasium, harness.gym_env
    env = gymnasium.make("diffosi/CartPole-v0", mu=0.3)

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

from pathlib import Path

import gymnasium
import numpy as np
from gymnasium import spaces

import diffosi

ENV_ID = "diffosi/CartPole-v0"
MODEL = Path(__file__).resolve().parent.parent / "reference_models" / "cartpole.xml"


def pole_com(mu: float) -> list:
    """The paper's mu as the pole COM in the pole frame (m): the geometric centre
    (0, 0, 0.5), the hinge being the frame's origin, moved by (mu, 0, 0.2 mu)."""
    return [mu, 0.0, 0.5 + 0.2 * mu]
X_LIMIT = 2.5
THETA_LIMIT = np.pi / 2
MAX_STEPS = 500
RESET_RANGE = 0.05


class CartPoleEnv(gymnasium.Env):
    """The cartpole on diffosi; see the module docstring for spaces, reward and mu."""

    metadata = {"render_modes": []}

    def __init__(self, mu=0.0, max_force=500.0):
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


gymnasium.register(id=ENV_ID, entry_point=CartPoleEnv)
