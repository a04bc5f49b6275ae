"""MuJoCo's ellipsoid fluid model (geom fluidshape="ellipsoid", fluidcoef) against MuJoCo itself.

Bodies of every primitive shape under the ellipsoid model (default and custom coefficients, a
body with two such geoms and one without, a body beside them left to the inertia-box model) in
a medium with wind: one step and a trajectory under Euler and RK4 agree with mj_step, the
sensors with mj_forward's sensordata, and the step Jacobians (dual numbers) with
mjd_transitionFD. The implicit integrators are refused for it, and so are planes.
"""

import mujoco
import numpy as np
import pytest

import diffosi

OFF = 'contype="0" conaffinity="0"'
ELL = 'fluidshape="ellipsoid"'
BODIES = f"""
<body name="chain" pos="0 0 1"><joint type="hinge" axis="0 1 0" damping="0.3"/>
  <geom type="capsule" fromto="0 0 0 0.3 0 0.1" size="0.05" {OFF} {ELL}/>
  <body pos="0.3 0 0.1"><joint type="hinge" axis="1 0.3 0"/>
    <geom type="box" size="0.1 0.05 0.2" pos="0.1 0 0" euler="10 20 30" {OFF} {ELL}
          fluidcoef="0.3 0.4 1.1 0.7 1.3"/>
    <geom type="sphere" size="0.06" pos="-0.1 0 0" {OFF}/>
    <body pos="0.2 0 0"><joint type="slide" axis="0 0.6 0.8" damping="0.4"/>
      <geom type="cylinder" size="0.07 0.03" {OFF} {ELL}/></body></body></body>
<body name="free" pos="1 0 1"><freejoint/><site name="tip" pos="0.1 0 0"/>
  <geom type="ellipsoid" size="0.2 0.1 0.05" pos="0.05 0.02 0" euler="40 0 -20" {OFF} {ELL}/>
  <geom type="sphere" size="0.08" pos="-0.1 0 0.05" {OFF} {ELL} fluidcoef="1 0 2 0 0.5"/>
  <body pos="0.2 0 0"><joint type="hinge" axis="0 0 1"/><geom type="box" size="0.1 0.05 0.02" {OFF}/></body>
</body>"""
SENSORS = """<sensor><accelerometer site="tip"/><framelinacc objtype="body" objname="free"/>
  <frameangacc objtype="body" objname="free"/></sensor>"""


def model_file(tmp_path, integrator="Euler", fluid='density="1.2" viscosity="0.02" wind="0.5 -0.3 0.2"'):
    xml = (f'<mujoco><option integrator="{integrator}" timestep="0.005" {fluid}/><worldbody>'
           f"{BODIES}</worldbody>{SENSORS}</mujoco>")
    path = tmp_path / f"ellipsoid_{integrator}.xml"
    path.write_text(xml)
    return path


def random_state(m, seed):
    rng = np.random.default_rng(seed)
    q = m.qpos0.copy()
    mujoco.mj_integratePos(m, q, rng.uniform(-0.5, 0.5, m.nv), 1.0)
    return q, 3 * rng.normal(size=m.nv), rng.normal(size=m.nv)


@pytest.mark.parametrize("integrator", ["Euler", "RK4"])
def test_steps_and_trajectory_match_mj_step(tmp_path, integrator):
    path = model_file(tmp_path, integrator)
    m, ours = mujoco.MjModel.from_xml_path(str(path)), diffosi.Model.load(str(path))
    # Every geom but the plain sphere and box carries the model (MuJoCo's geom_fluid[0]).
    assert (m.geom_fluid[:, 0] > 0).sum() == 5
    still = ours.with_options(density=0.0, viscosity=0.0)
    d = mujoco.MjData(m)
    for seed in range(3):
        q, v, tau = random_state(m, seed)
        d.qpos[:], d.qvel[:], d.qfrc_applied[:] = q, v, tau
        mujoco.mj_forward(m, d)
        assert np.abs(d.qfrc_fluid).max() > 0.1  # the medium acts
        mujoco.mj_step(m, d)
        q1, v1 = ours.step(q, v, tau)
        np.testing.assert_allclose(q1, d.qpos, rtol=0, atol=1e-12)
        np.testing.assert_allclose(v1, d.qvel, rtol=0, atol=1e-12)
        assert np.abs(still.step(q, v, tau)[1] - v1).max() > 1e-4
    # 2.5 s from a slower start, unforced (the light hinged box spins up under a constant tau).
    q, v, _ = random_state(m, 7)
    v, tau = v / 3, np.zeros(m.nv)
    d.qpos[:], d.qvel[:], d.qfrc_applied[:] = q, v, tau
    for _ in range(500):
        mujoco.mj_step(m, d)
        q, v = ours.step(q, v, tau)
    err = max(np.abs(q - d.qpos).max(), np.abs(v - d.qvel).max())
    assert err < 1e-10 and np.abs(v).max() > 5, err


def test_sensors_read_the_fluid_forces(tmp_path):
    path = model_file(tmp_path)
    m, ours = mujoco.MjModel.from_xml_path(str(path)), diffosi.Model.load(str(path))
    d = mujoco.MjData(m)
    for seed in range(3):
        q, v, tau = random_state(m, seed)
        d.qpos[:], d.qvel[:], d.qfrc_applied[:] = q, v, tau
        mujoco.mj_forward(m, d)
        theirs = d.sensordata.copy()
        np.testing.assert_array_less(np.abs(ours.sensors(q, v, tau) - theirs), 1e-10 * np.maximum(1, np.abs(theirs)))


def mj_step_jacobian(m, x, eps=1e-6):
    """A (mjd_transitionFD's layout: tangent-space q, then v) by centered differences of mj_step."""
    q, v, tau = x
    d = mujoco.MjData(m)

    def step(dx):
        d.qpos[:] = q
        mujoco.mj_integratePos(m, d.qpos, dx[:m.nv], 1.0)
        d.qvel[:], d.qfrc_applied[:] = v + dx[m.nv:], tau
        mujoco.mj_step(m, d)
        return d.qpos.copy(), d.qvel.copy()

    A = np.zeros((2 * m.nv, 2 * m.nv))
    for i in range(2 * m.nv):
        dx = np.zeros(2 * m.nv)
        dx[i] = eps
        (qp, vp), (qm, vm) = step(dx), step(-dx)
        dq = np.zeros(m.nv)
        mujoco.mj_differentiatePos(m, dq, 2 * eps, qm, qp)
        A[:, i] = np.concatenate([dq, (vp - vm) / (2 * eps)])
    return A


@pytest.mark.parametrize("integrator", ["Euler", "RK4"])
def test_jacobians_match_mujocos_differences(tmp_path, integrator):
    """The exact step Jacobians (dual numbers through the generic model) against centered
    differences of mj_step (mjd_transitionFD's under Euler; it has no RK4)."""
    path = model_file(tmp_path, integrator)
    m, ours = mujoco.MjModel.from_xml_path(str(path)), diffosi.Model.load(str(path))
    for seed in range(2):
        x = random_state(m, seed)
        if integrator == "Euler":
            d = mujoco.MjData(m)
            d.qpos[:], d.qvel[:], d.qfrc_applied[:] = x
            mujoco.mj_forward(m, d)
            A = np.zeros((2 * m.nv, 2 * m.nv))
            mujoco.mjd_transitionFD(m, d, 1e-6, True, A, None, None, None)
        else:
            A = mj_step_jacobian(m, x)
        a, _ = ours.transition_jacobians(*x)
        err = np.abs(a - A).max() / max(1.0, np.abs(A).max())
        assert err < 1e-6, f"{integrator}: {err:.1e}"


def test_still_fluid_and_refusals(tmp_path):
    """At rest with no wind the model exerts nothing; the implicit integrators and planes are refused."""
    path = model_file(tmp_path, fluid='density="1.2" viscosity="0.02"')
    ours, m = diffosi.Model.load(str(path)), mujoco.MjModel.from_xml_path(str(path))
    q, v = m.qpos0.copy(), np.zeros(m.nv)
    free = ours.with_options(density=0.0, viscosity=0.0)
    np.testing.assert_array_equal(ours.step(q, v, v)[1], free.step(q, v, v)[1])
    for integrator in ["implicitfast", "implicit"]:
        with pytest.raises(ValueError, match="ellipsoid fluid model.*implicit"):
            diffosi.Model.load(str(model_file(tmp_path, integrator)))
    plane = tmp_path / "plane.xml"
    plane.write_text(f'<mujoco><worldbody><geom type="plane" size="1 1 1" {ELL}/></worldbody></mujoco>')
    with pytest.raises(ValueError, match=r"plane.xml:1: <geom>: the ellipsoid fluid model \(fluidshape\) on a plane"):
        diffosi.Model.load(str(plane))
