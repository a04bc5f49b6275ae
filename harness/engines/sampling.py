"""Random states and torque scales for an engine's model (shared by golden, replay, tests).

q: uniform in a limited joint's range, else the reference configuration +- 1 (rad or m;
a free root's quaternion normalised after); v: uniform in [-1, 1]; tau_i: uniform in [-1, 1] times tau_scale_i = 10 M_ii(q_ref)
(3 significant digits), i.e. accelerations of order 10.
"""

from __future__ import annotations

import numpy as np

from harness.engines.base import Engine

TAU_ACCEL = 10.0


def sample_q(e: Engine, rng) -> np.ndarray:
    q = e.q_ref + rng.uniform(-1.0, 1.0, len(e.q_ref))
    first = 7 if e.free else 0
    if e.free:
        q[3:7] /= np.linalg.norm(q[3:7])
    for k, r in enumerate(e.ranges):
        if r is not None:
            q[first + k] = rng.uniform(r[0], r[1])
    return q


def sample_state(e: Engine, rng) -> tuple:
    """(q, v): q by sample_q, v uniform in [-1, 1]."""
    return sample_q(e, rng), rng.uniform(-1.0, 1.0, e.nv)


def sample_transition(e: Engine, rng, scale) -> tuple:
    """(q, v, tau) with tau_i uniform in [-1, 1] times scale_i."""
    q, v = sample_state(e, rng)
    return q, v, rng.uniform(-1.0, 1.0, len(v)) * scale


def sample_transitions(e: Engine, rng, n: int) -> list:
    """n transitions (q, v, tau) at the engine's tau_scale."""
    scale = tau_scale(e)
    return [sample_transition(e, rng, scale) for _ in range(n)]


def sample_rollout(e: Engine, rng, scale, steps: int) -> tuple:
    """(q0, v0, taus): a start state and `steps` torque rows, each scaled as in sample_transition."""
    q0, v0 = sample_state(e, rng)
    return q0, v0, rng.uniform(-1.0, 1.0, (steps, len(v0))) * scale


def round3(x) -> np.ndarray:
    return np.array([float(f"{v:.3g}") for v in x])


def tau_scale(e: Engine) -> np.ndarray:
    return round3(TAU_ACCEL * np.diag(e.mass_matrix(e.q_ref)))
