"""Sites and sensors through the Python module against MuJoCo's own mj_forward,
at random states (tests/sensors.rs checks the same models against golden data).

Run with `make test` (or `.venv/bin/python -m pytest -q harness/tests/test_sensors.py`
after `make setup`).
"""

from pathlib import Path

import mujoco
import numpy as np
import pytest

import diffosi

DATA = Path(__file__).resolve().parents[2] / "tests" / "data"


def mujoco_sensordata(mm, q, v, tau, ctrl=None, act=None):
    d = mujoco.MjData(mm)
    d.qpos[:], d.qvel[:], d.qfrc_applied[:] = q, v, tau
    if ctrl is not None:
        d.ctrl[:], d.act[:] = ctrl, act
    mujoco.mj_forward(mm, d)
    return d.sensordata.copy()


@pytest.mark.parametrize("name", ["sensor_chain", "sensor_box"])
def test_sensors_match_mujoco_forward(name):
    path = str(DATA / f"{name}.xml")
    m, mm = diffosi.Model.load(path), mujoco.MjModel.from_xml_path(path)
    names = [mujoco.mj_id2name(mm, mujoco.mjtObj.mjOBJ_SITE, i) for i in range(mm.nsite)]
    assert m.site_names == names
    assert list(m.sensor_adr) == mm.sensor_adr.tolist()
    assert list(m.sensor_dim) == mm.sensor_dim.tolist()
    assert len(m.sensor_names) == mm.nsensor
    rng = np.random.default_rng(7)
    for _ in range(4):
        if name == "sensor_box":  # near the floor: in contact or about to be
            quat = np.array([1.0, *(0.05 * rng.standard_normal(3))])
            q = np.concatenate([0.1 * rng.standard_normal(2), [0.098], quat / np.linalg.norm(quat)])
        else:
            q = mm.qpos0 + 0.2 * rng.standard_normal(mm.nq)  # limits entered, not by far
        v, tau = 0.5 * rng.standard_normal(mm.nv), rng.standard_normal(mm.nv)
        ours, theirs = m.sensors(q, v, tau), mujoco_sensordata(mm, q, v, tau)
        assert ours.shape == theirs.shape
        np.testing.assert_array_less(np.abs(ours - theirs) / np.maximum(1, np.abs(theirs)), 1e-12)


def test_sensors_not_computed_raise_value_error(tmp_path):
    path = tmp_path / "touch.xml"
    path.write_text('<mujoco><worldbody><body><joint/><geom size="0.1"/><site name="s"/></body>'
                    '</worldbody><sensor><touch name="foot" site="s"/></sensor></mujoco>')
    m = diffosi.Model.load(str(path))
    assert m.sensor_names == ["foot"] and list(m.sensor_dim) == [1]
    with pytest.raises(ValueError, match="'foot'.*<touch>"):
        m.sensors(np.zeros(1), np.zeros(1), np.zeros(1))
    with pytest.raises(ValueError, match="tau"):
        m.sensors(np.zeros(1), np.zeros(1), np.zeros(2))


ACTUATED = """<mujoco><option magnetic="0.2 -0.4 0.3"/><compiler autolimits="true"/><worldbody>
  <body name="a" pos="0 0 1" euler="10 20 30"><joint name="hinge" axis="0 1 0" damping="0.1"/>
    <geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.04"/>
    <site name="tip" pos="0.3 0 0" euler="30 -40 50"/>
    <body pos="0.3 0 0"><joint name="slide" type="slide" axis="1 0.5 0"/>
      <geom type="box" size="0.05 0.04 0.03"/></body></body></worldbody>
  <actuator>
    <position name="servo" joint="hinge" kp="20" kv="2" gear="1.5"/>
    <motor name="motor" joint="hinge" gear="-0.7"/>
    <general name="filter" joint="slide" gaintype="affine" gainprm="1 0.5 -0.7" biastype="affine"
             biasprm="0.3 -1 -0.3" dyntype="filter" dynprm="0.2" gear="2"/>
    <velocity name="damped" joint="slide" kv="4" forcerange="-0.1 0.1"/>
  </actuator>
  <sensor>
    <magnetometer site="tip"/>
    <actuatorpos actuator="servo"/><actuatorvel actuator="servo"/><actuatorfrc actuator="servo"/>
    <actuatorpos actuator="filter"/><actuatorvel actuator="filter"/><actuatorfrc actuator="filter"/>
    <actuatorfrc actuator="motor"/><actuatorfrc actuator="damped"/>
    <jointactuatorfrc joint="hinge"/><jointactuatorfrc joint="slide"/>
    <accelerometer site="tip"/>
  </sensor></mujoco>"""


def test_magnetometer_and_actuator_sensors_match_mujoco_forward(tmp_path):
    """At ctrl = 0 and act = 0, then at random ctrl and act: the actuators' bias forces, a clamped
    force range, two actuators on one joint, and their forces entering the accelerations."""
    path = tmp_path / "actuated.xml"
    path.write_text(ACTUATED)
    m, mm = diffosi.Model.load(str(path)), mujoco.MjModel.from_xml_path(str(path))
    assert list(m.sensor_dim) == mm.sensor_dim.tolist()
    rng = np.random.default_rng(11)
    for _ in range(5):
        q, v, tau = rng.standard_normal(2), rng.standard_normal(2), rng.standard_normal(2)
        ours, theirs = m.sensors(q, v, tau), mujoco_sensordata(mm, q, v, tau)
        assert theirs[5] != 0 and theirs[9] == 0 and np.abs(theirs[10]) <= 0.1  # bias acts; clamped
        np.testing.assert_array_less(np.abs(ours - theirs) / np.maximum(1, np.abs(theirs)), 1e-12)
        ctrl, act = rng.standard_normal(mm.nu), rng.standard_normal(mm.na)
        ours = m.sensors(q, v, tau, ctrl=ctrl, act=act)
        theirs = mujoco_sensordata(mm, q, v, tau, ctrl, act)
        assert np.abs(theirs - mujoco_sensordata(mm, q, v, tau)).max() > 1e-3  # the inputs act
        np.testing.assert_array_less(np.abs(ours - theirs) / np.maximum(1, np.abs(theirs)), 1e-12)
