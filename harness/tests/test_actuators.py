"""MuJoCo's actuators in our step against MuJoCo's mj_step: every kind (motor, position with
kv, dampratio and timeconst, velocity, intvelocity, damper, general with affine gain and bias,
filter, filterexact, integrator, actearly), control, force and activation clamping, under Euler
and RK4, one step from the same state to 1e-12, and activation trajectories."""

import re

import mujoco
import numpy as np
import pytest

import diffosi

MODEL = """
<mujoco>
  <compiler angle="radian" autolimits="true"/>
  <option timestep="0.01" integrator="{integrator}"/>
  <worldbody>
    <body name="a" pos="0 0 1">
      <joint name="j0" axis="0 1 0" damping="0.1" range="-1.5 1.5"/>
      <geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.05" contype="0" conaffinity="0"/>
      <body name="b" pos="0.3 0 0">
        <joint name="j1" axis="0 1 0" damping="0.05"/>
        <geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.04" contype="0" conaffinity="0"/>
        <body name="c" pos="0.3 0 0">
          <joint name="j2" type="slide" axis="1 0 0" range="-0.2 0.4"/>
          <geom type="box" size="0.05 0.04 0.03" contype="0" conaffinity="0"/>
          <body name="d" pos="0.1 0 0">
            <joint name="j3" axis="0 0 1" armature="0.01"/>
            <geom type="sphere" pos="0.1 0 0" size="0.04" contype="0" conaffinity="0"/>
          </body>
        </body>
      </body>
    </body>
  </worldbody>
  <actuator>
    <motor name="motor" joint="j0" gear="2" ctrlrange="-1 1"/>
    <position name="servo" joint="j1" kp="20" kv="1"/>
    <position name="ratio" joint="j2" kp="10" dampratio="0.7" timeconst="0.05"/>
    <velocity name="velocity" joint="j3" kv="3" forcerange="-0.5 0.5"/>
    <intvelocity name="intvel" joint="j0" kp="5" actrange="-0.3 0.3"/>
    <damper name="damper" joint="j1" kv="0.5" ctrlrange="0 1"/>
    <general name="filter" joint="j2" dyntype="filter" dynprm="0.1" gaintype="affine"
             gainprm="2 0.5 0.1" biastype="affine" biasprm="0.1 -1 -0.2"/>
    <general name="early" joint="j3" dyntype="integrator" actearly="true" actrange="-1 1"/>
    <general name="exact" joint="j0" dyntype="filterexact" dynprm="0.2" actearly="true" gear="1.5"/>
    <position name="inherit" joint="j2" kp="4" inheritrange="0.5"/>
  </actuator>
</mujoco>
"""


def models(integrator, tmp_path):
    path = tmp_path / f"actuators_{integrator}.xml"
    path.write_text(MODEL.format(integrator=integrator))
    return mujoco.MjModel.from_xml_path(str(path)), diffosi.Model.load(str(path))


def mujoco_step(m, d, q, v, act, ctrl, tau):
    d.qpos[:], d.qvel[:], d.act[:], d.ctrl[:], d.qfrc_applied[:] = q, v, act, ctrl, tau
    d.time = 0.0
    mujoco.mj_step(m, d)
    return d.qpos.copy(), d.qvel.copy(), d.act.copy()


@pytest.mark.parametrize("integrator", ["Euler", "RK4"])
def test_each_actuator_kind_steps_as_mujoco(integrator, tmp_path):
    m, ours = models(integrator, tmp_path)
    d = mujoco.MjData(m)
    assert (ours.nu, ours.na) == (m.nu, m.na) == (10, 5)
    assert ours.actuator_names[:3] == ["motor", "servo", "ratio"]
    rng = np.random.default_rng(0)
    for _ in range(20):
        q = rng.uniform(-0.5, 0.5, m.nq)
        v = rng.uniform(-2, 2, m.nv)
        act = rng.uniform(-0.5, 0.5, m.na)  # beyond some actranges: clamped after the step
        ctrl = rng.uniform(-1.5, 1.5, m.nu)  # beyond the ctrlranges: clamped
        tau = rng.uniform(-1, 1, m.nv)
        theirs = mujoco_step(m, d, q, v, act, ctrl, tau)
        mine = ours.step(q, v, tau, ctrl=ctrl, act=act)
        for a, b in zip(mine, theirs):
            np.testing.assert_allclose(a, b, rtol=0, atol=1e-12)


@pytest.mark.parametrize("integrator", ["Euler", "RK4"])
def test_activation_trajectories_follow_mujoco(integrator, tmp_path):
    m, ours = models(integrator, tmp_path)
    d = mujoco.MjData(m)
    steps = 200
    rng = np.random.default_rng(1)
    ctrls = rng.uniform(-1.5, 1.5, (steps, m.nu))
    ctrls[:150, [4, 7]] = 1.0  # intvel and early integrate up to their activation ranges
    taus = np.zeros((steps, m.nv))
    Q, V, A = ours.rollout(np.zeros(m.nq), np.zeros(m.nv), taus, ctrls=ctrls)
    for t in range(steps):
        d.ctrl[:] = ctrls[t]
        mujoco.mj_step(m, d)
        np.testing.assert_allclose(Q[t + 1], d.qpos, rtol=0, atol=1e-9)
        np.testing.assert_allclose(V[t + 1], d.qvel, rtol=0, atol=1e-9)
        np.testing.assert_allclose(A[t + 1], d.act, rtol=0, atol=1e-9)
    # The clamped activations sit at their ranges somewhere on the way.
    assert np.abs(A[:, 1]).max() == 0.3 and np.abs(A[:, 3]).max() == 1.0


def transition(j):
    """Our blocks as mjd_transitionFD's A (2nv + na square) and B (2nv + na x nu)."""
    a = np.block([[j["dq_dq"], j["dq_dv"], j["dq_dact"]],
                  [j["dv_dq"], j["dv_dv"], j["dv_dact"]],
                  [j["dact_dq"], j["dact_dv"], j["dact_dact"]]])
    b = np.vstack([j["dq_dctrl"], j["dv_dctrl"], j["dact_dctrl"]])
    return a, b


def sample(m, rng):
    """A state and inputs away from every clamp (ctrl, force and activation ranges)."""
    return (rng.uniform(-0.3, 0.3, m.nq), rng.uniform(-0.3, 0.3, m.nv), rng.uniform(-0.2, 0.2, m.na),
            rng.uniform(0.1, 0.3, m.nu), rng.uniform(-0.5, 0.5, m.nv))


def test_jacobians_match_mujoco_transition_fd(tmp_path):
    """A and B against MuJoCo's mjd_transitionFD (centered, eps 1e-6), as the gradchecks do:
    error max |ours - MuJoCo| / max(1, max |MuJoCo|) below 1e-5."""
    assert_jacobians_match_transition_fd(*models("Euler", tmp_path), seed=2, count=5)


def assert_jacobians_match_transition_fd(m, ours, seed, count):
    """Our A and B at `count` sampled points against mjd_transitionFD's."""
    d = mujoco.MjData(m)
    rng = np.random.default_rng(seed)
    n = 2 * m.nv + m.na
    for _ in range(count):
        q, v, act, ctrl, tau = sample(m, rng)
        d.qpos[:], d.qvel[:], d.act[:], d.ctrl[:], d.qfrc_applied[:] = q, v, act, ctrl, tau
        A, B = np.zeros((n, n)), np.zeros((n, m.nu))
        mujoco.mjd_transitionFD(m, d, 1e-6, True, A, B, None, None)
        a, b = transition(ours.step_jacobians(q, v, tau, ctrl=ctrl, act=act))
        for mine, theirs in ((a, A), (b, B)):
            assert np.abs(mine - theirs).max() / max(1.0, np.abs(theirs).max()) < 1e-5


@pytest.mark.parametrize("integrator", ["Euler", "RK4", "RK4 motors"])
def test_jacobians_match_central_differences(integrator, tmp_path):
    """Every block against central differences of our own step (hinges and slides: q indexed
    as v), at 1e-6 of the block's scale: every actuator kind (under RK4 by dual numbers
    through the step), and under RK4 motors alone too (the chain rule through tau)."""
    m, ours = models(integrator.split()[0], tmp_path)
    if integrator == "RK4 motors":
        motors = '<actuator><motor joint="j0" gear="2" ctrlrange="-1 1"/><motor joint="j2"/></actuator>'
        path = tmp_path / "motors.xml"
        path.write_text(re.sub("<actuator>.*</actuator>", motors, MODEL.format(integrator="RK4"),
                               flags=re.S))
        m, ours = mujoco.MjModel.from_xml_path(str(path)), diffosi.Model.load(str(path))
    rng = np.random.default_rng(3)
    q, v, act, ctrl, tau = sample(m, rng)
    a, b = transition(ours.step_jacobians(q, v, tau, ctrl=ctrl, act=act))
    eps = 1e-6

    def flat(x, c):
        out = ours.step(x[:m.nq], x[m.nq:m.nq + m.nv], tau, ctrl=c, act=x[m.nq + m.nv:])
        return np.concatenate(out)

    x0 = np.concatenate([q, v, act])
    fd_a = np.column_stack([(flat(x0 + eps * e, ctrl) - flat(x0 - eps * e, ctrl)) / (2 * eps)
                            for e in np.eye(len(x0))])
    fd_b = np.column_stack([(flat(x0, ctrl + eps * e) - flat(x0, ctrl - eps * e)) / (2 * eps)
                            for e in np.eye(m.nu)])
    for mine, fd in ((a, fd_a), (b, fd_b)):
        assert np.abs(mine - fd).max() / max(1.0, np.abs(fd).max()) < 1e-6


def test_plain_step_is_zero_controls_and_activations(tmp_path):
    m, ours = models("Euler", tmp_path)
    d = mujoco.MjData(m)
    q, v, tau = np.full(m.nq, 0.1), np.full(m.nv, -0.2), np.zeros(m.nv)
    q1, v1, act1 = ours.step(q, v, tau)
    theirs = mujoco_step(m, d, q, v, np.zeros(m.na), np.zeros(m.nu), tau)
    for a, b in zip((q1, v1, act1), theirs):
        np.testing.assert_allclose(a, b, rtol=0, atol=1e-12)


@pytest.mark.parametrize("bad, match", [
    ({"ctrl": np.zeros(3)}, "ctrl must be 1-D of length nu = 10"),
    ({"act": np.zeros(2)}, "act must be 1-D of length na = 5"),
    ({"ctrl": np.full(10, np.nan)}, "ctrl"),
])
def test_bad_inputs_are_value_errors(bad, match, tmp_path):
    _, ours = models("Euler", tmp_path)
    with pytest.raises(ValueError, match=match):
        ours.step(np.zeros(ours.nq), np.zeros(ours.nv), np.zeros(ours.nv), **bad)


# MuJoCo 4's actuator damping and armature: gear^2 times each joins its joint's damping and
# armature (mj_actuatorDamping, mj_actuatorArmature), two actuators on j0 summing, and the
# dampratio servo's kv following the armature it sees.
PASSIVE = {'name="motor"': 'name="motor" damping="0.3" armature="0.02"',
           'name="exact"': 'name="exact" damping="0.2" armature="0.01"',
           'name="ratio"': 'name="ratio" armature="0.05"',
           'name="velocity"': 'name="velocity" damping="0.7"'}


def passive_models(integrator, tmp_path):
    xml = MODEL.format(integrator=integrator)
    for old, new in PASSIVE.items():
        xml = xml.replace(old, new)
    path = tmp_path / f"actuator_passive_{integrator}.xml"
    path.write_text(xml)
    return mujoco.MjModel.from_xml_path(str(path)), diffosi.Model.load(str(path))


@pytest.mark.parametrize("integrator", ["Euler", "RK4", "implicitfast", "implicit"])
def test_actuator_damping_and_armature_step_as_mujoco(integrator, tmp_path):
    m, ours = passive_models(integrator, tmp_path)
    assert m.actuator_damping[0] == 0.3 and m.actuator_armature[2] == 0.05
    plain = models(integrator, tmp_path)[1]
    d = mujoco.MjData(m)
    rng = np.random.default_rng(3)
    for _ in range(10):
        q, v, act, ctrl, tau = (rng.uniform(-0.5, 0.5, m.nq), rng.uniform(-2, 2, m.nv),
                                rng.uniform(-0.2, 0.2, m.na), rng.uniform(-1, 1, m.nu),
                                rng.uniform(-1, 1, m.nv))
        theirs = mujoco_step(m, d, q, v, act, ctrl, tau)
        mine = ours.step(q, v, tau, ctrl=ctrl, act=act)
        for a, b in zip(mine, theirs):
            np.testing.assert_allclose(a, b, rtol=0, atol=1e-12)
        # They act: the model without them steps elsewhere.
        assert np.abs(plain.step(q, v, tau, ctrl=ctrl, act=act)[1] - theirs[1]).max() > 1e-3


def test_actuator_damping_and_armature_jacobians_match_mujoco_transition_fd(tmp_path):
    assert_jacobians_match_transition_fd(*passive_models("Euler", tmp_path), seed=4, count=3)
