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


def mujoco_sensordata(mm, q, v, tau):
    d = mujoco.MjData(mm)
    d.qpos[:], d.qvel[:], d.qfrc_applied[:] = q, v, tau
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
