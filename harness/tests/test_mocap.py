"""Mocap bodies against MuJoCo: their pose is an input of the step (mocap_pos,
mocap_quat), their geoms collide with the bodies that move.

A mocap box pushes a free sphere resting on a floor: one step from several
moving states and mocap poses agrees with mj_step to 1e-12 (contacts between
the box and the sphere included), with no mocap input the compiled pose is
MuJoCo's default, keyframes give MuJoCo's key_mpos and key_mquat, and the
step Jacobians at a mocap pose agree with mjd_transitionFD's centered
differences at that pose.
"""

import mujoco
import numpy as np
import pytest

import diffosi

SOLVER = 'tolerance="1e-15" ls_tolerance="1e-12" iterations="1000"'
XML = f"""<mujoco><option timestep="0.005" {SOLVER}/><worldbody>
<geom type="plane" size="2 2 .1"/>
<body name="pusher" mocap="true" pos="-0.3 0 0.1" quat="1 0 0 0.2">
  <geom type="box" size=".05 .1 .05"/><site name="tip" pos=".05 0 0"/></body>
<body name="ball" pos="0 0 .1"><freejoint/><geom size=".1" mass="1"/></body>
</worldbody>
<keyframe><key name="near" mpos="-0.2 0 0.1"/><key name="turned" mquat="0 1 0 0"/></keyframe>
</mujoco>"""


@pytest.fixture()
def models(tmp_path):
    path = tmp_path / "mocap.xml"
    path.write_text(XML)
    return mujoco.MjModel.from_xml_path(str(path)), diffosi.Model.load(str(path))


def poses(seed):
    """A pose of the box that presses into the sphere's side."""
    rng = np.random.default_rng(seed)
    pos = np.array([[-0.14 + 0.01 * rng.uniform(), 0.02 * rng.uniform(-1, 1), 0.1]])
    quat = np.array([[1.0, *rng.uniform(-0.1, 0.1, 3)]]) * rng.uniform(0.5, 2.0)
    return pos, quat


def state(m, seed):
    """The sphere 2 mm into the floor (a contact at distance 0 switches
    under differences), moving."""
    rng = np.random.default_rng([seed, 7])
    q = m.qpos0.copy()
    q[2] -= 0.002
    return q, 0.3 * rng.normal(size=m.nv), 0.5 * rng.normal(size=m.nv)


def test_one_step_matches_mj_step(models):
    m, ours = models
    assert ours.nmocap == m.nmocap == 1
    d = mujoco.MjData(m)
    for seed in range(4):
        q, v, tau = state(m, seed)
        pos, quat = poses(seed)
        mujoco.mj_resetData(m, d)
        d.qpos[:], d.qvel[:], d.qfrc_applied[:] = q, v, tau
        d.mocap_pos[:], d.mocap_quat[:] = pos, quat
        mujoco.mj_step(m, d)
        assert any(m.geom_bodyid[c.geom1] == 1 or m.geom_bodyid[c.geom2] == 1
                   for c in d.contact[:d.ncon]), "the box touches the sphere"
        q1, v1 = ours.step(q, v, tau, mocap_pos=pos, mocap_quat=quat)
        np.testing.assert_allclose(q1, d.qpos, rtol=0, atol=1e-12)
        np.testing.assert_allclose(v1, d.qvel, rtol=0, atol=1e-12)


def test_default_pose_and_keyframes_are_mujocos(models):
    m, ours = models
    d = mujoco.MjData(m)
    q, v, tau = state(m, 0)
    # A step without mocap inputs after one with them: the compiled pose.
    ours.step(q, v, tau, mocap_pos=poses(0)[0], mocap_quat=poses(0)[1])
    d.qpos[:], d.qvel[:], d.qfrc_applied[:] = q, v, tau
    mujoco.mj_step(m, d)
    q1, v1 = ours.step(q, v, tau)
    np.testing.assert_allclose(v1, d.qvel, rtol=0, atol=1e-12)
    for k, name in enumerate(["near", "turned"]):
        key = ours.keyframe(name)
        np.testing.assert_allclose(key["mocap_pos"].ravel(), m.key_mpos[k], rtol=0, atol=1e-15)
        np.testing.assert_allclose(key["mocap_quat"].ravel(), m.key_mquat[k], rtol=0, atol=1e-15)


def test_jacobians_match_mjd_transition_fd_at_a_mocap_pose(models):
    m, ours = models
    d = mujoco.MjData(m)
    q, v, tau = state(m, 1)
    pos, quat = poses(1)
    d.qpos[:], d.qvel[:], d.qfrc_applied[:] = q, v, tau
    d.mocap_pos[:], d.mocap_quat[:] = pos, quat
    mujoco.mj_forward(m, d)
    assert d.ncon >= 2
    A = np.zeros((2 * m.nv, 2 * m.nv))
    mujoco.mjd_transitionFD(m, d, 1e-6, True, A, None, None, None)
    J = ours.step_jacobians(q, v, tau, mocap_pos=pos, mocap_quat=quat)
    a = np.block([[J["dq_dq"], J["dq_dv"]], [J["dv_dq"], J["dv_dv"]]])
    err = np.abs(a - A).max() / max(1.0, np.abs(A).max())
    assert err < 1e-6, f"{err:.1e}"
    # The pose matters: at the compiled pose the box is away.
    J0 = ours.step_jacobians(q, v, tau)
    assert np.abs(J0["dv_dv"] - J["dv_dv"]).max() > 1e-3


def test_bad_mocap_inputs_are_refused(models):
    _, ours = models
    q, v, tau = ours.reference_q(), np.zeros(6), np.zeros(6)
    with pytest.raises(ValueError, match="mocap_pos has 2 rows, the model has nmocap = 1"):
        ours.step(q, v, tau, mocap_pos=np.zeros((2, 3)))
    with pytest.raises(ValueError, match="mocap_quat"):
        ours.step(q, v, tau, mocap_quat=np.array([[1.0, 0, 0, np.nan]]))
    with pytest.raises(ValueError, match="mocap_quat"):
        ours.step_jacobians(q, v, tau, mocap_quat=np.zeros((1, 3)))


@pytest.mark.parametrize("body, expected", [
    ('<body><joint/><geom size=".1"/><body mocap="true"/></body>',
     "mocap body '' is not a fixed child of world"),
    ('<body mocap="true"><joint/><geom size=".1"/></body>',
     "mocap body '' is not a fixed child of world"),
    ('<body mocap="true"><body><geom size=".1"/></body></body>',
     "bodies inside a mocap body"),
])
def test_mocap_bodies_that_mujoco_or_we_refuse(tmp_path, body, expected):
    path = tmp_path / "bad.xml"
    path.write_text(f"<mujoco><worldbody>{body}</worldbody></mujoco>")
    with pytest.raises(ValueError, match=expected):
        diffosi.Model.load(str(path))


def test_rollout_takes_a_mocap_pose_per_step_as_mj_step_does(models):
    m, ours = models
    d = mujoco.MjData(m)
    q, v, tau = state(m, 2)
    T = 6
    pos = np.stack([poses(k)[0] for k in range(T)])
    quat = np.stack([poses(k)[1] for k in range(T)])
    taus = np.tile(tau, (T, 1))
    d.qpos[:], d.qvel[:] = q, v
    expected = [d.qpos.copy()]
    for t in range(T):
        d.qfrc_applied[:] = tau
        d.mocap_pos[:], d.mocap_quat[:] = pos[t], quat[t]
        mujoco.mj_step(m, d)
        expected.append(d.qpos.copy())
    qs, _ = ours.rollout(q, v, taus, mocap_pos=pos, mocap_quat=quat)
    np.testing.assert_allclose(qs, np.array(expected), rtol=0, atol=1e-11)
    # One pose for every step is that pose repeated.
    one = ours.rollout(q, v, taus, mocap_pos=pos[0], mocap_quat=quat[0])
    repeated = ours.rollout(q, v, taus, mocap_pos=pos[[0] * T], mocap_quat=quat[[0] * T])
    np.testing.assert_array_equal(one[0], repeated[0])
    assert np.abs(one[0][-1] - qs[-1]).max() > 1e-6, "the poses matter"


def test_contacts_take_the_mocap_pose(models):
    m, ours = models
    d = mujoco.MjData(m)
    q, v, tau = state(m, 3)
    pos, quat = poses(3)
    d.qpos[:], d.qvel[:], d.qfrc_applied[:] = q, v, tau
    d.mocap_pos[:], d.mocap_quat[:] = pos, quat
    mujoco.mj_forward(m, d)
    pressed = ours.contacts(q, v, tau, mocap_pos=pos, mocap_quat=quat)
    depths = sorted(c["depth"] for c in pressed)
    np.testing.assert_allclose(depths, sorted(-c.dist for c in d.contact[:d.ncon]), rtol=0, atol=1e-12)
    # Without a pose, the compiled one (the box away), whatever was evaluated before.
    assert len(ours.contacts(q, v, tau)) == d.ncon - 1
    forces = ours.body_contact_forces(q, v, tau, mocap_pos=pos, mocap_quat=quat)
    assert np.abs(forces[1]).max() > 0, "the box feels the sphere"


def test_bad_rollout_mocap_inputs_are_refused(models):
    _, ours = models
    q, v, taus = ours.reference_q(), np.zeros(6), np.zeros((4, 6))
    with pytest.raises(ValueError, match=r"mocap_pos must be \(1, 3\) .* or \(4, 1, 3\) .* got shape \(3, 1, 3\)"):
        ours.rollout(q, v, taus, mocap_pos=np.zeros((3, 1, 3)))
    with pytest.raises(ValueError, match=r"mocap_quat must be \(1, 4\) .* got shape \(4,\)"):
        ours.rollout(q, v, taus, mocap_quat=np.ones(4))
    with pytest.raises(ValueError, match="mocap_pos.* is not finite"):
        ours.rollout(q, v, taus, mocap_pos=np.full((1, 3), np.inf))
