"""A mocap-driven arm against MuJoCo: tests/data/mocap_arm.xml welds an arm's
hand (hinge shoulder and elbow, ball wrist) to a mocap body that the step
moves, the hand's box touching the table on the way. With MuJoCo's converged
solver: a 400-step rollout under moving mocap poses stays on mj_step's to
1e-9, one step at a mocap pose away from the compiled one agrees to 1e-9
(the weld's rows read the step's mocap pose), and the step Jacobians there
agree with mjd_transitionFD's centred differences.
"""

import pathlib

import mujoco
import numpy as np
import pytest

import diffosi

FILE = pathlib.Path(__file__).resolve().parents[2] / "tests" / "data" / "mocap_arm.xml"
SOLVER = 'tolerance="1e-15" ls_tolerance="1e-12" iterations="1000"'


@pytest.fixture()
def models(tmp_path):
    path = tmp_path / "mocap_arm.xml"
    path.write_text(FILE.read_text().replace("<option ", f"<option {SOLVER} ", 1))
    return mujoco.MjModel.from_xml_path(str(path)), diffosi.Model.load(str(path))


def pose(t):
    """The mocap target's pose at step t: a slow loop that lowers the hand
    onto the table and turns it."""
    pos = np.array([[0.5 + 0.1 * np.sin(t / 50), 0.05 * np.cos(t / 40), 0.75 - 0.15 * np.sin(t / 70)]])
    quat = np.array([[1.0, 0.1 * np.sin(t / 30), 0.0, 0.1]])
    return pos, quat / np.linalg.norm(quat)


def test_rollout_follows_the_mocap_as_mj_step(models):
    m, ours = models
    d = mujoco.MjData(m)
    rng = np.random.default_rng(0)
    q, v = m.qpos0.copy(), np.zeros(m.nv)
    worst, touched = 0.0, 0
    for t in range(400):
        pos, quat = pose(t)
        tau = 0.1 * rng.normal(size=m.nv)
        d.mocap_pos[:], d.mocap_quat[:], d.qfrc_applied[:] = pos, quat, tau
        mujoco.mj_step(m, d)
        assert d.ne == 6  # the weld's rows
        touched += d.ncon > 0
        q, v = ours.step(q, v, tau, mocap_pos=pos, mocap_quat=quat)
        worst = max(worst, np.abs(q - d.qpos).max(), np.abs(v - d.qvel).max())
    assert worst < 1e-9, f"{worst:.1e}"
    assert touched > 50  # the hand's box on the table for part of the way


def test_one_step_and_jacobians_at_a_moved_mocap_pose(models):
    m, ours = models
    d = mujoco.MjData(m)
    rng = np.random.default_rng(4)
    q = m.qpos0.copy()
    mujoco.mj_integratePos(m, q, rng.uniform(-0.1, 0.1, m.nv), 1.0)
    v, tau = rng.normal(size=m.nv), rng.normal(size=m.nv)
    pos, quat = pose(90)
    d.qpos[:], d.qvel[:], d.qfrc_applied[:] = q, v, tau
    d.mocap_pos[:], d.mocap_quat[:] = pos, quat
    mujoco.mj_forward(m, d)
    A = np.zeros((2 * m.nv, 2 * m.nv))
    mujoco.mjd_transitionFD(m, d, 1e-6, True, A, None, None, None)
    mujoco.mj_step(m, d)
    q1, v1 = ours.step(q, v, tau, mocap_pos=pos, mocap_quat=quat)
    np.testing.assert_allclose(q1, d.qpos, rtol=0, atol=1e-9)
    np.testing.assert_allclose(v1, d.qvel, rtol=0, atol=1e-9)
    J = ours.step_jacobians(q, v, tau, mocap_pos=pos, mocap_quat=quat)
    a = np.block([[J["dq_dq"], J["dq_dv"]], [J["dv_dq"], J["dv_dv"]]])
    err = np.abs(a - A).max() / max(1.0, np.abs(A).max())
    assert err < 1e-6, f"{err:.1e}"
    # The pose matters: the compiled one gives another step.
    q0, v0 = ours.step(q, v, tau)
    assert np.abs(v0 - v1).max() > 1e-2
