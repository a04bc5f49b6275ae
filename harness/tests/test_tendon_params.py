"""Tendon named parameters against MuJoCo itself (tests/data/tendon_fixed.xml).

`tendon/<name>/stiffness`, `damping`, `frictionloss` and `springlength` are
MuJoCo's tendon_stiffness, tendon_damping, tendon_frictionloss and
tendon_lengthspring. Checked: the values read are MuJoCo's; a model edited
through them steps as MuJoCo with the same fields edited in place; their
step Jacobian columns (dual numbers through the tendon forces and rows)
equal central differences of our step; DiffOsi recovers a tendon's
stiffness from MuJoCo's own transitions to 1e-6; bad values and names are
refused with the reason.
"""

import pathlib
import re

import mujoco
import numpy as np
import pytest

import diffosi
from harness.tests.test_law_params import assert_columns_match_central_differences, mj_step, random_state

DATA = pathlib.Path(__file__).resolve().parents[2] / "tests" / "data"
FILE = "tendon_fixed.xml"
EDITS = [
    ("tendon/spring/stiffness", [55.0], "tendon_stiffness", 0),
    ("tendon/spring/damping", [0.7], "tendon_damping", 0),
    ("tendon/spring/springlength", [-0.05, 0.1], "tendon_lengthspring", 0),
    ("tendon/limited/frictionloss", [0.35], "tendon_frictionloss", 1),
    ("tendon/rest/stiffness", [9.0], "tendon_stiffness", 2),
]


def models(tmp_path, file, options=""):
    """MuJoCo's and ours from the file (its solver settings) with `options` added."""
    text = re.sub(r"<option ", f"<option {options} ", (DATA / file).read_text(), count=1)
    path = tmp_path / file
    path.write_text(text)
    return mujoco.MjModel.from_xml_path(str(path)), diffosi.Model.load(str(path))


def test_values_are_mujocos_fields(tmp_path):
    m, ours = models(tmp_path, FILE)
    for name, value, field, row in EDITS:
        assert list(ours.get_param(name)) == list(np.atleast_1d(getattr(m, field)[row])[: len(value)])
    assert not any(n.startswith("tendon/") for n in ours.param_names())


def test_edited_model_steps_as_mujoco_edited(tmp_path):
    m, ours = models(tmp_path, FILE)
    for name, value, field, row in EDITS:
        ours.set_param(name, np.array(value))
        if len(value) == 1:
            getattr(m, field)[row] = value[0]
        else:
            getattr(m, field)[row] = value
    d = mujoco.MjData(m)
    rng = np.random.default_rng(3)
    for _ in range(3):
        q, v, tau, ctrl = random_state(m, rng)
        q1, v1 = ours.step(q, v, tau)
        mq, mv = mj_step(m, d, q, v, tau, ctrl)
        np.testing.assert_allclose(q1, mq, rtol=0, atol=1e-10)
        np.testing.assert_allclose(v1, mv, rtol=0, atol=1e-10)


@pytest.mark.parametrize("integrator", ["Euler", "implicitfast"])
def test_jacobians_match_central_differences(tmp_path, integrator):
    _, ours = models(tmp_path, FILE, f'integrator="{integrator}"')
    m = mujoco.MjModel.from_xml_path(str(tmp_path / FILE))
    rng = np.random.default_rng(8)
    names = [e[0] for e in EDITS]
    for _ in range(2):
        q, v, tau, _ = random_state(m, rng)
        q[0] = 0.4  # the spring tendon h1 - h2 / 2 past its deadband's upper end
        J = assert_columns_match_central_differences(ours, (q, v, tau), names, {})
        # Only one end of the deadband acts at a time: each parameter moves something.
        col = 0
        for name in names:
            size = len(ours.get_param(name))
            assert np.abs(J["dv_dp"][:, col:col + size]).max() > 0, f"{name} moves nothing"
            col += size


def test_tendon_stiffness_identified_from_mujoco(tmp_path):
    """MuJoCo's spring tendon at stiffness 40, recovered from 20."""
    m, ours = models(tmp_path, FILE)
    ours.set_param("tendon/spring/stiffness", np.array([20.0]))
    osi = diffosi.DiffOsi(ours, params=["tendon/spring/stiffness"], lower=[1.0], upper=[100.0])
    d = mujoco.MjData(m)
    rng = np.random.default_rng(1)
    rows = []
    for _ in range(30):
        q, v, tau, _ = random_state(m, rng)
        rows.append((q, v, tau, *mj_step(m, d, q, v, tau, np.zeros(0))))
    est = osi.identify(*[np.array(x) for x in zip(*rows)])
    assert abs(est["params"][0] - 40.0) < 1e-6, est["params"]


def test_bad_values_and_names_are_refused(tmp_path):
    _, ours = models(tmp_path, FILE)
    cases = [
        ("tendon/spring/stiffness", [-1.0], "stiffness"),
        ("tendon/spring/springlength", [0.1, -0.1], "tendon 'spring'"),
        ("tendon/rest/springlength", [0.0, 0.0], "has springlength -1 -1"),
        ("tendon/nope/damping", [1.0], "no tendon named 'nope'"),
        ("tendon/spring/armature", [1.0], "tendon fields are stiffness, damping, frictionloss, springlength"),
        ("tendon/spring/damping", [np.nan], "not finite"),
    ]
    for name, value, message in cases:
        with pytest.raises(ValueError, match=re.escape(message)):
            ours.set_param(name, np.array(value))
    assert list(ours.get_param("tendon/spring/stiffness")) == [40.0]
