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
    path = tmp_path / "clock.xml"
    path.write_text('<mujoco><worldbody><body><joint/><geom size="0.1"/><site name="s"/></body>'
                    '</worldbody><sensor><clock name="foot"/></sensor></mujoco>')
    m = diffosi.Model.load(str(path))
    assert m.sensor_names == ["foot"] and list(m.sensor_dim) == [1]
    with pytest.raises(ValueError, match="'foot'.*<clock>"):
        m.sensors(np.zeros(1), np.zeros(1), np.zeros(1))
    with pytest.raises(ValueError, match="simulation time"):  # the state (q, v, act) has none
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


def assert_sensors_match(path, states, tol=1e-12):
    """Our readings against mj_forward's sensordata at each (q, v, tau), relative error with a
    floor of 1 below tol; returns MuJoCo's readings."""
    m, mm = diffosi.Model.load(str(path)), mujoco.MjModel.from_xml_path(str(path))
    assert list(m.sensor_dim) == mm.sensor_dim.tolist()
    readings = []
    for q, v, tau in states:
        ours, theirs = m.sensors(q, v, tau), mujoco_sensordata(mm, q, v, tau)
        np.testing.assert_array_less(np.abs(ours - theirs) / np.maximum(1, np.abs(theirs)), tol)
        readings.append(theirs)
    return np.array(readings)


TENDONS = """<mujoco><compiler autolimits="true"/><worldbody>
  <body name="upper" pos="0 0 1" euler="0 15 0">
    <joint name="shoulder" axis="0 1 0" stiffness="3" springref="0.2" armature="0.05"/>
    <geom type="capsule" fromto="0 0 0 0 0 -0.4" size="0.05"/>
    <body name="lower" pos="0 0 -0.4">
      <joint name="elbow" axis="1 0.5 0" stiffness="2"/>
      <joint name="slider" type="slide" axis="0 0 1" stiffness="10" springref="-0.02"/>
      <geom type="box" size="0.03 0.04 0.2" pos="0 0 -0.2" euler="5 0 0"/>
      <body name="ball_link" pos="0 0.1 -0.3"><joint type="ball"/>
        <geom type="capsule" size="0.02 0.05" pos="0.05 0 0" euler="0 80 10"/></body>
    </body></body></worldbody>
  <tendon>
    <fixed name="sum" stiffness="4" springlength="0.1 0.3" range="-0.3 0.4">
      <joint joint="shoulder" coef="1"/><joint joint="elbow" coef="-0.5"/></fixed>
    <fixed name="plain"><joint joint="slider" coef="2"/></fixed>
  </tendon>
  <sensor>
    <tendonpos tendon="sum"/><tendonvel tendon="sum"/><tendonpos tendon="plain"/>
    <tendonvel tendon="plain" cutoff="0.1"/>
    <tendonlimitpos tendon="sum"/><tendonlimitvel tendon="sum"/><tendonlimitfrc tendon="sum"/>
    <subtreeangmom body="upper"/><subtreeangmom body="lower"/><subtreeangmom body="ball_link"/>
    <e_potential/><e_kinetic/><e_kinetic cutoff="0.01"/><e_potential cutoff="0.5"/>
  </sensor></mujoco>"""


def test_tendon_momentum_and_energy_sensors_match_mujoco_forward(tmp_path):
    """Fixed tendons (a spring with a deadband, a limit entered or not), subtree angular momenta
    and the energies (gravity, joint and tendon springs; armature in the kinetic), cutoffs."""
    path = tmp_path / "tendons.xml"
    path.write_text(TENDONS)
    rng = np.random.default_rng(3)
    qpos0 = np.array([0, 0, 0, 1, 0, 0, 0])
    states = [(qpos0 + 0.4 * rng.standard_normal(7), rng.standard_normal(6), rng.standard_normal(6))
              for _ in range(6)]
    theirs = assert_sensors_match(path, states)
    assert (theirs[:, 6] != 0).sum() >= 2 and (theirs[:, 6] == 0).sum() >= 2  # limit in and out
    assert (theirs[:, 3] == 0.1).any() and (theirs[:, -2] == 0.01).all()  # cutoffs clip


RAYS = """<mujoco>
  <asset><material name="clear" rgba="1 1 1 0"/><material name="red" rgba="1 0 0 1"/></asset>
  <worldbody>
    <geom type="plane" size="3 2 0.1"/>
    <geom pos="1 0 0.5" size="0.2"/>
    <geom type="capsule" pos="-1 0 0.5" size="0.1 0.3" euler="30 40 0"/>
    <geom type="cylinder" pos="0 1 0.5" size="0.2 0.1" euler="10 70 0" material="red"/>
    <geom type="box" pos="0 -1 0.5" size="0.2 0.1 0.3" euler="0 20 50"/>
    <geom type="ellipsoid" pos="1 1 0.7" size="0.2 0.3 0.1" euler="0 20 50"/>
    <geom pos="0.5 0.5 0.5" size="0.3" rgba="1 1 1 0"/>
    <geom pos="-0.5 0.5 0.5" size="0.3" material="clear"/>
    <body name="box" pos="0 0 0.1"><freejoint/><geom type="box" size="0.1 0.1 0.1"/>
      <site name="bottom" type="box" pos="0 0 -0.1" size="0.12 0.12 0.03"/>
      <site name="half" type="box" pos="0.05 0 -0.1" size="0.06 0.12 0.03"/>
      <site name="top" pos="0 0 0.1" size="0.05"/>
      <site name="corner" type="capsule" pos="0.1 0.1 -0.1" size="0.02 0.05"/>
      <site name="eye" pos="0 0 0.1"/></body>
    <body name="scanner" pos="0 0 1.5">
      <joint axis="0 0 1"/><joint axis="0 1 0"/><joint axis="1 0 0"/><geom size="0.05"/>
      <site name="s0" euler="180 0 0"/><site name="s1" euler="150 30 0"/>
      <site name="s2" euler="120 -20 10"/><site name="s3" euler="100 60 -40"/>
      <site name="s4" euler="90 0 0"/></body>
  </worldbody>
  <sensor>
    <touch site="bottom"/><touch site="half"/><touch site="top"/><touch site="corner" cutoff="1"/>
    <rangefinder site="eye"/>
    <rangefinder site="s0" data="dist dir origin point normal depth"/>
    <rangefinder site="s1" data="dist dir origin point normal depth"/>
    <rangefinder site="s2" data="dist point normal"/>
    <rangefinder site="s3" data="dist origin normal depth" cutoff="1.2"/>
    <rangefinder site="s4" data="dist normal"/>
  </sensor></mujoco>"""


def test_touch_and_rangefinders_match_mujoco_forward(tmp_path):
    """A box resting on a plane under touch zones (all, half or none of its contacts), and
    rangefinders on a turning body that hit or miss a finite plane, each primitive, invisible geoms
    (rgba and material alpha 0) seen through, every data field, a cutoff."""
    path = tmp_path / "rays.xml"
    path.write_text(RAYS)
    mm = mujoco.MjModel.from_xml_path(str(path))
    rng = np.random.default_rng(5)
    states, hit = [], set()
    for _ in range(200):
        quat = np.array([1.0, *(0.05 * rng.standard_normal(3))])
        q = np.concatenate([0.1 * rng.standard_normal(2), [0.098 + 0.01 * rng.standard_normal()],
                            quat / np.linalg.norm(quat), rng.uniform(-np.pi, np.pi, 3)])
        states.append((q, rng.standard_normal(mm.nv), rng.standard_normal(mm.nv)))
        d = mujoco.MjData(mm)
        d.qpos[:] = q
        mujoco.mj_forward(mm, d)
        for s in range(5, 10):
            geom = np.array([-1], dtype=np.int32)
            z = d.site_xmat[s].reshape(3, 3)[:, 2]
            mujoco.mj_ray(mm, d, d.site_xpos[s], z, None, 1, mm.site_bodyid[s], geom, None)
            hit.add(int(geom[0]))
    assert hit >= {-1, 0, 1, 2, 3, 4, 5}  # misses, the plane and every primitive
    theirs = assert_sensors_match(path, states)
    touch = theirs[:, :4]
    assert (touch[:, 0] > touch[:, 1]).any() and (touch[:, 1] > 0).any() and (touch[:, 2] == 0).all()


BLOB = [(-0.239632, -0.195351, 0.009913), (-0.289095, -0.192839, 0.213391), (-0.266109, 0.197434, 0.010937),
        (-0.241176, 0.180853, 0.216401), (0.327906, -0.224887, -0.014464), (0.367965, -0.218808, 0.191226),
        (0.326543, 0.172284, 0.000244), (0.341732, 0.218822, 0.230202)]
BLOB_FACES = [(0, 1, 3), (0, 3, 2), (4, 6, 7), (4, 7, 5), (0, 4, 5), (0, 5, 1), (2, 3, 7), (2, 7, 6),
              (0, 2, 6), (0, 6, 4), (1, 5, 7), (1, 7, 3)]
FITTED = """<mujoco><compiler fitaabb="{aabb}"/><asset><mesh name="blob" file="blob.obj"/></asset>
  <worldbody>
    <body name="b0" pos="0 0 1"><joint/><geom name="g0" type="sphere" mesh="blob"/></body>
    <body name="b1" pos="1 0 1"><joint/><geom name="g1" type="capsule" mesh="blob" euler="10 20 30"/></body>
    <body name="b2" pos="2 0 1"><joint/><geom name="g2" type="cylinder" mesh="blob" pos="0.1 0 0"/></body>
    <body name="b3" pos="3 0 1"><joint/><geom name="g3" type="ellipsoid" mesh="blob" fitscale="1.3"/></body>
    <body name="b4" pos="4 0 1"><joint/><geom name="g4" type="box" mesh="blob"/></body>
    <body name="b5" pos="5 0 1"><joint/><geom name="g5" type="mesh" mesh="blob"/></body>
    <body name="eyes" pos="0 -2 1"><joint axis="1 0 0"/><geom size="0.01"/>
      {sites}</body>
  </worldbody>
  <sensor>{sensors}</sensor></mujoco>"""


@pytest.mark.parametrize("aabb", ["false", "true"])
def test_primitives_fitted_to_a_mesh_are_mujocos(tmp_path, aabb):
    """Sphere, capsule, cylinder, ellipsoid (fitscale) and box fitted to an irregular mesh, to its
    inertia box or (fitaabb) its bounding box: each body's mass and inertia (so the sizes), each
    geom's pose (framepos, framexaxis, framezaxis) and rays from the side onto each (its extent) as MuJoCo's;
    also rays onto the mesh itself (its triangles)."""
    (tmp_path / "blob.obj").write_text("".join(f"v {x} {y} {z}\n" for x, y, z in BLOB) +
                                       "".join(f"f {a + 1} {b + 1} {c + 1}\n" for a, b, c in BLOB_FACES))
    sites = "".join(f'<site name="e{i}{k}" pos="{i} 0 {0.1 * k}" euler="-90 0 0"/>'
                    for i in range(6) for k in range(-3, 4))
    # The axes, not framequat: a mesh frame's quaternion keeps the sign MuJoCo's eigensolver gave it.
    sensors = "".join(f'<framepos objtype="geom" objname="g{i}"/><framexaxis objtype="geom" objname="g{i}"/>'
                      f'<framezaxis objtype="geom" objname="g{i}"/>' for i in range(5))
    sensors += "".join(f'<rangefinder site="e{i}{k}" data="dist normal"/>'
                       for i in range(6) for k in range(-3, 4))
    path = tmp_path / "fitted.xml"
    path.write_text(FITTED.format(aabb=aabb, sites=sites, sensors=sensors))
    m, mm = diffosi.Model.load(str(path)), mujoco.MjModel.from_xml_path(str(path))
    for ours, mass, inertia in zip(m.compiled()["bodies"][1:], mm.body_mass[1:], mm.body_inertia[1:]):
        assert abs(ours["mass"] - mass) <= 1e-12 * mass
        moments = np.linalg.eigvalsh(ours["inertia"])
        np.testing.assert_allclose(moments, np.sort(inertia), rtol=1e-10)
    # 1e-11: the mesh frame's principal axes are our eigensolver's, MuJoCo's to about 5e-12.
    zero = (np.zeros(mm.nq), np.zeros(mm.nv), np.zeros(mm.nv))
    theirs = assert_sensors_match(path, [zero], tol=1e-11)
    assert (theirs[0, 45::4].reshape(6, 7) > 0).any(axis=1).all()  # each geom is hit


INSIDE = """<mujoco><compiler autolimits="true"/><worldbody>
  <site name="ball" type="sphere" pos="0.3 0 1" size="0.25"/>
  <site name="pill" type="capsule" pos="0 0.3 1" euler="30 60 0" size="0.1 0.2"/>
  <site name="egg" type="ellipsoid" pos="-0.3 0 1" euler="10 -20 40" size="0.3 0.15 0.2"/>
  <site name="can" type="cylinder" pos="0 -0.3 1" euler="-40 20 0" size="0.2 0.15"/>
  <site name="crate" type="box" pos="0 0 1.3" euler="0 30 70" size="0.25 0.1 0.2"/>
  <body name="arm" pos="0 0 1"><joint name="yaw" axis="0 0 1"/><joint name="pitch" axis="0 1 0"/>
    <geom name="rod" type="capsule" fromto="0 0 0 0.3 0 0" size="0.02"/>
    <body name="tip" pos="0.3 0 0"><joint name="reach" type="slide" axis="1 0 0" range="-0.2 0.2"/>
      <geom name="knob" size="0.03" pos="0 0.05 0"/><site name="probe" pos="0.02 0 0.04"/>
      <body name="ghost" pos="0 0 0.1"><body name="weight" pos="0.05 0 0">
        <geom size="0.01" mass="0.1"/></body></body></body></body>
</worldbody>
<tendon><fixed name="t"><joint joint="yaw" coef="1"/><joint joint="reach" coef="-0.5"/></fixed>
  <fixed name="idle"><joint joint="pitch" coef="1"/></fixed></tendon>
<actuator><motor name="m1" tendon="t" gear="2"/><position name="p" tendon="t" kp="3" kv="0.5"/>
  <motor joint="pitch"/><velocity tendon="idle" kv="2" forcerange="-0.4 0.4"/></actuator>
<sensor>{sensors}
  <tendonactuatorfrc tendon="t"/><tendonactuatorfrc tendon="idle" cutoff="0.3"/>
</sensor></mujoco>"""


def test_insidesite_and_tendon_actuator_force_match_mujoco_forward(tmp_path):
    """insidesite on every site shape, for a body (its COM; a massless body with a heavy child:
    its subtree's COM), an xbody, a geom and a site; tendonactuatorfrc summing two actuators on
    a tendon, a clamped one, a cutoff, under random ctrl."""
    objects = [("body", "tip"), ("xbody", "tip"), ("geom", "knob"), ("site", "probe"),
               ("body", "ghost"), ("geom", "rod")]
    sites = ["ball", "pill", "egg", "can", "crate"]
    sensors = "".join(f'<insidesite site="{s}" objtype="{t}" objname="{n}"/>' for s in sites for t, n in objects)
    path = tmp_path / "inside.xml"
    path.write_text(INSIDE.format(sensors=sensors))
    m, mm = diffosi.Model.load(str(path)), mujoco.MjModel.from_xml_path(str(path))
    assert list(m.sensor_dim) == mm.sensor_dim.tolist()
    rng = np.random.default_rng(13)
    readings = []
    for _ in range(300):
        q = np.array([rng.uniform(-np.pi, np.pi), rng.uniform(-1.2, 1.2), rng.uniform(-0.2, 0.2)])
        v, tau = rng.standard_normal(3), rng.standard_normal(3)
        ctrl, act = rng.standard_normal(mm.nu), np.zeros(0)
        ours = m.sensors(q, v, tau, ctrl=ctrl, act=act)
        theirs = mujoco_sensordata(mm, q, v, tau, ctrl, act)
        np.testing.assert_array_less(np.abs(ours - theirs) / np.maximum(1, np.abs(theirs)), 1e-12)
        readings.append(theirs)
    readings = np.array(readings)
    inside = readings[:, :-2]
    assert ((inside == 0) | (inside == 1)).all()
    assert (inside.mean(axis=0) > 0).sum() >= 20  # most (site, object) pairs are met
    assert (np.abs(readings[:, -2]) > 1).any() and (np.abs(readings[:, -1]) == 0.3).any()
