"""Pinocchio as a fourth oracle: mass matrix (CRBA) and forward dynamics (ABA) on the URDF twins.

Pinocchio loads each URDF twin with a fixed base (`buildModelFromUrdf`) and gives
M(q) and the acceleration a = M^-1 (tau - c(q, v)). Our module has neither call,
so both come out of one step of a copy of our model with explicit passive
forces, zero damping, stiffness and armature (Pinocchio's URDF model has none),
and timestep h = 1 s:

    v1 = v + h a            ->  a = v1 - v                (h = 1: no division, no cancellation)
    dv1/dtau = h M^-1       ->  M = inv(dv_dtau)          (h = 1)

Conventions: q and v in our joint order (asserted equal to Pinocchio's); an
unbounded revolute joint ("continuous" in URDF) is one angle for us and
(cos, sin) for Pinocchio. Gravity is (0, 0, -9.81) m/s^2 in both (asserted).
"""

from pathlib import Path

import numpy as np
import pinocchio
import pytest

import diffosi

MODELS = Path(__file__).resolve().parents[2] / "reference_models"
NAMES = ["cartpole", "pendulum", "double_pendulum", "half_cheetah", "wiping_arm"]
STATES = 20
# Both sides compute in float64 with different algorithms (our tree recursions
# vs Pinocchio's CRBA / ABA), so they differ by rounding amplified by the mass
# matrix's conditioning (inverting dv_dtau; cond(M) ~3e3 for the half cheetah):
# observed errors are <= 3e-15, and 1e-10 leaves room for other platforms' BLAS
# while still catching any convention bug (a forgotten armature: 1e-1 and more).
RTOL = 1e-10


def ours(name):
    """Our URDF twin, reduced to what Pinocchio models: rigid bodies under gravity, h = 1."""
    m = diffosi.Model.load(str(MODELS / f"{name}.urdf")).with_options(
        passive="explicit", timestep=1.0, limits=False, contact_model="smooth", contact=False)  # no contact in ABA
    for joint in m.joint_names:
        for kind in ["damping", "stiffness", "armature"]:
            m.set_param(f"joint/{joint}/{kind}", 0.0)
    return m


def oracle(name):
    model = pinocchio.buildModelFromUrdf(str(MODELS / f"{name}.urdf"))
    return model, model.createData()


def pinocchio_q(model, q):
    """Our joint coordinates as Pinocchio's configuration: integrated from its neutral (all zero) one."""
    return pinocchio.integrate(model, pinocchio.neutral(model), q)


def random_states(n, seed):
    rng = np.random.default_rng(seed)
    for _ in range(STATES):
        yield rng.uniform(-1.0, 1.0, n), rng.uniform(-2.0, 2.0, n), rng.uniform(-5.0, 5.0, n)


def relative_error(ours, theirs):
    return np.max(np.abs(ours - theirs)) / np.max(np.abs(theirs))


@pytest.mark.parametrize("name", NAMES)
def test_same_model(name):
    m, (model, _) = ours(name), oracle(name)
    assert (model.njoints - 1, model.nv) == (len(m.joint_names), m.nv)
    assert list(model.names)[1:] == m.joint_names
    np.testing.assert_array_equal(model.gravity.linear, m.gravity)


@pytest.mark.parametrize("name", NAMES)
def test_mass_matrix_matches_crba(name):
    m, (model, data) = ours(name), oracle(name)
    worst = 0.0
    for q, v, tau in random_states(m.nv, seed=1):
        M = np.linalg.inv(m.step_jacobians(q, v, tau)["dv_dtau"])
        upper = pinocchio.crba(model, data, pinocchio_q(model, q))
        expected = np.triu(upper) + np.triu(upper, 1).T  # only the upper triangle is filled
        worst = max(worst, relative_error(M, expected))
    assert worst <= RTOL, f"{name}: mass matrix relative error {worst:.1e}"


@pytest.mark.parametrize("name", NAMES)
def test_acceleration_matches_aba(name):
    m, (model, data) = ours(name), oracle(name)
    worst = 0.0
    for q, v, tau in random_states(m.nv, seed=2):
        _, v1 = m.step(q, v, tau)
        expected = pinocchio.aba(model, data, pinocchio_q(model, q), v, tau)
        worst = max(worst, relative_error(v1 - v, expected))
    assert worst <= RTOL, f"{name}: acceleration relative error {worst:.1e}"
