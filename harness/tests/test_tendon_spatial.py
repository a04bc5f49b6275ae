"""Spatial tendons against MuJoCo itself.

tests/data/tendon_spatial.xml (MuJoCo's solver run to convergence): on a
three-joint arm, a limited site path with a spring and a damper, a path over
a sphere held up by a sidesite, a path under a cylinder with dry friction,
and two branches joined by a pulley. At random states some paths wrap and
some stand straight. Lengths and moments agree with mj_fwdPosition's; one
step agrees with mj_step to 1e-10 under every integrator with the limit and
friction rows acting; a 200-step rollout stays on MuJoCo's to 1e-9; the step
Jacobians (dual numbers through the wrapped paths) agree with
mjd_transitionFD's centred differences.
"""

import pathlib

import mujoco
import numpy as np
import pytest

import diffosi
from harness.gradcheck_free import a_error
from harness.tests.test_tendon import (FRICTION_TENDON, INTEGRATORS, LIMIT_TENDON, matched_steps, models,
                                       rollout_error, state)

DATA = pathlib.Path(__file__).resolve().parents[2] / "tests" / "data"
TEXT = (DATA / "tendon_spatial.xml").read_text()


@pytest.mark.parametrize("integrator", INTEGRATORS)
def test_one_step_matches_mj_step(tmp_path, integrator):
    m, ours = models(tmp_path, integrator, TEXT)
    kinds, wrapped = set(), set()
    for d in matched_steps(m, ours, range(8), 1e-10):
        kinds |= set(d.efc_type[:d.nefc].tolist())
        wrapped |= set(d.wrap_obj.ravel().tolist())
    assert {FRICTION_TENDON, LIMIT_TENDON} <= kinds
    # Both the sphere (geom 2) and the cylinder (geom 3) wrapped somewhere.
    assert {2, 3} <= wrapped


def test_rollout_matches_mj_step(tmp_path):
    worst = rollout_error(*models(tmp_path, text=TEXT), np.random.default_rng(5))
    assert worst < 1e-9, f"{worst:.1e}"


@pytest.mark.parametrize("integrator", ["Euler", "implicitfast"])
def test_jacobians_match_mjd_transition_fd(tmp_path, integrator):
    m, ours = models(tmp_path, integrator, TEXT)
    for seed in range(3):
        err = a_error(m, ours, *state(m, seed))
        assert err < 1e-6, f"seed {seed}: {err:.1e}"


def test_coincident_sites_step_finitely(tmp_path):
    """A path through two sites at one point has a zero-length segment:
    MuJoCo's unit direction x for it, a finite step and Jacobian."""
    text = TEXT.replace('<site name="u_mid" pos="0.1 0 0.05"/>',
                        '<site name="u_mid" pos="0.1 0 0.05"/><site name="u_same" pos="0.1 0 0.05"/>')
    text = text.replace('<site site="u_mid"/>', '<site site="u_mid"/><site site="u_same"/>')
    m, ours = models(tmp_path, text=text)
    d = mujoco.MjData(m)
    q, v, tau = state(m, 1)
    d.qpos[:], d.qvel[:], d.qfrc_applied[:] = q, v, tau
    mujoco.mj_step(m, d)
    q1, v1 = ours.step(q, v, tau)
    np.testing.assert_allclose(v1, d.qvel, rtol=0, atol=1e-10)
    a, _ = ours.transition_jacobians(q, v, tau)
    assert np.isfinite(a).all()


BODY = ('<mujoco><worldbody><site name="w"/><body name="a"><joint name="h"/>'
        '<geom name="ball" size="0.1"/><geom name="box" type="box" size="1 1 1"/>'
        '<site name="s"/></body></worldbody>\n<tendon>\n{}\n</tendon></mujoco>')
BAD = [
    ('<spatial><site site="w"/><geom geom="box"/><site site="s"/></spatial>',
     r"bad.xml:3: <geom>: wrap geom 'box' must be a sphere or a cylinder"),
    ('<spatial><site site="w"/><site site="nowhere"/></spatial>',
     r"bad.xml:3: <site>: unknown site 'nowhere'"),
    ('<spatial><site site="w"/><geom geom="nothing"/><site site="s"/></spatial>',
     r"bad.xml:3: <geom>: unknown geom 'nothing'"),
    ('<spatial><site site="w"/><geom geom="ball" sidesite="gone"/><site site="s"/></spatial>',
     r"bad.xml:3: <geom>: unknown site 'gone'"),
    ('<spatial><site site="w"/><geom geom="ball"/></spatial>',
     r"bad.xml:3: <spatial>: .*starts and ends at a site"),
    ('<spatial><site site="w"/><pulley divisor="0"/><site site="s"/></spatial>',
     r"bad.xml:3: <spatial>: .*divisor must be finite and > 0"),
    ('<spatial><site site="w"/><joint joint="h" coef="1"/></spatial>',
     r"bad.xml:3: <joint>: a spatial tendon holds"),
    ('<spatial armature="1"><site site="w"/><site site="s"/></spatial>',
     r"bad.xml:3: <spatial>: .*tendon armature"),
]


@pytest.mark.parametrize("tendon, message", BAD)
def test_bad_spatial_tendons_name_the_line(tmp_path, tendon, message):
    path = tmp_path / "bad.xml"
    path.write_text(BODY.format(tendon))
    with pytest.raises(ValueError, match=message):
        diffosi.Model.load(str(path))



SIDES = {
    # The sphere without its sidesite (the shorter way round), the cylinder
    # held by one below it.
    "swapped": [('<geom geom="ball" sidesite="side_up"/>', '<geom geom="ball"/>'),
                ('<geom geom="drum"/>', '<geom geom="drum" sidesite="side_up"/>'),
                ('<site name="side_up" pos="0 0 0.2"/>', '<site name="side_up" pos="0.05 0 -0.2"/>')],
    # A sidesite inside the sphere: the path touches it from inside.
    "inside": [('<site name="side_up" pos="0 0 0.2"/>', '<site name="side_up" pos="0 0 0.03"/>'),
               ('<site name="u_top" pos="0.2 0.01 0.03"/>', '<site name="u_top" pos="0.2 0.01 0.08"/>'),
               ('<site name="f_top" pos="0.2 -0.01 0.03"/>', '<site name="f_top" pos="0.2 -0.01 0.07"/>')],
}


@pytest.mark.parametrize("case", SIDES)
def test_other_sides_match_mj_step(tmp_path, case):
    text = TEXT
    for old, new in SIDES[case]:
        assert old in text
        text = text.replace(old, new)
    m, ours = models(tmp_path, text=text)
    wrapped = set()
    for d in matched_steps(m, ours, range(8), 1e-10):
        wrapped |= set(d.wrap_obj.ravel().tolist())
    assert {2, 3} <= wrapped
    err = a_error(m, ours, *state(m, 0))
    assert err < 1e-6, f"{err:.1e}"


def test_ball_in_cup_matches_mujoco():
    """dm_control's ball_in_cup: the string is a limited spatial tendon from
    the cup to the ball. Stretched (the limit row acting), one step agrees
    with mj_step, 200 steps stay on MuJoCo's, and the step Jacobian agrees
    with mjd_transitionFD's."""
    from harness import corpus

    path = str(corpus.dm_control_suite() / "ball_in_cup.xml")
    m, ours = mujoco.MjModel.from_xml_path(path), diffosi.Model.load(path)
    d = mujoco.MjData(m)
    rng = np.random.default_rng(0)
    q = m.qpos0.copy() + rng.uniform(-0.1, 0.1, m.nq)
    q[2] -= 0.1
    v, tau = rng.normal(size=m.nv), rng.normal(size=m.nv)
    d.qpos[:], d.qvel[:], d.qfrc_applied[:] = q, v, tau
    mujoco.mj_step(m, d)
    assert LIMIT_TENDON in d.efc_type[:d.nefc]
    q1, v1 = ours.step(q, v, tau)
    np.testing.assert_allclose(np.r_[q1, v1], np.r_[d.qpos, d.qvel], rtol=0, atol=1e-12)
    err = a_error(m, ours, q, v, tau)
    assert err < 1e-6, f"{err:.1e}"
    worst = rollout_error(m, ours, rng, scale=0.5)
    assert worst < 1e-9, f"{worst:.1e}"
