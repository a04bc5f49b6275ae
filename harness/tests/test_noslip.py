"""MuJoCo's noslip post-processing (<option noslip_iterations>): one step of a box sliding
and spinning on a plane, in contact, against MuJoCo 4 for every cone and condim, a hinge
with dry friction, and the step's Jacobians against MuJoCo's mjd_transitionFD."""

import mujoco
import numpy as np
import pytest

import diffosi

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


def sliding():
    """The box 1 mm into the floor, tilted a little, sliding and spinning."""
    q = np.array([0.0, 0.0, 0.099, 1.0, 0.004, -0.003, 0.0])
    q[3:] /= np.linalg.norm(q[3:])
    v = np.array([0.8, -0.3, -0.05, 0.1, 0.2, 1.5])
    return q, v


def mujoco_step(mj, q, v, tau):
    d = mujoco.MjData(mj)
    d.qpos[:], d.qvel[:], d.qfrc_applied[:] = q, v, tau
    mujoco.mj_step(mj, d)
    return d.qpos.copy(), d.qvel.copy(), d


@pytest.mark.parametrize("cone,condim", [("pyramidal", 3), ("pyramidal", 4), ("pyramidal", 6),
                                         ("elliptic", 3), ("elliptic", 4), ("elliptic", 6)])
def test_sliding_box_steps_as_mujoco(tmp_path, cone, condim):
    q, v = sliding()
    tau = np.array([3.0, 1.0, 0.0, 0.0, 0.0, 0.2])
    m, mj = load(tmp_path, BOX.format(cone=cone, noslip=10, condim=condim, extra=""))
    q1, v1 = m.step(q, v, tau)
    mq, mv, d = mujoco_step(mj, q, v, tau)
    assert d.ncon >= 3
    assert np.abs(q1 - mq).max() < 1e-9 and np.abs(v1 - mv).max() < 1e-9
    # The sweeps changed the step: without them both engines agree on another answer.
    m0, mj0 = load(tmp_path, BOX.format(cone=cone, noslip=0, condim=condim, extra=""), "off.xml")
    _, v0 = m0.step(q, v, tau)
    assert np.abs(v0 - v1).max() > 1e-4
    assert np.abs(v0 - mujoco_step(mj0, q, v, tau)[1]).max() < 1e-9


@pytest.mark.parametrize("tolerance", [1e-6, 1e-2, 0.0])
def test_the_tolerance_stops_the_sweeps_as_mujocos(tmp_path, tolerance):
    q, v = sliding()
    text = BOX.format(cone="elliptic", noslip=3, condim=3, extra=f'noslip_tolerance="{tolerance}"')
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
    q, v = sliding()
    tau = np.array([3.0, 1.0, 0.0, 0.0, 0.0, 0.2])
    m, mj = load(tmp_path, BOX.format(cone="elliptic", noslip=10, condim=3, extra=""))
    J = m.step_jacobians(q, v, tau)
    d = mujoco.MjData(mj)
    d.qpos[:], d.qvel[:], d.qfrc_applied[:] = q, v, tau
    n = mj.nv
    A = np.zeros((2 * n, 2 * n))
    mujoco.mjd_transitionFD(mj, d, 1e-6, 1, A, None, None, None)
    ours = np.block([[J["dq_dq"], J["dq_dv"]], [J["dv_dq"], J["dv_dv"]]])
    scale = np.abs(A).max()
    assert np.abs(ours - A).max() < 1e-4 * scale
