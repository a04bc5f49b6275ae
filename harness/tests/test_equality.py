"""Equality constraints (connect, weld, joint) against MuJoCo itself.

The models in tests/data/equality_*.xml, run with MuJoCo's converged solver
(notes/reference-engines.md): one step from random moving states under
random applied forces agrees with mj_step to 1e-10 (contact-free) and 1e-9
(the gripper in contact); a 200-step rollout stays on MuJoCo's; the exact
step Jacobians (dual numbers through the equality rows) agree with
mjd_transitionFD's centred differences. Covered: a four-bar linkage closed
by a body connect, welds by body (pose at qpos0; an explicit relpose with
torquescale) and by sites, a site connect on a ball pendulum and a free
body, joint couplings (cubic, single joint, slide on hinge, direct solref),
a gripper whose fingers a joint equality couples closing on a box, and the
`active` attribute and `equality` flag.
"""

import pathlib
import re

import mujoco
import numpy as np
import pytest

import diffosi
from harness.gradcheck_free import a_error

DATA = pathlib.Path(__file__).resolve().parents[2] / "tests" / "data"
SOLVER = 'tolerance="1e-15" ls_tolerance="1e-12" iterations="1000"'
# name: (file, edit of its text, one-step tolerance)
MODELS = {
    "fourbar": ("equality_fourbar.xml", None, 1e-10),
    "welds": ("equality_weld.xml", None, 1e-10),
    "welds_relpose": ("equality_weld.xml", ('active="false"', ""), 1e-10),
    "joints": ("equality_joint.xml", None, 1e-10),
    "gripper": ("equality_gripper.xml", None, 1e-9),
}


def models(tmp_path, name, extra=""):
    file, edit, _ = MODELS[name]
    text = (DATA / file).read_text()
    if edit:
        text = text.replace(*edit)
    text = re.sub(r"<option ", f"<option {SOLVER} ", text, count=1)
    text = text.replace("</mujoco>", f"<option>{extra}</option></mujoco>")
    path = tmp_path / f"{name}.xml"
    path.write_text(text)
    return mujoco.MjModel.from_xml_path(str(path)), diffosi.Model.load(str(path))


def state(m, seed, name):
    rng = np.random.default_rng([seed, len(name)])
    q = m.qpos0.copy()
    if name == "gripper":  # the fingers closed on the box by their servo, then let go
        d = mujoco.MjData(m)
        d.ctrl[:] = 0.05
        for _ in range(150 + 10 * seed):
            mujoco.mj_step(m, d)
        return d.qpos.copy(), d.qvel.copy(), rng.normal(size=m.nv) * 0.1
    mujoco.mj_integratePos(m, q, rng.uniform(-0.2, 0.2, m.nv), 1.0)
    return q, rng.normal(size=m.nv), rng.normal(size=m.nv)


@pytest.mark.parametrize("name", list(MODELS))
def test_one_step_matches_mj_step(tmp_path, name):
    m, ours = models(tmp_path, name)
    d = mujoco.MjData(m)
    for seed in range(3):
        q, v, tau = state(m, seed, name)
        d.qpos[:], d.qvel[:], d.qfrc_applied[:] = q, v, tau
        mujoco.mj_step(m, d)
        assert d.ne > 0  # the equality rows act
        q1, v1 = ours.step(q, v, tau)
        tol = MODELS[name][2]
        np.testing.assert_allclose(q1, d.qpos, rtol=0, atol=tol)
        np.testing.assert_allclose(v1, d.qvel, rtol=0, atol=tol)


@pytest.mark.parametrize("name", list(MODELS))
def test_rollout_matches_mj_step(tmp_path, name):
    """200 steps from qpos0 under random forces (the gripper: on its fingers
    alone, its servo closing them on the box, which they then hold)."""
    m, ours = models(tmp_path, name)
    d = mujoco.MjData(m)
    rng = np.random.default_rng(5)
    steps = 200
    taus = 0.3 * rng.normal(size=(steps, m.nv))
    if name == "gripper":
        taus[:, :6] = 0.0  # the box's free joint
    ctrl = np.full((steps, m.nu), 0.05)
    q, v = d.qpos.copy(), d.qvel.copy()
    worst = 0.0
    for t in range(steps):
        d.qfrc_applied[:], d.ctrl[:] = taus[t], ctrl[t]
        mujoco.mj_step(m, d)
        if m.nu:
            q, v = ours.step(q, v, taus[t], ctrl=ctrl[t])
        else:
            q, v = ours.step(q, v, taus[t])
        worst = max(worst, np.abs(q - d.qpos).max(), np.abs(v - d.qvel).max())
    assert worst < 1e-9, f"{name}: {worst:.1e}"
    if name == "gripper":  # the box on the floor and in both fingers at the end
        geoms = {tuple(sorted((c.geom1, c.geom2))) for c in d.contact[:d.ncon]}
        assert {(0, 1), (1, 3), (1, 4)} <= geoms, geoms


@pytest.mark.parametrize("name", list(MODELS))
def test_jacobians_match_mjd_transition_fd(tmp_path, name):
    m, ours = models(tmp_path, name)
    err = a_error(m, ours, *state(m, 1, name))
    assert err < 1e-6, f"{name}: {err:.1e}"


def test_inactive_and_disabled_equalities_do_nothing(tmp_path):
    """active="false" leaves an equality out (the weld file's 'posed' weld: its
    step differs from the active copy's), and <flag equality="disable"/> runs
    the model as if it had none, as MuJoCo does."""
    m, ours = models(tmp_path, "welds")
    _, active = models(tmp_path, "welds_relpose")
    q, v, tau = state(m, 0, "welds")
    assert np.abs(ours.step(q, v, tau)[1] - active.step(q, v, tau)[1]).max() > 1e-3
    m, ours = models(tmp_path, "fourbar", extra='<flag equality="disable"/>')
    d = mujoco.MjData(m)
    q, v, tau = state(m, 0, "fourbar")
    d.qpos[:], d.qvel[:], d.qfrc_applied[:] = q, v, tau
    mujoco.mj_step(m, d)
    assert d.ne == 0
    q1, v1 = ours.step(q, v, tau)
    np.testing.assert_allclose(v1, d.qvel, rtol=0, atol=1e-12)


def test_bad_equalities_name_the_line(tmp_path):
    path = tmp_path / "bad.xml"
    path.write_text('<mujoco><worldbody><body name="a"><joint/><geom size="1"/></body></worldbody>\n'
                    '<equality>\n<connect body1="a" body2="nowhere" anchor="0 0 0"/></equality></mujoco>')
    with pytest.raises(ValueError, match=r"bad.xml:3: <connect>: body2 'nowhere' is not a body"):
        diffosi.Model.load(str(path))


def test_contradictory_equalities_give_mujocos_finite_step(tmp_path):
    """Over-constrained and contradictory equalities (a joint held at two
    offsets; a weld and a connect on the same bodies; a connect between
    two sites on one body) are soft constraints sharing the slack, as
    MuJoCo's: a finite step, MuJoCo's."""
    path = tmp_path / "contradictory.xml"
    path.write_text(f"""<mujoco><option timestep="0.002" {SOLVER}/>
<default><geom contype="0" conaffinity="0"/></default>
<worldbody>
  <body name="a" pos="0 0 1"><joint name="h" type="hinge" axis="0 1 0"/>
    <geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.03"/>
    <site name="s1" pos="0.3 0 0"/><site name="s2" pos="0.1 0 0"/>
    <body name="b" pos="0.3 0 0"><joint type="ball"/>
      <geom type="box" size="0.05 0.05 0.1"/></body></body>
</worldbody>
<equality>
  <joint joint1="h" polycoef="0.1"/><joint joint1="h" polycoef="-0.1"/>
  <weld body1="b"/><connect body1="b" anchor="0.1 0 0"/>
  <connect site1="s1" site2="s2"/>
</equality></mujoco>""")
    m, ours = mujoco.MjModel.from_xml_path(str(path)), diffosi.Model.load(str(path))
    d = mujoco.MjData(m)
    q, v, tau = state(m, 0, "contradictory")
    d.qpos[:], d.qvel[:], d.qfrc_applied[:] = q, v, tau
    mujoco.mj_step(m, d)
    q1, v1 = ours.step(q, v, tau)
    assert np.isfinite(v1).all()
    np.testing.assert_allclose(v1, d.qvel, rtol=0, atol=1e-9)
