"""Actuators on fixed tendons against MuJoCo itself (tests/data/tendon_actuators.xml: a motor with
a gear, a position servo with a damping ratio, a velocity servo and a filtered affine general
sharing a tendon with a spring, an inherited control range, and a joint motor beside them,
contact-free). One step agrees with mj_step to 1e-10 under every integrator (the implicit ones
take the servos' velocity terms along the tendon, off the diagonal), a 200-step rollout stays
within 1e-9, the step Jacobians in (q, v, act) and ctrl agree with mjd_transitionFD, the actuator
sensors read what mj_forward's do, and a target that does not exist is named with its line."""

import pathlib
import re

import mujoco
import numpy as np
import pytest

import diffosi
from harness.tests.test_actuators import assert_jacobians_match_transition_fd, mujoco_step

DATA = pathlib.Path(__file__).resolve().parents[2] / "tests" / "data"
INTEGRATORS = ["Euler", "RK4", "implicitfast", "implicit"]


def models(tmp_path, integrator="Euler"):
    text = (DATA / "tendon_actuators.xml").read_text()
    text = re.sub(r"<option ", f'<option integrator="{integrator}" ', text, count=1)
    path = tmp_path / f"tendon_actuators_{integrator}.xml"
    path.write_text(text)
    return mujoco.MjModel.from_xml_path(str(path)), diffosi.Model.load(str(path))


def test_compiled_as_mujoco(tmp_path):
    """The servo's damping ratio gives MuJoCo's kv (the mass the tendon sees, 1 / r^T M^-1 r),
    and inheritrange reads the tendon's range."""
    m, ours = models(tmp_path)
    assert (ours.nu, ours.na) == (m.nu, m.na) == (6, 1)
    assert m.actuator_trntype[:5].tolist() == [mujoco.mjtTrn.mjTRN_TENDON] * 5
    bias = ours.get_param("actuator/servo/bias")
    np.testing.assert_allclose(bias, m.actuator_biasprm[1, :3], rtol=1e-14, atol=0)
    assert m.actuator_ctrlrange[4].tolist() == [-0.25, 0.25]


@pytest.mark.parametrize("integrator", INTEGRATORS)
def test_one_step_matches_mj_step(tmp_path, integrator):
    m, ours = models(tmp_path, integrator)
    d = mujoco.MjData(m)
    rng = np.random.default_rng(0)
    for _ in range(10):
        q, v = rng.uniform(-0.4, 0.4, m.nq), rng.uniform(-2, 2, m.nv)
        act, ctrl = rng.uniform(-0.5, 0.5, m.na), rng.uniform(-1.5, 1.5, m.nu)
        tau = rng.uniform(-1, 1, m.nv)
        theirs = mujoco_step(m, d, q, v, act, ctrl, tau)
        mine = ours.step(q, v, tau, ctrl=ctrl, act=act)
        for a, b in zip(mine, theirs):
            np.testing.assert_allclose(a, b, rtol=0, atol=1e-10)


@pytest.mark.parametrize("integrator", ["Euler", "implicitfast"])
def test_rollout_matches_mj_step(tmp_path, integrator):
    m, ours = models(tmp_path, integrator)
    d = mujoco.MjData(m)
    steps = 200
    rng = np.random.default_rng(1)
    ctrls = rng.uniform(-1, 1, (steps, m.nu))
    Q, V, A = ours.rollout(m.qpos0.copy(), np.zeros(m.nv), np.zeros((steps, m.nv)), ctrls=ctrls)
    worst = 0.0
    for t in range(steps):
        d.ctrl[:] = ctrls[t]
        mujoco.mj_step(m, d)
        worst = max(worst, *(np.abs(x[t + 1] - y).max() for x, y in ((Q, d.qpos), (V, d.qvel), (A, d.act))))
    assert worst < 1e-9, f"{worst:.1e}"


def test_jacobians_match_mujoco_transition_fd(tmp_path):
    assert_jacobians_match_transition_fd(*models(tmp_path), seed=3, count=5)


def test_sensors_read_as_mj_forward(tmp_path):
    m, ours = models(tmp_path)
    d = mujoco.MjData(m)
    rng = np.random.default_rng(4)
    q, v = rng.uniform(-0.4, 0.4, m.nq), rng.uniform(-2, 2, m.nv)
    act, ctrl = rng.uniform(-0.5, 0.5, m.na), rng.uniform(-1, 1, m.nu)
    d.qpos[:], d.qvel[:], d.act[:], d.ctrl[:] = q, v, act, ctrl
    mujoco.mj_forward(m, d)
    mine = ours.sensors(q, v, np.zeros(m.nv), ctrl=ctrl, act=act)
    np.testing.assert_allclose(mine, d.sensordata, rtol=0, atol=1e-12)


BAD = [
    ('<motor tendon="nowhere"/>', r"bad.xml:4: <motor>: unknown tendon 'nowhere'"),
    ('<motor joint="h" tendon="t"/>', r"bad.xml:4: <motor>: an actuator has one transmission target"),
    ('<motor site="nowhere"/>', r"bad.xml:4: <motor>: unknown site 'nowhere'"),
    ('<position tendon="t" kp="1" inheritrange="1"/>', r"bad.xml:4: <position>: inheritrange needs"),
    ('<motor tendon="t" damping="1"/>', r"actuator 'bad'.*tendon or site are not supported"),
]


@pytest.mark.parametrize("actuator, message", BAD)
def test_bad_targets_name_the_line(tmp_path, actuator, message):
    path = tmp_path / "bad.xml"
    actuator = actuator.replace("/>", ' name="bad"/>')
    path.write_text('<mujoco><worldbody><body name="a"><joint name="h"/><geom size="1"/>\n'
                    '<site name="s"/></body></worldbody>\n'
                    '<tendon><fixed name="t"><joint joint="h" coef="1"/></fixed></tendon><actuator>\n'
                    f'{actuator}\n'
                    '</actuator></mujoco>')
    with pytest.raises(ValueError, match=message):
        diffosi.Model.load(str(path))
