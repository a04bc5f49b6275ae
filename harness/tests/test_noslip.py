"""MuJoCo's noslip post-processing (<option noslip_iterations>): one step of a box sliding
and spinning on a plane, in contact, against MuJoCo 4 for every cone and condim, a hinge
with dry friction, and the step's Jacobians against MuJoCo's mjd_transitionFD."""

import mujoco
import numpy as np
import pytest

import diffosi
from harness import corpus

BOX = """<mujoco>
  <option timestep="0.002" cone="{cone}" noslip_iterations="{noslip}" {extra}/>
  <worldbody>
    <geom name="floor" type="plane" size="5 5 0.1"/>
    <body name="box" pos="0 0 0.1">
      <freejoint/>
      <geom type="box" size="0.2 0.15 0.1" mass="2" condim="{condim}" friction="0.6 0.02 0.01"/>
    </body>
  </worldbody>
</mujoco>"""

HINGE = """<mujoco>
  <option timestep="0.01" noslip_iterations="{noslip}"/>
  <worldbody>
    <body name="arm">
      <joint name="a" type="hinge" axis="0 1 0" frictionloss="0.8"/>
      <geom type="capsule" fromto="0 0 0 0.4 0 0" size="0.04" mass="1"/>
      <body pos="0.4 0 0">
        <joint name="b" type="hinge" axis="0 1 0" frictionloss="0.3"/>
        <geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.03" mass="0.5"/>
      </body>
    </body>
  </worldbody>
</mujoco>"""


def load(tmp_path, text, name="m.xml"):
    path = tmp_path / name
    path.write_text(text)
    return diffosi.Model.load(str(path)), mujoco.MjModel.from_xml_path(str(path))


def sliding(speed=1.0):
    """The box 1 mm into the floor, tilted a little, sliding and spinning (at `speed` times
    0.8 m/s): at 0.01 it nearly sticks, and the soft contact's creep is what the sweeps remove."""
    q = np.array([0.0, 0.0, 0.099, 1.0, 0.004, -0.003, 0.0])
    q[3:] /= np.linalg.norm(q[3:])
    v = speed * np.array([0.8, -0.3, -0.05, 0.1, 0.2, 1.5])
    return q, v


def mujoco_step(mj, q, v, tau):
    d = mujoco.MjData(mj)
    d.qpos[:], d.qvel[:], d.qfrc_applied[:] = q, v, tau
    mujoco.mj_step(mj, d)
    return d.qpos.copy(), d.qvel.copy(), d


# MuJoCo's Newton solver converged (tolerance 1e-15; ours ignores it and converges anyway):
# its elliptic cones otherwise stop 1e-11 to 1e-7 from the optimum, and the sweeps, which
# start from its forces and stop at noslip_tolerance, carry that on (x20 to x50 measured).
CONVERGED = 'tolerance="1e-15"'


@pytest.mark.parametrize("cone,condim,speed", [
    ("pyramidal", 3, 1.0), ("pyramidal", 4, 1.0), ("pyramidal", 6, 1.0),
    ("pyramidal", 3, 0.01), ("pyramidal", 4, 0.01), ("pyramidal", 6, 0.01),
    ("elliptic", 3, 0.01), ("elliptic", 4, 0.01), ("elliptic", 6, 0.01)])
def test_sliding_box_steps_as_mujoco(tmp_path, cone, condim, speed):
    q, v = sliding(speed)
    tau = np.array([0.5, 0.2, 0.0, 0.0, 0.0, 0.01]) if speed < 1 else np.array([3.0, 1.0, 0, 0, 0, 0.2])
    m, mj = load(tmp_path, BOX.format(cone=cone, noslip=10, condim=condim, extra=CONVERGED))
    q1, v1 = m.step(q, v, tau)
    mq, mv, d = mujoco_step(mj, q, v, tau)
    assert d.ncon >= 3
    assert np.abs(q1 - mq).max() < 1e-9 and np.abs(v1 - mv).max() < 1e-9
    if speed < 1 and (cone, condim) != ("elliptic", 6):
        # The sweeps changed the step: without them both engines agree on another answer.
        # (An elliptic cone of condim 6 holds the slow box with its torsion and rolling
        # friction already: the sweeps move it by 3e-12.)
        off = BOX.format(cone=cone, noslip=0, condim=condim, extra=CONVERGED)
        m0, mj0 = load(tmp_path, off, "off.xml")
        _, v0 = m0.step(q, v, tau)
        assert np.abs(v0 - v1).max() > 1e-4
        assert np.abs(v0 - mujoco_step(mj0, q, v, tau)[1]).max() < 1e-9


@pytest.mark.parametrize("tolerance", [1e-6, 1e-2, 0.0])
def test_the_tolerance_stops_the_sweeps_as_mujocos(tmp_path, tolerance):
    q, v = sliding(0.01)
    extra = f'{CONVERGED} noslip_tolerance="{tolerance}"'
    text = BOX.format(cone="elliptic", noslip=3, condim=3, extra=extra)
    m, mj = load(tmp_path, text)
    q1, v1 = m.step(q, v, np.zeros(6))
    mq, mv, _ = mujoco_step(mj, q, v, np.zeros(6))
    assert np.abs(q1 - mq).max() < 1e-9 and np.abs(v1 - mv).max() < 1e-9


def test_dry_friction_rows_are_swept(tmp_path):
    q, v, tau = np.array([0.3, -0.5]), np.array([0.02, -0.01]), np.array([0.5, 0.1])
    m, mj = load(tmp_path, HINGE.format(noslip=5))
    q1, v1 = m.step(q, v, tau)
    mq, mv, _ = mujoco_step(mj, q, v, tau)
    assert np.abs(q1 - mq).max() < 1e-9 and np.abs(v1 - mv).max() < 1e-9


def test_jacobians_through_the_sweeps_match_mujocos_finite_differences(tmp_path):
    """Dual numbers through a fixed sequence of sweeps against mjd_transitionFD (centred, eps
    1e-6) and our own central differences: where no sweep switches branch they agree to the
    differences' truncation."""
    q, v = sliding(0.01)
    tau = np.array([0.5, 0.2, 0.0, 0.0, 0.0, 0.01])
    m, mj = load(tmp_path, BOX.format(cone="elliptic", noslip=10, condim=3, extra=CONVERGED))
    J = m.step_jacobians(q, v, tau)
    d = mujoco.MjData(mj)
    d.qpos[:], d.qvel[:], d.qfrc_applied[:] = q, v, tau
    n = mj.nv
    A = np.zeros((2 * n, 2 * n))
    mujoco.mjd_transitionFD(mj, d, 1e-6, 1, A, None, None, None)
    ours = np.block([[J["dq_dq"], J["dq_dv"]], [J["dv_dq"], J["dv_dv"]]])
    assert np.abs(ours - A).max() < 1e-5 * np.abs(A).max()  # 2.6e-6 of 5.2 measured
    h = 1e-6
    for k in range(n):
        up, down = v.copy(), v.copy()
        up[k] += h
        down[k] -= h
        column = (m.step(q, up, tau)[1] - m.step(q, down, tau)[1]) / (2 * h)
        assert np.abs(column - J["dv_dv"][:, k]).max() < 1e-8  # 4.6e-10 measured


@pytest.mark.parametrize("cone,drop,bound", [("pyramidal", 0.05, 1e-10), ("elliptic", 0.05, 1e-9)])
def test_dm_control_dog_in_contact_steps_as_mujoco(cone, drop, bound):
    """dm_control's dog (noslip_iterations 4, springdamper joints, filter actuators) from its
    keyframe, lowered into its floor (34 contacts); MuJoCo converged as above. Measured: 2.6e-12
    (pyramidal) and 2.4e-12 (elliptic) in v."""
    suite = corpus.dm_control_suite()
    text = (suite / "dog.xml").read_text().replace(
        'noslip_iterations="4"', f'noslip_iterations="4" cone="{cone}" {CONVERGED}')
    path = suite / f"dog-noslip-{cone}.xml"  # beside it: its includes and meshes are relative
    path.write_text(text)
    try:
        m, mj = diffosi.Model.load(str(path)), mujoco.MjModel.from_xml_path(str(path))
    finally:
        path.unlink()
    # The springdamper joints' stiffness and damping, as MuJoCo's compiler sets them.
    for j in range(mj.njnt):
        name = mujoco.mj_id2name(mj, mujoco.mjtObj.mjOBJ_JOINT, j)
        if name and mj.jnt_type[j] == mujoco.mjtJoint.mjJNT_HINGE:
            stiffness = m.get_param(f"joint/{name}/stiffness")[0]
            damping = m.get_param(f"joint/{name}/damping")[0]
            assert stiffness == pytest.approx(mj.jnt_stiffness[j], rel=1e-12)
            assert damping == pytest.approx(mj.dof_damping[mj.jnt_dofadr[j]], rel=1e-12)
    d = mujoco.MjData(mj)
    mujoco.mj_resetDataKeyframe(mj, d, 0)
    d.qpos[2] -= drop
    q, v, act = d.qpos.copy(), d.qvel.copy(), d.act.copy()
    mujoco.mj_step(mj, d)
    assert d.ncon > 30
    q1, v1, _ = m.step(q, v, np.zeros(mj.nv), ctrl=np.zeros(mj.nu), act=act)
    assert np.abs(q1 - d.qpos).max() < bound and np.abs(v1 - d.qvel).max() < bound
