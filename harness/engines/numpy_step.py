"""A numpy integrator built from an engine's own M(q), c(q, v) and passive convention,
and the error measure every comparison in the harness uses.

With D = diag(damping), K = diag(stiffness), q_s the spring reference and h the step:
  explicit:                   M a = tau - c - D v - K (q - q_s)
  implicit_damping:           (M + h D) a = tau - c - D v - K (q - q_s)        (MuJoCo Euler)
  implicit_damping_stiffness: (M + h D + h^2 K) a = tau - c - D v - K (q + h v - q_s)  (DART)
Euler is semi-implicit: v' = v + h a, q' = q + h v'. RK4 is classic RK4 on (q, v) with the
passive forces explicit at every stage (MuJoCo's mj_RungeKutta).
"""

from __future__ import annotations

import numpy as np

from harness.engines.base import Engine


def passive_force(e: Engine, q, v):
    return -e.damping * v - e.stiffness * (q - e.springref)


def euler_step(e: Engine, q, v, tau):
    h = e.timestep
    M, c = e.dynamics(q, v)
    D, K = np.diag(e.damping), np.diag(e.stiffness)
    if e.passive == "explicit":
        lhs, rhs = M, tau - c + passive_force(e, q, v)
    elif e.passive == "implicit_damping":  # damping at v', stiffness at q
        lhs, rhs = M + h * D, tau - c + passive_force(e, q, v)
    elif e.passive == "implicit_damping_stiffness":  # damping at v', stiffness at q'
        lhs, rhs = M + h * D + h * h * K, tau - c + passive_force(e, q + h * v, v)
    else:
        raise ValueError(e.passive)
    v1 = v + h * np.linalg.solve(lhs, rhs)
    return q + h * v1, v1


def rk4_step(e: Engine, q, v, tau):
    h = e.timestep

    def acc(q, v):
        M, c = e.dynamics(q, v)
        return np.linalg.solve(M, tau - c + passive_force(e, q, v))

    k1q, k1v = v, acc(q, v)
    k2q, k2v = v + h / 2 * k1v, acc(q + h / 2 * k1q, v + h / 2 * k1v)
    k3q, k3v = v + h / 2 * k2v, acc(q + h / 2 * k2q, v + h / 2 * k2v)
    k4q, k4v = v + h * k3v, acc(q + h * k3q, v + h * k3v)
    q1 = q + h / 6 * (k1q + 2 * k2q + 2 * k3q + k4q)
    v1 = v + h / 6 * (k1v + 2 * k2v + 2 * k3v + k4v)
    return q1, v1


def reference_step(e: Engine, q, v, tau):
    """One step of the numpy integrator with the engine's integrator and passive mode."""
    return rk4_step(e, q, v, tau) if e.integrator == "RK4" else euler_step(e, q, v, tau)


def step_error(q1, v1, q1_ref, v1_ref) -> float:
    """max(|dq| / max(1, |q_ref|), |dv| / max(1, |v_ref|)) in max norms: relative to
    max(1, |x|), so fast rollouts are judged fairly."""
    eq = np.abs(q1 - q1_ref).max() / max(1.0, np.abs(q1_ref).max())
    ev = np.abs(v1 - v1_ref).max() / max(1.0, np.abs(v1_ref).max())
    return float(max(eq, ev))
