"""MuJoCo's implicitfast and implicit integrators, and gravcomp, against MuJoCo itself.

One step of each model from a random moving state under random applied forces
agrees with mj_step to 1e-12 (a damped hinge-and-slide chain, a lone free
body whose gyroscopic block implicitfast treats implicitly, a free body with
a child, a free box and a pendulum on a floor, gravcomp on a ball chain), and
the exact step Jacobians (tangent space, mjd_transitionFD's layout) agree with
mjd_transitionFD's centered differences, contacts included; in a fluid with
wind too (the fluid forces' velocity derivative in qDeriv).
"""

import mujoco
import numpy as np
import pytest

import diffosi

OFF = 'contype="0" conaffinity="0"'
CHAIN = f"""
<body pos="0 0 1"><joint type="hinge" axis="0 1 0" damping="0.7"/>
  <geom type="capsule" fromto="0 0 0 0.3 0 0.1" size="0.05" {OFF}/>
  <body pos="0.3 0 0.1"><joint type="hinge" axis="1 0.3 0" damping="1.3"/>
    <geom type="box" size="0.1 0.05 0.2" pos="0.1 0 0" {OFF}/>
    <body pos="0.2 0 0"><joint type="slide" axis="0 0.6 0.8" damping="0.4" stiffness="3"/>
      <geom type="sphere" size="0.07" {OFF}/></body></body></body>"""
FREE = f"""
<body pos="0 0 1"><joint type="free" damping="0.2"/>
  <geom type="box" size=".1 .2 .3" pos="0.05 0.02 0" {OFF}/></body>"""
FREE_CHILD = f"""
<body pos="0 0 1"><freejoint/><geom type="box" size=".1 .2 .3" {OFF}/>
  <body pos="0.2 0 0"><joint type="hinge" axis="0 0 1" damping="0.3"/>
    <geom type="sphere" size="0.1" {OFF}/></body></body>"""
CONTACT = """
<geom type="plane" size="5 5 0.1"/>
<body pos="0 0 0.09"><freejoint/><geom type="box" size=".1 .2 .1"/></body>
<body pos="0.5 0 0.29"><joint type="hinge" axis="0 1 0" damping="0.5"/>
  <geom type="capsule" fromto="0 0 0 0.3 0 -0.25" size="0.05"/></body>"""
GRAVCOMP = f"""
<body pos="0 0 1" gravcomp="0.7"><joint type="hinge" axis="0 1 0" damping="0.2"/>
  <geom type="capsule" fromto="0 0 0 0.3 0 0.1" size="0.05" {OFF}/>
  <body pos="0.3 0 0.1" gravcomp="1"><joint type="ball" damping="0.1"/>
    <geom type="box" size="0.1 0.05 0.2" pos="0.1 0 0" {OFF}/></body></body>"""
MODELS = {"chain": CHAIN, "free": FREE, "free_child": FREE_CHILD, "contact": CONTACT,
          "gravcomp": GRAVCOMP}
# MuJoCo's converged constraint solve (see notes/reference-engines.md).
SOLVER = 'tolerance="1e-15" ls_tolerance="1e-12" iterations="1000"'


def models(tmp_path, name, integrator):
    xml = (f'<mujoco><option integrator="{integrator}" timestep="0.01" {SOLVER}/>'
           f"<worldbody>{MODELS[name]}</worldbody></mujoco>")
    path = tmp_path / f"{name}_{integrator}.xml"
    path.write_text(xml)
    return mujoco.MjModel.from_xml_path(str(path)), diffosi.Model.load(str(path))


def state(m, name, seed):
    rng = np.random.default_rng([seed, len(name)])
    q = m.qpos0.copy()
    scale = 0.1 if name == "contact" else 1.0  # the contact model stays on its floor
    if name != "contact":
        mujoco.mj_integratePos(m, q, rng.uniform(-0.5, 0.5, m.nv), 1.0)
    return q, scale * rng.normal(size=m.nv) * 2, rng.normal(size=m.nv)


@pytest.mark.parametrize("integrator", ["implicitfast", "implicit"])
@pytest.mark.parametrize("name", list(MODELS))
def test_one_step_matches_mj_step(tmp_path, name, integrator):
    m, ours = models(tmp_path, name, integrator)
    assert ours.integrator == integrator
    d = mujoco.MjData(m)
    for seed in range(3):
        q, v, tau = state(m, name, seed)
        d.qpos[:], d.qvel[:], d.qfrc_applied[:] = q, v, tau
        mujoco.mj_step(m, d)
        if name == "contact":
            assert d.ncon > 0
        q1, v1 = ours.step(q, v, tau)
        np.testing.assert_allclose(q1, d.qpos, rtol=0, atol=1e-12)
        np.testing.assert_allclose(v1, d.qvel, rtol=0, atol=1e-12)


def test_implicit_differs_from_euler_where_mujoco_says(tmp_path):
    """The free body's gyroscopic term moves implicitfast off Euler (MuJoCo 4),
    and the chain's Coriolis term moves implicit off implicitfast: the
    comparisons above are not Euler's in disguise."""
    stepped = {}
    for integrator in ["Euler", "implicitfast", "implicit"]:
        for name in ["free", "chain"]:
            m, ours = models(tmp_path, name, integrator)
            q, v, tau = state(m, name, 0)
            stepped[name, integrator] = ours.step(q, v, tau)[1]
    assert np.abs(stepped["free", "implicitfast"] - stepped["free", "Euler"]).max() > 1e-6
    assert np.abs(stepped["chain", "implicit"] - stepped["chain", "implicitfast"]).max() > 1e-6


@pytest.mark.parametrize("integrator", ["implicitfast", "implicit"])
@pytest.mark.parametrize("name", list(MODELS))
def test_jacobians_match_mjd_transition_fd(tmp_path, name, integrator):
    m, ours = models(tmp_path, name, integrator)
    q, v, tau = state(m, name, 1)
    assert_state_jacobian_matches(m, ours, (q, v, tau), f"{name} {integrator}")


def assert_state_jacobian_matches(m, ours, x, label):
    """Our A at x = (q, v, tau) against mjd_transitionFD's centered differences."""
    d = mujoco.MjData(m)
    d.qpos[:], d.qvel[:], d.qfrc_applied[:] = x
    mujoco.mj_forward(m, d)
    A = np.zeros((2 * m.nv, 2 * m.nv))
    mujoco.mjd_transitionFD(m, d, 1e-6, True, A, None, None, None)
    a, _ = ours.transition_jacobians(*x)
    err = np.abs(a - A).max() / max(1.0, np.abs(A).max())
    assert err < 1e-6, f"{label}: {err:.1e}"


FLUID = 'density="1.2" viscosity="0.02" wind="0.5 -0.3 0.2"'


@pytest.mark.parametrize("integrator", ["implicitfast", "implicit"])
@pytest.mark.parametrize("name", ["chain", "free", "free_child"])
def test_fluid_forces_velocity_derivative_in_qderiv(tmp_path, name, integrator):
    """In a fluid (MuJoCo's inertia-box model, with wind) the step and its Jacobians
    match mj_step and mjd_transitionFD: the fluid forces' J^T B J joins qDeriv."""
    xml = (f'<mujoco><option integrator="{integrator}" timestep="0.01" {FLUID} {SOLVER}/>'
           f"<worldbody>{MODELS[name]}</worldbody></mujoco>")
    path = tmp_path / f"fluid_{name}_{integrator}.xml"
    path.write_text(xml)
    m, ours = mujoco.MjModel.from_xml_path(str(path)), diffosi.Model.load(str(path))
    euler = ours.with_options(integrator="Euler")
    d = mujoco.MjData(m)
    for seed in range(3):
        q, v, tau = state(m, name, seed)
        v = 3 * v  # fast enough for the quadratic drag to matter
        d.qpos[:], d.qvel[:], d.qfrc_applied[:] = q, v, tau
        mujoco.mj_step(m, d)
        q1, v1 = ours.step(q, v, tau)
        np.testing.assert_allclose(q1, d.qpos, rtol=0, atol=1e-12)
        np.testing.assert_allclose(v1, d.qvel, rtol=0, atol=1e-12)
        assert np.abs(euler.step(q, v, tau)[1] - v1).max() > 1e-6
    assert_state_jacobian_matches(m, ours, (q, v, tau), f"{name} {integrator}")


@pytest.mark.parametrize("integrator", ["Euler", "RK4"])
def test_gravcomp_under_the_explicit_integrators(tmp_path, integrator):
    m, ours = models(tmp_path, "gravcomp", integrator)
    d = mujoco.MjData(m)
    q, v, tau = state(m, "gravcomp", 2)
    d.qpos[:], d.qvel[:], d.qfrc_applied[:] = q, v, tau
    mujoco.mj_forward(m, d)
    assert np.abs(d.qfrc_gravcomp).max() > 1.0  # the compensation acts
    mujoco.mj_step(m, d)
    q1, v1 = ours.step(q, v, tau)
    np.testing.assert_allclose(q1, d.qpos, rtol=0, atol=1e-12)
    np.testing.assert_allclose(v1, d.qvel, rtol=0, atol=1e-12)


SERVOS = f"""
<worldbody>
<body pos="0 0 1"><joint name="a" type="hinge" axis="0 1 0" damping="0.3"/>
  <geom type="capsule" fromto="0 0 0 0.3 0 0.1" size="0.05" {OFF}/>
  <body pos="0.3 0 0.1"><joint name="b" type="slide" axis="1 0 0"/>
    <geom type="box" size="0.1 0.05 0.2" {OFF}/></body></body>
</worldbody>
<actuator>
  <position joint="a" kp="40" kv="3" gear="1.5"/>
  <velocity joint="b" kv="7" forcerange="-2 2"/>
  <general joint="a" gaintype="affine" gainprm="2 0 -0.5" biastype="affine" biasprm="0 0 -1"/>
</actuator>"""


@pytest.mark.parametrize("integrator", ["implicitfast", "implicit"])
def test_servos_velocity_slopes_are_implicit(tmp_path, integrator):
    """The actuators' d(force)/dv (kv, an affine gain's and bias's velocity
    terms; zero where the force range clamps) joins qDeriv under the implicit
    integrators, as in MuJoCo: one step and A, B against mj_step and
    mjd_transitionFD."""
    path = tmp_path / f"servos_{integrator}.xml"
    path.write_text(f'<mujoco><option integrator="{integrator}" timestep="0.01"/>{SERVOS}</mujoco>')
    m, ours = mujoco.MjModel.from_xml_path(str(path)), diffosi.Model.load(str(path))
    d = mujoco.MjData(m)
    rng = np.random.default_rng(7)
    for _ in range(4):
        q, v = rng.normal(size=m.nq), 3 * rng.normal(size=m.nv)
        tau, ctrl = rng.normal(size=m.nv), rng.normal(size=m.nu)
        d.qpos[:], d.qvel[:], d.qfrc_applied[:], d.ctrl[:] = q, v, tau, ctrl
        mujoco.mj_forward(m, d)
        A = np.zeros((2 * m.nv, 2 * m.nv))
        B = np.zeros((2 * m.nv, m.nu))
        mujoco.mjd_transitionFD(m, d, 1e-6, True, A, B, None, None)
        mujoco.mj_step(m, d)
        q1, v1 = ours.step(q, v, tau, ctrl=ctrl)
        np.testing.assert_allclose(q1, d.qpos, rtol=0, atol=1e-12)
        np.testing.assert_allclose(v1, d.qvel, rtol=0, atol=1e-12)
        J = ours.step_jacobians(q, v, tau, ctrl=ctrl)
        a = np.block([[J["dq_dq"], J["dq_dv"]], [J["dv_dq"], J["dv_dv"]]])
        b = np.vstack([J["dq_dctrl"], J["dv_dctrl"]])
        for ours_, theirs in [(a, A), (b, B)]:
            err = np.abs(ours_ - theirs).max() / max(1.0, np.abs(theirs).max())
            assert err < 1e-6, f"{integrator}: {err:.1e}"
