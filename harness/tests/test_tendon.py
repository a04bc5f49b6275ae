"""Fixed tendons against MuJoCo itself.

tests/data/tendon_fixed.xml (MuJoCo's solver run to convergence): a spring
with a deadband and a damper across two hinges, a limited tendon with dry
friction and a margin, a spring at the length at qpos_spring, and a tendon
equality with a polynomial. One step from random moving states under random
applied forces agrees with mj_step to 1e-12 under every integrator, with
the tendon friction, limit and equality rows acting; a 200-step rollout
stays on MuJoCo's; the step Jacobians (dual numbers through the tendon
forces and rows) agree with mjd_transitionFD's centred differences.
"""

import pathlib
import re

import mujoco
import numpy as np
import pytest

import diffosi
from harness.gradcheck_free import a_error

DATA = pathlib.Path(__file__).resolve().parents[2] / "tests" / "data"
INTEGRATORS = ["Euler", "RK4", "implicitfast", "implicit"]
# MuJoCo's efc_type of the tendon rows.
FRICTION_TENDON, LIMIT_TENDON = 2, 4


def models(tmp_path, integrator="Euler", text=None):
    text = text or (DATA / "tendon_fixed.xml").read_text()
    text = re.sub(r"<option ", f'<option integrator="{integrator}" ', text, count=1)
    path = tmp_path / f"tendon_{integrator}.xml"
    path.write_text(text)
    return mujoco.MjModel.from_xml_path(str(path)), diffosi.Model.load(str(path))


def state(m, seed):
    rng = np.random.default_rng(seed)
    q = m.qpos0.copy()
    mujoco.mj_integratePos(m, q, rng.uniform(-0.3, 0.3, m.nv), 1.0)
    return q, rng.normal(size=m.nv), rng.normal(size=m.nv)


def matched_steps(m, ours, seeds, atol):
    """One step from each seed's state, ours against mj_step to `atol`;
    yields MuJoCo's data after each."""
    d = mujoco.MjData(m)
    for seed in seeds:
        q, v, tau = state(m, seed)
        d.qpos[:], d.qvel[:], d.qfrc_applied[:] = q, v, tau
        mujoco.mj_step(m, d)
        q1, v1 = ours.step(q, v, tau)
        np.testing.assert_allclose(q1, d.qpos, rtol=0, atol=atol)
        np.testing.assert_allclose(v1, d.qvel, rtol=0, atol=atol)
        yield d


@pytest.mark.parametrize("integrator", INTEGRATORS)
def test_one_step_matches_mj_step(tmp_path, integrator):
    m, ours = models(tmp_path, integrator)
    kinds = set()
    for d in matched_steps(m, ours, range(5), 1e-12):
        kinds |= set(d.efc_type[:d.nefc].tolist())
    assert {mujoco.mjtConstraint.mjCNSTR_EQUALITY, FRICTION_TENDON, LIMIT_TENDON} <= kinds


def rollout_error(m, ours, rng, scale=1.0):
    """The largest difference of (q, v) over 200 steps from qpos0 at rest
    under random applied forces (standard deviation `scale`)."""
    d = mujoco.MjData(m)
    q, v = d.qpos.copy(), d.qvel.copy()
    worst = 0.0
    for _ in range(200):
        tau = rng.normal(size=m.nv) * scale
        d.qfrc_applied[:] = tau
        mujoco.mj_step(m, d)
        q, v = ours.step(q, v, tau)
        worst = max(worst, np.abs(q - d.qpos).max(), np.abs(v - d.qvel).max())
    return worst


def test_rollout_matches_mj_step(tmp_path):
    worst = rollout_error(*models(tmp_path), np.random.default_rng(5))
    assert worst < 1e-9, f"{worst:.1e}"


@pytest.mark.parametrize("integrator", ["Euler", "implicitfast"])
def test_jacobians_match_mjd_transition_fd(tmp_path, integrator):
    m, ours = models(tmp_path, integrator)
    for seed in range(3):
        err = a_error(m, ours, *state(m, seed))
        assert err < 1e-6, f"seed {seed}: {err:.1e}"


def test_springlength_and_disabled_rows(tmp_path):
    """springlength given as one number is both ends of the deadband; with
    limits and frictionloss disabled, no tendon rows, as MuJoCo."""
    text = (DATA / "tendon_fixed.xml").read_text()
    text = text.replace('springlength="-0.1 0.05"', 'springlength="0.02"')
    text = text.replace('iterations="1000"/>',
                        'iterations="1000"><flag limit="disable" frictionloss="disable"/></option>')
    m, ours = models(tmp_path, text=text)
    assert m.tendon_lengthspring[0].tolist() == [0.02, 0.02]
    d = mujoco.MjData(m)
    q, v, tau = state(m, 0)
    d.qpos[:], d.qvel[:], d.qfrc_applied[:] = q, v, tau
    mujoco.mj_step(m, d)
    assert set(d.efc_type[:d.nefc].tolist()) == {mujoco.mjtConstraint.mjCNSTR_EQUALITY}
    q1, v1 = ours.step(q, v, tau)
    np.testing.assert_allclose(v1, d.qvel, rtol=0, atol=1e-12)


BAD = [
    ('<fixed><joint joint="nowhere" coef="1"/></fixed>', r"bad.xml:4: <joint>: unknown joint 'nowhere'"),
    ('<fixed><joint joint="h"/></fixed>', r"bad.xml:4: <joint>: a tendon's <joint> needs coef"),
    ('<fixed armature="0.1"><joint joint="h" coef="1"/></fixed>', r"bad.xml:4: <fixed>: .*tendon armature"),
    ('<fixed stiffness="-1"><joint joint="h" coef="1"/></fixed>', r"bad.xml:4: <fixed>: .*stiffness must be"),
    ('<spatial><site site="s"/></spatial>', r"bad.xml:4: <site>: unknown site 's'"),
    ('<fixed name="t"><joint joint="b" coef="1"/></fixed>', r"bad.xml:4: <fixed>: .*'b' must be a hinge or a slide"),
]


@pytest.mark.parametrize("tendon, message", BAD)
def test_bad_tendons_name_the_line(tmp_path, tendon, message):
    path = tmp_path / "bad.xml"
    path.write_text('<mujoco><worldbody><body name="a"><joint name="h"/><geom size="1"/>\n'
                    '<body><joint name="b" type="ball"/><geom size="1"/></body></body></worldbody>\n'
                    '<tendon>\n'
                    f'{tendon}\n'
                    '</tendon></mujoco>')
    with pytest.raises(ValueError, match=message):
        diffosi.Model.load(str(path))


def test_tendon_equality_naming_no_tendon(tmp_path):
    path = tmp_path / "bad.xml"
    path.write_text('<mujoco><worldbody><body name="a"><joint name="h"/><geom size="1"/></body>'
                    '</worldbody>\n<equality>\n<tendon tendon1="t"/></equality></mujoco>')
    with pytest.raises(ValueError, match=r"bad.xml:3: <tendon>: tendon1 't' is not a tendon"):
        diffosi.Model.load(str(path))
