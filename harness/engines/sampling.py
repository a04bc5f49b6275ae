"""Random states and torque scales for an engine's model (shared by golden, replay, tests).

q: uniform in a limited joint's range, else the reference configuration +- 1 (rad or m);
v: uniform in [-1, 1]; tau_i: uniform in [-1, 1] times tau_scale_i = 10 M_ii(q_ref)
(3 significant digits), i.e. accelerations of order 10.
"""

from __future__ import annotations

import numpy as np

from harness.engines.base import Engine

TAU_ACCEL = 10.0


def sample_q(e: Engine, rng) -> np.ndarray:
    q = e.q_ref + rng.uniform(-1.0, 1.0, len(e.q_ref))
    for k, r in enumerate(e.ranges):
        if r is not None:
            q[k] = rng.uniform(r[0], r[1])
    return q


def round3(x) -> np.ndarray:
    return np.array([float(f"{v:.3g}") for v in x])


def tau_scale(e: Engine) -> np.ndarray:
    return round3(TAU_ACCEL * np.diag(e.mass_matrix(e.q_ref)))
