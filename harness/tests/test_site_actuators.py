"""Actuators on sites and on spatial tendons against MuJoCo itself, on two crafted models
(tests/data/site_actuators.xml: an arm driven at its end effector by a Cartesian motor, a
position servo and a velocity servo relative to a reference site on its moving base, and a
filtered affine general on a pendulum relative to a world site; tests/data/
spatial_tendon_actuators.xml: a finger with a wrapped flexor, a pulley extensor under a servo
with a damping ratio, and a tendon across two bodies that share no dof). Contact-free: one step
agrees with mj_step to 1e-10 under every integrator, the transmissions (actuator sensors) with
mj_forward's to 1e-12, the step Jacobians in (q, v, act) and ctrl with mjd_transitionFD's and
with central differences of our own step (the moments move with q: dual numbers through the
step); bad site targets are named with their line."""

import pathlib

import mujoco
import numpy as np
import pytest

import diffosi
from harness.tests.test_actuators import mujoco_step, transition

DATA = pathlib.Path(__file__).resolve().parents[2] / "tests" / "data"
MODELS = ["site_actuators", "spatial_tendon_actuators"]
INTEGRATORS = ["Euler", "RK4", "implicitfast", "implicit"]


def models(tmp_path, name, integrator="Euler"):
    text = (DATA / f"{name}.xml").read_text().replace("<option ", f'<option integrator="{integrator}" ', 1)
    path = tmp_path / f"{name}_{integrator}.xml"
    path.write_text(text)
    return mujoco.MjModel.from_xml_path(str(path)), diffosi.Model.load(str(path))


def sample(m, rng):
    """A state (hinges and slides only) and inputs inside the control ranges."""
    return (m.qpos0 + rng.uniform(-0.4, 0.4, m.nq), rng.uniform(-1.5, 1.5, m.nv),
            rng.uniform(-0.5, 0.5, m.na), rng.uniform(-0.9, 0.9, m.nu), rng.uniform(-1, 1, m.nv))


def test_compiled_as_mujoco(tmp_path):
    """The servo's damping ratio reads the spatial tendon's moment at qpos0; the sites' gears
    are read whole."""
    m, ours = models(tmp_path, "spatial_tendon_actuators")
    np.testing.assert_allclose(ours.get_param("actuator/extend/bias"), m.actuator_biasprm[1, :3],
                               rtol=1e-12, atol=0)
    m, ours = models(tmp_path, "site_actuators")
    assert m.actuator_trntype.tolist() == [mujoco.mjtTrn.mjTRN_SITE] * 4
    assert (ours.nu, ours.na) == (4, 1)


@pytest.mark.parametrize("name", MODELS)
@pytest.mark.parametrize("integrator", INTEGRATORS)
def test_one_step_matches_mj_step(tmp_path, name, integrator):
    m, ours = models(tmp_path, name, integrator)
    d = mujoco.MjData(m)
    rng = np.random.default_rng(0)
    for _ in range(10):
        q, v, act, ctrl, tau = sample(m, rng)
        theirs = mujoco_step(m, d, q, v, act, ctrl, tau)
        mine = ours.step(q, v, tau, ctrl=ctrl, act=act)
        for a, b in zip(mine, theirs):
            np.testing.assert_allclose(a, b, rtol=0, atol=1e-10)


@pytest.mark.parametrize("name", MODELS)
def test_transmissions_read_as_mj_forward(tmp_path, name):
    """actuatorpos, actuatorvel and actuatorfrc: the lengths, velocities and forces."""
    m, ours = models(tmp_path, name)
    d = mujoco.MjData(m)
    rng = np.random.default_rng(4)
    for _ in range(5):
        q, v, act, ctrl, _ = sample(m, rng)
        d.qpos[:], d.qvel[:], d.act[:], d.ctrl[:] = q, v, act, ctrl
        mujoco.mj_forward(m, d)
        mine = ours.sensors(q, v, np.zeros(m.nv), ctrl=ctrl, act=act)
        np.testing.assert_allclose(mine, d.sensordata, rtol=0, atol=1e-12)
        assert np.abs(d.sensordata).min() > 1e-3


@pytest.mark.parametrize("name", MODELS)
def test_jacobians_match_mujoco_transition_fd(tmp_path, name):
    """A and B against mjd_transitionFD (centered, eps 1e-6): max |ours - MuJoCo| / max(1,
    max |MuJoCo|) below 1e-6."""
    m, ours = models(tmp_path, name)
    d = mujoco.MjData(m)
    rng = np.random.default_rng(2)
    n = 2 * m.nv + m.na
    for _ in range(3):
        q, v, act, ctrl, tau = sample(m, rng)
        d.qpos[:], d.qvel[:], d.act[:], d.ctrl[:], d.qfrc_applied[:] = q, v, act, ctrl, tau
        A, B = np.zeros((n, n)), np.zeros((n, m.nu))
        mujoco.mjd_transitionFD(m, d, 1e-6, True, A, B, None, None)
        a, b = transition(ours.step_jacobians(q, v, tau, ctrl=ctrl, act=act))
        for mine, theirs in ((a, A), (b, B)):
            assert np.abs(mine - theirs).max() / max(1.0, np.abs(theirs).max()) < 1e-6


@pytest.mark.parametrize("name", MODELS)
@pytest.mark.parametrize("integrator", ["Euler", "implicitfast"])
def test_jacobians_match_central_differences(tmp_path, name, integrator):
    """Every block against central differences of our own step (hinges and slides: q indexed
    as v), at 1e-6 of the block's scale; the position block is where a moving moment shows."""
    m, ours = models(tmp_path, name, integrator)
    q, v, act, ctrl, tau = sample(m, np.random.default_rng(3))
    a, b = transition(ours.step_jacobians(q, v, tau, ctrl=ctrl, act=act))
    eps = 1e-6

    def flat(x, c):
        return np.concatenate(ours.step(x[:m.nq], x[m.nq:m.nq + m.nv], tau, ctrl=c, act=x[m.nq + m.nv:]))

    x0 = np.concatenate([q, v, act])
    fd_a = np.column_stack([(flat(x0 + eps * e, ctrl) - flat(x0 - eps * e, ctrl)) / (2 * eps)
                            for e in np.eye(len(x0))])
    fd_b = np.column_stack([(flat(x0, ctrl + eps * e) - flat(x0, ctrl - eps * e)) / (2 * eps)
                            for e in np.eye(m.nu)])
    for mine, fd in ((a, fd_a), (b, fd_b)):
        assert np.abs(mine - fd).max() / max(1.0, np.abs(fd).max()) < 1e-6


BAD = [
    ('<motor site="nowhere"/>', r"bad.xml:4: <motor>: unknown site 'nowhere'"),
    ('<motor site="s" refsite="nowhere"/>', r"bad.xml:4: <motor>: unknown site 'nowhere'"),
    ('<motor joint="h" refsite="s"/>', r"bad.xml:4: <motor>: refsite needs a site"),
    ('<motor joint="h" site="s"/>', r"bad.xml:4: <motor>: an actuator has one transmission target"),
    ('<motor site="s" armature="1"/>', r"actuator 'bad'.*tendon or site are not supported"),
]


@pytest.mark.parametrize("actuator, message", BAD)
def test_bad_site_targets_name_the_line(tmp_path, actuator, message):
    path = tmp_path / "bad.xml"
    actuator = actuator.replace("/>", ' name="bad"/>')
    path.write_text('<mujoco><worldbody><body name="a"><joint name="h"/><geom size="1"/>\n'
                    '<site name="s"/></body></worldbody>\n'
                    '<actuator>\n'
                    f'{actuator}\n'
                    '</actuator></mujoco>')
    with pytest.raises(ValueError, match=message):
        diffosi.Model.load(str(path))


def test_gain_derivatives_are_refused_by_name(tmp_path):
    """The dual path does not carry an actuator's gain and bias yet: asking for them says so."""
    m, ours = models(tmp_path, "site_actuators")
    q, v, act, ctrl, tau = sample(m, np.random.default_rng(5))
    with pytest.raises(ValueError, match="nor with actuators on sites or spatial tendons"):
        ours.step_jacobians(q, v, tau, params=["actuator/reach/gain"], ctrl=ctrl, act=act)
